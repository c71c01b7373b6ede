"""Coons predictors on control nets (eq. 11), at the Greville abscissae (eq. 17).

For a non-rational surface with clamped knots, the bilinearly blended Coons
patch of its four boundary curves lies in the surface's own spline space
(splines reproduce linear functions, and the Greville abscissae are where they
do so), and its control net is the discrete Coons formula taken at the
normalised Greville abscissae.  For rational surfaces the same net is used as
a predictor only; the weights are kept exactly (docs/design.md §4).

The paper's bicubically blended variant (eq. 11: S = S1 + S2 − S3 with cubic
blends) is :func:`bicubic_net`: cross-boundary derivatives are cubic curves
between the boundary curves' end slopes (docs/design.md §4), the corners' bilinear
twist as their end slopes.  It is not
in the spline space, so it is a predictor only, for every net.
"""

from __future__ import annotations

import functools

import numpy as np


def full_knots(knots: np.ndarray, mults: np.ndarray) -> np.ndarray:
    """The knot vector with each knot repeated by its multiplicity."""
    return np.repeat(np.asarray(knots, float), np.asarray(mults, int))


def greville(knots: np.ndarray, mults: np.ndarray, degree: int, n: int) -> np.ndarray:
    """Greville abscissae, û_i = (1/p)·Σ_{k=i+1}^{i+p} u_k (eq. 17, corrected), shape (n,).

    A periodic B-spline's knots (first and last multiplicities equal, n = Σ
    mults − mults[0]) do not reach u_{n+p}: the sequence is then continued
    periodically, u_{k+n} = u_k + (last knot − first knot), as far as the sum
    needs (:func:`periodic_flat`).  A clamped or non-periodic sequence is long
    enough and is used as it is.
    """
    t = full_knots(knots, mults)
    if len(t) < n + degree:
        t = periodic_flat(t, int(np.asarray(mults)[0]), n, n + degree)
    if degree == 0:
        return t[:n].copy()
    c = np.concatenate([[0.0], np.cumsum(t)])
    i = np.arange(n)
    return (c[i + degree + 1] - c[i + 1]) / degree


def periodic_flat(t: np.ndarray, m0: int, n: int, length: int) -> np.ndarray:
    """The flat knot sequence ``t`` of a periodic B-spline with ``n`` poles,
    continued to ``length`` knots by u_{k+n} = u_k + period.

    ``m0`` is the first knot's multiplicity; the knots after the first
    occurrence of the first knot, shifted by the period, follow the last.
    """
    period = t[-1] - t[0]
    k = np.arange(len(t), length)
    src = m0 + (k - len(t)) % max(n, 1)
    turns = 1 + (k - len(t)) // max(n, 1)
    src = np.minimum(src, len(t) - 1)
    return np.concatenate([t, t[src] + turns * period])


def unit_abscissae(g: np.ndarray) -> np.ndarray:
    """Greville abscissae mapped onto [0, 1] (equal spacing if they coincide)."""
    span = g[-1] - g[0]
    if not span > 0:
        return np.linspace(0.0, 1.0, len(g))
    return (g - g[0]) / span


class Blends:
    """The blends of both Coons nets at (s_i, t_j), shaped for broadcasting.

    They depend on the abscissae alone: an encoder trying many boundaries of
    one net computes them once (each net below computes them itself when not
    given them, with the same arithmetic).
    """

    def __init__(self, s: np.ndarray, t: np.ndarray) -> None:
        self.s, self.t = s, t
        S, T = s[:, None, None], t[None, :, None]
        # bilinear: 1-s, 1-t and the corners' products, as coons_net writes them
        self.s_, self.t_, self.ms, self.mt = S, T, 1 - S, 1 - T
        self.w00, self.w01 = (1 - S) * (1 - T), (1 - S) * T
        self.w10, self.w11 = S * (1 - T), S * T

    @functools.cached_property
    def hermite(self) -> tuple[tuple[np.ndarray, ...], ...]:
        """Bicubic: Hermite blends H0..H3 of s as (nu, 1) and (nu, 1, 1), of t
        as (nv, 1) and (1, nv, 1), and H2 + H3 of s and of t, as (nu, 1) and (nv, 1)."""
        hs, ht = _hermite(self.s), _hermite(self.t)
        s_col = tuple(h[:, None] for h in hs)
        t_col = tuple(h[:, None] for h in ht)
        return (
            s_col,
            tuple(h[:, None, None] for h in hs),
            t_col,
            tuple(h[None, :, None] for h in ht),
            (s_col[2] + s_col[3], t_col[2] + t_col[3]),
        )


def coons_net(
    u0: np.ndarray,
    u1: np.ndarray,
    v0: np.ndarray,
    v1: np.ndarray,
    s: np.ndarray,
    t: np.ndarray,
    blends: Blends | None = None,
) -> np.ndarray:
    """The discrete bilinearly blended Coons net (eq. 11, bilinear blends).

    Parameters
    ----------
    u0, u1 : ndarray, shape (nv, 3)
        Boundary rows P[0, :] and P[nu-1, :].
    v0, v1 : ndarray, shape (nu, 3)
        Boundary columns P[:, 0] and P[:, nv-1]; their ends must equal the
        rows' ends (the four corners).
    s, t : ndarray, shapes (nu,), (nv,)
        Blending abscissae in [0, 1] (normalised Greville abscissae).
    blends : Blends, optional
        ``Blends(s, t)``, if already made.

    Returns
    -------
    ndarray, shape (nu, nv, 3)
        A net whose boundary rows and columns are the given ones.

    Boundaries with leading axes (..., nv, 3) give the nets (..., nu, nv, 3)
    of each, value for value the same.
    """
    b = Blends(s, t) if blends is None else blends
    ruled_u = b.ms * _row(u0) + b.s_ * _row(u1)  # (1-s)·u0 + s·u1
    ruled_v = b.mt * _col(v0) + b.t_ * _col(v1)  # (1-t)·v0 + t·v1
    # (1-s)(1-t)·P00 + (1-s)t·P0m + s(1-t)·Pn0 + st·Pnm
    corners = (
        b.w00 * _pole(u0[..., 0, :])
        + b.w01 * _pole(u0[..., -1, :])
        + b.w10 * _pole(u1[..., 0, :])
        + b.w11 * _pole(u1[..., -1, :])
    )
    return ruled_u + ruled_v - corners


def _row(c: np.ndarray) -> np.ndarray:
    """A row (..., nv, 3) broadcast over a net's rows: (..., 1, nv, 3)."""
    return c[..., None, :, :]


def _col(c: np.ndarray) -> np.ndarray:
    """A column (..., nu, 3) broadcast over a net's columns: (..., nu, 1, 3)."""
    return c[..., :, None, :]


def _pole(x: np.ndarray) -> np.ndarray:
    """A point (..., 3) broadcast over a net (..., 1, 1, 3)."""
    return x[..., None, None, :]


def _vec(x: np.ndarray) -> np.ndarray:
    """A point (..., 3) broadcast over a curve (..., 1, 3)."""
    return x[..., None, :]


def _hermite(x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Cubic Hermite blends H0..H3 at ``x``: values at 0 and 1, then slopes at 0 and 1."""
    x2, x3 = x * x, x * x * x
    return 2 * x3 - 3 * x2 + 1, -2 * x3 + 3 * x2, x3 - 2 * x2 + x, x3 - x2


def _slope(row: np.ndarray, x: np.ndarray, end: int) -> np.ndarray:
    """Slope of a boundary (as a polyline over abscissae ``x``) at its first or last pole."""
    if end == 0:
        d, h = row[..., 1, :] - row[..., 0, :], x[1] - x[0]
    else:
        d, h = row[..., -1, :] - row[..., -2, :], x[-1] - x[-2]
    return d / h if h > 0 else np.zeros_like(d)


def bicubic_net(
    u0: np.ndarray,
    u1: np.ndarray,
    v0: np.ndarray,
    v1: np.ndarray,
    s: np.ndarray,
    t: np.ndarray,
    blends: Blends | None = None,
) -> np.ndarray:
    """The bicubically blended Coons net (eq. 11: S1 + S2 − S3), at (s_i, t_j).

    Arguments as :func:`coons_net`.  S1 blends the columns v0, v1 along t
    with Hermite cubics and the cross-boundary derivatives ∂S/∂t along them;
    S2 the rows u0, u1 along s likewise; S3 is the bicubic Hermite patch of
    the corners, their slopes and twists.  Each cross-boundary derivative is
    the cubic Hermite curve between the two corner slopes of the boundaries
    that meet it, with the twist as its end slopes (the paper's "cubic Bezier
    curves", twists "from the network of boundary curves": here the bilinear
    twist P00 − P0m − Pn0 + Pnm of the four corners).  Every boundary is
    reproduced exactly, and so is a bilinear patch.  Leading axes as
    :func:`coons_net`.
    """
    bl = Blends(s, t) if blends is None else blends
    # corner slopes: along t from the rows, along s from the columns, (..., 1, 3)
    dt = [
        [_vec(_slope(u0, t, 0)), _vec(_slope(u0, t, 1))],
        [_vec(_slope(u1, t, 0)), _vec(_slope(u1, t, 1))],
    ]
    ds = [
        [_vec(_slope(v0, s, 0)), _vec(_slope(v1, s, 0))],
        [_vec(_slope(v0, s, 1)), _vec(_slope(v1, s, 1))],
    ]
    (H0s, H1s, H2s, H3s), hs_net, (H0t, H1t, H2t, H3t), ht_net, (h23s, h23t) = bl.hermite
    p00, p0m, pn0, pnm = (_vec(c[..., i, :]) for c in (u0, u1) for i in (0, -1))
    w = p00 - p0m - pn0 + pnm  # one twist for all four corners: the bilinear one
    dv0 = H0s * dt[0][0] + H1s * dt[1][0] + h23s * w  # ∂S/∂t along t = 0, over s
    dv1 = H0s * dt[0][1] + H1s * dt[1][1] + h23s * w  # along t = 1
    du0 = H0t * ds[0][0] + H1t * ds[0][1] + h23t * w  # ∂S/∂s along s = 0, over t
    du1 = H0t * ds[1][0] + H1t * ds[1][1] + h23t * w  # along s = 1
    g0 = H0s * p00 + H1s * pn0 + H2s * ds[0][0] + H3s * ds[1][0]  # S3 at t = 0
    g1 = H0s * p0m + H1s * pnm + H2s * ds[0][1] + H3s * ds[1][1]  # S3 at t = 1

    def along_t(a: np.ndarray, b: np.ndarray, da: np.ndarray, db: np.ndarray) -> np.ndarray:
        h0, h1, h2, h3 = ht_net
        return h0 * _col(a) + h1 * _col(b) + h2 * _col(da) + h3 * _col(db)

    h0, h1, h2, h3 = hs_net
    s2 = h0 * _row(u0) + h1 * _row(u1) + h2 * _row(du0) + h3 * _row(du1)
    return along_t(v0, v1, dv0, dv1) + s2 - along_t(g0, g1, dv0, dv1)
