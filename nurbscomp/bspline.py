"""Points of B-spline curves by de Boor's algorithm, in numpy (eq. 1-2).

The encoder's joins compare two curves point by point (``joins._apart``);
``scipy.interpolate.BSpline`` did that, and importing it costs 0.3-0.4 s in a
process that needs nothing else from it (``scipy.special`` and
``scipy.optimize`` come with it), which on a small IGES file was a third of
compress.  The D-map's basis matrices (``dmap.basis_matrices``) stay on
scipy: their values are part of the decoder's closed loop.
"""

from __future__ import annotations

import functools

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


def refinement(old: np.ndarray, new: np.ndarray, degree: int) -> tuple[np.ndarray, np.ndarray]:
    """The knot-insertion matrix A (Oslo algorithm, eq. 1), as its band: the
    B-spline of degree ``degree`` on the expanded knot vector ``old`` with
    poles P is the one on ``new`` (``old``'s knots and more, the same clamped
    ends) with poles A @ P.  Returns ``(first, w)``: row j of A is ``w[j]``
    (degree + 1 non-negative weights summing to one) in columns
    ``first[j] .. first[j] + degree``, and 0 elsewhere.

    Row j holds the discrete B-splines α_{i,k}(j), k = degree + 1, by the
    recursion α_{i,1}(j) = [t_i ≤ τ_j < t_{i+1}] and
    α_{i,r}(j) = ω_{i,r} α_{i,r-1}(j) + (1 − ω_{i+1,r}) α_{i+1,r-1}(j),
    ω_{i,r} = (τ_{j+r-1} − t_i) / (t_{i+r-1} − t_i) (0 over an empty span).
    Only α_{μ-r+1..μ, r}(j) can be non-zero, where t_μ ≤ τ_j < t_{μ+1}, so
    each row costs O(k²), not O(k·n).
    """
    t, tau, k = np.asarray(old, float), np.asarray(new, float), int(degree) + 1
    m = len(tau) - k
    mu = np.searchsorted(t, tau[:m], side="right") - 1  # t_μ ≤ τ_j < t_{μ+1}
    if m and (mu[0] < k - 1 or mu[-1] > len(t) - k - 1):
        raise ValueError("refinement: the new knots leave the old vector's span")
    # ω_{i,r} for the band's i = μ-r+2 .. μ: their spans hold [t_μ, t_{μ+1}],
    # so no denominator is 0; α_{μ-r+1,r} takes only 1 − ω_{μ-r+2,r}
    b = np.ones((m, 1))
    for r in range(2, k + 1):
        i = mu[:, None] + np.arange(2 - r, 1)[None, :]
        lo = t[i]
        w = (tau[r - 1 : m + r - 1, None] - lo) / (t[i + r - 1] - lo)
        nb = np.empty((m, r))
        nb[:, :-1] = (1.0 - w) * b
        nb[:, -1] = 0.0
        nb[:, 1:] += w * b
        b = nb
    return mu - k + 1, b


def subdivision(knots: np.ndarray, mults: np.ndarray, degree: int, pieces: int) -> np.ndarray:
    """The dense knot-insertion matrix (eq. 1, :func:`refinement`) that takes
    the poles of a clamped B-spline on ``knots`` (distinct values, with
    ``mults``) to those of the same B-spline with every span cut into
    ``pieces`` equal parts: shape (n', n), each row ``degree`` + 1
    non-negative weights summing to one.  The refined control polygon
    converges to the curve as ``pieces`` grows (quadratically in the span's
    length), so its poles bound the curve more tightly than the original's."""
    k = np.asarray(knots, float)
    flat = np.repeat(k, np.asarray(mults, int))
    cuts = k[:-1, None] + (k[1:] - k[:-1])[:, None] * (np.arange(1, pieces) / pieces)[None, :]
    new = np.sort(np.concatenate([flat, cuts.reshape(-1)]))
    first, w = refinement(flat, new, degree)
    a = np.zeros((len(first), len(flat) - degree - 1))
    rows = np.arange(len(first))[:, None]
    a[rows, first[:, None] + np.arange(w.shape[1])[None, :]] = w
    return a


def refine(
    knots: np.ndarray, mults: np.ndarray, poles: np.ndarray, degree: int, target: np.ndarray
) -> np.ndarray:
    """The poles (along axis 0; a surface's other direction rides along) of
    the same clamped B-spline on the expanded knot vector ``target``, which
    holds every knot of ``knots`` (distinct values, with ``mults``) at least
    as often, and the same ends."""
    flat = np.repeat(np.asarray(knots, float), np.asarray(mults, int))
    first, w = refinement(flat, target, degree)
    p = np.asarray(poles, float)
    rows = p[first[:, None] + np.arange(w.shape[1])[None, :]]  # (m, k, ...)
    return np.einsum("jk,jk...->j...", w, rows)


def bezier_form(knots: np.ndarray, degree: int) -> np.ndarray:
    """The expanded knot vector of a clamped B-spline of ``degree`` on
    ``knots`` (distinct values) cut into its Bezier pieces: each inner value
    ``degree`` times, the ends ``degree`` + 1 times."""
    k = np.asarray(knots, float)
    reps = np.full(len(k), int(degree))
    reps[[0, -1]] = int(degree) + 1
    return np.repeat(k, reps)


def elevation(
    knots: np.ndarray,
    mults: np.ndarray,
    degree: int,
    to: int,
    breaks: np.ndarray | None = None,
) -> np.ndarray:
    """The dense matrix E (n', n) that takes the poles of the clamped B-spline
    of ``degree`` on ``knots`` (distinct values, with ``mults``) to those of
    the same curve of degree ``to`` >= ``degree`` in its Bezier form over
    ``breaks`` (distinct values holding ``knots``, the same ends; ``knots``
    by default; :func:`bezier_form` at ``to``): knot insertion up to that
    form (eq. 1, :func:`refinement`), then each piece raised t = ``to`` −
    ``degree`` times at once, Q_i = Σ_j C(p, j)·C(t, i − j) / C(p + t, i)·P_j
    (p = ``degree``).  Every row's weights are non-negative and sum to one.
    The matrix is shared between calls (a cache): read it, do not write it."""
    k = np.ascontiguousarray(knots, float)
    b = k if breaks is None else np.ascontiguousarray(breaks, float)
    m = np.ascontiguousarray(mults, np.int64)
    return _elevation(k.tobytes(), m.tobytes(), int(degree), int(to), b.tobytes())


@functools.lru_cache(maxsize=4096)
def _elevation(k: bytes, m: bytes, p: int, q: int, b: bytes) -> np.ndarray:
    from math import comb

    if q < p:
        raise ValueError("elevation lowers no degree")
    knots, mults = np.frombuffer(k), np.frombuffer(m, np.int64)
    breaks = np.frombuffer(b)
    flat = np.repeat(knots, mults)
    n = len(flat) - p - 1
    first, w = refinement(flat, bezier_form(breaks, p), p)
    a = np.zeros((len(first), n))
    a[np.arange(len(first))[:, None], first[:, None] + np.arange(w.shape[1])[None, :]] = w
    t = q - p
    if t == 0:
        a.setflags(write=False)
        return a
    z = np.zeros((q + 1, p + 1))
    for i in range(q + 1):
        for j in range(max(0, i - t), min(p, i) + 1):
            z[i, j] = comb(p, j) * comb(t, i - j) / comb(q, i)
    pieces = len(breaks) - 1
    e = np.zeros((q * pieces + 1, p * pieces + 1))
    for s in range(pieces):  # neighbouring pieces share their end poles
        e[q * s : q * s + q + 1, p * s : p * s + p + 1] = z
    out = e @ a
    out.setflags(write=False)
    return out
