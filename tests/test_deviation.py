"""The certified move of a coded row measured on its refined error net
(``encode.deviation``): an upper bound of the move at every parameter, never
above the largest pole error, and what the codec's search does with it."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from nurbscomp import bspline, codec
from nurbscomp.coons import full_knots
from nurbscomp.encode import deviation, nets
from nurbscomp.encode import weights as W
from nurbscomp.model import BSplineCurve, BSplineSurface


def _surface(rng: np.random.Generator, rational: bool) -> BSplineSurface:
    poles = rng.normal(size=(7, 5, 3)) * [3.0, 2.0, 0.5]
    poles[..., 0] += np.arange(7)[:, None] * 10.0
    poles[..., 1] += np.arange(5)[None, :] * 8.0
    w = rng.uniform(0.6, 1.8, (7, 5)) if rational else None
    uk, um = np.array([0.0, 0.2, 0.45, 0.5, 1.0]), np.array([4, 1, 1, 1, 4])
    vk, vm = np.array([-2.0, 0.5, 3.0]), np.array([4, 1, 4])
    return BSplineSurface(poles, w, uk, vk, um, vm, 3, 3, False, False)


def _values(g: BSplineSurface, n: int = 161) -> np.ndarray:
    """Points of ``g`` on an n x n grid of its parameters."""
    tu, tv = full_knots(g.uknots, g.umults), full_knots(g.vknots, g.vmults)
    xu = np.linspace(g.uknots[0], g.uknots[-1], n)
    xv = np.linspace(g.vknots[0], g.vknots[-1], n)
    w = np.ones(g.poles.shape[:2]) if g.weights is None else g.weights
    h = np.concatenate([g.poles * w[..., None], w[..., None]], -1)
    rows = np.stack([bspline.points(tv, h[i], g.vdegree, xv) for i in range(len(h))])
    p = np.stack([bspline.points(tu, rows[:, k], g.udegree, xu) for k in range(n)])
    return p[..., :3] / p[..., 3:]


@pytest.mark.parametrize("rational", [False, True])
@pytest.mark.parametrize("seed", range(4))
def test_the_refined_bound_holds_at_every_point(seed: int, rational: bool) -> None:
    """Poles moved at random (within a cube, as a quantizer moves them): the
    measured move is at least every evaluated point's, at most the largest
    pole error, and close to the evaluated largest move."""
    rng = np.random.default_rng(seed)
    g = _surface(rng, rational)
    moved = replace(g, poles=g.poles + rng.uniform(-0.01, 0.01, g.poles.shape))
    true = float(np.sqrt(((_values(moved) - _values(g)) ** 2).sum(-1)).max())
    bound = deviation.moved(moved, g)
    pole = float(np.sqrt(((moved.poles - g.poles) ** 2).sum(-1)).max())
    assert true <= bound <= pole
    assert bound <= 1.05 * true  # eight cuts a span: within a few per cent
    assert W.moved(moved, g) == bound  # same weights: no weight term


def test_a_rational_row_is_refined_in_homogeneous_coordinates() -> None:
    """With weights far from one, the bound still holds (it is measured on
    the errors weighted by the decoded row's weights)."""
    rng = np.random.default_rng(7)
    g = _surface(rng, True)
    g.weights[2:5, 1:4] = 25.0  # type: ignore[index]
    e = np.zeros_like(g.poles)
    e[3, 2] = [0.0, 0.0, 0.02]  # under a heavy weight
    e[0, 4] = [0.01, 0.0, 0.0]  # a corner
    moved = replace(g, poles=g.poles + e)
    true = float(np.sqrt(((_values(moved) - _values(g)) ** 2).sum(-1)).max())
    assert true <= deviation.moved(moved, g) <= 0.02


def test_a_curve_and_a_periodic_row() -> None:
    """A clamped curve is refined (a bound at most its pole bound, at least
    the evaluated move); a periodic one keeps the pole bound."""
    rng = np.random.default_rng(3)
    p = np.cumsum(rng.normal(size=(9, 3)), axis=0)
    k, m = np.array([0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0]), np.array([4, 1, 1, 1, 1, 1, 4])
    c = BSplineCurve(p, None, k, m, 3, False)
    e = rng.uniform(-0.01, 0.01, p.shape)
    moved = BSplineCurve(p + e, None, k, m, 3, False)
    x = np.linspace(0.0, 6.0, 2001)
    t = full_knots(k, m)
    true = float(np.sqrt(((bspline.points(t, e, 3, x)) ** 2).sum(-1)).max())
    pole = float(np.sqrt(((moved.poles - p) ** 2).sum(-1)).max())
    assert true <= deviation.moved(moved, c) <= pole
    per = BSplineCurve(p, None, np.arange(10.0), np.ones(10, int), 3, True)
    assert deviation.matrices(per) is None
    assert deviation.moved(BSplineCurve(p + e, None, per.knots, per.mults, 3, True), per) == pole


def test_refinement_rows_are_convex_weights() -> None:
    """Each row of the subdivision matrix is non-negative and sums to one,
    and the refined poles are those of the same curve (points agree)."""
    k, m = np.array([0.0, 0.3, 1.0]), np.array([3, 2, 3])
    a = bspline.subdivision(k, m, 2, 5)
    assert (a >= 0).all() and np.allclose(a.sum(1), 1.0)
    rng = np.random.default_rng(1)
    p = rng.normal(size=(a.shape[1], 2))
    cuts = k[:-1, None] + np.diff(k)[:, None] * (np.arange(1, 5) / 5)[None]
    new = np.sort(np.r_[np.repeat(k, m), cuts.ravel()])
    x = np.linspace(0, 1, 57)
    assert np.allclose(bspline.points(full_knots(k, m), p, 2, x), bspline.points(new, a @ p, 2, x))


def test_the_search_takes_coarser_codes_within_the_limit() -> None:
    """A dense smooth net: with the refined measure the search's code costs
    no more, and its decoded row is within the limit by the refined bound
    and by evaluated points (its largest pole error may be past it)."""
    rng = np.random.default_rng(5)
    n = 14
    u = np.linspace(0, 1, n)
    poles = np.stack(np.meshgrid(u * 40, u * 30, indexing="ij"), -1)
    z = 3 * np.sin(poles[..., :1] / 7) * np.cos(poles[..., 1:] / 9)
    poles = np.concatenate([poles, z + rng.normal(0, 1e-3, z.shape)], -1)
    kn = np.linspace(0, 1, n - 2)
    mu = np.r_[4, np.ones(n - 4, int), 4]
    g = BSplineSurface(poles, None, kn, kn, mu, mu, 3, 3, False, False)
    tol = 0.01
    plain, _ = nets._net_code(g, tol, codec.SURFACE_SEARCH, None, tol, spread=False)
    code, net = nets._net_code(g, tol, codec.SURFACE_SEARCH, None, tol)
    assert code.bits <= plain.bits
    decoded = BSplineSurface(net, None, kn, kn, mu, mu, 3, 3, False, False)
    assert deviation.moved(decoded, g) <= tol
    true = float(np.sqrt(((_values(decoded, 81) - _values(g, 81)) ** 2).sum(-1)).max())
    assert true <= tol
