"""Format 2.10 (docs/format.md §2.4, *(2.10)*): a curve whose ends the decoder
pins to its edge's two vertices may be coded between them (``CNET`` method 11,
``codec.Method.ANCHORED``): no integers for its ends, which are the vertices
as ``VERT`` decodes them (``encode.assembly._anchor_curves``)."""

from __future__ import annotations

import numpy as np
import pytest

from nurbscomp import codec, container, decode, pipeline, serialize
from nurbscomp.codec import search
from nurbscomp.codec.coder import _ladder_settings, _Memo
from nurbscomp.errors import SectionError
from nurbscomp.model import BSplineCurve
from nurbscomp.rules import joins
from nurbscomp.serialize import NetTable, coded_rows
from nurbscomp.streams import BlockReader

A = codec.Method.ANCHORED


def _curve(n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 1.0, n)
    p = np.stack([20 * t, 3 * np.sin(4 * t), t * t], 1) + rng.normal(0, 1e-3, (n, 3))
    anchors = p[[0, -1]] + rng.normal(0, 2e-3, (2, 3))  # vertices moved onto their grid
    return p, anchors


@pytest.mark.parametrize("n", [2, 3, 6, 11])
def test_anchored_codes(n: int) -> None:
    """The ends are the anchors bit for bit, the bound counts their moves, and
    the ladder computed at once (``_Rungs``) gives each rung's code as one
    trial (``_try``) does, bit for bit."""
    p, anchors = _curve(n, n)
    code = codec.encode_net(p, None, None, 0.01, methods=(A,), origin=anchors)
    net, _ = codec.decode_net(code, p.shape, None, None, 0.01, anchors)
    assert np.array_equal(net[0], anchors[0]) and np.array_equal(net[-1], anchors[1])
    assert len(code.ints) == 3 * max(n - 2, 0)
    assert np.sqrt(((net - p) ** 2).sum(-1)).max() <= code.bound <= 0.01
    assert code.bound >= np.sqrt(((anchors - p[[0, -1]]) ** 2).sum(-1)).max()
    settings = _ladder_settings(codec.Quant.TOL, codec.ladder(0.01, 0.01), 1, 0.01)
    rungs = search._Rungs(p, A, settings, anchors, _Memo())
    for i, st in enumerate(settings):
        one = search._try(p, None, None, 0.01, A, st, anchors, memo=_Memo())
        got = rungs.code(i)
        assert (got is None) == (one is None)
        if got is not None and one is not None:
            assert got.bound == one.bound and np.array_equal(got.ints, one.ints)


def test_anchors_are_required_and_stay() -> None:
    p, anchors = _curve(5, 1)
    code = codec.encode_net(p, None, None, 0.01, methods=(A,), origin=anchors)
    for origin in (None, anchors[0]):
        with pytest.raises(ValueError, match="two anchors"):
            codec.decode_net(code, p.shape, None, None, 0.01, origin)
    assert codec.reorigin(code, anchors.copy(), 0.01).ints is not None
    with pytest.raises(ValueError, match="cannot move"):
        codec.reorigin(code, anchors + 1e-9, 0.01)


def test_method_11_only_from_2_10() -> None:
    one = np.ones(1, np.int64)
    t = NetTable(11 * one, 0 * one, 0 * one, 0 * one, [np.zeros(3, np.int64)], np.zeros(0))
    decode._check_headers(t, "CNET", 0.01, decode.ANCHORED_CURVES)
    with pytest.raises(SectionError, match="does not apply"):
        decode._check_headers(t, "CNET", 0.01, decode.ANCHORED_CURVES - 1)
    with pytest.raises(SectionError, match="does not apply"):
        decode._check_headers(t, "SNET", 0.01, decode.ANCHORED_CURVES)


@pytest.fixture(scope="module")
def spline_part(tmp_path_factory: pytest.TempPathFactory) -> str:
    """A plate between two spline sides, its top edges filleted: B-spline
    edges between vertices that the encoder snaps to the vertex grid."""
    import cadquery as cq

    w = cq.Workplane("XY").moveTo(0, 0).spline([(3, 1.5), (6, -1), (10, 0)], includeCurrent=True)
    w = w.lineTo(10, 6).spline([(6, 7.5), (3, 5), (0, 6)], includeCurrent=True).close()
    path = str(tmp_path_factory.mktemp("anchored") / "spline_part.step")
    cq.exporters.export(w.extrude(3).edges(">Z").fillet(0.8), path)
    return path


def _methods(path: str) -> np.ndarray:
    c = container.unpack(open(path, "rb").read())
    return BlockReader(c.get("CNET"), "CNET").ints()


def test_curves_coded_between_their_vertices(spline_part, tmp_path, monkeypatch) -> None:
    """Compress codes some curves between their vertices; decoded, their end
    poles are the vertices bit for bit.  Without the rule the container holds
    no method 11, and its curves more integers."""
    from nurbscomp.encode import assembly

    out = tmp_path / "a.nzc"
    pipeline.compress_file(spline_part, out, tol=0.01)
    methods = _methods(str(out))
    assert (methods == int(A)).sum() >= 2
    c = container.unpack(out.read_bytes())
    m, meta, t = serialize.read_sections(c.get, c.revision, None)
    rows = coded_rows(m.curves3d)  # before the nets are decoded
    decode.apply(m, t, serialize.tolerance(meta), c.revision)
    ends = joins.anchors(m, m.curves3d, set(rows))
    for row, method in zip(rows, methods.tolist(), strict=True):
        if method == int(A):
            g = m.curves3d[row]
            assert isinstance(g, BSplineCurve)
            assert np.array_equal(g.poles[[0, -1]], ends[row])
    monkeypatch.setattr(assembly, "ANCHOR_CURVES", False)
    plain = tmp_path / "b.nzc"
    pipeline.compress_file(spline_part, plain, tol=0.01)
    assert (_methods(str(plain)) == int(A)).sum() == 0
    assert _cnet_ints(out) < _cnet_ints(plain)


def _cnet_ints(path) -> int:
    """How many integers the ``CNET`` streams hold (on a part this small the
    entropy stage's few bytes either way say nothing)."""
    c = container.unpack(path.read_bytes())
    _, _, t = serialize.read_sections(c.get, c.revision, None)
    return sum(len(x) for x in t.cnet.ints)
