"""Inner knots removed within tol (``encode.removal``): the certified bound
against evaluated points, what the removal keeps, and a dense surface that
comes back with fewer poles."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import cadquery as cq
import numpy as np
import pytest

from nurbscomp import bspline, container, occ, pipeline
from nurbscomp.coons import full_knots
from nurbscomp.encode import knots as K
from nurbscomp.encode import removal
from nurbscomp.model import BSplineCurve, BSplineSurface
from nurbscomp.occ import topology

from .conftest import assert_comes_back, wavy_plate


def _coarse(rng: np.random.Generator, rational: bool) -> BSplineSurface:
    """A bicubic 6 x 5 net over a chord-length-like vector."""
    poles = rng.normal(size=(6, 5, 3)) * [30.0, 20.0, 4.0]
    poles[..., 0] += np.arange(6)[:, None] * 40.0
    poles[..., 1] += np.arange(5)[None, :] * 30.0
    w = rng.uniform(0.7, 1.4, (6, 5)) if rational else None
    uk, um = np.array([0.0, 13.1, 29.4, 51.7]), np.array([4, 1, 1, 4])
    vk, vm = np.array([2.0, 7.25, 10.9]), np.array([4, 1, 4])
    return BSplineSurface(poles, w, uk, vk, um, vm, 3, 3, False, False)


def _dense(g: BSplineSurface, noise: float, rng: np.random.Generator) -> BSplineSurface:
    """``g`` with knots inserted (the same surface, more poles), its poles then
    moved by up to ``noise`` (a fit's residue)."""
    new_u = np.sort(np.r_[g.uknots, [4.0, 9.0, 20.0, 22.5, 40.0, 45.0]])
    new_v = np.sort(np.r_[g.vknots, [4.0, 5.5, 9.0]])
    um = np.r_[4, np.ones(len(new_u) - 2, int), 4]
    vm = np.r_[4, np.ones(len(new_v) - 2, int), 4]
    h = (
        g.poles
        if g.weights is None
        else np.concatenate([g.poles * g.weights[..., None], g.weights[..., None]], -1)
    )
    h = bspline.refine(g.uknots, g.umults, K.homogeneous(g), 3, np.repeat(new_u, um))
    h = np.swapaxes(
        bspline.refine(g.vknots, g.vmults, np.swapaxes(h, 0, 1), 3, np.repeat(new_v, vm)), 0, 1
    )
    if g.weights is None:
        poles, w = h, None
    else:
        poles, w = h[..., :3] / h[..., 3:], h[..., 3]
    poles = poles + rng.uniform(-noise, noise, poles.shape)
    return BSplineSurface(poles, w, new_u, new_v, um, vm, 3, 3, False, False)


def _points(g: BSplineSurface, n: int = 41) -> np.ndarray:
    tu, tv = full_knots(g.uknots, g.umults), full_knots(g.vknots, g.vmults)
    xu = np.linspace(g.uknots[0], g.uknots[-1], n)
    xv = np.linspace(g.vknots[0], g.vknots[-1], n)
    h = (
        g.poles
        if g.weights is None
        else np.concatenate([g.poles * g.weights[..., None], g.weights[..., None]], -1)
    )
    rows = np.stack([bspline.points(tv, h[i], g.vdegree, xv) for i in range(len(h))])
    p = np.stack([bspline.points(tu, rows[:, k], g.udegree, xu) for k in range(n)])
    return p if g.weights is None else p[..., :3] / p[..., 3:]


@pytest.mark.parametrize("rational", [False, True])
@pytest.mark.parametrize("seed", range(3))
def test_removed_knots_stay_within_the_certified_bound(seed: int, rational: bool) -> None:
    """Evaluated points (same parameters) move no further than the certified
    move, which is within the budget; most of the inserted knots go."""
    rng = np.random.default_rng(seed)
    dense = _dense(_coarse(rng, rational), 1e-4, rng)
    budget = 0.01
    out = removal.removed(dense, budget)
    assert out is not None
    thin, bound = out
    assert bound <= budget
    assert K.moved(thin, dense) == bound
    measured = np.linalg.norm(_points(thin) - _points(dense), axis=-1).max()
    assert measured <= bound
    assert thin.poles.shape[0] * thin.poles.shape[1] <= 0.6 * dense.poles[..., 0].size
    # clamped ends: corners and the first and last rows of each direction stay
    for a, b in ((thin.poles[0], dense.poles[0]), (thin.poles[:, -1], dense.poles[:, -1])):
        if a.shape == b.shape:
            np.testing.assert_allclose(a, b, rtol=0, atol=1e-9)
    for i, j in ((0, 0), (0, -1), (-1, 0), (-1, -1)):
        np.testing.assert_allclose(thin.poles[i, j], dense.poles[i, j], rtol=0, atol=1e-9)


def test_a_surface_with_no_spare_knot_keeps_them() -> None:
    """A net whose every knot carries shape (noise far above the budget) loses
    none, and a tiny budget removes nothing."""
    rng = np.random.default_rng(5)
    g = _coarse(rng, False)
    assert removal.removed(g, 1e-9) is None
    assert removal.removed(_dense(g, 5.0, rng), 0.01) is None


def test_only_the_directions_asked_lose_knots() -> None:
    rng = np.random.default_rng(8)
    dense = _dense(_coarse(rng, False), 0.0, rng)
    out = removal.removed(dense, 0.01, axes=(1,))
    assert out is not None
    thin, _ = out
    np.testing.assert_array_equal(thin.uknots, dense.uknots)
    assert len(thin.vknots) < len(dense.vknots)
    # v's first and last columns are the sides along u: they keep their poles
    np.testing.assert_allclose(thin.poles[:, 0], dense.poles[:, 0], rtol=0, atol=1e-9)


def test_raised_refuses_rows_that_are_not_a_part() -> None:
    rng = np.random.default_rng(2)
    dense = _dense(_coarse(rng, False), 0.0, rng)
    thin, _ = removal.removed(dense, 0.01) or (None, 0)
    assert thin is not None
    assert K.raised(thin, dense) is not None
    moved_knot = thin.uknots.copy()
    moved_knot[1] += 0.5  # not a knot of the source
    other = BSplineSurface(
        thin.poles, None, moved_knot, thin.vknots, thin.umults, thin.vmults, 3, 3, False, False
    )
    assert K.raised(other, dense) is None
    # the source has no fewer poles than itself: nothing to raise
    assert K.raised(dense, dense) is None


def _dense_face(path: Path) -> Path:
    """A smooth wavy plate fitted through a 40 x 40 grid of points to 1e-6
    mm (``makeSplineApprox``): far more poles than its shape needs at 0.1 mm."""
    return wavy_plate(path, 40, (80.0, 60.0), (4.0, 25.0, 20.0), 1e-6, 3)


def _coded_pairs(src: Path, tmp_path: Path, bound: str, table: str) -> list[tuple[Any, Any]]:
    """``src`` compressed at 0.1 mm, verified within ``bound`` (a report key)
    and decoded: the (source, decoded) rows of ``table`` (a model field)."""
    nzc = tmp_path / "out.nzc"
    rep = pipeline.compress_file(src, nzc, tol=0.1)
    assert rep["verified"] and rep[bound] <= 0.1
    assert_comes_back(src, nzc, 0.1, n=7)
    back, _ = pipeline.decode(container.unpack(nzc.read_bytes()))
    source, _ = topology.shape_to_model(occ.read_cad(src).shape)
    return list(zip(getattr(source, table), getattr(back, table)))


def test_a_dense_fitted_face_comes_back_with_fewer_poles(tmp_path: Path) -> None:
    pairs = [
        (a, b)
        for a, b in _coded_pairs(
            _dense_face(tmp_path / "plate.step"), tmp_path, "max_bound_mm", "surfaces"
        )
        if isinstance(a, BSplineSurface) and isinstance(b, BSplineSurface)
    ]
    assert pairs
    assert all(b.poles[..., 0].size < a.poles[..., 0].size / 2 for a, b in pairs)


def _dense_curve(rng: np.random.Generator, rational: bool, noise: float) -> BSplineCurve:
    """A cubic of 7 poles over a chord-length-like vector with 9 knots
    inserted (the same curve, more poles), its poles then moved by up to
    ``noise``."""
    poles = np.cumsum(rng.normal(size=(7, 3)) * [20.0, 15.0, 5.0] + [30.0, 0.0, 0.0], 0)
    w = rng.uniform(0.7, 1.4, 7) if rational else None
    k, mu = np.array([0.0, 11.5, 20.25, 37.0, 48.5]), np.array([4, 1, 1, 1, 4])
    coarse = BSplineCurve(poles, w, k, mu, 3, False)
    new_k = np.sort(np.r_[k, [3.0, 6.5, 15.0, 17.0, 26.0, 30.5, 41.0, 44.0, 46.0]])
    new_m = np.r_[4, np.ones(len(new_k) - 2, int), 4]
    h = bspline.refine(k, mu, K.homogeneous(coarse), 3, np.repeat(new_k, new_m))
    if rational:
        p, w = h[:, :3] / h[:, 3:], h[:, 3]
    else:
        p, w = h, None
    return BSplineCurve(p + rng.uniform(-noise, noise, p.shape), w, new_k, new_m, 3, False)


def _curve_points(g: BSplineCurve, n: int = 401) -> np.ndarray:
    x = np.linspace(g.knots[0], g.knots[-1], n)
    p = bspline.points(full_knots(g.knots, g.mults), K.homogeneous(g), g.degree, x)
    return p if g.weights is None else p[:, :3] / p[:, 3:]


@pytest.mark.parametrize("rational", [False, True])
@pytest.mark.parametrize("seed", range(3))
def test_a_curve_loses_knots_within_the_certified_bound(seed: int, rational: bool) -> None:
    """A 3-D curve's inner knots go as a surface's do: evaluated points move no
    further than the certified move, within the budget; its end poles stay
    (the vertices pinned to them see the same ends)."""
    rng = np.random.default_rng(seed)
    dense = _dense_curve(rng, rational, 1e-4)
    out = removal.removed(dense, 0.01)
    assert out is not None
    thin, bound = out
    assert bound <= 0.01 and K.moved(thin, dense) == bound
    assert np.linalg.norm(_curve_points(thin) - _curve_points(dense), axis=-1).max() <= bound
    assert len(thin.poles) <= len(dense.poles) - 6
    for i in (0, -1):
        np.testing.assert_allclose(thin.poles[i], dense.poles[i], rtol=0, atol=1e-9)
    # a curve whose every knot carries shape keeps them
    assert removal.removed(_dense_curve(rng, rational, 5.0), 0.01) is None


def _spline_plate(path: Path) -> Path:
    """A flat plate bounded by a closed spline through 48 points of a smooth
    wavy loop: one planar face and one interpolated B-spline edge of some 50
    poles (far more than it needs at 0.1 mm), not the side of any coded
    surface and sharing its knot vector with no other row."""
    t = np.linspace(0.0, 2 * np.pi, 48, endpoint=False)
    r = 40.0 + 3.0 * np.sin(3 * t)
    pts = [(float(a), float(b)) for a, b in zip(r * np.cos(t), 0.7 * r * np.sin(t))]
    wire = cq.Workplane("XY").spline(pts, periodic=False).close().wires().val()
    cq.exporters.export(cq.Workplane().add(cq.Face.makeFromWires(wire)), str(path))
    return path


def test_a_dense_spline_edge_comes_back_with_fewer_poles(tmp_path: Path) -> None:
    src = _spline_plate(tmp_path / "plate.step")
    pairs = [
        (a, b)
        for a, b in _coded_pairs(src, tmp_path, "max_curve_bound_mm", "curves3d")
        if isinstance(a, BSplineCurve) and isinstance(b, BSplineCurve) and len(a.poles) > 20
    ]
    assert pairs
    assert all(len(b.poles) < len(a.poles) / 2 for a, b in pairs)


@pytest.mark.parametrize("rational", [False, True])
@pytest.mark.parametrize("seed", range(3))
def test_a_reduced_curve_with_rounded_knots_is_within_its_bridged_bound(
    seed: int, rational: bool
) -> None:
    """Knots removed, then those left rounded (``knots.apply_reduced``): the
    vector is no longer a part of the source's, so the bound refines both
    rows onto the union of their vectors (``knots.bridged``), and evaluated
    points move no further.  On a row whose vector is a part of the
    source's, it agrees with the bound on the source's knots."""
    rng = np.random.default_rng(seed)
    dense = _dense_curve(rng, rational, 1e-4)
    out = removal.removed(dense, 0.01)
    assert out is not None
    thin, _ = out
    assert abs(K.bridged(thin, dense) - K.moved(thin, dense)) <= 1e-9
    coarse = BSplineCurve(
        thin.poles, thin.weights, K.rounded(thin.knots, 5, True), thin.mults, 3, False
    )
    assert not np.array_equal(coarse.knots, thin.knots)
    assert K.raised(coarse, dense) is None  # not on a part of the source's knots
    bound = K.moved(coarse, dense)
    assert np.isfinite(bound) and bound == K.bridged(coarse, dense)
    assert np.linalg.norm(_curve_points(coarse) - _curve_points(dense), axis=-1).max() <= bound
    # a rational row against a plain one has no such bound
    plain = BSplineCurve(coarse.poles, None, coarse.knots, coarse.mults, 3, False)
    assert rational == (K.bridged(plain, dense) == float("inf"))


@pytest.mark.parametrize("n, degree", [(132, 1), (150, 3), (300, 8), (200, 14)])
def test_banded_fit_is_the_dense_fit(n: int, degree: int) -> None:
    """From ``BANDED_MIN`` inner poles a fit solves the band's normal
    equations; it gives the dense least-squares poles to rounding, with a knot
    removed anywhere, the ends held."""
    rng = np.random.default_rng(n + degree)
    inner = np.sort(rng.uniform(0.0, 1.0, n - degree - 1))
    full = np.concatenate([[0.0] * (degree + 1), inner, [1.0] * (degree + 1)])
    for gone in (degree + 1, degree + 1 + n // 3, len(full) - degree - 2):
        band = removal._insertion(np.delete(full, gone), full, degree)
        assert band[2] - 2 >= removal.BANDED_MIN
        h = rng.normal(size=(n, 4)) * 50.0
        a = removal._dense(*band)
        rhs = h - np.outer(a[:, 0], h[0]) - np.outer(a[:, -1], h[-1])
        dense = np.linalg.lstsq(a[:, 1:-1], rhs, rcond=None)[0]
        fit = removal._fit(h, *band)
        assert np.array_equal(fit[[0, -1]], h[[0, -1]])
        assert np.abs(fit[1:-1] - dense).max() < 1e-9


def test_a_long_curve_of_high_degree_loses_knots() -> None:
    """A curve of some 400 poles and degree 8 (as an offset's approximation
    has) that is a curve of 13 poles with knots inserted loses most of them
    within its budget (to 130 of 403), the move certified (the band's fits, O(n·p²) each)."""
    rng = np.random.default_rng(5)
    k = np.r_[0.0, np.sort(rng.uniform(0.05, 0.95, 4)), 1.0]
    m = np.r_[9, np.ones(4, int), 9]
    fine_k = np.unique(np.r_[k, rng.uniform(0.0, 1.0, 390)])
    fine_m = np.r_[9, np.ones(len(fine_k) - 2, int), 9]
    a = removal._dense(*removal._insertion(np.repeat(k, m), np.repeat(fine_k, fine_m), 8))
    poles = a @ (rng.normal(size=(a.shape[1], 3)) * 20.0)
    fine = BSplineCurve(poles, None, fine_k, fine_m, 8, False)
    assert len(poles) > 300
    out = removal.removed(fine, 1e-6)
    assert out is not None
    reduced, moved = out
    assert moved <= 1e-6
    assert len(reduced.poles) < len(poles) // 2
