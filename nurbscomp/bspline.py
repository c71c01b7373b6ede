"""Points of B-spline curves by de Boor's algorithm, in numpy (eq. 1-2).

The encoder's joins compare two curves point by point (``joins._apart``);
``scipy.interpolate.BSpline`` did that, and importing it costs 0.3-0.4 s in a
process that needs nothing else from it (``scipy.special`` and
``scipy.optimize`` come with it), which on a small IGES file was a third of
compress.  The D-map's basis matrices (``dmap.basis_matrices``) stay on
scipy: their values are part of the decoder's closed loop.
"""

from __future__ import annotations

import numpy as np


def points(knots: np.ndarray, poles: np.ndarray, degree: int, x: np.ndarray) -> np.ndarray:
    """Curve points at ``x`` of the B-spline with the expanded knot vector
    ``knots`` (length n + degree + 1) and ``poles`` (n, d).

    Like ``scipy.interpolate.BSpline(knots, poles, degree, extrapolate=False)``:
    NaN outside [knots[degree], knots[n]], and the last non-empty span holds
    its right end.

    Returns
    -------
    ndarray, shape (len(x), d)
    """
    t = np.asarray(knots, float)
    c = np.asarray(poles, float)
    x = np.asarray(x, float)
    n, p = len(c), int(degree)
    if len(t) != n + p + 1 or n <= p:
        raise ValueError("a B-spline needs n + degree + 1 knots and more poles than its degree")
    out = np.full((len(x), c.shape[1]), np.nan)
    inside = (x >= t[p]) & (x <= t[n])
    if not inside.any():
        return out
    xs = x[inside]
    # the span of each x: t[i] <= x < t[i+1], the last non-empty one at t[n]
    i = np.searchsorted(t, xs, side="right") - 1
    last = int(np.flatnonzero(t[p : n + 1] < t[n])[-1]) + p if t[n] > t[p] else p
    i = np.clip(i, p, last)
    # de Boor: d_j = c[i - p + j], j = 0..p, shape (m, p + 1, d)
    d = c[i[:, None] + np.arange(-p, 1)[None, :]]
    for r in range(1, p + 1):
        for j in range(p, r - 1, -1):
            lo = t[i + j - p]
            hi = t[i + 1 + j - r]
            den = hi - lo
            a = np.divide(xs - lo, den, out=np.zeros_like(xs), where=den != 0)
            d[:, j] = (1.0 - a)[:, None] * d[:, j - 1] + a[:, None] * d[:, j]
    out[inside] = d[:, p]
    return out


def refinement(old: np.ndarray, new: np.ndarray, degree: int) -> np.ndarray:
    """The knot-insertion matrix A (Oslo algorithm, eq. 1): the B-spline of
    degree ``degree`` on the expanded knot vector ``old`` with poles P is the
    one on ``new`` (``old``'s knots and more, the same clamped ends) with
    poles A @ P.  Each row of A is non-negative and sums to one.

    Row j holds the discrete B-splines α_{i,k}(j), k = degree + 1, by the
    recursion α_{i,1}(j) = [t_i ≤ τ_j < t_{i+1}] and
    α_{i,r}(j) = ω_{i,r} α_{i,r-1}(j) + (1 − ω_{i+1,r}) α_{i+1,r-1}(j),
    ω_{i,r} = (τ_{j+r-1} − t_i) / (t_{i+r-1} − t_i) (0 over an empty span).
    """
    t, tau, k = np.asarray(old, float), np.asarray(new, float), int(degree) + 1
    n, m = len(t) - k, len(tau) - k
    x = tau[:m, None]
    a = ((t[None, :-1] <= x) & (x < t[None, 1:])).astype(float)  # (m, n + k - 1)
    for r in range(2, k + 1):
        x = tau[r - 1 : m + r - 1, None]
        i = np.arange(n + k - r)
        lo, hi = t[i], t[i + r - 1]
        w1 = np.divide(x - lo, hi - lo, out=np.zeros((m, len(i))), where=hi > lo)
        lo2, hi2 = t[i + 1], t[i + r]
        w2 = np.divide(hi2 - x, hi2 - lo2, out=np.zeros((m, len(i))), where=hi2 > lo2)
        a = w1 * a[:, :-1] + w2 * a[:, 1:]
    return a


def refine(
    knots: np.ndarray, mults: np.ndarray, poles: np.ndarray, degree: int, target: np.ndarray
) -> np.ndarray:
    """The poles (along axis 0; a surface's other direction rides along) of
    the same clamped B-spline on the expanded knot vector ``target``, which
    holds every knot of ``knots`` (distinct values, with ``mults``) at least
    as often, and the same ends."""
    flat = np.repeat(np.asarray(knots, float), np.asarray(mults, int))
    a = refinement(flat, target, degree)
    return np.tensordot(a, poles, axes=(1, 0))
