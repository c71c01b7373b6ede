"""Inner knots within tol (``encode.knots``): Boehm's insertion, rounding, the
certified bound against evaluated points, and the plan's choices."""

from __future__ import annotations

from pathlib import Path

import cadquery as cq
import numpy as np
import pytest

from nurbscomp import bspline, container, occ, pipeline
from nurbscomp.coons import full_knots
from nurbscomp.encode import knots as K
from nurbscomp.model import BSplineCurve, BSplineSurface
from nurbscomp.occ import topology

from .conftest import assert_comes_back, assert_step_keeps_floor


def _clamped(rng: np.random.Generator, n: int, deg: int, span: float) -> tuple:
    inner = n - deg - 1
    gaps = rng.uniform(0.5, 1.5, inner + 1)  # chord-length-like: uneven, none tiny
    k = np.cumsum(gaps)[:-1] / gaps.sum() * span
    return np.r_[0.0, k, span], np.r_[deg + 1, np.ones(inner, int), deg + 1]


def _curve(rng: np.random.Generator, n: int = 12, deg: int = 3) -> BSplineCurve:
    k, m = _clamped(rng, n, deg, 37.3)
    return BSplineCurve(rng.normal(size=(n, 3)) * 20, None, k + 4.1, m, deg, False)


def _surface(rng: np.random.Generator, nu: int = 9, nv: int = 7) -> BSplineSurface:
    (uk, um), (vk, vm) = _clamped(rng, nu, 3, 51.7), _clamped(rng, nv, 2, 8.9)
    poles = rng.normal(size=(nu, nv, 3)) * [30.0, 20.0, 4.0]
    return BSplineSurface(poles, None, uk, vk, um, vm, 3, 2, False, False)


def _curve_points(g: BSplineCurve, x: np.ndarray) -> np.ndarray:
    return bspline.points(full_knots(g.knots, g.mults), g.poles, g.degree, x)


def _surface_points(g: BSplineSurface, n: int = 61) -> np.ndarray:
    tu, tv = full_knots(g.uknots, g.umults), full_knots(g.vknots, g.vmults)
    xu = np.linspace(g.uknots[0], g.uknots[-1], n)
    xv = np.linspace(g.vknots[0], g.vknots[-1], n)
    rows = np.stack([bspline.points(tv, g.poles[i], g.vdegree, xv) for i in range(len(g.poles))])
    return np.stack([bspline.points(tu, rows[:, k], g.udegree, xu) for k in range(n)])


def test_insertion_keeps_every_point() -> None:
    rng = np.random.default_rng(1)
    g = _curve(rng)
    target = np.sort(np.r_[full_knots(g.knots, g.mults), g.knots[1:-1] + 0.01, g.knots[3]])
    poles = bspline.refine(g.knots, g.mults, g.poles, g.degree, target)
    assert len(poles) == len(target) - g.degree - 1
    x = np.linspace(g.knots[0], g.knots[-1], 501)
    a = _curve_points(g, x)
    b = bspline.points(target, poles, g.degree, x)
    assert np.abs(a - b).max() < 1e-12 * np.abs(g.poles).max()


@pytest.mark.parametrize("degree", [1, 2, 3, 5, 8, 11])
def test_refinement_band_is_the_oslo_matrix(degree: int) -> None:
    """The band (first column, degree + 1 weights) makes a matrix whose rows
    are non-negative and sum to one, and whose poles give the same curve,
    inner knots of every multiplicity included."""
    rng = np.random.default_rng(degree)
    for _ in range(20):
        inner = np.unique(rng.uniform(0.0, 1.0, int(rng.integers(0, 25))))
        knots = np.r_[0.0, inner, 1.0]
        mults = np.r_[degree + 1, rng.integers(1, degree + 1, len(inner)), degree + 1]
        flat = np.repeat(knots, mults)
        target = np.sort(np.r_[flat, rng.uniform(0.0, 1.0, int(rng.integers(0, 15)))])
        first, w = bspline.refinement(flat, target, degree)
        assert w.shape == (len(target) - degree - 1, degree + 1)
        assert (w >= 0).all() and np.allclose(w.sum(1), 1.0, atol=1e-13)
        assert first.min() >= 0 and first.max() + degree < len(flat) - degree - 1
        poles = rng.normal(size=(len(flat) - degree - 1, 3))
        new = bspline.refine(knots, mults, poles, degree, target)
        x = np.linspace(0.0, 1.0, 301)
        a = bspline.points(flat, poles, degree, x)
        assert np.abs(a - bspline.points(target, new, degree, x)).max() < 1e-11
    with pytest.raises(ValueError):  # new knots outside the old span
        bspline.refinement(flat, np.r_[-1.0, target], degree)


@pytest.mark.parametrize("unit", [False, True])
def test_rounding_keeps_ends_order_and_bits(unit: bool) -> None:
    rng = np.random.default_rng(2)
    k = np.r_[3.7, np.sort(rng.uniform(3.7, 91.3, 40)), 91.3]
    for bits in (8, 16, 30):
        r = K.rounded(k, bits, unit)
        assert r[0] == k[0] and r[-1] == k[-1]
        assert (np.abs(r - k)[1:-1] <= (k[-1] - k[0] if unit else k[1:-1]) * 2.0**-bits).all()
        if unit:  # mapped onto [0, 1] as the writer maps curves: short binary fractions
            q = (r - r[0]) / (r[-1] - r[0])
            # most: a span above 1 spaces the knots' floats wider than the places'
            assert (np.ldexp(q, bits) % 1 == 0).mean() > 0.6
        else:
            m, _ = np.frexp(r[1:-1])
            np.testing.assert_array_equal(np.ldexp(m, bits + 1) % 1, 0)


@pytest.mark.parametrize("seed", range(5))
def test_the_bound_holds_on_evaluated_points(seed: int) -> None:
    """Knots rounded: no evaluated point (same parameter) moves further than
    ``move`` says, and the bound is not loose by orders of magnitude."""
    rng = np.random.default_rng(seed)
    c = _curve(rng)
    for bits in (8, 12, 16):
        new = K.with_bits(c, bits)
        bound = K.move(c, new)
        assert np.isfinite(bound)
        x = np.linspace(c.knots[0], c.knots[-1], 4001)
        measured = np.linalg.norm(_curve_points(new, x) - _curve_points(c, x), axis=-1).max()
        assert 0 < measured <= bound
        assert measured > bound / 30
    s = _surface(rng)
    new_s = K.with_bits(s, 8)
    bound = K.move(s, new_s)
    measured = np.linalg.norm(_surface_points(new_s) - _surface_points(s), axis=-1).max()
    assert 0 < measured <= bound
    assert measured > bound / 30
    # the certified move of a coded row adds the knots' term (knots.moved)
    assert K.moved(new_s, s) == pytest.approx(bound)
    assert K.move(s, s) == 0.0 and K.term(s, s) == 0.0


def test_a_move_that_breaks_the_vector_is_refused() -> None:
    c = _curve(np.random.default_rng(7))
    k = c.knots.copy()
    k[2], k[3] = k[3], k[2]
    assert K.move(c, BSplineCurve(c.poles, None, k, c.mults, c.degree, False)) == np.inf
    periodic = BSplineCurve(c.poles, None, c.knots, c.mults, c.degree, True)
    assert K.need(periodic, 1.0) is None


@pytest.mark.parametrize("seed", range(4))
def test_the_bound_holds_on_a_rational_curve(seed: int) -> None:
    """Rational rows are refined in homogeneous coordinates; the bound adds
    what the refined weights' ratio moves (``weights.weight_bound``)."""
    rng = np.random.default_rng(10 + seed)
    c = _curve(rng)
    w = rng.uniform(0.4, 2.5, len(c.poles))
    r = BSplineCurve(c.poles, w, c.knots, c.mults, c.degree, False)
    new = K.with_bits(r, 10)
    bound = K.move(r, new)
    x = np.linspace(c.knots[0], c.knots[-1], 4001)

    def pts(g: BSplineCurve) -> np.ndarray:
        assert g.weights is not None
        h = np.c_[g.poles * g.weights[:, None], g.weights]
        q = bspline.points(full_knots(g.knots, g.mults), h, g.degree, x)
        return q[:, :3] / q[:, 3:]

    measured = np.linalg.norm(pts(new) - pts(r), axis=-1).max()
    assert 0 < measured <= bound
    assert measured > bound / 100


def test_need_follows_the_limit() -> None:
    c = _curve(np.random.default_rng(3))
    fine, coarse = K.need(c, 1e-4), K.need(c, 1e-1)
    assert fine is not None and coarse is not None and fine > coarse
    for bits, lim in ((fine, 1e-4), (coarse, 1e-1)):
        assert K.move(c, K.with_bits(c, bits)) <= K.SHARE * lim


def test_the_plan_keeps_frozen_and_equal_vectors() -> None:
    rng = np.random.default_rng(4)
    curves = [_curve(rng) for _ in range(30)]
    twin = BSplineCurve(curves[0].poles + 1.0, None, curves[0].knots, curves[0].mults, 3, False)
    plan = K.plan([*((g, 0.01) for g in curves), (twin, 0.01)])
    assert plan, "thirty curves of random knots should pay for rounding"
    assert len({b for b, _ in plan.values()}) == 1  # one precision for all
    a, _ = K.apply(curves[0], plan, 0.01)
    b, _ = K.apply(twin, plan, 0.01)
    np.testing.assert_array_equal(a.knots, b.knots)  # equal in the source, equal after
    frozen = K.plan([*((g, 0.01) for g in curves), (twin, None)])
    assert curves[0].knots.tobytes() not in frozen
    assert curves[1].knots.tobytes() in frozen
    # evenly spaced vectors are the writer's already: nothing to plan
    even = BSplineCurve(curves[0].poles, None, np.linspace(0, 1, 10), curves[0].mults, 3, False)
    assert K.plan([(even, 0.01)]) == {}


def test_linked_rows_round_together_and_copies_map_onto_their_ends() -> None:
    rng = np.random.default_rng(5)
    curves = [_curve(rng) for _ in range(30)]
    lead, member = curves[0], curves[1]
    # the member keeps its knots (limit None): its leader's stay too, once linked
    plan = K.plan([*((g, 0.01) for g in curves[2:]), (lead, 0.01), (member, None)])
    assert lead.knots.tobytes() in plan
    linked = K.plan(
        [*((g, 0.01) for g in curves[2:]), (lead, 0.01), (member, None)], [(member, lead)]
    )
    assert lead.knots.tobytes() not in linked and curves[2].knots.tobytes() in linked
    # a copy takes its leader's knots mirrored and mapped onto its own ends
    own = np.array([2.0, 2.5, 4.0, 7.0])
    got = K.mapped(np.array([0.0, 0.1, 0.6, 1.0]), own, True)
    assert got[0] == 2.0 and got[-1] == 7.0
    np.testing.assert_allclose(got, [2.0, 4.0, 6.5, 7.0])
    # and the bound of such a copy maps the knots back before it compares them
    c = curves[3]
    shifted = BSplineCurve(
        c.poles, None, K.mapped(c.knots, c.knots - 5.0, False), c.mults, 3, False
    )
    assert K.term(c, shifted) == 0.0


def _loft(path: Path) -> Path:
    """A loft through three spline profiles: its B-spline face has chord-length
    knots (0.190307695229, 0.229162115976, …), and its boundary edges are
    iso-boundaries of it."""
    profiles = (
        [(0, 0), (10, 3), (22, -2), (35, 6), (50, 0)],
        [(0, 2), (12, 6), (20, 1), (38, 9), (50, 3)],
        [(2, 0), (14, 2), (25, -3), (36, 4), (48, 1)],
    )
    wp = cq.Workplane("XY")
    for i, pts in enumerate(profiles):
        if i:
            wp = wp.workplane(offset=15 - 3 * (i - 1))
        (x0, _), (x1, _) = pts[0], pts[-1]
        wp = wp.spline(pts).lineTo(x1, -20 + i).lineTo(x0, -20 + i).close()
    cq.exporters.export(wp.loft(ruled=False), str(path))
    return path


@pytest.fixture(scope="module")
def loft(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path, dict]:
    d = tmp_path_factory.mktemp("knots")
    src = _loft(d / "loft.step")
    nzc = d / "loft.nzc"
    return src, nzc, pipeline.compress_file(src, nzc, tol=0.01)


def test_a_loft_comes_back_within_tol_with_its_knots_rounded(loft) -> None:
    src, nzc, rep = loft
    assert rep["verified"] and rep["max_bound_mm"] <= 0.01
    source, _ = topology.shape_to_model(occ.read_cad(src).shape)
    back, _ = pipeline.decode(container.unpack(nzc.read_bytes()))
    moved = [  # (a surface mapped onto [0, 1] by pcurves.unit_surfaces moves too)
        (a, b)
        for a, b in zip(source.surfaces, back.surfaces)
        if isinstance(a, BSplineSurface)
        and len(a.uknots) > 2
        and not np.array_equal(K.mapped(b.uknots, a.uknots, False), a.uknots)
    ]
    assert moved, "the loft's chord-length knots should be rounded"
    for a, b in moved:  # rounded to one precision: the knots end in zeros
        assert _mantissa_bits(b.uknots[1:-1]) < _mantissa_bits(a.uknots[1:-1]) / 2
    # its iso-boundary edges took the rounded knots with it: one curve still
    sides = {b.uknots.tobytes() for _, b in moved} | {
        (b.uknots[-1] + b.uknots[0] - b.uknots[::-1]).tobytes() for _, b in moved
    }
    iso = [g for g in back.curves3d if isinstance(g, BSplineCurve) and g.knots.tobytes() in sides]
    assert iso
    assert_comes_back(src, nzc, 0.01, n=7)


def test_the_loft_keeps_the_step_floor(loft, tmp_path: Path) -> None:
    src, nzc, _ = loft
    assert_step_keeps_floor(occ.read_cad(src), nzc, tmp_path)


def _mantissa_bits(x: np.ndarray) -> int:
    """Significant bits after the leading one, summed."""
    m, _ = np.frexp(np.abs(x))
    bits = 0
    for v in m.tolist():
        k = 0
        while v != int(v) and k < 60:
            v, k = v * 2, k + 1
        bits += k
    return bits
