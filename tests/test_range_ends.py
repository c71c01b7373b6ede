"""Stored 3-D ranges cut a hair short of their curve's end go to that end
(``encode.pcurves.natural_ends``), within tol along the curve
(``curve_speed``)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from nurbscomp import bspline, occ
from nurbscomp.encode import pcurves
from nurbscomp.model import EC, REBUILD, BSplineCurve, RepKind, ShapeType, below
from nurbscomp.rules import ranges

from .conftest import SAMPLES


@pytest.mark.parametrize("seed", range(5))
def test_speed_bounds_the_derivative(seed: int) -> None:
    rng = np.random.default_rng(seed)
    p, n = int(rng.integers(1, 5)), int(rng.integers(6, 12))
    inner = np.sort(rng.uniform(0, 3, n - p - 1))
    knots = np.r_[0.0, inner, 3.0]
    mults = np.r_[p + 1, np.ones(len(inner), int), p + 1]
    g = BSplineCurve(rng.normal(size=(n, 3)) * 10, None, knots, mults, p, False)
    t = np.linspace(0, 3, 20001)
    pts = bspline.points(np.repeat(knots, mults), g.poles, p, t)
    measured = (np.linalg.norm(np.diff(pts, axis=0), axis=-1) / np.diff(t)).max()
    bound = pcurves.curve_speed(g)
    assert measured <= bound * (1 + 1e-9)
    assert measured > bound / 20  # a bound, not a guess far above it
    w = rng.uniform(0.3, 3.0, n)
    rational = replace(g, weights=w)
    tw = np.linspace(0, 3, 40001)
    hom = bspline.points(np.repeat(knots, mults), np.c_[g.poles * w[:, None], w], p, tw)
    pts = hom[:, :3] / hom[:, 3:]
    measured = (np.linalg.norm(np.diff(pts, axis=0), axis=-1) / np.diff(tw)).max()
    assert measured <= pcurves.curve_speed(rational) * (1 + 1e-9)
    assert pcurves.curve_speed(replace(rational, weights=-w)) == np.inf  # no bound claimed


@pytest.fixture(scope="module")
def blob():
    """blob's first edge on a B-spline curve with a speed bound, used whole."""
    m, _ = occ.shape_to_model(occ.read_cad(SAMPLES / "blob.step").shape)
    reps, kinds = m.edge_reps, ranges.range_kinds(m)
    for q in np.flatnonzero(reps[:, EC.KIND] == RepKind.CURVE3D).tolist():
        g = m.curves3d[int(reps[q, EC.CURVE])]
        if kinds[q] == ranges.RANGE_NATURAL and np.isfinite(pcurves.curve_speed(g)):
            assert isinstance(g, BSplineCurve)
            return m, q, g
    raise AssertionError("blob has no such edge")


@pytest.mark.parametrize("cut, back", [(1e-9, True), (1e-2, False)])
def test_a_range_cut_short_goes_to_the_curve_end(blob, cut: float, back: bool) -> None:
    m, q, g = blob
    e = int(m.edge_reps[q, EC.EDGE])
    lo, hi = float(g.knots[0]), float(g.knots[-1])
    short = m.edge_rep_range.copy()
    mine = (m.edge_reps[:, EC.EDGE] == e) & (short == short[q]).all(-1)
    short[mine] = (lo, hi - cut * (hi - lo))
    m = replace(m, edge_rep_range=short)
    assert ranges.range_kinds(m)[q] == ranges.RANGE_STORED
    out = pcurves.natural_ends(m, 0.01)
    tidx = m.type_index()
    s = int(np.flatnonzero(m.shape_type == ShapeType.EDGE)[e])
    vs = [tidx[v] for v in below(m, s, ShapeType.VERTEX)]
    if back:
        np.testing.assert_array_equal(out.edge_rep_range[mine], [[lo, hi]] * int(mine.sum()))
        assert ranges.range_kinds(out)[q] == ranges.RANGE_NATURAL
        moved = cut * (hi - lo) * pcurves.curve_speed(g)
        assert (out.vertex_tol[vs] >= m.vertex_tol[vs] + moved).all()
    else:
        assert out is m


@pytest.fixture(scope="module")
def bracket():
    """bracket's first pcurve that is a B-spline over its whole edge, whose
    edge's 3-D curve has a speed bound."""
    m, _ = occ.shape_to_model(occ.read_cad(SAMPLES / "bracket.step").shape)
    reps = m.edge_reps
    for q in np.flatnonzero(reps[:, EC.KIND] == RepKind.ON_SURFACE).tolist():
        g = m.curves2d[int(reps[q, EC.CURVE])]
        e = int(reps[q, EC.EDGE])
        q3 = [p for p in np.flatnonzero(reps[:, EC.EDGE] == e).tolist() if reps[p, EC.KIND] == 0]
        if not isinstance(g, BSplineCurve) or g.periodic or g.bezier or len(q3) != 1:
            continue
        speed = pcurves.curve_speed(m.curves3d[int(reps[q3[0], EC.CURVE])])
        if np.isfinite(speed) and np.allclose(g.knots[[0, -1]], m.edge_rep_range[q], 0, 1e-12):
            return m, q, e, speed
    raise AssertionError("bracket has no such pcurve")


def test_a_stored_pcurve_short_of_its_range_is_stretched_onto_it(bracket) -> None:
    """A pcurve stored over a range that passes its end by more than BRepCheck
    allows (an edge that ``natural_ends`` took to its curve's end, from a STEP
    file that cut both a hair short): BRepCheck rejects it (InvalidRange)
    until ``stretch_short`` maps the pcurve onto the range and widens the
    edge's tolerance by what that moves."""
    m, q, e, speed = bracket
    g = m.curves2d[int(m.edge_reps[q, EC.CURVE])]
    assert isinstance(g, BSplineCurve)
    lo, hi = float(g.knots[0]), float(g.knots[-1])
    cut = 4e-7 * (hi - lo)  # past BRepCheck's 1e-9, within REACH_SLACK
    short_knots = lo + (g.knots - lo) * ((hi - cut - lo) / (hi - lo))
    short_knots[-1] = hi - cut
    curves2d = [*m.curves2d, replace(g, knots=short_knots)]  # a row of its own
    reps = m.edge_reps.copy()
    reps[q, EC.CURVE] = len(curves2d) - 1
    rng = m.edge_rep_range.copy()
    rng[m.edge_reps[:, EC.EDGE] == e] = (lo, hi)
    tol = m.edge_tol
    out = replace(m, curves2d=curves2d, edge_reps=reps, edge_rep_range=rng)
    assert occ.failures(occ.model_to_shape(m)) == (set(), set())
    assert occ.failures(occ.model_to_shape(out)) != (set(), set())  # its face, on a plane

    fixed = pcurves.stretch_short(out)
    assert occ.failures(occ.model_to_shape(fixed)) == (set(), set())
    h = fixed.curves2d[int(fixed.edge_reps[q, EC.CURVE])]
    assert isinstance(h, BSplineCurve) and (h.knots[0], h.knots[-1]) == (lo, hi)
    assert fixed.edge_tol[e] >= tol[e] + cut * speed
    others = np.arange(len(tol)) != e
    np.testing.assert_array_equal(fixed.edge_tol[others], out.edge_tol[others])
    assert pcurves.stretch_short(fixed) is fixed  # nothing left past its ends
    # a pcurve shared with another edge's representation is copied, not changed
    assert all(fixed.curves2d[i] is out.curves2d[i] for i in range(len(m.curves2d)))


def _cut(m, q: int, t: tuple[float, float]):
    """``m`` with the range of representation ``q`` and of its edge's
    representations that had the same set to ``t``, its pcurves computed by
    the decoder (as ``drop_pcurves`` leaves them), and their ranges zeros."""
    e = int(m.edge_reps[q, EC.EDGE])
    rng, reps = m.edge_rep_range.copy(), m.edge_reps.copy()
    mine = (reps[:, EC.EDGE] == e) & (rng == rng[q]).all(-1)
    rng[mine] = t
    pcs = (reps[:, EC.EDGE] == e) & np.isin(reps[:, EC.KIND], pcurves.PCURVE_KINDS)
    reps[pcs, EC.CURVE] = REBUILD
    rng[pcs] = 0.0
    return replace(m, edge_rep_range=rng, edge_reps=reps), e


def test_a_stored_range_is_rounded_inwards_within_its_share(blob) -> None:
    """``rounded_ranges``: a range cut mid-curve ends on multiples of a power
    of two that moves each end by at most RANGE_STEP·tol along the curve,
    inside the range it had (every pcurve reaches it); the edge's vertices
    cover the move; an edge in ``keep`` stays."""
    m, q, g = blob
    lo, hi = float(g.knots[0]), float(g.knots[-1])
    t = (lo + 0.1234567891234 * (hi - lo), lo + 0.8765432198765 * (hi - lo))
    cut, e = _cut(m, q, t)
    assert ranges.range_kinds(cut)[q] == ranges.RANGE_STORED
    tol = 0.01
    out = pcurves.rounded_ranges(cut, tol)
    new = out.edge_rep_range[q]
    speed = pcurves.curve_speed(g)
    step = 2.0 ** np.floor(np.log2(pcurves.RANGE_STEP * tol / speed))
    assert t[0] <= new[0] < new[1] <= t[1]
    np.testing.assert_array_equal(new % step, 0.0)
    moved = float(np.abs(new - np.array(t)).max()) * speed
    assert 0 < moved <= pcurves.RANGE_STEP * tol
    tidx = cut.type_index()
    s = int(np.flatnonzero(cut.shape_type == ShapeType.EDGE)[e])
    vs = [tidx[v] for v in below(cut, s, ShapeType.VERTEX)]
    assert (out.vertex_tol[vs] >= cut.vertex_tol[vs] + moved).all()
    others = np.ones(len(cut.edge_reps), bool)
    others[q] = False
    np.testing.assert_array_equal(out.edge_rep_range[others], cut.edge_rep_range[others])
    assert pcurves.rounded_ranges(cut, tol, keep={e}) is cut
    assert pcurves.rounded_ranges(out, tol) is out  # rounded once and for all


def test_a_stored_pcurve_over_its_own_range_keeps_the_edge(blob) -> None:
    """Moved with its edge, a pcurve stored over its own range would need its
    range stored too: ``rounded_ranges`` leaves such an edge alone, and
    rounds it once the pcurve is left to the decoder."""
    m, q, g = blob
    lo, hi = float(g.knots[0]), float(g.knots[-1])
    t = (lo + 0.1234567891234 * (hi - lo), lo + 0.8765432198765 * (hi - lo))
    cut, e = _cut(m, q, t)
    reps = cut.edge_reps.copy()
    p = next(
        p
        for p in np.flatnonzero(reps[:, EC.EDGE] == e).tolist()
        if reps[p, EC.KIND] == RepKind.ON_SURFACE
    )
    line = BSplineCurve(
        np.array([[0.0, 0.0], [1.0, 1.0]]), None, np.array(t), np.array([2, 2]), 1, False
    )
    reps[p, EC.CURVE] = len(cut.curves2d)
    rng = cut.edge_rep_range.copy()
    rng[p] = t
    kept = replace(cut, curves2d=[*cut.curves2d, line], edge_reps=reps, edge_rep_range=rng)
    assert ranges.range_kinds(kept)[p] == ranges.RANGE_NATURAL
    assert pcurves.rounded_ranges(kept, 0.01) is kept
    assert pcurves.rounded_ranges(cut, 0.01) is not cut
