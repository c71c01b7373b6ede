"""The D-map (eq. 14–25): one distance per interior pole, along the Coons surface normal.

The optimal surface moves each pole of the interpolating (Coons) net along
the unit normal of the interpolating surface at the pole's Greville point,
P^A_ij = P^I_ij + d_ij·n_ij (eq. 15–17).  The distances minimise the squared
distance between the optimal and the original surface over the grid of
Greville points (eq. 18).  The optimal surface is linear in d (the weights
are exact, so the rational basis R_ij = N_i·N_j·w_ij / Σ N·N·w is fixed), and
eq. 19–24 are the normal equations of that linear least-squares problem; we
solve it with ``scipy.linalg.lstsq`` on the design matrix instead of forming
and inverting A (docs/design.md §4).

As docs/design.md asks, only interior poles are unknowns: the boundary rows and
columns are the decoded boundary curves, shared with the neighbours.  The
paper's eq. 19 sums over all (n+1)(m+1) poles.

Periodic surfaces are not handled (their flat knots wrap); the caller offers
this method only for clamped, non-periodic nets.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .coons import full_knots, greville


@dataclass(frozen=True)
class Basis:
    """What the D-map needs of a surface besides its poles.

    Attributes
    ----------
    uflat, vflat : ndarray
        Knot vectors with multiplicities expanded (``coons.full_knots``).
    udegree, vdegree : int
    weights : ndarray, shape (nu, nv), or None
    """

    uflat: np.ndarray
    vflat: np.ndarray
    udegree: int
    vdegree: int
    weights: np.ndarray | None

    @classmethod
    def of(
        cls,
        uknots: np.ndarray,
        umults: np.ndarray,
        vknots: np.ndarray,
        vmults: np.ndarray,
        udegree: int,
        vdegree: int,
        weights: np.ndarray | None,
    ) -> Basis:
        return cls(
            full_knots(uknots, umults), full_knots(vknots, vmults), udegree, vdegree, weights
        )

    def abscissae(self, nu: int, nv: int) -> tuple[np.ndarray, np.ndarray]:
        """The Greville grid (eq. 17), clipped into the knot domain."""
        u = greville_flat(self.uflat, self.udegree, nu)
        v = greville_flat(self.vflat, self.vdegree, nv)
        return u, v


def greville_flat(flat: np.ndarray, degree: int, n: int) -> np.ndarray:
    """Greville abscissae of an expanded knot vector, inside [t_p, t_n]."""
    g = greville(flat, np.ones(len(flat), int), degree, n)
    return np.clip(g, flat[degree], flat[n])


def basis_matrices(
    flat: np.ndarray, degree: int, x: np.ndarray, n: int
) -> tuple[np.ndarray, np.ndarray]:
    """B-spline basis values N_{i,p}(x) and first derivatives, shapes (len(x), n) (eq. 2)."""
    x = np.clip(x, flat[degree], flat[n])
    from scipy.interpolate import BSpline  # on first use: ~0.3 s that decoding skips

    spline = BSpline(flat, np.eye(n), degree, extrapolate=True)
    der = spline.derivative()(x) if degree > 0 else np.zeros((len(x), n))
    return spline(x), der


def _surface(
    net: np.ndarray,
    w: np.ndarray,
    nu_: tuple[np.ndarray, np.ndarray],
    nv_: tuple[np.ndarray, np.ndarray],
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Points, u- and v-derivatives of a rational net on a grid (quotient rule)."""
    (bu, du), (bv, dv) = nu_, nv_
    hw = net * w[..., None]
    s = np.einsum("ki,ijc,lj->klc", bu, hw, bv)
    su = np.einsum("ki,ijc,lj->klc", du, hw, bv)
    sv = np.einsum("ki,ijc,lj->klc", bu, hw, dv)
    ws = np.einsum("ki,ij,lj->kl", bu, w, bv)[..., None]
    wu = np.einsum("ki,ij,lj->kl", du, w, bv)[..., None]
    wv = np.einsum("ki,ij,lj->kl", bu, w, dv)[..., None]
    p = s / ws
    return p, (su - wu * p) / ws, (sv - wv * p) / ws


def normals(net: np.ndarray, basis: Basis) -> np.ndarray:
    """Unit normals n_ij of the surface of ``net`` at its Greville points (eq. 16), (nu, nv, 3).

    Where the normal is undefined (a collapsed edge), it is zero.
    """
    nu, nv = net.shape[:2]
    u, v = basis.abscissae(nu, nv)
    w = np.ones((nu, nv)) if basis.weights is None else basis.weights
    _, su, sv = _surface(
        net,
        w,
        basis_matrices(basis.uflat, basis.udegree, u, nu),
        basis_matrices(basis.vflat, basis.vdegree, v, nv),
    )
    n = np.cross(su, sv)
    length = np.sqrt((n**2).sum(-1, keepdims=True))
    return np.divide(n, length, out=np.zeros_like(n), where=length > 1e-300)


def design(net: np.ndarray, basis: Basis) -> tuple[np.ndarray, np.ndarray]:
    """The linear model of eq. 14–15 on the Greville grid.

    Returns
    -------
    M : ndarray, shape (3·nu·nv, (nu-2)·(nv-2))
        Column (i, j) is R_ij(û_k, v̂_l)·n_ij for every sample (k, l) and axis.
    R : ndarray, shape (nu·nv, nu·nv)
        The rational basis at the samples, to evaluate a net there.
    """
    nu, nv = net.shape[:2]
    u, v = basis.abscissae(nu, nv)
    w = np.ones((nu, nv)) if basis.weights is None else basis.weights
    bu, _ = basis_matrices(basis.uflat, basis.udegree, u, nu)
    bv, _ = basis_matrices(basis.vflat, basis.vdegree, v, nv)
    r = np.einsum("ki,lj,ij->klij", bu, bv, w)
    r /= r.sum(axis=(2, 3), keepdims=True)
    r = r.reshape(nu * nv, nu * nv)
    n = normals(net, basis)[1:-1, 1:-1].reshape(-1, 3)
    inner = (np.arange(nu)[:, None] > 0) & (np.arange(nu)[:, None] < nu - 1)
    inner = inner & (np.arange(nv)[None, :] > 0) & (np.arange(nv)[None, :] < nv - 1)
    cols = r[:, inner.reshape(-1)]  # (samples, interior poles)
    m = (cols[:, None, :] * n.T[None, :, :]).reshape(-1, cols.shape[1])
    return m, r


def fit(poles: np.ndarray, coons: np.ndarray, basis: Basis) -> np.ndarray:
    """The D-map: distances d_ij of the interior poles, shape (nu-2, nv-2) (eq. 18–25).

    ``coons`` is the interpolating net P^I (from the *decoded* boundaries).
    """
    nu, nv = poles.shape[:2]
    m, r = design(coons, basis)
    g = r @ (poles - coons).reshape(-1, 3)  # G_kl (eq. 20)
    from scipy.linalg import lstsq

    d, *_ = lstsq(m, g.reshape(-1), lapack_driver="gelsd")
    return d.reshape(nu - 2, nv - 2)


def apply(coons: np.ndarray, d: np.ndarray, basis: Basis) -> np.ndarray:
    """P^A = P^I + d·n on the interior (eq. 15)."""
    out = coons.copy()
    out[1:-1, 1:-1] += d[..., None] * normals(coons, basis)[1:-1, 1:-1]
    return out
