"""Net methods and quantizers that today's writer does not search (issue 31,
deliverable 1): each is either specified and decoded alike by ``nurbscomp``
and the independent reader (``tests/independent``), or retired and refused.

* Methods 5 (D-map) and 7 (boundary with the bicubic Coons net) were written
  by the 1.0–1.2 writers (their search held them until ``codec.SURFACE_SEARCH``
  left them out); docs/format.md §2.4.1 specifies them.  Containers that use
  them are made here by coding a golden file's nets again with them.
* Quantizer 1 (the paper's) was never written by any writer: the format
  reserves it, and both readers refuse a container that uses it.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from nurbscomp import codec, container, coons, decode, dmap, pipeline, serialize
from nurbscomp.encode import nets as encode_nets
from nurbscomp.errors import SectionError
from nurbscomp.model import BSplineSurface

from .golden.make_golden import _arrays, _replace, _write_arrays, pack_raw
from .independent import nets, reader
from .independent.container import ReadError
from .test_independent_reader import same_floats

HERE = Path(__file__).resolve().parent
SAMPLES = HERE.parent / "samples"


def _methods(data: bytes, tag: str) -> list[int]:
    raw = container.unpack(data).get(tag)
    return _arrays(raw, tag)[0][1].tolist()


def recoded(name: str, method: codec.Method) -> tuple[bytes, int]:
    """Golden file ``name`` (a 1.0 container, whose SNET is laid out with a
    count column) with every surface net made one that ``method`` predicts
    (the Coons net of its boundaries; for the D-map, its interior moved along
    the normals by up to 2 mm) and coded again by ``method`` where that codes it
    within tol (by ``SPATIAL`` elsewhere), each against the previous net's
    decoded first pole: the container and how many nets use ``method``."""
    base = (HERE / "golden" / f"{name}.nzc").read_bytes()
    c = container.unpack(base)
    assert (c.major, c.minor) == (1, 0)
    raw, _, _ = serialize.read_sections(c.get, revision=0)
    rows = serialize.coded_rows(raw.surfaces)
    m, meta = pipeline.decode(c)
    tol = float(meta["tolerance_mm"])
    codes, origin, used = [], None, 0
    for row in rows:
        g = m.surfaces[row]
        s, t = decode.net_abscissae(g)
        basis = decode.net_basis(g)
        p = g.poles
        edges = (p[0], p[-1], p[:, 0], p[:, -1])
        if method == codec.Method.BOUNDARY3:
            p = coons.bicubic_net(*edges, s, t)
        elif basis is not None and min(p.shape[:2]) > 2:
            p = coons.coons_net(*edges, s, t)
            n = dmap.normals(p, basis)[1:-1, 1:-1]
            d = np.linspace(-2.0, 2.0, n.shape[0] * n.shape[1]).reshape(n.shape[:2])
            p[1:-1, 1:-1] += d[..., None] * n
        try:
            code = codec.encode_net(p, s, t, tol, (method,), origin=origin, basis=basis)
            used += 1
        except codec.NoCodeError:
            code = codec.encode_net(p, s, t, tol, (codec.Method.SPATIAL,), origin=origin)
        net, _ = codec.decode_net(code, p.shape, s, t, tol, origin, basis)
        origin = net.reshape(-1, 3)[0]
        codes.append(code)
    ints = [np.asarray(cd.ints, np.int64) for cd in codes]
    arrays = [
        ("i", np.array([int(cd.method) for cd in codes])),
        ("i", np.array([int(cd.quant) for cd in codes])),
        ("i", np.array([cd.level for cd in codes])),
        ("i", np.array([cd.slope for cd in codes])),
        ("i", np.array([len(x) for x in ints])),
        ("i", np.concatenate(ints)),
        ("f", np.zeros(0)),
    ]
    secs = _replace([(x.tag, x.raw) for x in c.sections], "SNET", _write_arrays(arrays))
    return pack_raw(secs, c.flags, minor=0, major=1), used


@pytest.mark.parametrize(
    ("method", "name"),
    [
        (codec.Method.DMAP, "teapot.tol0.01"),
        (codec.Method.BOUNDARY3, "teapot.tol0.01"),
        (codec.Method.BOUNDARY3, "loft.tol0.01"),
    ],
)
def test_method_decodes_alike(method: codec.Method, name: str) -> None:
    """Methods 5 and 7, as the 1.0–1.2 writers wrote them: a container whose
    surface nets use them decodes to the same poles, bit for bit, with the
    independent reader (docs/format.md §2.4.1) as with ``nurbscomp``."""
    data, used = recoded(name, method)
    assert used >= 1
    assert _methods(data, "SNET").count(int(method)) == used
    got = reader.read(data).floats()
    assert same_floats(data, got) == []


def _with_quantizer_1(data: bytes) -> bytes:
    c = container.unpack(data)
    secs = [(s.tag, s.raw) for s in c.sections]
    arrays = _arrays(c.get("SNET"), "SNET")
    kind, quant = arrays[1]
    assert len(quant) > 0 and (quant == 0).all()
    quant = quant.copy()
    quant[0] = 1
    arrays[1] = (kind, quant)
    return pack_raw(
        _replace(secs, "SNET", _write_arrays(arrays)), c.flags, minor=c.minor, major=c.major
    )


@pytest.mark.parametrize("name", ["blob.v2_1.tol0.1", "blob.tol0.01", "loft.v2.tol0.01"])
def test_quantizer_1_is_refused(name: str) -> None:
    """Quantizer 1 is reserved (docs/format.md §2.4): a net that claims it is a
    SectionError for ``nurbscomp`` and an error for the independent reader,
    in every version."""
    base = (HERE / "golden" / f"{name}.nzc").read_bytes()
    reader.read(base)  # the file as written decodes
    bad = _with_quantizer_1(base)
    with pytest.raises(SectionError, match="quantizer 1 is reserved"):
        pipeline.decode(container.unpack(bad))
    with pytest.raises(ReadError, match="quantizer 1 is reserved"):
        reader.read(bad)


def test_writer_never_writes_quantizer_1() -> None:
    """Even with the paper's whole set of methods searched (``paper``), the
    encoder codes every net with quantizer 0."""
    data = (HERE / "golden" / "loft.v2_1.tol0.01.nzc").read_bytes()
    m, _ = pipeline.decode(container.unpack(data))
    nets = [g for g in m.surfaces if isinstance(g, BSplineSurface)]
    assert nets
    for g in nets:
        code, _ = encode_nets._code_one(g, 0.01, codec.SURFACE_METHODS, True, None, 0.01)
        assert code.quant == codec.Quant.TOL


def test_copies_across_placements() -> None:
    """Method 9 copies between curves of two parts placed apart (docs/format.md
    §2.4, placements): a cadquery assembly of two parts that meet along a
    spline edge, each built in a frame of its own and located into the
    model, compressed at 0.01 mm.  The independent reader moves the copied
    poles by inv(P_row)·P_leader and gets nurbscomp's poles bit for bit."""
    cq = pytest.importorskip("cadquery")
    import nurbscomp

    pts = [(0.0, 0.0), (3.0, 1.5), (6.0, -1.0), (10.0, 0.0)]

    def region(side: float) -> object:
        w = cq.Workplane("XY").moveTo(0, 0).spline(pts[1:], includeCurrent=True)
        return w.lineTo(10, 5 * side).lineTo(0, 5 * side).close().extrude(2)

    loc = cq.Location(cq.Vector(4, -3, 1), cq.Vector(0, 0, 1), 30)
    assy = cq.Assembly(name="top")
    assy.add(region(-1.0), name="a")
    assy.add(cq.Workplane().add(region(1.0).val().moved(loc.inverse)), name="b", loc=loc)
    data = nurbscomp.compress(assy, tol=0.01)
    m = reader.read(data)
    assert len(m.copies) >= 2
    where = nets.curve_placements(m)
    for row, leader in m.copies:
        assert row in where and leader in where
        assert not np.array_equal(where[row], where[leader])
        a, b = m.curves3d[row].poles, m.curves3d[leader].poles  # type: ignore[union-attr]
        assert not (np.array_equal(a, b) or np.array_equal(a, b[::-1]))
    assert same_floats(data, m.floats()) == []
