"""Vertices on a binary grid (format 2.13, `VERT` kind 3, docs/format.md §2.6).

A vertex that cannot move to the vertex grid (on a feature finer than tol, or
one that would land on another vertex) is rounded by the encoder to the binary
grid 2**(floor(log2 tol) - 10); from 2.13 it is stored as integers on that
grid, predicted from its kind-3 neighbours as grid vertices are from theirs.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from nurbscomp import container, pipeline, serialize
from nurbscomp.errors import SectionError
from nurbscomp.serialize import vertices
from nurbscomp.streams import BlockReader, BlockWriter

GOLDEN = Path(__file__).resolve().parent / "golden" / "bracket.v2_13.tol0.01.nzc"
TOL = 0.01


def _model():
    c = container.unpack(GOLDEN.read_bytes())
    m, _, _ = serialize.read_sections(c.get, c.revision)
    return m


def _on_binary_grid(m, every: int = 1, seed: int = 4):
    """``m`` with every ``every``-th vertex moved off the vertex grid onto the
    binary grid (by less than tol/1000), the others as they are."""
    e = vertices.binary_exponent(TOL)
    rng = np.random.default_rng(seed)
    p = m.vertex_point.copy()
    rows = np.arange(0, len(p), every)
    moved = p[rows] + rng.uniform(-1e-5, 1e-5, (len(rows), 3))
    p[rows] = np.ldexp(np.rint(np.ldexp(moved, -e)), e)
    return replace(m, vertex_point=p), rows


def _kinds(raw: bytes) -> np.ndarray:
    return BlockReader(raw, "VERT").ints()


def test_binary_vertices_round_trip_bit_for_bit() -> None:
    m, rows = _on_binary_grid(_model(), every=1)
    raw = vertices._write_vertices(m, TOL)
    kinds = _kinds(raw)
    assert (kinds[rows] == 3).all()
    back = replace(m)
    vertices._read_vertices(raw, back, TOL, container.REVISION)
    assert back.vertex_point.tobytes() == m.vertex_point.tobytes()
    # as floats (before 2.13) the same vertices cost more
    plain = vertices._vertex_arrays(
        m, np.zeros(len(rows), bool), np.zeros((len(rows), 3), np.int64),
        np.full(len(rows), -1), np.zeros((len(rows), 3), np.int64),
        np.zeros(len(rows), bool), ([], {}), np.zeros(len(rows), bool), 0,
    )  # fmt: skip
    import lzma

    assert len(lzma.compress(raw)) < len(lzma.compress(plain))


def test_kinds_mix_and_a_twin_may_refer_to_a_binary_vertex() -> None:
    """Kinds 1, 2 and 3 in one section: a vertex at the point of a kind-3
    vertex is a kind-2 copy of it, and reads back as its point."""
    m = _model()
    m, rows = _on_binary_grid(m, every=2)
    p = m.vertex_point.copy()
    p[1] = p[0]  # row 0 is kind 3, row 1 its twin
    m = replace(m, vertex_point=p)
    raw = vertices._write_vertices(m, TOL)
    kinds = _kinds(raw)
    back = replace(m)
    vertices._read_vertices(raw, back, TOL, container.REVISION)
    assert back.vertex_point.tobytes() == p.tobytes()
    assert kinds[0] == 3 and set(kinds.tolist()) >= {3}


def _section(kinds, e: int, ints: np.ndarray) -> bytes:
    """A VERT section of vertices of ``kinds`` (3 only), no tolerances
    beyond 1.0, no representations."""
    w = BlockWriter()
    w.ints(kinds)
    w.floats([])
    for _ in range(3):
        w.ints([])
    w.ints([e])
    for axis in range(3):
        w.ints(ints[:, axis])
    vertices._write_tolerances(w, np.ones(len(kinds)))
    w.ints([])
    for _ in range(4):
        w.ints([])
    w.floats([])
    return bytes(w)


@pytest.mark.parametrize(
    "e, ints, revision, fragment",
    [
        (-20, [[1, 2, 3]], 15, "unknown vertex kind"),
        (1, [[1, 2, 3]], 16, "exponent is out of range"),
        (-1075, [[1, 2, 3]], 16, "exponent is out of range"),
        (-20, [[2**53, 0, 0]], 16, "out of range"),
    ],
)
def test_reader_refuses_bad_binary_arrays(e: int, ints, revision: int, fragment: str) -> None:
    m = _model()
    one = replace(m, shape_type=m.shape_type[:0])  # no neighbours needed
    raw = _section([3], e, np.array(ints, np.int64))
    with pytest.raises(SectionError, match=fragment):
        vertices._read_vertices(raw, one, TOL, revision)


def test_a_valid_binary_section_reads() -> None:
    m = _model()
    one = replace(m, shape_type=m.shape_type[:0])
    raw = _section([3, 3], -20, np.array([[1, 2, 3], [-4, 0, 5]], np.int64))
    vertices._read_vertices(raw, one, TOL, container.REVISION)
    want = np.ldexp(np.array([[1, 2, 3], [-3, 2, 8]], float), -20)  # the second predicted
    assert one.vertex_point.tobytes() == want.tobytes()


@pytest.mark.slow
def test_a_part_finer_than_tol_stores_binary_vertices(tmp_path: Path, one_coding: None) -> None:
    """The blob sample scaled to 0.13 mm across, at 0.01 mm: its B-spline
    edges' vertices cannot all snap to the vertex grid; those that go to the
    binary grid are kind 3, and the container checks and decodes."""
    import cadquery as cq

    samples = Path(__file__).resolve().parent.parent / "samples"
    small = cq.importers.importStep(str(samples / "blob.step")).val().scale(0.002)
    src = tmp_path / "tiny.step"
    cq.exporters.export(cq.Workplane().add(small), str(src))
    dst = tmp_path / "tiny.nzc"
    rep = pipeline.compress_file(src, dst, tol=TOL)
    assert rep["verified"]
    c = container.unpack(dst.read_bytes())
    kinds = _kinds(c.get("VERT"))
    assert (kinds == 3).sum() > len(kinds) / 2, np.bincount(kinds)
    m, _ = pipeline.decode(c)
    e = vertices.binary_exponent(TOL)
    on = m.vertex_point[kinds == 3]
    assert (np.ldexp(np.rint(np.ldexp(on, -e)), e) == on).all()


def test_coarsest_exponent() -> None:
    pts = np.array([[3.5, 40.0, -0.25], [1.0, 2.0, 0.0]])
    assert vertices.coarsest_exponent(pts, -17) == -2
    assert vertices.coarsest_exponent(np.array([[4.0, 8.0, 0.0]]), -17) == 0
    assert vertices.coarsest_exponent(np.array([[0.1, 0.0, 0.0]]), -17) == -17
    # a point off every grid from -3 up keeps the tolerance's exponent
    assert vertices.coarsest_exponent(np.array([[0.125, 0.0, 1.0 / 1024]]), -7) == -7


def test_exact_vertices_take_their_coarsest_grid_at_every_tolerance() -> None:
    """Vertices no coding moved (a machined plate's, at multiples of 1/8 mm)
    are written on the coarsest binary grid that holds them, where that is
    smaller than the tolerance's grid: the section is then the same at 0.01
    and 0.1 mm (it was 252 and 276 bytes LZMA-alone on a plate of 48
    filleted bosses), and reads back bit for bit."""
    m = _model()
    rng = np.random.default_rng(7)
    moved = m.vertex_point + rng.uniform(-1, 1, m.vertex_point.shape)
    p = np.ldexp(np.rint(np.ldexp(moved, 3)), -3)
    m = replace(m, vertex_point=p)
    raws = []
    for tol in (0.01, 0.1):
        raw = vertices._write_vertices(m, tol)
        back = replace(m)
        vertices._read_vertices(raw, back, tol, container.REVISION)
        assert back.vertex_point.tobytes() == p.tobytes()
        r = BlockReader(raw, "VERT")
        kinds = r.ints()
        assert (kinds == 3).sum() > len(p) // 2, kinds
        r.floats(3 * int((kinds == 0).sum()))
        for _ in range(3):
            r.ints(int((kinds == 1).sum()))
        assert int(r.ints(1)[0]) == -3  # the plate's grid, not 2**(floor(log2 tol) - 10)
        raws.append(raw)
    assert raws[0] == raws[1]
