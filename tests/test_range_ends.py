"""Stored 3-D ranges cut a hair short of their curve's end go to that end
(``encode.pcurves.natural_ends``), within tol along the curve
(``curve_speed``)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from nurbscomp import bspline, occ
from nurbscomp.encode import pcurves
from nurbscomp.model import EC, BSplineCurve, RepKind, ShapeType, below
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
    rational = replace(g, weights=np.ones(n))
    assert pcurves.curve_speed(rational) == np.inf  # no bound claimed


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
