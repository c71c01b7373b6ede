"""Format 2.14 (docs/format.md §2.4, "Rows of arcs"): surface methods 12 and
13 predict a net's rows along v or u as chains of equal-angle quadratic arcs,
the poles a rational quadratic B-spline with double inner knots writes for
a circle."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from nurbscomp import codec, decode, spatial
from nurbscomp.errors import SectionError
from nurbscomp.serialize import NetTable

ARCS = (codec.Method.ARCS_V, codec.Method.ARCS_U)


def arc_row(center: np.ndarray, x: np.ndarray, y: np.ndarray, r: float, turns: int) -> np.ndarray:
    """The 2·turns + 1 poles of ``turns`` equal arcs of a quarter turn each
    (a rational quadratic circle's: a point, the tangents' corner, a point...)."""
    out = []
    for k in range(2 * turns + 1):
        a = k * math.pi / 4
        scale = r if k % 2 == 0 else r * math.sqrt(2.0)
        out.append(center + scale * (math.cos(a) * x + math.sin(a) * y))
    return np.array(out)


def cone_net(rng: np.random.Generator, turns: int = 2, rows: int = 3) -> np.ndarray:
    """Rows of arcs about one axis, of growing radius: a cone's net, turned
    and moved anywhere (rows along v)."""
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    x, y, z = q.T
    base = rng.uniform(-500, 500, 3)
    r0 = rng.uniform(2, 40)
    return np.stack(
        [arc_row(base + 7.0 * i * z, x, y, r0 * (1 + 0.3 * i), turns) for i in range(rows)]
    )


@settings(max_examples=60, deadline=None)
@given(st.integers(1, 7), st.integers(1, 9), st.sampled_from([0, 1]), st.integers(0, 2**31))
def test_arc_rows_are_exactly_inverted(nu: int, nv: int, axis: int, seed: int) -> None:
    rng = np.random.default_rng(seed)
    q = rng.integers(-(10**9), 10**9, (nu, nv, 3))
    r = spatial.arc_residuals(q, axis)
    assert np.array_equal(spatial.arc_integrate(r, axis), q)


def test_circles_leave_nothing_past_their_first_arc() -> None:
    """On a cone's net, each row past its first arc is predicted to within
    the rounding of the grid; the parallelogram rule leaves whole legs."""
    rng = np.random.default_rng(4)
    p = cone_net(rng, turns=4)
    q = spatial.snap(p, 0.001)
    r = spatial.arc_residuals(q, 1)
    assert np.abs(r[:, 3:]).max() <= 3
    assert np.abs(spatial.residuals(q)[:, 3:]).max() > 1000
    # the same net transposed, with its rows along u
    rt = spatial.arc_residuals(np.ascontiguousarray(q.transpose(1, 0, 2)), 0)
    assert np.array_equal(rt, r.transpose(1, 0, 2))


@pytest.mark.parametrize("method", ARCS, ids=lambda m: m.name)
@pytest.mark.parametrize("tol", [0.001, 0.01, 0.1])
def test_arc_codes_hold_their_bound_and_beat_the_grid_methods(method, tol) -> None:
    rng = np.random.default_rng(int(method) + int(tol * 1000))
    p = cone_net(rng, turns=4, rows=2)  # a full circle along the rows, as in a cylinder's net
    if method == codec.Method.ARCS_U:
        p = np.ascontiguousarray(p.transpose(1, 0, 2))
    origin = p[0, 0] + rng.normal(0, 5, 3)
    code = codec.encode_net(p, None, None, tol, methods=(method,), origin=origin)
    assert code.method == method and code.bound <= tol
    dec, _ = codec.decode_net(code, p.shape, None, None, tol, origin)
    assert np.sqrt(((dec - p) ** 2).sum(-1)).max() == pytest.approx(code.bound)
    h = tol * code.grid  # every pole on its nearest grid point
    assert np.array_equal(dec, np.rint(p / h) * h)
    moved = codec.reorigin(code, None, tol)
    assert np.array_equal(codec.decode_net(moved, p.shape, None, None, tol)[0], dec)
    for other in (codec.Method.SPATIAL, codec.Method.SPATIAL2):
        rival = codec.encode_net(p, None, None, tol, methods=(other,), origin=origin)
        assert code.bits < 0.8 * rival.bits, other.name


@settings(max_examples=40, deadline=None)
@given(st.integers(1, 6), st.integers(1, 8), st.sampled_from(ARCS), st.integers(0, 2**31))
def test_arc_hostile_integers_never_crash(nu: int, nv: int, method, seed: int) -> None:
    """Any integers decode to some net or a ValueError: wrapped sums, zero
    legs and predictions past 2^62 take the pole before."""
    rng = np.random.default_rng(seed)
    big = rng.integers(-(2**63), 2**63 - 1, nu * nv * 3)
    big[rng.random(big.shape) < 0.5] = 0
    code = codec.NetCode(method, codec.Quant.TOL, 0, 0, big, np.zeros(0), 0, 0)
    with np.errstate(all="raise"):  # no warning escapes either
        net, _ = codec.decode_net(code, (nu, nv, 3), None, None, 0.01)
    assert net.shape == (nu, nv, 3)


def test_a_zero_leg_falls_back_to_the_pole_before() -> None:
    q = np.zeros((1, 5, 3), np.int64)
    q[0, 3] = [5, 0, 0]  # v1 = q[1] - q[0] = 0: the fifth pole is predicted by the fourth
    assert np.array_equal(spatial.arc_column(q, 4), q[:, 3])
    q[0, 1] = [2**61, 0, 0]  # a leg so long that the prediction passes 2^62
    q[0, 2] = [-(2**61), 2**61, 0]
    assert np.array_equal(spatial.arc_column(q, 4), q[:, 3])


def test_arcs_are_refused_before_format_2_14() -> None:
    one = np.ones(1, np.int64)
    for m in ARCS:
        t = NetTable(one * int(m), one * 0, one * 0, one * 0, [np.zeros(3, np.int64)], np.zeros(0))
        decode._check_headers(t, "SNET", 0.01, decode.ARC_ROWS)
        with pytest.raises(SectionError):
            decode._check_headers(t, "SNET", 0.01, decode.ARC_ROWS - 1)
        with pytest.raises(SectionError):
            decode._check_headers(t, "CNET", 0.01, decode.ARC_ROWS)


def test_arcs_are_surface_methods_only() -> None:
    code = codec.NetCode(
        codec.Method.ARCS_V, codec.Quant.TOL, 0, 0, np.zeros(6, np.int64), np.zeros(0), 0, 0
    )
    with pytest.raises(ValueError):
        codec.decode_net(code, (2, 3), None, None, 0.01)
