"""Vertices that stay off the vertex grid are rounded to a fine binary grid
(issue 28 §2; encode.assembly._fine_points): within the grid's bound, in
floats with trailing zero bits, never onto another vertex, twin clusters
moved as one."""

from __future__ import annotations

import numpy as np

from nurbscomp.encode import assembly


def _points(n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return rng.uniform(-150.0, 150.0, (n, 3))


def test_rounded_within_the_bound_and_short():
    p = _points(200, 1)
    lead = np.arange(len(p))
    fine, at, bound = assembly._fine_points(p, lead, np.ones(len(p), bool), 0.01)
    assert fine.all()
    step = 2.0 ** (np.floor(np.log2(0.01)) - assembly.FINE_BITS)
    # the grid's half diagonal, and what a twin's rounded offset may add (format 2.5)
    assert step * np.sqrt(3) / 2 < bound <= step * np.sqrt(3) / 2 + 2.0**-31 < 0.01 / 1000
    moved = np.linalg.norm(at - p, axis=1)
    assert moved.max() <= bound
    assert np.array_equal(at / step, np.rint(at / step))  # on the grid, exactly
    # the floats end in zero bits: at least 52 - (7 + 17) of them here
    low = at.view(np.int64) & ((1 << 20) - 1)
    assert not low.any()


def test_twins_merges_and_few_stay():
    p = _points(40, 2)
    p[1] = p[0] + 1e-9  # a twin of vertex 0
    lead = np.arange(len(p))
    lead[1] = 0
    step = 2.0 ** (np.floor(np.log2(0.1)) - assembly.FINE_BITS)
    p[3] = np.rint(p[2] / step) * step + step * 0.3  # lands where vertex 2 lands
    may = np.ones(len(p), bool)
    may[5] = False  # kept by the caller (exact curve faults, ladder)
    fine, at, bound = assembly._fine_points(p, lead, may, 0.1)
    assert not fine[[2, 3, 5]].any()
    assert fine[6:].all()
    assert np.array_equal(at[6:] / step, np.rint(at[6:] / step))
    # the twins move as one: the first to the grid, the other keeps its offset,
    # rounded to a multiple of 2**TWIN_EXP (what format 2.5 stores)
    assert fine[[0, 1]].all()
    assert np.array_equal(at[0] / step, np.rint(at[0] / step))
    assert np.abs((at[1] - at[0]) - (p[1] - p[0])).max() <= 2.0**-33 + 2 * np.spacing(150.0)
    assert (np.sqrt(((at[fine] - p[fine]) ** 2).sum(-1)) <= bound).all()
    # fewer than MIN_FINE to move: none move
    few = np.zeros(len(p), bool)
    few[6 : 6 + assembly.MIN_FINE - 1] = True
    assert not assembly._fine_points(p, lead, few, 0.1)[0].any()
    # a twin cluster with a vertex that may not move stays whole
    held = may.copy()
    held[1] = False
    fine, at, _ = assembly._fine_points(p, lead, held, 0.1)
    assert not fine[[0, 1]].any() and fine[6:].all()
    # twins at one point stay at one point; twins apart stay apart
    q = p.copy()
    q[1] = q[0]
    fine, at, _ = assembly._fine_points(q, lead, may, 0.1)
    assert fine[[0, 1]].all() and np.array_equal(at[0], at[1])
    # a move that would bring two clusters within TWIN_VERTEX leaves both where they are
    r = p.copy()
    r[7] = np.rint(r[6] / step) * step + [step * 0.49, 0, 0]
    r[6] = np.rint(r[6] / step) * step - [step * 0.49, 0, 0]
    fine, at, _ = assembly._fine_points(r, lead, may, 0.1)
    assert not fine[[6, 7]].any()
    # lossless: nothing
    assert not assembly._fine_points(p, lead, may, 0.0)[0].any()


def test_micro_grid_for_vertices_that_would_stay():
    """MICRO_BITS: what stays off both grids is still rounded, by under 1e-9 mm here."""
    p = _points(50, 4)
    lead = np.arange(len(p))
    fine, at, bound = assembly._fine_points(
        p, lead, np.ones(len(p), bool), 0.01, assembly.MICRO_BITS
    )
    assert fine.all() and bound < 1e-9  # the half diagonal, and a twin offset's rounding
    assert np.linalg.norm(at - p, axis=1).max() <= bound
    step = 2.0 ** (np.floor(np.log2(0.01)) - assembly.MICRO_BITS)
    assert np.array_equal(at / step, np.rint(at / step))


def test_point_ids_are_bit_for_bit():
    p = np.array([[0.0, 1.0, 2.0], [-0.0, 1.0, 2.0], [0.0, 1.0, 2.0], [0.0, 1.0, 2.5]])
    ids = assembly._point_ids(p)
    assert ids[0] == ids[2] and len({ids[0], ids[1], ids[3]}) == 3
    assert len(assembly._point_ids(np.zeros((0, 3)))) == 0


def test_coarse_grid_where_the_features_leave_room():
    """``_fine_levels``: a vertex whose finest feature is at least COARSE_ROOM
    times the coarse grid's bound goes to the coarse grid (4 bits a
    coordinate fewer), the others to the fine one; each within its own
    bound, which is the coarse feature's share at most."""
    tol = 0.1
    p = _points(120, 3)
    lead = np.arange(len(p))
    e = np.floor(np.log2(tol))
    coarse, fine = 2.0 ** (e - assembly.COARSE_BITS), 2.0 ** (e - assembly.FINE_BITS)
    scale = np.full(len(p), tol)
    scale[60:] = coarse  # features finer than the coarse grid's room
    may = np.ones(len(p), bool)
    moved, at, bound = assembly._fine_levels(p, lead, may, scale, tol)
    assert moved.all()
    assert np.array_equal(at[:60] / coarse, np.rint(at[:60] / coarse))
    assert not np.array_equal(at[60:] / coarse, np.rint(at[60:] / coarse))
    assert np.array_equal(at[60:] / fine, np.rint(at[60:] / fine))
    d = np.linalg.norm(at - p, axis=1)
    assert (d <= bound).all()
    assert np.allclose(bound[:60], coarse * np.sqrt(3) / 2, rtol=1e-6)
    assert np.allclose(bound[60:], fine * np.sqrt(3) / 2, rtol=1e-6)
    assert (bound[:60] * assembly.COARSE_ROOM <= scale[:60]).all()
    # a vertex the caller keeps stays, bound 0
    may[0] = False
    moved, at, bound = assembly._fine_levels(p, lead, may, scale, tol)
    assert not moved[0] and np.array_equal(at[0], p[0]) and bound[0] == 0.0
    # a coarse point that would land on another vertex's point leaves that one where it is
    q = p.copy()
    q[1] = np.rint(q[2] / coarse) * coarse  # vertex 1 sits where vertex 2 would land
    moved, at, _ = assembly._fine_levels(q, lead, np.ones(len(q), bool), scale, tol)
    assert len({tuple(x) for x in at.tolist()}) == len(at)


def test_fewer_than_min_fine_when_told():
    """``least``: the caller's own minimum count (crowded vertices round however few)."""
    p = _points(5, 6)
    lead = np.arange(len(p))
    may = np.ones(len(p), bool)
    assert not assembly._fine_levels(p, lead, may, np.full(len(p), 0.1), 0.1)[0].any()
    moved, at, bound = assembly._fine_levels(p, lead, may, np.full(len(p), 0.1), 0.1, 1)
    assert moved.all() and (np.linalg.norm(at - p, axis=1) <= bound).all()


def _sliver_part(path):
    """A rotated machined block whose chamfer meets its pocket's fillets in
    sliver edges 0.0072 mm long: 14 vertices two by two closer than the
    vertex grid's step at 0.1 mm, all beside lines and circles."""
    import cadquery as cq

    p = (
        cq.Workplane()
        .box(80, 50, 20)
        .faces(">Z")
        .workplane()
        .rect(30, 12)
        .cutBlind(-8)
        .edges("|Z")
        .fillet(3)
        .faces(">Y")
        .workplane()
        .circle(5)
        .cutThruAll()
        .edges(">Z")
        .chamfer(1)
    )
    cq.exporters.export(cq.Workplane().add(p.val().rotate((0, 0, 0), (1, 2, 3), 27)), str(path))
    return path


def test_crowded_vertices_round_finer(tmp_path_factory):
    """Vertices that would land on one vertex-grid point go to a binary grid
    instead of staying floats (``_snap_vertices``: crowded), however few and
    beside exact curves: at 0.1 mm the part came out larger than at 0.01 mm
    (1,853 bytes against 1,647, 14 float vertices)."""
    from nurbscomp import container
    from nurbscomp.streams import BlockReader

    from .conftest import assert_comes_back, compressed_part

    sizes, kinds = [], []
    for tol in (0.01, 0.1):
        src, nzc, _ = compressed_part(tmp_path_factory, _sliver_part, f"sliver{tol:g}", tol)
        data = nzc.read_bytes()
        sizes.append(len(data))
        kinds.append(BlockReader(container.unpack(data).get("VERT"), "VERT").ints())
        assert_comes_back(src, nzc, tol)
    assert sizes[1] <= sizes[0], sizes
    assert (kinds[1] != 0).all()  # no vertex stays a float
    assert (kinds[1] == 3).sum() >= 8  # the crowded ones, on the binary grid
