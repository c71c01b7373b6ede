"""Degrees lowered within tol (``encode.removal.removed``, certified by
``encode.knots.lowered``): the raised form is the same curve, the bound holds
at evaluated points, a row of raised degree comes back down, and a part of
high-degree faces and edges comes back with fewer poles."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from nurbscomp import bspline, container, occ, pipeline
from nurbscomp.coons import full_knots
from nurbscomp.encode import knots as K
from nurbscomp.encode import removal
from nurbscomp.model import BSplineCurve, BSplineSurface
from nurbscomp.occ import topology

from .conftest import assert_comes_back, wavy_plate


def _random_curve(rng: np.random.Generator, degree: int) -> BSplineCurve:
    """A clamped curve of ``degree`` over an uneven vector, one double knot."""
    k = np.array([0.0, 3.5, 7.25, 9.0, 15.0])
    m = np.array([degree + 1, 1, 2, 1, degree + 1])
    n = int(m.sum()) - degree - 1
    poles = np.cumsum(rng.normal(size=(n, 3)) * [10.0, 8.0, 3.0] + [12.0, 0.0, 0.0], 0)
    return BSplineCurve(poles, None, k, m, degree, False)


def _curve_points(g: BSplineCurve, n: int = 601) -> np.ndarray:
    x = np.linspace(g.knots[0], g.knots[-1], n)
    return bspline.points(full_knots(g.knots, g.mults), g.poles, g.degree, x)


def _raised(g: BSplineCurve, to: int) -> BSplineCurve:
    """``g`` at degree ``to`` in its Bezier form: the same curve, more poles."""
    e = bspline.elevation(g.knots, g.mults, g.degree, to)
    m = np.full(len(g.knots), to)
    m[[0, -1]] = to + 1
    return BSplineCurve(e @ g.poles, None, g.knots, m, to, False)


@pytest.mark.parametrize("seed", range(3))
@pytest.mark.parametrize("to", [3, 5, 8])
def test_the_raised_form_is_the_same_curve(seed: int, to: int) -> None:
    rng = np.random.default_rng(seed)
    g = _random_curve(rng, 3)
    breaks = np.union1d(g.knots, [1.0, 8.0, 12.5])
    e = bspline.elevation(g.knots, g.mults, 3, to, breaks)
    assert (e >= 0).all() and np.allclose(e.sum(1), 1.0)
    raised = BSplineCurve(
        e @ g.poles, None, breaks, np.r_[to + 1, np.full(len(breaks) - 2, to), to + 1], to, False
    )
    scale = np.abs(g.poles).max()
    assert np.abs(_curve_points(raised) - _curve_points(g)).max() < 1e-12 * scale


@pytest.mark.parametrize("seed", range(3))
def test_a_curve_of_raised_degree_comes_back_down(seed: int) -> None:
    """A cubic written at degree 7 in its Bezier form is lowered to a cubic
    again, its knots' multiplicities back to the cubic's, with a move of
    rounding only."""
    rng = np.random.default_rng(seed)
    g = _random_curve(rng, 3)
    high = _raised(g, 7)
    out = removal.removed(high, 1e-6)
    assert out is not None
    low, moved = out
    assert low.degree == 3 and moved <= 1e-6
    assert len(low.poles) == len(g.poles)
    np.testing.assert_allclose(_curve_points(low), _curve_points(g), rtol=0, atol=1e-9)


@pytest.mark.parametrize("seed", range(4))
def test_lowered_rows_stay_within_the_certified_bound(seed: int) -> None:
    """A degree (5, 5) patch that is a bicubic one raised, its poles then
    moved by up to 1e-3: lowered within a budget of 0.01, evaluated points
    (the same parameters) move no further than the certified move, and the
    end poles (the corners, the vertices) stay."""
    rng = np.random.default_rng(seed)
    cubic = rng.normal(size=(4, 4, 3)) * [8.0, 8.0, 3.0]
    cubic[..., 0] += np.arange(4)[:, None] * 20.0
    cubic[..., 1] += np.arange(4)[None, :] * 15.0
    k, m3 = np.array([0.0, 1.0]), np.array([4, 4])
    e = bspline.elevation(k, m3, 3, 5)
    poles = np.einsum("ia,jb,abk->ijk", e, e, cubic) + rng.uniform(-1e-3, 1e-3, (6, 6, 3))
    m5 = np.array([6, 6])
    high = BSplineSurface(poles, None, k, k, m5, m5, 5, 5, False, False, bezier=True)
    out = removal.removed(high, 0.01)
    assert out is not None
    low, moved = out
    assert (low.udegree, low.vdegree) == (3, 3) and low.bezier
    assert moved <= 0.01
    assert moved == K.moved(low, high)
    x = np.linspace(0.0, 1.0, 61)

    def grid(s: BSplineSurface) -> np.ndarray:
        tu, tv = full_knots(s.uknots, s.umults), full_knots(s.vknots, s.vmults)
        rows = np.stack([bspline.points(tv, s.poles[i], s.vdegree, x) for i in range(len(s.poles))])
        return np.stack([bspline.points(tu, rows[:, j], s.udegree, x) for j in range(len(x))])

    assert np.sqrt(((grid(low) - grid(high)) ** 2).sum(-1)).max() <= moved
    for i in (0, -1):
        for j in (0, -1):
            np.testing.assert_array_equal(low.poles[i, j], high.poles[i, j])


def test_lowered_refuses_what_it_cannot_bound() -> None:
    """A rational row, or one of higher degree than the source, has no
    lowered bound (inf), and a rational row keeps its degree."""
    rng = np.random.default_rng(3)
    g = _random_curve(rng, 3)
    high = _raised(g, 5)
    assert K.lowered(high, g) == np.inf  # a degree higher
    w = rng.uniform(0.8, 1.2, len(high.poles))
    rational = BSplineCurve(high.poles, w, high.knots, high.mults, 5, False)
    assert K.lowered(g, rational) == np.inf
    out = removal.removed(rational, 1e-6)
    assert out is None or out[0].degree == 5


def _high_degree_plate(path: Path) -> Path:
    """A wavy plate fitted at degree 7 through a 30 x 30 grid of points to
    1e-5 mm: poles of a degree its shape does not need at 0.01 mm (as the
    Bezier patches of degree 5 to 9 some CAD systems write)."""
    return wavy_plate(path, 30, (60.0, 40.0), (5.0, 9.0, 7.0), 1e-5, 7)


def test_a_high_degree_face_comes_back_of_lower_degree(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Within tol, valid, of lower degree and fewer poles, and no larger than
    with its knots removed only."""
    src = _high_degree_plate(tmp_path / "plate.step")
    nzc = tmp_path / "plate.nzc"
    rep = pipeline.compress_file(src, nzc, tol=0.01)
    assert rep["verified"] and rep["max_bound_mm"] <= 0.01
    assert_comes_back(src, nzc, 0.01, n=7)
    back, _ = pipeline.decode(container.unpack(nzc.read_bytes()))
    source, _ = topology.shape_to_model(occ.read_cad(src).shape)
    pairs = [
        (a, b)
        for a, b in zip(source.surfaces, back.surfaces)
        if isinstance(a, BSplineSurface) and isinstance(b, BSplineSurface)
    ]
    assert pairs and all((a.udegree, a.vdegree) == (7, 7) for a, _ in pairs)
    assert all(max(b.udegree, b.vdegree) < 7 for _, b in pairs)
    assert all(b.poles[..., 0].size < a.poles[..., 0].size for a, b in pairs)
    monkeypatch.setattr(removal, "LOWER", False)
    knots_only = tmp_path / "knots.nzc"
    pipeline.compress_file(src, knots_only, tol=0.01)
    assert nzc.stat().st_size <= knots_only.stat().st_size
