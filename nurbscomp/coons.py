"""Coons predictors on control nets (eq. 11), at the Greville abscissae (eq. 17).

For a non-rational surface with clamped knots, the bilinearly blended Coons
patch of its four boundary curves lies in the surface's own spline space
(splines reproduce linear functions, and the Greville abscissae are where they
do so), and its control net is the discrete Coons formula taken at the
normalised Greville abscissae.  For rational surfaces the same net is used as
a predictor only; the weights are kept exactly (DESIGN §4).

The paper's bicubically blended variant (eq. 11 with cubic Bezier blends and
cross-boundary derivatives from corner twists) is not implemented yet.
"""

from __future__ import annotations

import numpy as np


def full_knots(knots: np.ndarray, mults: np.ndarray) -> np.ndarray:
    """The knot vector with each knot repeated by its multiplicity."""
    return np.repeat(np.asarray(knots, float), np.asarray(mults, int))


def greville(knots: np.ndarray, mults: np.ndarray, degree: int, n: int) -> np.ndarray:
    """Greville abscissae, û_i = (1/p)·Σ_{k=i+1}^{i+p} u_k (eq. 17, corrected), shape (n,)."""
    t = full_knots(knots, mults)
    if degree == 0:
        return t[:n].copy()
    c = np.concatenate([[0.0], np.cumsum(t)])
    i = np.arange(n)
    return (c[i + degree + 1] - c[i + 1]) / degree


def unit_abscissae(g: np.ndarray) -> np.ndarray:
    """Greville abscissae mapped onto [0, 1] (equal spacing if they coincide)."""
    span = g[-1] - g[0]
    if not span > 0:
        return np.linspace(0.0, 1.0, len(g))
    return (g - g[0]) / span


def coons_net(
    u0: np.ndarray, u1: np.ndarray, v0: np.ndarray, v1: np.ndarray, s: np.ndarray, t: np.ndarray
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

    Returns
    -------
    ndarray, shape (nu, nv, 3)
        A net whose boundary rows and columns are the given ones.
    """
    s = s[:, None, None]
    t = t[None, :, None]
    ruled_u = (1 - s) * u0[None] + s * u1[None]
    ruled_v = (1 - t) * v0[:, None] + t * v1[:, None]
    corners = (
        (1 - s) * (1 - t) * u0[0] + (1 - s) * t * u0[-1] + s * (1 - t) * u1[0] + s * t * u1[-1]
    )
    return ruled_u + ruled_v - corners
