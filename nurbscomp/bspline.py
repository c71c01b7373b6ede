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
