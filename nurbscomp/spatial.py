"""Closed-loop spatial prediction on a tolerance grid, the way PRC codes control nets.

Each pole is snapped to a uniform grid of step ``h`` and predicted from its
already decoded neighbours by the parallelogram rule,
``P'[i,j] ≈ P'[i-1,j] + P'[i,j-1] - P'[i-1,j-1]``.  On a grid the prediction of
grid points is exact integer arithmetic, so closed-loop prediction is the same
as taking the mixed second difference of the snapped integer net, and the
decoder is two cumulative sums.  The error of every coordinate is at most h/2,
so every pole moves by at most h·√3/2: an L∞ bound by construction.
"""

from __future__ import annotations

import numpy as np


def snap(p: np.ndarray, h: float) -> np.ndarray:
    """Grid coordinates of points, int64, same shape."""
    return np.rint(p / h).astype(np.int64)


def residuals(q: np.ndarray) -> np.ndarray:
    """Parallelogram-rule residuals of an integer net (nu, nv, c), first pole absolute.

    r[i, j] = q[i, j] - q[i-1, j] - q[i, j-1] + q[i-1, j-1], terms outside the
    net taken as 0 (integers: any order of the sums is exact).
    """
    a = q.copy()
    a[1:] -= q[:-1]
    r = a.copy()
    r[:, 1:] -= a[:, :-1]
    return r


def integrate(r: np.ndarray) -> np.ndarray:
    """Inverse of :func:`residuals`."""
    return np.cumsum(np.cumsum(r, axis=0), axis=1)


def encode(poles: np.ndarray, h: float) -> np.ndarray:
    """Residual integers of a net (nu, nv, c) on the grid of step ``h``."""
    return residuals(snap(poles, h))


def decode(r: np.ndarray, h: float) -> np.ndarray:
    """Decoded net from the residuals of :func:`encode`."""
    return integrate(r) * h
