"""The net codec on random periodic and rational B-spline records (issue 10).

For random ``BSplineSurface`` records (periodic in u, v, both or neither;
degrees 1-5; random interior multiplicities; rational or not; nets from 2 x N
up to 12 x 12) and random ``BSplineCurve`` records, ``nets._code_one`` (what
the encoder runs on every record: ``rules.nets.net_abscissae`` and
``net_basis``, ``codec.encode_net``, then ``codec.decode_net``) must not
raise, and no decoded pole may be further than tol from its original.

Knot vectors follow OCCT's rules, and every record is first built as an OCCT
``Geom_BSplineSurface`` / ``Geom_BSplineCurve`` to prove it is one OCCT
accepts: non-periodic, clamped ends and sum(mults) = poles + degree + 1;
periodic, mults[0] == mults[-1] <= degree and sum(mults) - mults[-1] = poles
(OCCT also takes fewer poles than degree + 1 then).
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from OCP.Geom import Geom_BSplineCurve, Geom_BSplineSurface

from nurbscomp import codec
from nurbscomp.encode import deviation, nets
from nurbscomp.model import BSplineCurve, BSplineSurface

from .stress.shapes import _ints, _poles1, _poles2, _reals, _weights2

TOLS = (0.001, 0.01, 0.1)


@st.composite
def knot_vectors(draw: st.DrawFn, degree: int, n: int, periodic: bool) -> tuple[np.ndarray, ...]:
    """(knots, mults) of an OCCT B-spline with ``n`` poles."""
    if periodic:
        first = draw(st.integers(1, min(degree, n)))
        left = n - first
    else:
        first = degree + 1
        left = n - degree - 1
    inner = []
    while left > 0:
        m = draw(st.integers(1, min(degree, left)))
        inner.append(m)
        left -= m
    mults = np.array([first, *inner, first], np.int64)
    if draw(st.booleans()):
        gaps = np.ones(len(mults) - 1)
    else:
        gaps = np.array(
            draw(st.lists(st.floats(0.05, 5.0), min_size=len(mults) - 1, max_size=len(mults) - 1))
        )
    start = draw(st.sampled_from([0.0, -1.5, 3.0]))
    return start + np.concatenate([[0.0], np.cumsum(gaps)]), mults


@st.composite
def direction(draw: st.DrawFn, periodic: bool) -> tuple[int, int, np.ndarray, np.ndarray]:
    """(degree, poles, knots, mults) along one parametric direction."""
    degree = draw(st.integers(1, 5))
    lo = 2 if periodic else degree + 1
    n = draw(st.integers(lo, max(lo, 12)))
    knots, mults = draw(knot_vectors(degree, n, periodic))
    return degree, n, knots, mults


def _poles(seed: int, shape: tuple[int, ...], scale: float, smooth: bool) -> np.ndarray:
    rng = np.random.default_rng(seed)
    p = rng.normal(size=shape) * scale
    if smooth:  # a gently curved net: cumulative steps, as on real parts
        p = np.cumsum(np.abs(p) * 0.2 + scale * 0.05, axis=0)
        if len(shape) == 3:
            p = np.cumsum(p, axis=1) / shape[1]
    return p


@st.composite
def surfaces(draw: st.DrawFn) -> BSplineSurface:
    uper, vper = draw(st.sampled_from([(True, False), (False, True), (True, True), (False, False)]))
    du, nu, uk, um = draw(direction(uper))
    dv, nv, vk, vm = draw(direction(vper))
    seed = draw(st.integers(0, 2**31))
    scale = draw(st.sampled_from([0.01, 1.0, 30.0, 500.0]))
    poles = _poles(seed, (nu, nv, 3), scale, draw(st.booleans()))
    weights = None
    if draw(st.booleans()):
        weights = np.random.default_rng(seed + 1).uniform(0.2, 5.0, (nu, nv))
    g = BSplineSurface(poles, weights, uk, vk, um, vm, du, dv, uper, vper)
    _occt_surface(g)
    return g


@st.composite
def curves(draw: st.DrawFn) -> BSplineCurve:
    periodic = draw(st.booleans())
    degree, n, knots, mults = draw(direction(periodic))
    if draw(st.booleans()):  # longer curves too
        n2 = draw(st.integers(max(n, 2), 40))
        if n2 > n:
            n = n2
            knots, mults = draw(knot_vectors(degree, n, periodic))
    seed = draw(st.integers(0, 2**31))
    scale = draw(st.sampled_from([0.01, 1.0, 30.0, 500.0]))
    poles = _poles(seed, (n, 3), scale, draw(st.booleans()))
    weights = np.random.default_rng(seed + 1).uniform(0.2, 5.0, n) if draw(st.booleans()) else None
    g = BSplineCurve(poles, weights, knots, mults, degree, periodic)
    _occt_curve(g)
    return g


def _occt_surface(g: BSplineSurface) -> None:
    """Build the record as OCCT would hold it (raises if OCCT rejects it)."""
    nu, nv = g.poles.shape[:2]
    args: list = [_poles2(g.poles)]
    if g.weights is not None:
        args.append(_weights2(g.weights))
    s = Geom_BSplineSurface(
        *args,
        _reals(g.uknots),
        _reals(g.vknots),
        _ints(g.umults),
        _ints(g.vmults),
        g.udegree,
        g.vdegree,
        g.uperiodic,
        g.vperiodic,
    )
    assert (s.NbUPoles(), s.NbVPoles()) == (nu, nv)
    assert (s.IsUPeriodic(), s.IsVPeriodic()) == (g.uperiodic, g.vperiodic)


def _occt_curve(g: BSplineCurve) -> None:
    args: list = [_poles1(g.poles)]
    if g.weights is not None:
        args.append(_reals(g.weights))
    c = Geom_BSplineCurve(*args, _reals(g.knots), _ints(g.mults), g.degree, g.periodic)
    assert c.NbPoles() == len(g.poles) and c.IsPeriodic() == g.periodic


def _coded_within_tol(g: BSplineSurface | BSplineCurve, tol: float, methods: tuple) -> object:
    """Code ``g`` as the encoder does; the decoded record, checked to be of the
    same kind and shape, finite, and within tol by the certified bound (on its
    refined error net where the row is clamped, its poles' otherwise)."""
    code, back = nets._code_one(g, tol, methods, False, None, tol)
    assert type(back) is type(g) and back.poles.shape == g.poles.shape
    assert np.isfinite(back.poles).all()
    assert deviation.moved(back, g) <= tol, (code.method.name, code.bound)
    return back


@pytest.mark.slow
@settings(max_examples=300, deadline=None)
@given(surfaces(), st.sampled_from(TOLS))
def test_surface_nets_code_within_tol(g: BSplineSurface, tol: float) -> None:
    back = _coded_within_tol(g, tol, codec.SURFACE_METHODS)
    assert isinstance(back, BSplineSurface)
    # knots, degrees, periodicity and weights are kept exactly
    assert back.uperiodic == g.uperiodic and back.vperiodic == g.vperiodic
    assert (back.umults == g.umults).all() and (back.vmults == g.vmults).all()
    assert (back.weights is None) == (g.weights is None)


@pytest.mark.slow
@settings(max_examples=300, deadline=None)
@given(curves(), st.sampled_from(TOLS))
def test_curve_nets_code_within_tol(g: BSplineCurve, tol: float) -> None:
    back = _coded_within_tol(g, tol, codec.CURVE_METHODS)
    assert isinstance(back, BSplineCurve)
    assert back.periodic == g.periodic and (back.mults == g.mults).all()


def test_periodic_net_with_low_end_multiplicity() -> None:
    """The case that raised IndexError in ``coons.greville``: a periodic net whose
    end multiplicity (1) is below its degree (3), rational."""
    rng = np.random.default_rng(7)
    nu, nv = 8, 5
    a = 2 * np.pi * np.arange(nu) / nu
    poles = (
        np.stack(
            [
                10 * np.cos(a)[:, None] * np.ones((1, nv)),
                10 * np.sin(a)[:, None] * np.ones((1, nv)),
                np.linspace(0, 20, nv)[None, :] * np.ones((nu, 1)),
            ],
            -1,
        )
        + rng.normal(size=(nu, nv, 3)) * 0.3
    )
    g = BSplineSurface(
        poles,
        rng.uniform(0.5, 2.0, (nu, nv)),
        np.arange(nu + 1, dtype=float),
        np.array([0.0, 1.0, 2.0]),
        np.ones(nu + 1, np.int64),
        np.array([3, 2, 3]),
        3,
        2,
        True,
        False,
    )
    _occt_surface(g)
    for tol in TOLS:
        _, back = nets._code_one(g, tol, codec.SURFACE_METHODS, False, None, tol)
        assert deviation.moved(back, g) <= tol
