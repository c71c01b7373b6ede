"""The D-map (eq. 14-25): least squares against a brute-force solve, recovery, codec round trip."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from nurbscomp import codec, coons, dmap


def _surface(rng: np.random.Generator, nu: int, nv: int, p: int, q: int, rational: bool):
    """A random clamped B-spline surface: poles, basis, Coons net of its boundaries."""
    inner_u = np.sort(rng.uniform(0.1, 0.9, nu - p - 1))
    inner_v = np.sort(rng.uniform(0.1, 0.9, nv - q - 1))
    uk = np.concatenate([[0.0], inner_u, [1.0]]) * rng.uniform(0.5, 20)
    vk = np.concatenate([[0.0], inner_v, [1.0]]) * rng.uniform(0.5, 20)
    um = np.array([p + 1, *[1] * len(inner_u), p + 1])
    vm = np.array([q + 1, *[1] * len(inner_v), q + 1])
    w = rng.uniform(0.5, 2.0, (nu, nv)) if rational else None
    basis = dmap.Basis.of(uk, um, vk, vm, p, q, w)
    x, y = np.meshgrid(np.linspace(0, 30, nu), np.linspace(0, 20, nv), indexing="ij")
    poles = np.stack([x, y, 3 * np.sin(x / 7) + 0.2 * y], -1) + rng.normal(0, 0.3, (nu, nv, 3))
    s = coons.unit_abscissae(coons.greville(uk, um, p, nu))
    t = coons.unit_abscissae(coons.greville(vk, vm, q, nv))
    net = coons.coons_net(poles[0], poles[-1], poles[:, 0], poles[:, -1], s, t)
    return poles, basis, net, s, t


def _brute_force(poles: np.ndarray, net: np.ndarray, basis: dmap.Basis) -> np.ndarray:
    """Eq. 19-24 summed term by term (non-rational), interior unknowns only."""
    nu, nv = poles.shape[:2]
    u, v = basis.abscissae(nu, nv)
    bu, _ = dmap.basis_matrices(basis.uflat, basis.udegree, u, nu)
    bv, _ = dmap.basis_matrices(basis.vflat, basis.vdegree, v, nv)
    n = dmap.normals(net, basis)
    idx = [(i, j) for i in range(1, nu - 1) for j in range(1, nv - 1)]
    a = np.zeros((len(idx), len(idx)))
    b = np.zeros(len(idx))
    for r, (i, j) in enumerate(idx):
        for c, (s_, t_) in enumerate(idx):
            for k in range(nu):
                for l_ in range(nv):
                    f = bu[k, i] * bv[l_, j] * bu[k, s_] * bv[l_, t_]  # F_ijstkl (eq. 20)
                    a[r, c] += f * (n[i, j] @ n[s_, t_])
        for k in range(nu):
            for l_ in range(nv):
                s_kl = np.einsum("a,ab...,b->...", bu[k], poles, bv[l_])
                si_kl = np.einsum("a,ab...,b->...", bu[k], net, bv[l_])
                b[r] += bu[k, i] * bv[l_, j] * ((s_kl - si_kl) @ n[i, j])  # eq. 24 (n_ij)
    return np.linalg.solve(a, b).reshape(nu - 2, nv - 2)


@pytest.mark.parametrize("seed", range(4))
def test_dmap_matches_brute_force_normal_equations(seed: int) -> None:
    rng = np.random.default_rng(seed)
    poles, basis, net, _, _ = _surface(rng, 5, 4, 3, 2, rational=False)
    np.testing.assert_allclose(
        dmap.fit(poles, net, basis), _brute_force(poles, net, basis), atol=1e-9
    )


@settings(max_examples=25, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    nu=st.integers(3, 9),
    nv=st.integers(3, 9),
    p=st.integers(1, 3),
    q=st.integers(1, 3),
    rational=st.booleans(),
)
def test_dmap_recovers_normal_offsets(seed, nu, nv, p, q, rational) -> None:
    """A net that is its Coons net moved along the normals is fitted exactly."""
    p, q = min(p, nu - 1), min(q, nv - 1)
    rng = np.random.default_rng(seed)
    _, basis, net, _, _ = _surface(rng, nu, nv, p, q, rational)
    d = rng.normal(0, 0.5, (nu - 2, nv - 2))
    target = dmap.apply(net, d, basis)
    np.testing.assert_allclose(dmap.fit(target, net, basis), d, atol=1e-7)


@pytest.mark.parametrize("rational", [False, True])
def test_dmap_codes_a_normal_offset_surface_within_tol(rational: bool) -> None:
    rng = np.random.default_rng(7)
    _, basis, net, s, t = _surface(rng, 8, 7, 3, 3, rational)
    poles = dmap.apply(net, rng.normal(0, 0.5, (6, 5)), basis)
    tol = 0.01
    code = codec.encode_net(poles, s, t, tol, (codec.Method.DMAP,), basis=basis)
    assert code.method == codec.Method.DMAP
    dec, _ = codec.decode_net(code, poles.shape, s, t, tol, None, basis)
    bound = np.sqrt(((dec - poles) ** 2).sum(-1)).max()
    assert bound <= tol and bound == pytest.approx(code.bound)


def test_dmap_needs_a_basis() -> None:
    rng = np.random.default_rng(3)
    poles, basis, _, s, t = _surface(rng, 6, 6, 3, 3, False)
    code = codec.encode_net(poles, s, t, 0.1, codec.SURFACE_METHODS, basis=basis)
    with pytest.raises(ValueError):
        codec.decode_net(
            codec.NetCode(codec.Method.DMAP, code.quant, 0, 0, code.ints, code.dcs, 0, 0),
            poles.shape,
            s,
            t,
            0.1,
        )
