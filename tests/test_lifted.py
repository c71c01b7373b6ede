"""Format 2.14 (docs/format.md §2.4, "Extrapolation on the abscissae"):
surface methods 14-22 predict each pole along v, and its row's error along
u, by polynomials of degree 0 to 2 through the poles before it at the
net's Greville abscissae."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from nurbscomp import codec, coons, spatial

LIFTED = tuple(codec.LIFTED)


def clamped_abscissae(n: int, degree: int = 3) -> np.ndarray:
    """The normalised Greville abscissae of a clamped uniform B-spline of n poles."""
    spans = max(n - degree, 1)
    knots = np.arange(spans + 1, dtype=float)
    mults = np.r_[degree + 1, np.ones(spans - 1, int), degree + 1]
    return coons.unit_abscissae(coons.greville(knots, mults, degree, n))


def smooth_net(
    rng: np.random.Generator, nu: int, nv: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A net whose poles sit at a smooth surface's points at its abscissae."""
    s, t = clamped_abscissae(nu), clamped_abscissae(nv)
    S, T = np.meshgrid(s, t, indexing="ij")
    p = np.stack([40 * S, 30 * T, 6 * np.sin(2 * S + 1) * np.cos(3 * T)], -1)
    return p + rng.uniform(-500, 500, 3), s, t


def test_weights_are_lagrange_rounded_and_sum_to_one() -> None:
    g = np.array([0.0, 1 / 3, 1.0, 2.0, 3.0])
    w = spatial.node_weights(g, 2)
    assert w[1].tolist() == [1.0, 0.0, 0.0]
    assert w[2].tolist() == [3.0, -2.0, 0.0]  # the line through 0 and 1/3, at 1
    assert w[4].tolist() == [2.0, -1.0, 0.0]  # equal steps
    for o in spatial.ORDERS:
        w = spatial.node_weights(np.sort(np.random.default_rng(o).random(9)), o)
        assert np.all(w[1:].sum(1) == 1.0)
        assert np.all(np.ldexp(w, spatial.WEIGHT_BITS) == np.rint(np.ldexp(w, spatial.WEIGHT_BITS)))


def test_coincident_abscissae_take_equal_steps() -> None:
    w = spatial.node_weights(np.array([0.0, 0.0, 0.5, 1.0]), 3)
    assert w[2].tolist() == [2.0, -1.0, 0.0] and w[3].tolist() == [3.0, -3.0, 1.0]


@settings(max_examples=60, deadline=None)
@given(st.integers(1, 8), st.integers(1, 8), st.sampled_from(LIFTED), st.integers(0, 2**31))
def test_lifting_is_exactly_inverted(nu: int, nv: int, method, seed: int) -> None:
    rng = np.random.default_rng(seed)
    s, t = np.sort(rng.random(nu)), np.sort(rng.random(nv))
    wu, wv = codec.lifted_weights(method, s, t)
    q = rng.integers(-(10**9), 10**9, (nu, nv, 3))
    r = spatial.lifted_residuals(q, wu, wv)
    assert np.array_equal(spatial.lifted_integrate(r, wu, wv), q)
    # the encoder's choice with no room is the nearest grid points' residuals
    p = q * 0.01 + rng.normal(0, 1e-3, q.shape)
    no_room = spatial.rd_lifted(p, np.array([0.01]), 1e-12, np.zeros((1, 3), np.int64), wu, wv)
    assert np.array_equal(no_room[0][0], spatial.lifted_residuals(spatial.snap(p, 0.01), wu, wv))
    # with room, the closed loop's grid points are what its residuals decode to
    qo = rng.integers(-50, 50, (2, 3))
    res, grid = spatial.rd_lifted(p, np.array([0.01, 0.02]), 0.015, qo, wu, wv)
    for k in range(2):
        r = res[k].copy()
        r[0, 0] += qo[k]
        assert np.array_equal(spatial.lifted_integrate(r, wu, wv), grid[k])


@pytest.mark.parametrize("method", LIFTED, ids=lambda m: m.name)
def test_lifted_codes_hold_their_bound_and_decode_as_written(method) -> None:
    rng = np.random.default_rng(int(method))
    p, s, t = smooth_net(rng, 9, 7)
    origin = p[0, 0] + rng.normal(0, 4, 3)
    code = codec.encode_net(p, s, t, 0.01, methods=(method,), origin=origin)
    assert code.method == method and code.bound <= 0.01
    dec, _ = codec.decode_net(code, p.shape, s, t, 0.01, origin)
    assert np.sqrt(((dec - p) ** 2).sum(-1)).max() == code.bound
    moved = codec.reorigin(code, None, 0.01)
    assert np.array_equal(codec.decode_net(moved, p.shape, s, t, 0.01)[0], dec)
    with pytest.raises(ValueError, match="abscissae"):
        codec.decode_net(code, p.shape, None, None, 0.01, origin)


def test_the_abscissae_beat_equal_steps_near_clamped_ends() -> None:
    """On a smooth clamped cubic net, quadratic extrapolation at the Greville
    abscissae costs far less than method 10's lines at equal steps."""
    rng = np.random.default_rng(2)
    p, s, t = smooth_net(rng, 12, 12)
    # without the abscissae, SPATIAL2 alone
    two = codec.encode_net(p, None, None, 0.001, methods=(codec.Method.SPATIAL2,))
    assert two.method == codec.Method.SPATIAL2
    for method in (codec.Method.ORDERS_22, codec.Method.ORDERS_33):
        own = codec.encode_net(p, s, t, 0.001, methods=(method,))
        assert own.bits < 0.85 * two.bits, method.name
    # the search tries them with SPATIAL2, given the abscissae
    best = codec.encode_net(p, s, t, 0.001, methods=(codec.Method.SPATIAL2,))
    assert best.method in codec.LIFTED and best.bits < two.bits


@settings(max_examples=40, deadline=None)
@given(st.integers(1, 6), st.integers(1, 6), st.sampled_from(LIFTED), st.integers(0, 2**31))
def test_lifted_hostile_integers_never_crash(nu: int, nv: int, method, seed: int) -> None:
    rng = np.random.default_rng(seed)
    big = rng.integers(-(2**63), 2**63 - 1, nu * nv * 3)
    big[rng.random(big.shape) < 0.5] = 0
    s = np.sort(rng.random(nu)) if rng.random() < 0.5 else np.zeros(nu)
    t = np.sort(rng.random(nv))
    code = codec.NetCode(method, codec.Quant.TOL, 0, 0, big, np.zeros(0), 0, 0)
    with np.errstate(all="raise"):
        net, _ = codec.decode_net(code, (nu, nv, 3), s, t, 0.01)
    assert net.shape == (nu, nv, 3)
