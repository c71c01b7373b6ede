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

import functools

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


# ---------------------------------------------------------------- extrapolating spatial (2.0)
#
# Method 10 (docs/format.md §2.4): each pole predicted by linear extrapolation
# from the two before it along u and along v, the separable operator A_u∘A_v
# with A: y_0 = x_0, y_1 = x_1 - x_0, y_k = x_k - 2·x_{k-1} + x_{k-2}.  On
# smooth nets the second differences of the poles are much smaller than the
# first (a B-spline's control polygon follows its curve), so the residuals are.


def _extrapolate_axis(x: np.ndarray, axis: int) -> np.ndarray:
    """A along ``axis`` (integers: exact)."""
    x = np.moveaxis(x, axis, 0)
    y = x.copy()
    y[1:] -= x[:-1]
    y[2:] -= x[1:-1] - x[:-2]
    return np.moveaxis(y, 0, axis)


def _unextrapolate_axis(y: np.ndarray, axis: int) -> np.ndarray:
    """Inverse of :func:`_extrapolate_axis`: w_0 = y_0, w_1 = y_1, w_k = y_k +
    w_{k-1} (k ≥ 2), x = running sum of w (int64; wraps, never raises)."""
    y = np.moveaxis(y, axis, 0)
    w = y.copy()
    if len(w) > 2:
        w[1:] = np.cumsum(y[1:], axis=0)
    return np.moveaxis(np.cumsum(w, axis=0), 0, axis)


def extrapolate(q: np.ndarray) -> np.ndarray:
    """Residuals A_u∘A_v of an integer net (nu, nv, c), first pole absolute."""
    return _extrapolate_axis(_extrapolate_axis(q, 1), 0)


def unextrapolate(r: np.ndarray) -> np.ndarray:
    """Inverse of :func:`extrapolate` (along v, then along u)."""
    with np.errstate(over="ignore"):
        return _unextrapolate_axis(_unextrapolate_axis(r, 1), 0)


def _axis_weights(idx: np.ndarray) -> np.ndarray:
    """A's weights on lags 0, 1, 2 at positions ``idx`` along an axis (k, 3)."""
    w = np.zeros((len(idx), 3), np.int64)
    w[:, 0] = 1
    w[idx == 1, 1] = -1
    w[idx >= 2, 1] = -2
    w[idx >= 2, 2] = 1
    return w


#: Offsets of the candidate residuals around the shrunk target (27 in 3-D).
_OFFSETS = np.array([(a, b, c) for a in (-1, 0, 1) for b in (-1, 0, 1) for c in (-1, 0, 1)])
#: Candidates must lie this much (relative) inside the bound: the
#: certified bound is measured on the decoded poles afterwards anyway.
_MARGIN = 1e-6


def eg_bits(r: np.ndarray) -> np.ndarray:
    """Exp-Golomb length of zig-zag mapped integers (as ``codec.cost_bits``), elementwise."""
    z = np.abs(r).astype(np.float64) * 2 - (r < 0)
    return 2 * np.floor(np.log2(z + 1.0)) + 1


def rd_extrapolate(
    p: np.ndarray, h: np.ndarray, bound: float | np.ndarray, qo: np.ndarray
) -> np.ndarray:
    """Residuals (R, nu, nv, 3) of :func:`extrapolate` chosen within ``bound``
    (one for all, or one per step), on each grid step of ``h`` (R,) at once.

    The closed loop of the decoder, run in its own order along the
    anti-diagonals (each pole's predictors lie on earlier ones, so a diagonal
    is one vectorised step): each pole's prediction from the decoded poles
    before it; of the grid points within ``bound`` of the pole, the one whose
    residual is cheapest (Exp-Golomb bits and one more per non-zero integer,
    then nearest to the pole), searched among the 27 around the point of the
    bound's ball nearest to the prediction.  A per-net rate-distortion
    choice: the pole moves anywhere within its bound, not only to its
    nearest grid point.  The four corners
    go to their nearest grid point (a corner pinned to a vertex stays within
    a grid step of it), as does any pole with no candidate inside (``h`` ≤
    2·bound/√3 makes the nearest one fit).  ``qo`` (R, 3): the origin's grid
    point on each grid, subtracted from the first residual.
    """
    nu, nv, c = p.shape
    nr = len(h)
    t_all = (p[None] / h[:, None, None, None]).reshape(nr, nu * nv, c)
    rho2 = ((bound / h) ** 2 * (1 - _MARGIN))[:, None]
    rho = np.sqrt(rho2)
    flat = np.zeros((nr, (nu + 2) * (nv + 2), c), np.int64)  # decoded grid points, padded by 2
    r = np.zeros((nr, nu * nv, c), np.int64)
    with np.errstate(divide="ignore", invalid="ignore"):
        for d, (at, pad, nbr, w, corner) in enumerate(_diagonals(nu, nv)):
            pred = -np.einsum("rkmc,km->rkc", flat[:, nbr], w)
            if d == 0:
                pred += qo[:, None, :]
            t = t_all[:, at] - pred  # the residual that would land on the pole (R, k, c)
            norm = np.sqrt((t * t).sum(-1))
            shrink = np.nan_to_num(np.clip(1 - rho / norm, 0, 1))
            base = np.rint(t * shrink[..., None])
            if c == 3:
                best, nearest = _cheapest3(base, t, rho2)
            else:  # no offsets: the shrunk point, or the nearest one
                best, nearest = base, ((base - t) ** 2).sum(-1) > rho2
            nearest |= corner[None]
            best = np.where(nearest[..., None], np.rint(t), best)
            rr = best.astype(np.int64)
            r[:, at] = rr
            flat[:, pad] = pred + rr
    return r.reshape(nr, nu, nv, c)


#: The three offsets tried per coordinate, in :data:`_OFFSETS`'s order.
_STEPS = np.array([-1.0, 0.0, 1.0])


def _cheapest3(base: np.ndarray, t: np.ndarray, rho2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Of the 27 candidates ``base`` + :data:`_OFFSETS` (R, k, 3), the cheapest
    within ``rho2`` of ``t`` (:func:`rd_extrapolate`'s cost), and where none is.
    Each coordinate's bits and squared distance take three values, one per
    offset: they are summed over the 27 combinations in the order the full
    (R, k, 27, 3) arrays would sum them, so the costs are theirs bit for bit."""
    cand = base[..., None] + _STEPS  # (R, k, 3 coordinates, 3 offsets)
    bits = eg_bits(cand) + (cand != 0)
    sq = (cand - t[..., None]) ** 2
    shape = (*base.shape[:2], 27)
    dist = _combined(sq).reshape(shape)
    # one bit more per non-zero integer: of two candidates of equal
    # Exp-Golomb bits, the one with more zeros (trj7 at 0.01 mm: -52 bytes)
    cost = _combined(bits).reshape(shape) + 1e-3 * dist
    cost[dist > rho2[:, :, None]] = np.inf
    pick = cost.argmin(-1)
    best = base + _OFFSETS[pick]
    nearest = ~np.isfinite(np.take_along_axis(cost, pick[..., None], axis=2)[..., 0])
    return best, nearest


def _combined(a: np.ndarray) -> np.ndarray:
    """Per (R, k), the 3 x 3 x 3 sums a[0, i] + a[1, j] + a[2, l] of a per-coordinate,
    per-offset array (R, k, 3, 3), summed in that order."""
    return (a[:, :, 0, :, None, None] + a[:, :, 1, None, :, None]) + a[:, :, 2, None, None, :]


@functools.lru_cache(maxsize=256)
def _diagonals(
    nu: int, nv: int
) -> tuple[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray], ...]:
    """Per anti-diagonal of a (nu, nv) net, in order: its poles' flat indices,
    their flat indices in the net padded by 2 rows and columns before,
    their 8 predictors' padded indices and weights (A_u∘A_v without the
    pole itself, int64) and which are corners."""
    out = []
    wide = nv + 2
    for d in range(nu + nv - 1):
        i = np.arange(max(0, d - nv + 1), min(nu, d + 1))
        j = d - i
        wu, wv = _axis_weights(i), _axis_weights(j)
        lags = [(a, b) for a in range(3) for b in range(3) if a or b]
        nbr = np.stack([(i + 2 - a) * wide + (j + 2 - b) for a, b in lags], 1)
        w = np.stack([wu[:, a] * wv[:, b] for a, b in lags], 1)
        corner = ((i == 0) | (i == nu - 1)) & ((j == 0) | (j == nv - 1))
        out.append((i * nv + j, (i + 2) * wide + j + 2, nbr, w, corner))
    return tuple(out)
