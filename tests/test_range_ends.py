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
