"""Vertices near an earlier vertex (format 2.5, `VERT` kind 2, docs/format.md §2.6).

An IGES surface model gives every face its own corners: four vertices at one
corner, a few 1e-9 mm apart.  They are stored as a reference and an offset in
multiples of 2**-32 mm, not as floats.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from nurbscomp import container, pipeline, serialize
from nurbscomp.encode import assembly
from nurbscomp.errors import SectionError
from nurbscomp.serialize import vertices
from nurbscomp.streams import BlockReader
from tests.golden.make_golden import faces_iges

SAMPLES = Path(__file__).resolve().parent.parent / "samples"


def _kinds(nzc: bytes) -> np.ndarray:
    c = container.unpack(nzc)
    return BlockReader(c.get("VERT"), "VERT").ints()


def test_twin_refs_reproduce_points_bit_for_bit() -> None:
    rng = np.random.default_rng(7)
    first = rng.uniform(-50, 50, (20, 3))
    k = rng.integers(-300, 300, (20, 3))
    twins = vertices.twin_offset(first, k)
    noisy = first + rng.uniform(-3e-8, 3e-8, (20, 3))  # not multiples of 2**-32
    pts = np.concatenate([first, twins, first.copy(), noisy])
    ref, got = vertices._twin_refs(pts)
    assert (ref[:20] == -1).all()
    assert (ref[20:40] == np.arange(20)).all() and (got[20:40] == k).all()
    assert (ref[40:60] == np.arange(20)).all() and (got[40:60] == 0).all()  # at one point
    for v in np.flatnonzero(ref >= 0):
        back = vertices.twin_offset(pts[ref[v]], got[v])
        assert back.tobytes() == pts[v].tobytes()
    # a noisy vertex is kind 2 only if some earlier vertex reproduces it exactly
    for v in range(60, 80):
        if ref[v] >= 0:
            assert vertices.twin_offset(pts[ref[v]], got[v]).tobytes() == pts[v].tobytes()


def test_twin_refs_with_close_points_none_of_them_exact() -> None:
    """Points within reach of each other, none an exact offset from another."""
    p = np.array([[1.0, 2.0, 3.0], [1.0 + 1e-12, 2.0, 3.0]])
    ref, k = vertices._twin_refs(p)
    assert (ref == -1).all() and not k.any()


def test_twin_refs_signed_zeros() -> None:
    """-0.0 and 0.0 are one point to np.unique but not bit for bit, and
    -0.0 + 0.0 is 0.0: a vertex at -0.0 is not a kind-2 copy of anything."""
    p = np.array([[0.0, 1.0, 2.0], [-0.0, 1.0, 2.0], [-0.0, 1.0, 2.0], [0.0, 1.0, 2.0]])
    ref, k = vertices._twin_refs(p)
    for v in np.flatnonzero(ref >= 0):
        assert vertices.twin_offset(p[ref[v]], k[v]).tobytes() == p[v].tobytes()
    assert ref[3] == 0 and ref[1] == -1 and ref[2] == -1


def test_twin_points_keep_twins_apart_and_on_the_step() -> None:
    p = np.array(
        [[10.0, 20.0, 30.0], [10.0 + 3e-11, 20.0, 30.0], [10.0, 20.0 + 4.7e-8, 30.0], [10.0] * 3]
    )
    lead = np.array([0, 0, 0, 3])
    base = p + 1e-3  # the first vertices' new places
    at = assembly._twin_points(p, lead, base)
    assert at[0].tobytes() == base[0].tobytes() and at[3].tobytes() == base[3].tobytes()
    # 3e-11 rounds to 0 steps of 2**-32 (2.3e-10): kept one step apart
    assert not np.array_equal(at[1], at[0])
    assert assembly._kept_apart(p, at, lead).all()
    for v in (1, 2):
        k = np.rint(np.ldexp(at[v] - at[0], -vertices.TWIN_EXP))
        assert vertices.twin_offset(at[0], k.astype(np.int64)).tobytes() == at[v].tobytes()
        # moved with its first, and by at most a step further
        assert np.abs((at[v] - base[0]) - (p[v] - p[0])).max() <= 2.0**vertices.TWIN_EXP
    assert assembly._twin_slack(at) < 1e-9


def test_reader_refuses_bad_twin_arrays() -> None:
    c = container.unpack(_faces_container(SAMPLES / "teapot.step", 0.01))
    raw = c.get("VERT")
    m, _, _ = serialize.read_sections(c.get, c.revision)
    kinds = BlockReader(raw, "VERT").ints()
    assert (kinds == 2).any()
    # the same section read as revision 7 (format 2.4): kind 2 is unknown there
    with pytest.raises(SectionError, match="unknown vertex kind"):
        vertices._read_vertices(raw, m, 0.01, revision=7)


def _faces_container(step: Path, tol: float | None) -> bytes:
    """``step`` written as an IGES surface model and compressed at ``tol``
    (lossless if None)."""
    import tempfile

    with tempfile.TemporaryDirectory() as d:
        src = faces_iges(step, Path(d) / "s.igs")
        dst = Path(d) / "s.nzc"
        if tol is None:
            pipeline.compress_file(src, dst, lossless=True)
        else:
            pipeline.compress_file(src, dst, tol=tol)
        return dst.read_bytes()


@pytest.mark.parametrize("tol", [0.01, None])
def test_faces_model_twins_are_kind_2(tol: float | None) -> None:
    """A faces-mode IGES file (OCCT writes each corner's twins at one point):
    every twin is stored as its reference, lossless or not."""
    data = _faces_container(SAMPLES / "teapot.step", tol)
    kinds = _kinds(data)
    m, _ = pipeline.decode(container.unpack(data))
    pts = m.vertex_point
    distinct = len(np.unique(pts, axis=0))
    assert int((kinds == 2).sum()) == len(pts) - distinct > 0


@pytest.mark.slow
def test_noisy_twins_come_back_apart(tmp_path: Path) -> None:
    """Twins a few 1e-9 mm apart (as surface modellers write them) stay apart
    and within tol, stored as kind 2 with non-zero offsets."""
    from OCP.BRep import BRep_Builder, BRep_Tool
    from OCP.gp import gp_Pnt
    from OCP.TopAbs import TopAbs_VERTEX
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopoDS import TopoDS

    import nurbscomp
    from nurbscomp import occ

    src = faces_iges(SAMPLES / "teapot.step", tmp_path / "s.igs")
    shape = occ.read_cad(src).shape
    rng = np.random.default_rng(3)
    b = BRep_Builder()
    seen = set()
    ex = TopExp_Explorer(shape, TopAbs_VERTEX)
    while ex.More():
        v = TopoDS.Vertex_s(ex.Current())
        ex.Next()
        if v.TShape().__hash__() in seen:
            continue
        seen.add(v.TShape().__hash__())
        p = BRep_Tool.Pnt_s(v)
        d = rng.uniform(-3e-8, 3e-8, 3)
        b.UpdateVertex(v, gp_Pnt(p.X() + d[0], p.Y() + d[1], p.Z() + d[2]), 1e-6)
    before = serialize_points(shape)
    data = nurbscomp.compress(shape, tol=0.01)
    kinds = _kinds(data)
    m, _ = pipeline.decode(container.unpack(data))
    after = m.vertex_point
    assert (kinds == 2).sum() >= len(after) // 2
    assert len(after) == len(before)
    assert len(np.unique(after, axis=0)) == len(np.unique(before, axis=0))
    assert np.sqrt(((after - before) ** 2).sum(-1)).max() <= 0.01


def serialize_points(shape) -> np.ndarray:
    """The vertex points of ``shape`` as the encoder's model holds them."""
    from nurbscomp import occ

    return occ.shape_to_model(shape)[0].vertex_point


GOLDEN_2_18 = Path(__file__).resolve().parent / "golden" / "bracket.v2_18.faces.tol0.01.nzc"


def _golden_2_18():
    c = container.unpack(GOLDEN_2_18.read_bytes())
    m, _, _ = serialize.read_sections(c.get, c.revision)
    return c, m


def _twin_block(raw: bytes) -> tuple[np.ndarray, list[int]]:
    """The kinds, and the offset at which the kind-2 arrays start, of a
    ``VERT`` section (walking its arrays as the reader does)."""
    r = BlockReader(raw, "VERT")
    k = r.ints()
    r.floats(3 * int((k == 0).sum()))
    for _ in range(3):
        r.ints(int((k == 1).sum()))
    if (k == 3).any():
        r.ints(1)
        for _ in range(3):
            r.ints(int((k == 3).sum()))
    back = r.ints(int((k == 2).sum()))
    return back, r.ints(2).tolist()


@pytest.mark.parametrize("deltas", [False, True])
def test_twin_references_both_ways_read_back_bit_for_bit(deltas: bool) -> None:
    """Format 2.18: a kind-2 vertex's reference as a distance back (mode 0)
    or as the difference from the previous one's (mode 1); both read back
    the same points, and the 2.18 writer keeps the smaller."""
    c, m = _golden_2_18()
    pts = m.vertex_point
    ref, k = vertices._twin_refs(pts)
    twin = ref >= 0
    assert twin.sum() > 50
    none = np.zeros(len(pts), bool)
    q = np.zeros_like(pts, dtype=np.int64)
    raw = vertices._vertex_arrays(m, none, q, ref, k, twin, ([], {}), none, 0, deltas)
    back, (e, mode) = _twin_block(raw)
    assert mode == int(deltas) and e == vertices.TWIN_EXP
    rows = np.flatnonzero(twin)
    assert back.tolist() == (np.diff(ref[rows], prepend=0) if deltas else rows - ref[rows]).tolist()
    got = serialize.read_sections(c.get, c.revision)[0]
    vertices._read_vertices(raw, got, 0.01, container.REVISION)
    assert got.vertex_point.tobytes() == pts.tobytes()


def test_the_golden_surface_model_codes_its_references_as_differences() -> None:
    """The 2.18 golden file (the bracket as an IGES surface model) holds
    references as differences, far smaller than the distances; the independent
    reader decodes it as ``nurbscomp`` does."""
    from tests.independent import reader

    from .test_independent_reader import same_floats

    c, m = _golden_2_18()
    back, (_, mode) = _twin_block(c.get("VERT"))
    assert mode == 1
    ref = np.cumsum(back)
    rows = np.flatnonzero(vertices._twin_refs(m.vertex_point)[0] >= 0)
    assert np.median(np.abs(back)) * 2 < np.median(rows - ref)  # differences, not distances
    data = GOLDEN_2_18.read_bytes()
    assert same_floats(data, reader.read(data).floats()) == []


@pytest.mark.parametrize(
    "mode, change, fragment",
    [
        (2, None, "unknown reference mode"),
        (1, lambda b: b[:-1] + [10**6], "not an earlier vertex"),  # past its own row
        (1, lambda b: [-1] + b[1:], "not an earlier vertex"),  # below row 0
        (1, lambda b: [2**31] + b[1:], "not an earlier vertex"),
        (0, lambda b: [0] + b[1:], "not an earlier vertex"),
    ],
)
def test_reader_refuses_bad_twin_references(mode, change, fragment) -> None:
    """A 2.18 section whose mode is unknown, or whose references leave the
    earlier rows, is refused; the same arrays in 2.17's layout read as
    distances."""
    from nurbscomp.streams import BlockWriter

    c, m = _golden_2_18()
    pts = m.vertex_point
    ref, k = vertices._twin_refs(pts)
    twin = ref >= 0
    rows = np.flatnonzero(twin)
    back = (np.diff(ref[rows], prepend=0) if mode == 1 else rows - ref[rows]).tolist()
    if change is not None:
        back = change(back)[: len(rows)]
    w = BlockWriter()
    w.ints(np.where(twin, 2, 0))
    w.floats(pts[~twin].reshape(-1))
    for _ in range(3):
        w.ints([])
    w.ints(back)
    w.ints([vertices.TWIN_EXP, mode])
    for axis in range(3):
        w.ints(k[rows, axis])
    vertices._write_tolerances(w, m.vertex_tol)
    w.ints([])
    for _ in range(4):
        w.ints([])
    w.floats([])
    got = serialize.read_sections(c.get, c.revision)[0]
    with pytest.raises(SectionError, match=fragment):
        vertices._read_vertices(bytes(w), got, 0.01, container.REVISION)
