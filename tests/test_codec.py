"""The surface codec on numpy nets: transforms, Coons nets, and the certified bound."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.interpolate import BSpline

from nurbscomp import codec, coons, dct, dmap, spatial


@given(st.integers(1, 12), st.integers(1, 12), st.integers(0, 2**31))
def test_dct_round_trips(n: int, m: int, seed: int) -> None:
    x = np.random.default_rng(seed).normal(size=(n, m, 3))
    assert np.allclose(dct.idct1(dct.dct1(x)), x)
    assert np.allclose(dct.idct2(dct.dct2(x)), x)
    # orthonormal: energy is kept (Parseval), as eq. 8-9 with N = n-1 intends
    assert np.isclose((dct.dct2(x) ** 2).sum(), (x**2).sum())


@given(st.integers(1, 9), st.floats(1e-4, 1.0), st.integers(0, 2**31))
def test_quantizer_error_is_half_a_step(n: int, delta: float, seed: int) -> None:
    d = np.random.default_rng(seed).normal(size=(n, 3)) * 10
    steps = dct.tol_steps((n,), delta, 1.0)
    back = dct.dequantize(dct.quantize(d, steps), steps)
    assert np.all(np.abs(back - d) <= steps / 2 + 1e-12)


def test_paper_steps_follow_eq_27() -> None:
    q = dct.paper_steps((3, 2), np.array([8.0, -4.0, 0.0]), a=2)
    assert q.shape == (3, 2, 3)
    assert q[0, 0, 0] == 2.0 and q[2, 1, 0] == 8.0  # (1+k+l)·|D00|/2^a
    assert q[1, 1, 1] == 3.0 and np.all(q[..., 2] == 0)


def test_greville_eq_17() -> None:
    g = coons.greville(np.array([0.0, 0.5, 1.0]), np.array([3, 1, 3]), 2, 4)
    assert np.allclose(g, [0.0, 0.25, 0.75, 1.0])


def test_coons_net_reproduces_bilinear_patches_and_boundaries() -> None:
    rng = np.random.default_rng(1)
    s, t = np.sort(rng.random(6)), np.sort(rng.random(5))
    s[[0, -1]] = 0, 1
    t[[0, -1]] = 0, 1
    c = rng.normal(size=(2, 2, 3))
    S, T = s[:, None, None], t[None, :, None]
    bil = (1 - S) * ((1 - T) * c[0, 0] + T * c[0, 1]) + S * ((1 - T) * c[1, 0] + T * c[1, 1])
    net = coons.coons_net(bil[0], bil[-1], bil[:, 0], bil[:, -1], s, t)
    assert np.allclose(net, bil)
    p = rng.normal(size=(6, 5, 3))
    net = coons.coons_net(p[0], p[-1], p[:, 0], p[:, -1], s, t)
    for a, b in ((net[0], p[0]), (net[-1], p[-1]), (net[:, 0], p[:, 0]), (net[:, -1], p[:, -1])):
        assert np.allclose(a, b)


def test_spatial_is_exact_integer_prediction() -> None:
    p = np.random.default_rng(2).normal(size=(5, 7, 3)) * 100
    h = 0.01
    r = spatial.encode(p, h)
    assert np.array_equal(spatial.integrate(r), spatial.snap(p, h))
    assert np.abs(spatial.decode(r, h) - p).max() <= h / 2 + 1e-9


# ---------------------------------------------------------------- random B-spline surfaces


def _knots(rng: np.random.Generator, n: int, deg: int) -> tuple[np.ndarray, np.ndarray]:
    inner = n - deg - 1
    ks = np.concatenate([[0.0], np.sort(rng.uniform(0.05, 0.95, inner)), [1.0]]) * rng.uniform(
        0.5, 20
    )
    ks = np.unique(ks)
    mults = np.ones(len(ks), int)
    mults[[0, -1]] = deg + 1
    return ks, mults


def _evaluate(p: np.ndarray, w: np.ndarray, uk, um, ud, vk, vm, vd, uv: np.ndarray) -> np.ndarray:
    tu, tv = coons.full_knots(uk, um), coons.full_knots(vk, vm)
    bu = BSpline.design_matrix(uv[:, 0], tu, ud).toarray()
    bv = BSpline.design_matrix(uv[:, 1], tv, vd).toarray()
    basis = bu[:, :, None] * bv[:, None, :] * w[None]
    return np.einsum("kij,ijc->kc", basis, p) / basis.sum(axis=(1, 2))[:, None]


surfaces = st.tuples(
    st.integers(2, 9),
    st.integers(2, 9),
    st.integers(1, 3),
    st.integers(1, 3),
    st.booleans(),
    st.sampled_from([1e-3, 1e-2, 1e-1, 1.0]),
    st.integers(0, 2**31),
)


@settings(max_examples=60, deadline=None)
@given(surfaces)
def test_decoded_surface_within_tol_and_bound_covers_sampled_error(args) -> None:
    nu, nv, ud, vd, rational, tol, seed = args
    ud, vd = min(ud, nu - 1), min(vd, nv - 1)
    rng = np.random.default_rng(seed)
    uk, um = _knots(rng, nu, ud)
    vk, vm = _knots(rng, nv, vd)
    p = np.cumsum(np.cumsum(rng.normal(size=(nu, nv, 3)), 0), 1) * rng.uniform(0.1, 100)
    p += rng.uniform(-1000, 1000, 3)
    w = rng.uniform(0.5, 2.0, (nu, nv)) if rational else np.ones((nu, nv))
    s = coons.unit_abscissae(coons.greville(uk, um, ud, nu))
    t = coons.unit_abscissae(coons.greville(vk, vm, vd, nv))
    prev = rng.uniform(-1000, 1000, 3)
    code = codec.encode_net(p, s, t, tol, origin=prev, paper=bool(seed % 2))
    dec, _ = codec.decode_net(code, p.shape, s, t, tol, prev)
    moved = np.sqrt(((dec - p) ** 2).sum(-1)).max()
    assert moved == pytest.approx(code.bound, abs=1e-12)
    assert code.bound <= tol
    uv = np.column_stack([rng.uniform(uk[0], uk[-1], 200), rng.uniform(vk[0], vk[-1], 200)])
    err = np.sqrt(
        (
            (
                _evaluate(dec, w, uk, um, ud, vk, vm, vd, uv)
                - _evaluate(p, w, uk, um, ud, vk, vm, vd, uv)
            )
            ** 2
        ).sum(-1)
    ).max()
    assert err <= code.bound * (1 + 1e-9) + 1e-12


def test_every_method_round_trips() -> None:
    rng = np.random.default_rng(5)
    s, t = np.linspace(0, 1, 6), np.linspace(0, 1, 5)
    c = rng.normal(size=(2, 2, 3)) * 10
    S, T = s[:, None, None], t[None, :, None]
    p = (1 - S) * ((1 - T) * c[0, 0] + T * c[0, 1]) + S * ((1 - T) * c[1, 0] + T * c[1, 1])
    p += rng.normal(size=p.shape) * 1e-4  # a near-bilinear net: every method can code it
    # degree 1 on uniform knots: the Greville abscissae are s and t
    basis = dmap.Basis.of(s, [2, 1, 1, 1, 1, 2], t, [2, 1, 1, 1, 2], 1, 1, None)
    for method in codec.SURFACE_METHODS:
        code = codec.encode_net(p, s, t, 0.01, methods=(method,), paper=True, basis=basis)
        assert code.method == method
        dec, _ = codec.decode_net(code, p.shape, s, t, 0.01, None, basis)
        assert np.sqrt(((dec - p) ** 2).sum(-1)).max() == pytest.approx(code.bound)


@settings(max_examples=60, deadline=None)
@given(
    st.integers(2, 15),
    st.sampled_from([2, 3]),
    st.sampled_from([1e-3, 1e-2, 1.0]),
    st.integers(0, 2**31),
)
def test_curves_within_tol(n: int, dim: int, tol: float, seed: int) -> None:
    rng = np.random.default_rng(seed)
    p = np.cumsum(rng.normal(size=(n, dim)), 0) * rng.uniform(0.1, 50) + rng.uniform(-500, 500)
    prev = rng.uniform(-500, 500, dim)
    for methods in ((codec.Method.DELTA,), codec.CURVE_METHODS):
        code = codec.encode_net(p, None, None, tol, methods=methods, origin=prev, paper=True)
        dec, used = codec.decode_net(code, p.shape, None, None, tol, prev)
        assert used == len(code.dcs)
        assert np.sqrt(((dec - p) ** 2).sum(-1)).max() == pytest.approx(code.bound, abs=1e-12)
        assert code.bound <= tol


def test_method_must_fit_the_net() -> None:
    p = np.zeros((4, 3))
    code = codec.encode_net(p, None, None, 0.1, methods=codec.CURVE_METHODS)
    with pytest.raises(ValueError):
        codec.decode_net(code, (2, 2, 3), None, None, 0.1)


@given(st.integers(0, 2**31))
@settings(max_examples=30, deadline=None)
def test_reorigin_keeps_the_decoded_net(seed: int) -> None:
    rng = np.random.default_rng(seed)
    p = np.cumsum(rng.normal(size=(5, 4, 3)), 0) * 10 + rng.uniform(-900, 900, 3)
    s, t = np.linspace(0, 1, 5), np.linspace(0, 1, 4)
    a, b = rng.uniform(-900, 900, 3), rng.uniform(-900, 900, 3)
    code = codec.encode_net(p, s, t, 0.01, origin=a)
    net_a, _ = codec.decode_net(code, p.shape, s, t, 0.01, a)
    moved = codec.reorigin(code, b, 0.01)
    net_b, _ = codec.decode_net(moved, p.shape, s, t, 0.01, b)
    assert np.array_equal(net_a, net_b)


@given(st.sampled_from([0.5, 0.1, 0.01]), st.integers(0, 2**31))
@settings(max_examples=20, deadline=None)
def test_a_limit_below_tol_holds_with_tol_steps(frac: float, seed: int) -> None:
    """A net held to a limit < tol (a feature smaller than tol) is coded within
    it, with steps that are still multiples of tol (the container's)."""
    rng = np.random.default_rng(seed)
    p = np.cumsum(rng.normal(size=(5, 4, 3)), 0) * 0.003 + rng.uniform(-9, 9, 3)
    s, t = np.linspace(0, 1, 5), np.linspace(0, 1, 4)
    tol = 0.01
    limit = frac * tol
    code = codec.encode_net(p, s, t, tol, limit=limit)
    assert code.bound <= limit
    if frac < 0.1:
        assert code.level < min(codec.E_LADDER)  # below where tol alone goes
    net, _ = codec.decode_net(code, p.shape, s, t, tol)
    assert np.sqrt(((net - p) ** 2).sum(-1)).max() == pytest.approx(code.bound, abs=1e-15)
    assert codec.ladder(tol, tol) == codec.E_LADDER


def test_bicubic_coons_keeps_boundaries_and_bilinear_patches() -> None:
    """Eq. 11 with cubic blends: every boundary comes back, and so does a
    bilinear patch (the corners' twist is the bilinear one)."""
    rng = np.random.default_rng(5)
    s, t = np.linspace(0, 1, 6), np.sort(np.r_[0, rng.random(3), 1])
    p = rng.normal(size=(6, 5, 3))
    net = coons.bicubic_net(p[0], p[-1], p[:, 0], p[:, -1], s, t)
    for a, b in ((net[0], p[0]), (net[-1], p[-1]), (net[:, 0], p[:, 0]), (net[:, -1], p[:, -1])):
        assert np.allclose(a, b, atol=1e-14)
    c = rng.normal(size=(2, 2, 3))
    S, T = s[:, None, None], t[None, :, None]
    bil = (1 - S) * ((1 - T) * c[0, 0] + T * c[0, 1]) + S * ((1 - T) * c[1, 0] + T * c[1, 1])
    assert np.allclose(coons.bicubic_net(bil[0], bil[-1], bil[:, 0], bil[:, -1], s, t), bil)


@settings(deadline=None, max_examples=60)
@given(
    st.sampled_from([codec.Method.SPATIAL, codec.Method.DELTA, codec.Method.CHORD]),
    st.integers(2, 9),
    st.integers(0, 2),
    st.integers(0, 1),
    st.sampled_from([1e-3, 0.01, 0.1]),
    st.sampled_from([1.0, 1e3, 1e9]),
    st.integers(0, 2**31),
)
def test_ladders_at_once_are_the_trials(
    method: codec.Method, n: int, rows: int, slope: int, tol: float, scale: float, seed: int
) -> None:
    """Every rung computed at once (codec._Rungs) has the bound and the code
    that its own trial (codec._try) gives, bit for bit, unusable rungs too."""
    rng = np.random.default_rng(seed)
    p = rng.normal(size=(n, 4, 3) if method == codec.Method.SPATIAL else (n, 3)) * scale
    origin = rng.normal(size=(rows, 3) if rows else 3) * scale
    if method == codec.Method.SPATIAL and rows == 2:
        origin = origin[0]
    settings_ = [codec._Stepper(codec.Quant.TOL, e, slope, tol) for e in codec.ladder(tol, tol)]
    memo = codec._Memo()
    assert codec._rungs_apply(p, method, settings_)
    runs = codec._Rungs(p, method, settings_, origin, memo)
    for i, s_ in enumerate(settings_):
        c = codec._try(p, None, None, tol, method, s_, origin)
        assert runs.bound(i) == (None if c is None else c.bound)
        if c is not None:
            r = runs.code(i)
            assert r is not None
            assert (r.method, r.quant, r.level, r.slope) == (c.method, c.quant, c.level, c.slope)
            assert r.ints.dtype == c.ints.dtype and np.array_equal(r.ints, c.ints)
            assert r.bits == c.bits and r.dcs.size == c.dcs.size == 0
            assert r.origin is not None and np.array_equal(r.origin, origin)


@settings(deadline=None, max_examples=40)
@given(
    st.integers(2, 7),
    st.integers(2, 7),
    st.integers(0, 1),
    st.sampled_from([1e-3, 0.01, 0.1]),
    st.sampled_from([1.0, 1e3, 1e9]),
    st.integers(0, 2**31),
)
def test_boundaries_at_once_are_the_trials(
    nu: int, nv: int, slope: int, tol: float, scale: float, seed: int
) -> None:
    """Boundaries coded for every rung at once (codec._trial_boundaries) give
    each Coons method's trial the code it has alone, bit for bit, and so do
    whole Coons ladders at once (codec._CoonsRungs)."""
    rng = np.random.default_rng(seed)
    p = rng.normal(size=(nu, nv, 3)) * scale
    origin = rng.normal(size=3) * scale
    s, t = np.linspace(0, 1, nu) ** 1.5, np.linspace(0, 1, nv)
    settings_ = [codec._Stepper(codec.Quant.TOL, e, slope, tol) for e in codec.ladder(tol, tol)]
    memo = codec._Memo()
    codec._trial_boundaries(p, settings_, origin, memo)
    for method in (codec.Method.BOUNDARY, codec.Method.DDMAP, codec.Method.DDMAP3):
        for s_ in settings_:
            alone = codec._try(p, s, t, tol, method, s_, origin)
            shared = codec._try(p, s, t, tol, method, s_, origin, memo=memo)
            assert (alone is None) == (shared is None)
            if alone is not None and shared is not None:
                assert np.array_equal(alone.ints, shared.ints)
                assert (alone.bound, alone.bits) == (shared.bound, shared.bits)
    for method in (codec.Method.BOUNDARY, codec.Method.DDMAP, codec.Method.DDMAP3):
        runs = codec._CoonsRungs(p, s, t, method, settings_, origin, codec._Memo())
        for i, s_ in enumerate(settings_):
            alone = codec._try(p, s, t, tol, method, s_, origin)
            assert runs.bound(i) == (None if alone is None else alone.bound)
            if alone is not None:
                c = runs.code(i)
                assert c is not None and c.ints.dtype == alone.ints.dtype
                assert np.array_equal(c.ints, alone.ints) and c.bits == alone.bits
                assert (c.method, c.level, c.slope) == (method, s_.level, s_.slope)


@settings(deadline=None, max_examples=30)
@given(st.integers(2, 8), st.integers(2, 8), st.integers(1, 4), st.integers(0, 2**31))
def test_coons_nets_of_stacked_boundaries_are_each_net(nu: int, nv: int, r: int, seed: int) -> None:
    """Boundaries with a leading axis give each one's Coons nets, bit for bit."""
    rng = np.random.default_rng(seed)
    u0, u1 = rng.normal(size=(2, r, nv, 3))
    v0, v1 = rng.normal(size=(2, r, nu, 3))
    s, t = np.linspace(0, 1, nu) ** 2, np.linspace(0, 1, nv)
    for net in (coons.coons_net, coons.bicubic_net):
        stacked = net(u0, u1, v0, v1, s, t)
        for i in range(r):
            assert np.array_equal(stacked[i], net(u0[i], u1[i], v0[i], v1[i], s, t))


# ----------------------------------------------------- extrapolating spatial (format 2.0)


@given(st.integers(1, 9), st.integers(1, 9), st.integers(0, 2**31))
def test_extrapolation_is_exactly_inverted(nu: int, nv: int, seed: int) -> None:
    q = np.random.default_rng(seed).integers(-(2**40), 2**40, (nu, nv, 3))
    r = spatial.extrapolate(q)
    assert np.array_equal(spatial.unextrapolate(r), q)
    if nu > 2 and nv > 2:  # the interior is the 9-point stencil of Δu²Δv²
        d = np.diff(np.diff(q, 2, axis=0), 2, axis=1)
        assert np.array_equal(r[2:, 2:], d)


def _smooth_net(rng: np.random.Generator, nu: int, nv: int) -> np.ndarray:
    u, v = np.meshgrid(np.linspace(0, 1, nu), np.linspace(0, 1, nv), indexing="ij")
    a = rng.uniform(1, 50, 3)
    return (
        np.stack([a[0] * u, a[1] * v, a[2] * np.sin(3 * u + 1) * np.cos(2 * v)], -1)
        + rng.uniform(-900, 900, 3)
        + rng.normal(size=(nu, nv, 3)) * rng.choice([0.0, 1e-3, 1.0])
    )


@settings(max_examples=60, deadline=None)
@given(
    st.integers(2, 12),
    st.integers(2, 12),
    st.sampled_from([1e-3, 1e-2, 1e-1]),
    st.sampled_from([1.0, 0.3]),
    st.integers(0, 2**31),
)
def test_spatial2_holds_its_bound_and_decodes_as_written(
    nu: int, nv: int, tol: float, frac: float, seed: int
) -> None:
    rng = np.random.default_rng(seed)
    p = _smooth_net(rng, nu, nv)
    origin = rng.uniform(-900, 900, 3)
    limit = tol * frac
    code = codec.encode_net(
        p, None, None, tol, methods=(codec.Method.SPATIAL2,), origin=origin, limit=limit
    )
    assert code.method == codec.Method.SPATIAL2 and code.bound <= limit
    dec, _ = codec.decode_net(code, p.shape, None, None, tol, origin)
    err = np.sqrt(((dec - p) ** 2).sum(-1))
    assert err.max() == code.bound
    h = tol * code.grid  # corners on their nearest grid point: pinned as a spatial net's
    corners = dec[[0, 0, -1, -1], [0, -1, 0, -1]]
    assert np.array_equal(np.rint(corners / h), np.rint(p[[0, 0, -1, -1], [0, -1, 0, -1]] / h))
    moved = codec.reorigin(code, None, tol)  # the decoded net does not depend on the origin
    assert np.array_equal(codec.decode_net(moved, p.shape, None, None, tol)[0], dec)


@settings(max_examples=60, deadline=None)
@given(st.integers(1, 9), st.integers(1, 9), st.integers(0, 2**31))
def test_spatial2_closed_loop_grid_is_the_decoders(nu: int, nv: int, seed: int) -> None:
    """The grid points ``rd_extrapolate`` returns are what its residuals decode
    to (the search measures its trials on them, not on a decoded net)."""
    rng = np.random.default_rng(seed)
    p = _smooth_net(rng, nu, nv) if min(nu, nv) >= 2 else rng.uniform(-900, 900, (nu, nv, 3))
    qo = rng.integers(-(10**5), 10**5, (3, 3))
    h = np.array([0.01, 0.02, 0.005])
    res, grid = spatial.rd_extrapolate(p, h, np.array([0.012, 0.03, 0.004]), qo)
    for k in range(3):
        r = res[k].copy()
        r[0, 0] += qo[k]
        assert np.array_equal(spatial.unextrapolate(r), grid[k])


def test_spatial2_beats_the_parallelogram_on_smooth_nets() -> None:
    rng = np.random.default_rng(3)
    u, v = np.meshgrid(np.linspace(0, 1, 12), np.linspace(0, 1, 12), indexing="ij")
    p = np.stack([30 * u, 20 * v, 5 * np.sin(3 * u) * np.cos(2 * v)], -1) + rng.uniform(-90, 90, 3)
    plain = codec.encode_net(p, None, None, 0.01, methods=(codec.Method.SPATIAL,))
    two = codec.encode_net(p, None, None, 0.01, methods=(codec.Method.SPATIAL2,))
    assert two.bits < 0.8 * plain.bits


def test_spatial2_is_refused_before_format_2() -> None:
    from nurbscomp import decode
    from nurbscomp.errors import SectionError
    from nurbscomp.serialize import NetTable

    one = np.ones(1, np.int64)
    t = NetTable(one * 10, one * 0, one * 0, one * 0, [np.zeros(3, np.int64)], np.zeros(0))
    decode._check_headers(t, "SNET", 0.01, 3)
    for revision in (0, 1, 2):
        with pytest.raises(SectionError):
            decode._check_headers(t, "SNET", 0.01, revision)
    with pytest.raises(SectionError):
        decode._check_headers(t, "CNET", 0.01, 3)


@settings(max_examples=40, deadline=None)
@given(st.integers(1, 6), st.integers(1, 6), st.integers(0, 2**31))
def test_spatial2_hostile_integers_never_crash(nu: int, nv: int, seed: int) -> None:
    rng = np.random.default_rng(seed)
    big = rng.integers(-(2**63), 2**63 - 1, nu * nv * 3 + int(rng.integers(-1, 2)))
    code = codec.NetCode(codec.Method.SPATIAL2, codec.Quant.TOL, 0, 0, big, np.zeros(0), 0, 0)
    try:
        codec.decode_net(code, (nu, nv, 3), None, None, 0.01)
    except ValueError:
        pass  # too few or too many integers
    for bad in (replace_quant(code), replace_slope(code)):
        with pytest.raises(ValueError):
            codec.decode_net(bad, (nu, nv, 3), None, None, 0.01)
    with pytest.raises(ValueError):
        codec.decode_net(code, (nu * nv, 3), None, None, 0.01)  # not for curves


def replace_quant(code: codec.NetCode) -> codec.NetCode:
    from dataclasses import replace

    return replace(code, quant=codec.Quant.PAPER)


def replace_slope(code: codec.NetCode) -> codec.NetCode:
    from dataclasses import replace

    return replace(code, slope=1)


# ---------------------------------------------------------------- format 2.1 streams


@settings(max_examples=60, deadline=None)
@given(st.integers(2, 7), st.integers(2, 7), st.booleans(), st.integers(0, 2**31))
def test_segments_count_every_methods_integers(nu: int, nv: int, paper: bool, seed: int) -> None:
    """codec.segments says how many integers of each kind a code holds (the
    2.1 layout has no count column): it must match what _code records, for
    every method, quantizer and shape, curves included."""
    rng = np.random.default_rng(seed)
    p = np.cumsum(rng.normal(size=(nu, nv, 3)), 0) * 10
    s, t = np.linspace(0, 1, nu), np.linspace(0, 1, nv)
    basis = dmap.Basis.of(s, [2] + [1] * (nu - 2) + [2], t, [2] + [1] * (nv - 2) + [2], 1, 1, None)
    quant = codec.Quant.PAPER if paper else codec.Quant.TOL
    level = 8 if paper else 0
    for m in codec.SURFACE_METHODS_2:
        if m == codec.Method.DMAP and (nu < 3 or nv < 3):
            with pytest.raises(ValueError):
                codec.segments(m, quant, p.shape)
            continue
        if m == codec.Method.SPATIAL2 and paper:
            continue
        st_ = codec._Stepper(quant, level, 0, 0.01)
        w = codec._Writer(st_)
        w.bound = 0.01
        codec._code(w, p, m, s, t, np.zeros(3), basis)
        n = sum(len(x) for x in w.ints)
        runs = codec.segments(m, quant, p.shape)
        assert sum(c for _, c in runs) == n, (m, quant, p.shape)
        if n:
            assert runs[0][0] == codec.POS
    curve = p[:, 0]
    for m in codec.CURVE_METHODS:
        w = codec._Writer(codec._Stepper(quant, level, 0, 0.01))
        codec._code(w, curve, m, None, None, np.zeros(3))
        n = sum(len(x) for x in w.ints)
        assert sum(c for _, c in codec.segments(m, quant, curve.shape)) == n
    with pytest.raises(ValueError):
        codec.segments(codec.Method.CHORD, quant, p.shape)  # a curve method on a net
    with pytest.raises(ValueError):
        codec.segments(codec.Method.SPATIAL, quant, curve.shape)
    with pytest.raises(ValueError):
        codec.segments(99, quant, curve.shape)


def _tables(rng: np.random.Generator, surfaces: bool) -> tuple[object, list[tuple[int, ...]]]:
    """A random net table and its rows' shapes, coded by encode_net."""
    from nurbscomp.serialize import NetTable

    codes, shapes = [], []
    for _ in range(int(rng.integers(0, 6))):
        if surfaces:
            nu, nv = (int(x) for x in rng.integers(2, 7, 2))
            p = np.cumsum(rng.normal(size=(nu, nv, 3)), 0) * 5
            s, t = np.linspace(0, 1, nu), np.linspace(0, 1, nv)
            codes.append(codec.encode_net(p, s, t, 0.01, methods=codec.SURFACE_SEARCH))
        elif rng.random() < 0.3:  # references: an ISO or a COPY code
            iso = bool(rng.random() < 0.5)
            m = codec.Method.ISO if iso else codec.Method.COPY
            ints = rng.integers(0, 9, 3 if iso else 2)
            codes.append(codec.NetCode(m, codec.Quant.TOL, 0, 0, ints, np.zeros(0), 0.0, 0.0))
            p = np.zeros((int(rng.integers(2, 9)), 3))
        else:
            p = np.cumsum(rng.normal(size=(int(rng.integers(2, 9)), 3)), 0) * 5
            codes.append(codec.encode_net(p, None, None, 0.01, methods=codec.CURVE_METHODS))
        shapes.append(p.shape)
    col = lambda name: np.array([int(getattr(c, name)) for c in codes], np.int64)  # noqa: E731
    anchor = rng.integers(0, 3, len(codes)) if surfaces else None
    t = NetTable(
        col("method"),
        col("quant"),
        col("level"),
        col("slope"),
        [c.ints for c in codes],
        np.concatenate([c.dcs for c in codes]) if codes else np.zeros(0),
        anchor,
    )
    return t, shapes


@settings(max_examples=60, deadline=None)
@given(st.booleans(), st.integers(0, 2**31))
def test_net_tables_round_trip_in_2_0_and_2_1(surfaces: bool, seed: int) -> None:
    from nurbscomp import serialize

    t, shapes = _tables(np.random.default_rng(seed), surfaces)
    tag = "SNET" if surfaces else "CNET"
    for revision in (3, 4):
        data = serialize._write_nets(t, shapes, surfaces, revision)
        back = serialize._read_nets(data, len(shapes), tag, shapes, revision)
        for name in ("method", "quant", "level", "slope", "dcs"):
            assert np.array_equal(getattr(back, name), getattr(t, name))
        assert len(back.ints) == len(t.ints)
        assert all(np.array_equal(a, b) for a, b in zip(back.ints, t.ints, strict=True))
        if revision == 4 and surfaces and shapes:
            assert np.array_equal(back.anchor, t.anchor)
        else:  # no anchor column before 2.1, in CNET, or in a table of no rows
            assert back.anchor is None
        if not shapes:  # a table of no rows is laid out as in 2.0
            assert data == serialize._write_nets(t, shapes, surfaces, 3)


def test_a_2_1_net_table_refuses_short_and_long_streams() -> None:
    from nurbscomp import serialize
    from nurbscomp.errors import SectionError

    rng = np.random.default_rng(7)
    t, shapes = _tables(rng, True)
    while not shapes:
        t, shapes = _tables(rng, True)
    data = serialize._write_nets(t, shapes, True, 4)
    bigger = [(s[0] + 1, *s[1:]) for s in shapes]  # rows asking for more integers
    with pytest.raises(SectionError, match="too short"):
        serialize._read_nets(data, len(shapes), "SNET", bigger, 4)
    smaller = [(1, 1, 3)] * len(shapes)  # rows leaving integers over
    with pytest.raises(SectionError):
        serialize._read_nets(data, len(shapes), "SNET", smaller, 4)
    curves = [(s[0] * s[1], 3) for s in shapes]  # surface methods on curve rows
    with pytest.raises(SectionError, match="does not apply"):
        serialize._read_nets(data, len(shapes), "SNET", curves, 4)
