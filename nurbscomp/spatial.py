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
import math

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
    """Exp-Golomb length of zig-zag mapped integers (as ``codec.cost_bits``),
    elementwise: 2·floor(log2(z + 1)) + 1 for z = 2|r| − (r < 0), the floor
    read off the binary exponent (exact, where a rounded log2 of 2^k − 1
    reaches k past 2^48)."""
    z = np.abs(r).astype(np.float64) * 2 - (r < 0)
    return 2.0 * (np.frexp(z + 1.0)[1] - 1) + 1.0


def rd_extrapolate(
    p: np.ndarray, h: np.ndarray, bound: float | np.ndarray, qo: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Residuals (R, nu, nv, 3) of :func:`extrapolate` chosen within ``bound``
    (one for all, or one per step), on each grid step of ``h`` (R,) at once,
    and the grid points (R, nu, nv, 3) they decode to (:func:`unextrapolate`
    of the residuals with the origin's grid point added to the first: the
    closed loop computes the same integers).

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
            rr = _choose(t_all[:, at] - pred, rho, rho2, corner)
            r[:, at] = rr
            flat[:, pad] = pred + rr
    grid = flat.reshape(nr, nu + 2, nv + 2, c)[:, 2:, 2:]
    return r.reshape(nr, nu, nv, c), grid


def _choose(t: np.ndarray, rho: np.ndarray, rho2: np.ndarray, corner: np.ndarray) -> np.ndarray:
    """The residuals (R, k, c) :func:`rd_extrapolate` stores for the poles of
    one anti-diagonal, ``t`` the residuals that would land on the poles."""
    c = t.shape[-1]
    norm = np.sqrt((t * t).sum(-1))
    # clipped to [0, 1], NaN (a NaN target) to 0: fmax and fmin drop NaN
    shrink = np.fmin(np.fmax(1 - rho / norm, 0.0), 1.0)
    base = np.rint(t * shrink[..., None])
    if c == 3:
        best, nearest = _cheapest3(base, t, rho2)
    else:  # no offsets: the shrunk point, or the nearest one
        best, nearest = base, ((base - t) ** 2).sum(-1) > rho2
    nearest |= corner[None]
    best = np.where(nearest[..., None], np.rint(t), best)
    return best.astype(np.int64)


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
    d = cand - t[..., None]
    sq = d * d
    shape = (*base.shape[:2], 27)
    dist = _combined(sq).reshape(shape)
    # one bit more per non-zero integer: of two candidates of equal
    # Exp-Golomb bits, the one with more zeros (trj7 at 0.01 mm: -52 bytes)
    cost = _combined(bits).reshape(shape) + 1e-3 * dist
    cost[dist > rho2[:, :, None]] = np.inf
    pick = cost.argmin(-1)
    best = base + _OFFSETS[pick]
    nearest = np.isinf(cost.min(-1))  # the pick's cost: inf where every candidate is out
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


# ------------------------------------------------------ extrapolation on the abscissae (2.14)
#
# Methods 14-22 (docs/format.md §2.4, "Extrapolation on the abscissae"): each
# pole predicted along v from the poles before it in its row, and the row's
# prediction errors along u from the rows before, each by the polynomial of
# degree o - 1 through the o poles before it (o the method's order along that
# direction, 1 to 3) at their Greville abscissae, not at equal steps.  Near a
# clamped end of a B-spline the abscissae crowd (a cubic's: 0, 1/3, 1, 2 ...),
# where linear extrapolation at equal steps misses by a whole leg.  The
# weights are not integers: each prediction is rounded to the grid, so the
# two directions are applied one after the other (lifting), v first.

#: Extrapolation orders along a direction: the pole before (1), the line (2)
#: or the parabola (3) through the poles before.
ORDERS = (1, 2, 3)
#: Predictions (2.14's lifted and arc rules) past this magnitude, and
#: non-finite ones, are not used (docs/format.md §2.4).
PREDICTION_LIMIT = 2.0**62
#: Rows and columns of zeros before a net in :func:`rd_lifted`'s decoded grid.
_PAD = 3


#: Node weights are rounded to multiples of 2^-WEIGHT_BITS (all but the first,
#: which takes what makes their sum 1): a few ulps of the abscissae (knots
#: mapped onto [0, 1]) then leave them as they are, and a prediction of grid
#: integers below 2^(52 - WEIGHT_BITS) is computed exactly.
WEIGHT_BITS = 20
#: Rows of node weights past this size take the weights of equal steps.
WEIGHT_MAX = 1024.0


def node_weights(g: np.ndarray, order: int) -> np.ndarray:
    """:func:`_node_weights` of ``g`` (read-only; the same abscissae give the
    same array, kept for the nets that follow)."""
    return _node_weights(np.asarray(g, np.float64).tobytes(), order)


@functools.lru_cache(maxsize=4096)
def _node_weights(key: bytes, order: int) -> np.ndarray:
    """The weights (n, 3) of x_{k-1}, x_{k-2}, x_{k-3} in the prediction of
    x_k at abscissae ``g`` (n,): Lagrange's extrapolation through the a =
    min(k, ``order``) values before k.  In binary64, in this order::

        L_m = num / den,  num = Π (g[k] − g[k−l]),  den = Π (g[k−m] − g[k−l])
              over l = 1 .. a, l ≠ m, in increasing l (empty products: 1.0)
        w[k, m-1] = ldexp(rint(ldexp(L_m, B)), −B)  for m = 2 .. a  (B = WEIGHT_BITS)
        w[k, 0] = (1.0 − w[k, 1]) − w[k, 2]

    0 past a.  Where some den is 0, or some L_m is not finite or past
    :data:`WEIGHT_MAX` in size, the row takes the weights of equal steps
    (order 2: 2, −1; order 3: 3, −3, 1)."""
    g = np.frombuffer(key, np.float64)
    n = len(g)
    w = np.zeros((n, 3))
    for k in range(1, n):
        a = min(k, order)
        lag = []
        for m in range(1, a + 1):
            num = den = 1.0
            for ll in range(1, a + 1):
                if ll != m:
                    num = num * (float(g[k]) - float(g[k - ll]))
                    den = den * (float(g[k - m]) - float(g[k - ll]))
            lag.append(num / den if den != 0 else math.nan)
        if all(math.isfinite(x) and abs(x) <= WEIGHT_MAX for x in lag):
            row = [0.0] + [
                math.ldexp(round(math.ldexp(x, WEIGHT_BITS)), -WEIGHT_BITS) for x in lag[1:]
            ]
            row += [0.0] * (3 - len(row))
            row[0] = (1.0 - row[1]) - row[2]
        else:
            row = [(-1.0) ** (m + 1) * math.comb(a, m) for m in range(1, a + 1)] + [0.0] * (3 - a)
        w[k] = row
    w.setflags(write=False)
    return w


def _predict(w: np.ndarray, x1: np.ndarray, x2: np.ndarray, x3: np.ndarray) -> np.ndarray:
    """rint((w1·x1 + w2·x2) + w3·x3) of int64 values (…, c) with weights (…, 3),
    in binary64 in that order, as int64; a prediction that is not finite or
    not below 2^62 in size is 0."""
    with np.errstate(over="ignore", invalid="ignore"):
        p = (w[..., 0, None] * x1.astype(np.float64) + w[..., 1, None] * x2.astype(np.float64)) + w[
            ..., 2, None
        ] * x3.astype(np.float64)
        return _rounded(p)


def _rounded(p: np.ndarray) -> np.ndarray:
    """rint(p) as int64, 0 where p is not finite or not below 2^62 in size."""
    with np.errstate(invalid="ignore"):
        ok = np.abs(p) < PREDICTION_LIMIT  # NaN fails too
    if ok.all():
        return np.rint(p).astype(np.int64)
    return np.where(ok, np.rint(np.where(ok, p, 0.0)), 0.0).astype(np.int64)


def _back(x: np.ndarray, m: int) -> np.ndarray:
    """x_{k−m} along axis 0 for every k (zeros before the first)."""
    out = np.zeros_like(x)
    if m < len(x):
        out[m:] = x[:-m]
    return out


def _lift(x: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Along axis 0 of ``x`` (n, …, c): y_k = x_k − the prediction of x_k from
    x_{k−1..k−3} with the weights ``w`` (n, 3) (:func:`_predict`), every k at once."""
    wk = w.reshape(len(x), *([1] * (x.ndim - 2)), 3)
    with np.errstate(over="ignore"):
        return x - _predict(wk, _back(x, 1), _back(x, 2), _back(x, 3))


def _unlift(y: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Inverse of :func:`_lift`: x_k = y_k + the prediction from the x before,
    k by k (int64; wraps).  The same operations as :func:`_predict`: a weight
    of 0 adds nothing (a sum with ±0 is exact), so its term is left out."""
    x = y.copy()
    xf = np.zeros(y.shape)
    xf[0] = x[0]
    with np.errstate(over="ignore", invalid="ignore"):
        for k in range(1, len(y)):
            p = None
            for m in (1, 2, 3):
                c = float(w[k, m - 1])
                if c != 0.0 and k >= m:
                    term = c * xf[k - m]
                    p = term if p is None else p + term
            if p is not None:
                x[k] += _rounded(p)
            xf[k] = x[k]
    return x


def _lift_v(q: np.ndarray, w: np.ndarray) -> np.ndarray:
    """:func:`_lift` of a net (nu, nv, c) along v."""
    return np.moveaxis(_lift(np.moveaxis(q, 1, 0), w), 0, 1)


def lifted_residuals(q: np.ndarray, wu: np.ndarray, wv: np.ndarray) -> np.ndarray:
    """Residuals (nu, nv, c) of grid integers ``q``: along v with the weights
    ``wv`` (:func:`node_weights`), then along u with ``wu``; first pole absolute."""
    return _lift(_lift_v(q, wv), wu)


def lifted_trials(
    q: np.ndarray, wu: dict[int, np.ndarray], wv: dict[int, np.ndarray]
) -> dict[tuple[int, int], np.ndarray]:
    """:func:`lifted_residuals` of ``q`` for every pair of orders (u, v) of
    the weights ``wu``, ``wv`` (order -> weights), each lift along v made once."""
    out = {}
    for b, w in wv.items():
        z = _lift_v(q, w)
        for a, x in wu.items():
            out[(a, b)] = _lift(z, x)
    return out


def lifted_integrate(r: np.ndarray, wu: np.ndarray, wv: np.ndarray) -> np.ndarray:
    """Inverse of :func:`lifted_residuals`: along u, then along v (int64; wraps)."""
    z = _unlift(r, wu)
    return np.ascontiguousarray(np.moveaxis(_unlift(np.moveaxis(z, 1, 0), wv), 0, 1))


def rd_lifted(
    p: np.ndarray,
    h: np.ndarray,
    bound: float | np.ndarray,
    qo: np.ndarray,
    wu: np.ndarray,
    wv: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """Residuals (R, nu, nv, 3) of :func:`lifted_residuals` chosen within
    ``bound`` on each grid step of ``h`` (R,), as :func:`rd_extrapolate`
    chooses its own, and the grid points (R, nu, nv, 3) they decode to
    (:func:`lifted_integrate`'s, by the same operations): the decoder's
    closed loop, one anti-diagonal at a time.
    A pole's prediction is its row's (from the grid points before it in the
    row) plus the prediction of its row's error (from the errors of the rows
    before, at its column); its error is its grid point less its row's
    prediction."""
    nu, nv, c = p.shape
    nr = len(h)
    t_all = (p[None] / h[:, None, None, None]).reshape(nr, nu * nv, c)
    rho2 = ((bound / h) ** 2 * (1 - _MARGIN))[:, None]
    rho = np.sqrt(rho2)
    wide = nv + _PAD
    q = np.zeros((nr, (nu + _PAD) * wide, c), np.int64)  # decoded grid points, padded
    e = np.zeros_like(q)  # their rows' prediction errors
    r = np.zeros((nr, nu * nv, c), np.int64)
    with np.errstate(divide="ignore", invalid="ignore"):
        for d in range(nu + nv - 1):
            i = np.arange(max(0, d - nv + 1), min(nu, d + 1))
            j = d - i
            at = (i + _PAD) * wide + j + _PAD
            pv = _predict(wv[j][None], *(q[:, at - m] for m in (1, 2, 3)))
            pu = _predict(wu[i][None], *(e[:, at - m * wide] for m in (1, 2, 3)))
            pred = pv + pu
            if d == 0:
                pred += qo[:, None, :]
            corner = ((i == 0) | (i == nu - 1)) & ((j == 0) | (j == nv - 1))
            rr = _choose(t_all[:, i * nv + j] - pred, rho, rho2, corner)
            r[:, i * nv + j] = rr
            q[:, at] = pred + rr
            e[:, at] = q[:, at] - pv
    grid = q.reshape(nr, nu + _PAD, wide, c)[:, _PAD:, _PAD:]
    return r.reshape(nr, nu, nv, c), grid


# ---------------------------------------------------------------- arcs (2.14)
#
# Methods 12 and 13 (docs/format.md §2.4, "Rows of arcs"): the rows of a net
# along one direction predicted as chains of equal-angle quadratic arcs, the
# way a rational quadratic B-spline with double inner knots writes a circle
# (its poles alternate: a point on the curve, the corner where the tangents at
# the segment's two ends meet).  Along such a row a corner is the linear
# extrapolation of the two poles before it (the tangent at the end of the last
# segment goes on), and a point on the curve is the last corner plus the last
# segment's leg turned by the angle between its two legs: for legs v1, v2 of
# equal length, v2 turned as v1 turned into it is 2·(v1·v2)/(v1·v1)·v2 − v1.
# Across the rows the predictions' errors are differenced (the parallelogram
# rule where a row predicts each pole by the one before it), so rows that are
# translates, or arcs of one axis, leave residuals of 0.


def arc_column(x: np.ndarray, j: int) -> np.ndarray:
    """The predictions (k, c) of column ``j`` of rows ``x`` (k, n, c) of grid
    integers from their columns before ``j`` (docs/format.md §2.4): 0 for the
    first, the pole before for the second, the linear extrapolation
    2·x[j−1] − x[j−2] at odd ``j`` and at 2, and at even ``j`` ≥ 4 the arc
    continuation (:func:`_arcs_at`).  Integers wrap (int64) rather than raise."""
    k, _, c = x.shape
    if j == 0:
        return np.zeros((k, c), np.int64)
    if j == 1:
        return x[:, 0].copy()
    if j % 2 or j == 2:
        with np.errstate(over="ignore"):
            return 2 * x[:, j - 1] - x[:, j - 2]
    return _arcs_at(x, np.array([j]))[:, 0]


def _arcs_at(x: np.ndarray, js: np.ndarray) -> np.ndarray:
    """The arc continuations (k, len(js), c) at the even columns ``js`` (≥ 4)
    of rows ``x`` (k, n, c), each from the four columns before it, rounded
    half to even, in binary64 operations in this order::

        v1 = float(x[j-3] - x[j-4]); v2 = float(x[j-2] - x[j-3])   # int64, then exact
        d11 = (v1x*v1x + v1y*v1y) + v1z*v1z; d12 likewise with v2
        p = (float(x[j-1]) + ((2*d12) / d11) * v2) - v1

    or the pole before where d11 is not > 0 or some |p| is not < :data:`PREDICTION_LIMIT`."""
    c = x.shape[2]
    with np.errstate(over="ignore"):
        v1 = (x[:, js - 3] - x[:, js - 4]).astype(np.float64)
        v2 = (x[:, js - 2] - x[:, js - 3]).astype(np.float64)
    d11, d12 = v1[..., 0] * v1[..., 0], v1[..., 0] * v2[..., 0]
    for a in range(1, c):
        d11 = d11 + v1[..., a] * v1[..., a]
        d12 = d12 + v1[..., a] * v2[..., a]
    back = x[:, js - 1]
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        ok = d11 > 0
        turn = np.where(ok, (2.0 * d12) / np.where(ok, d11, 1.0), 0.0)
        p = (back.astype(np.float64) + turn[..., None] * v2) - v1
        ok &= (np.abs(p) < PREDICTION_LIMIT).all(-1)  # NaN fails too
        p = np.where(ok[..., None], p, 0.0)
    return np.where(ok[..., None], np.rint(p).astype(np.int64), back)


def _rows_along(q: np.ndarray, axis: int) -> np.ndarray:
    """The net (nu, nv, c) as rows along ``axis`` (0: u, 1: v)."""
    return q if axis == 1 else q.transpose(1, 0, 2)


def arc_residuals(q: np.ndarray, axis: int) -> np.ndarray:
    """Residuals (nu, nv, c) of grid integers ``q`` whose rows along ``axis``
    are predicted as arcs (:func:`arc_column`), the rows' errors differenced
    across the rows; the first pole absolute."""
    x = _rows_along(q, axis)
    e = x.copy()
    n = x.shape[1]
    with np.errstate(over="ignore"):  # every column at once: x is known
        if n > 1:
            e[:, 1] -= x[:, 0]
        line = np.array([j for j in range(2, n) if j % 2 or j == 2], np.int64)
        if len(line):
            e[:, line] -= 2 * x[:, line - 1] - x[:, line - 2]
        even = np.arange(4, n, 2)
        if len(even):
            e[:, even] -= _arcs_at(x, even)
        r = e.copy()
        r[1:] -= e[:-1]
    return np.ascontiguousarray(_rows_along(r, axis))


def arc_integrate(r: np.ndarray, axis: int) -> np.ndarray:
    """Inverse of :func:`arc_residuals`: the errors are running sums across
    the rows, then each column is its prediction plus its error (int64;
    wraps, never raises)."""
    with np.errstate(over="ignore"):
        e = np.cumsum(_rows_along(r, axis), axis=0)
        x = np.zeros_like(e)
        for j in range(e.shape[1]):
            x[:, j] = e[:, j] + arc_column(x, j)
    return np.ascontiguousarray(_rows_along(x, axis))
