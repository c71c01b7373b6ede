"""Inner knots of coded surfaces removed, and their degrees lowered, within
tol (issue 28: a ratio that grows with the tolerance).

A surface fitted by a CAD system to scattered data or to another surface
(a sphere's rational patches re-approximated, a lens blended in Rhino)
carries far more poles than its shape needs within 0.01 or 0.1 mm.  The
paper's codec codes every pole it is given, so its size hardly shrinks as
the tolerance grows.  Removing knots (Tiller's knot removal, done here as a
least-squares refit on the reduced vector) leaves fewer poles to code.  Only
the writer changes: the reader takes a row's knots and poles as they are.

**The bound.**  The reduced row S' has knots K' ⊂ K (the source's vector,
same ends, each knot at most as often).  Inserting the removed knots back
(:func:`knots.raised`, Boehm's algorithm, eq. 1) gives the same surface on
K, with poles Q'; on K the basis is non-negative and sums to one, so
|S' − S| ≤ max |Q' − P| (in homogeneous coordinates and
:func:`weights.weight_bound` for a rational row), which
:func:`knots.moved` certifies.  A row is reduced to at most a share of its
limit, and its poles are then coded to the limit less that move
(``nets._code_one``).

**Which rows.**  Clamped B-spline surfaces (not periodic, not Bezier: a
Bezier row has no inner knot, but may have its degree lowered) whose
sides no other net copies (``coincide.twin_sides``).  Clamped ends keep
their poles exactly (the least-squares fit holds the first and last row of
poles of each direction), so corners and the boundaries across the reduced
direction do not move: vertex pins and iso-boundary curves see the same
corners.  An iso-boundary curve takes the reduced side's knots with its
poles (``assembly._copy_iso``).

Coded 3-D curves too (``nets.CURVE_REMOVAL``): those the encoder codes
itself, not an iso-boundary copy, not a twin curve's leader (a twin
copies its leader's poles on its own knots, ``assembly._copy_twins``), and
not a curve whose knot vector another coded row has (a sweep's or a
loft's curves and surfaces share theirs, which the container stores once:
a swept tube grew by 255 bytes at 0.01 mm with its curves reduced).
Their end poles stay, so the vertices pinned to them and the edge ranges
(the first and last knot) see the same ends; an interpolated edge of 50
poles (a spline through points) keeps a dozen at 0.1 mm.  Their remaining
knots are the source's, not rounded (``nets.RAW_KNOT_BITS`` prices them).

**Degrees lowered** (:func:`_lowered`, ``LOWER``).  Some CAD systems write
patches and edges of degree 5 to 12 (CATIA's Bezier patches: trj7's 167
patches of degree (5, 5), 129 ruled ones of degree 8 along v) whose shape
a cubic or a quadratic holds within 0.01 or 0.1 mm.  A non-rational
clamped row (a Bezier one too) has each direction's degree lowered one at
a time while it fits: the poles of degree q on the same knots (each inner
knot p − q fewer times, at least once: :func:`lowered_mults`) fitted in
least squares to the row's in their Bezier form at degree p (the lower
row raised there is a linear map, :func:`bspline.elevation`), the end
poles held as above.  Its move is certified by :func:`knots.lowered`:
both rows in their Bezier form at degree p over every knot of either, the
same surfaces, compared pole by pole.  It may take ``LOWER_SHARE`` of the
budget; knots are then removed from the lowered row, and of that and the
row with knots removed only, the one with fewer poles is kept.  An
iso-boundary curve takes a lowered side's degree with its poles.  The
reader needs nothing new: a row's degrees and knots are in its header.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from .. import bspline
from ..model import BSplineCurve, BSplineSurface
from . import knots

Row = BSplineSurface | BSplineCurve

#: Passes over a vector's inner knots (each pass tries every knot once).
PASSES = 2


#: Inner poles from which a fit solves its normal equations in band form
#: (:func:`_banded`) rather than by a dense least-squares solve: the dense
#: solve costs O(n³) a call and a direction makes O(n) of them, so a curve of
#: 436 poles (an offset of a lofted shell, degree 8) took 6.8 s in 544 calls.
BANDED_MIN = 128


def _insertion(
    sub: np.ndarray, full: np.ndarray, degree: int
) -> tuple[np.ndarray, np.ndarray, int]:
    """The knot-insertion matrix A from the expanded vector ``sub`` to ``full``
    as its band (:func:`bspline.refinement`): poles on ``full`` = A @ poles
    on ``sub``; returns ``(first, w, columns of A)``."""
    first, w = bspline.refinement(sub, full, degree)
    return first, w, len(sub) - degree - 1


def _dense(first: np.ndarray, w: np.ndarray, ncols: int) -> np.ndarray:
    """The band (``first``, ``w``) as a dense matrix of ``ncols`` columns."""
    a = np.zeros((len(first), ncols))
    rows = np.arange(len(first))[:, None]
    a[rows, first[:, None] + np.arange(w.shape[1])[None, :]] = w
    return a


def _banded(
    first: np.ndarray, w: np.ndarray, inner: np.ndarray, rhs: np.ndarray
) -> np.ndarray | None:
    """The least-squares poles of the inner columns 1 .. ncols − 2 of the band
    (``first``, ``w``), ``inner`` those columns dense, against ``rhs``, by the
    normal equations AᵀA x = Aᵀ rhs: AᵀA is a band of half-width p =
    ``w.shape[1]`` − 1, gathered from the rows' products and solved by
    Cholesky in O(n·p²).  None where it is not positive definite (the caller
    then solves densely)."""
    from scipy.linalg import LinAlgError, solveh_banded

    n, k = inner.shape[1], w.shape[1]
    cols = first[:, None] + np.arange(k)[None, :] - 1  # each weight's inner column
    t1, t2 = np.triu_indices(k)
    # row r adds w[r, t1]·w[r, t2] to AᵀA[i, j], i = cols[r, t1] <= j = cols[r, t2],
    # held (upper form) at ab[p − (j − i), j] = ab[p − (t2 − t1), j]
    at = (k - 1 - (t2 - t1))[None, :] * n + cols[:, t2]
    ok = (cols[:, t1] >= 0) & (cols[:, t2] < n)
    ab = np.bincount(at[ok], (w[:, t1] * w[:, t2])[ok], minlength=k * n).reshape(k, n)
    try:
        return np.asarray(solveh_banded(ab, inner.T @ rhs, check_finite=False))
    except (LinAlgError, ValueError):
        return None


def _fit(h: np.ndarray, first: np.ndarray, w: np.ndarray, ncols: int) -> np.ndarray:
    """Poles x (along axis 0) on the smaller vector with ``A @ x`` nearest ``h``
    in least squares, A the band (``first``, ``w``) of ``ncols`` columns, its
    first and last pole ``h``'s (clamped ends).  From :data:`BANDED_MIN` inner
    poles by the band's normal equations (:func:`_banded`), else (or where
    those fail) by a dense least-squares solve."""
    flat = h.reshape(h.shape[0], -1)
    x = np.empty((ncols, flat.shape[1]))
    x[0], x[-1] = flat[0], flat[-1]
    if ncols > 2:
        a = _dense(first, w, ncols)
        rhs = flat - np.outer(a[:, 0], x[0]) - np.outer(a[:, -1], x[-1])
        inner = _banded(first, w, a[:, 1:-1], rhs) if ncols - 2 >= BANDED_MIN else None
        if inner is None:
            inner = np.linalg.lstsq(a[:, 1:-1], rhs, rcond=None)[0]
        x[1:-1] = inner
    return x.reshape((ncols, *h.shape[1:]))


def _from_homogeneous(g: Row, h: np.ndarray) -> Row | None:
    if g.weights is None:
        return replace(g, poles=h)
    w = h[..., -1]
    if not (w > 0).all():
        return None
    return replace(g, poles=h[..., :-1] / w[..., None], weights=w)


def _with_knots(g: Row, axis: int, k: np.ndarray, m: np.ndarray) -> Row:
    if isinstance(g, BSplineCurve):
        return replace(g, knots=k, mults=m)
    if axis == 0:
        return replace(g, uknots=k, umults=m)
    return replace(g, vknots=k, vmults=m)


def _direction(g: Row, source: Row, axis: int, budget: float) -> tuple[Row, float]:
    """``g`` (``source`` reduced so far) with inner knots of direction ``axis``
    (0: u, or a curve's) removed, one multiplicity at a time, while its move from
    ``source`` (:func:`knots.moved`) stays within ``budget``."""
    full_k, full_m, degree = knots.directions(g)[axis]
    target = np.swapaxes(knots.homogeneous(g), 0, axis)  # fitted against, poles on full_k
    flat_full = np.repeat(full_k, full_m)
    best, moved = g, knots.moved(g, source)
    kn, mu = full_k.copy(), full_m.copy()
    for _ in range(PASSES):
        changed = False
        i = 1
        while i < len(kn) - 1:
            tk, tm = kn, mu.copy()
            tm[i] -= 1
            if tm[i] == 0:
                tk, tm = np.delete(kn, i), np.delete(tm, i)
            band = _insertion(np.repeat(tk, tm), flat_full, degree)
            h = np.swapaxes(_fit(target, *band), 0, axis)
            cand = _from_homogeneous(_with_knots(best, axis, tk, tm), h)
            d = float("inf") if cand is None else knots.moved(cand, source)
            if cand is not None and d <= budget:
                gone = len(tk) < len(kn)
                best, moved, kn, mu, changed = cand, d, tk, tm, True
                if gone:  # the next knot is now at i
                    continue
            i += 1
        if not changed:
            break
    return best, moved


#: Whether a row's degree may be lowered before its knots are removed
#: (:func:`lowered`).
LOWER = True

#: The least degree a direction must have to be lowered (:func:`_lowered`).
LOWER_FROM = 4

#: The share of the budget a lowered degree may take (:func:`removed`).
LOWER_SHARE = 0.5

#: Most poles of a direction's Bezier form that :func:`lowered` fits
#: (a dense least-squares solve per degree tried).
LOWER_MAX = 2048


def _with_degree(g: Row, axis: int, degree: int, k: np.ndarray, m: np.ndarray) -> Row:
    if isinstance(g, BSplineCurve):
        return replace(g, degree=degree, knots=k, mults=m)
    if axis == 0:
        return replace(g, udegree=degree, uknots=k, umults=m)
    return replace(g, vdegree=degree, vknots=k, vmults=m)


def lowered_mults(m: np.ndarray, degree: int, to: int) -> np.ndarray:
    """The multiplicities of a clamped vector of ``degree`` (``m``) lowered to
    degree ``to``: the ends ``to`` + 1, each inner knot ``degree`` − ``to``
    fewer times but at least once, so that a knot keeps its continuity
    order where the lower degree allows it (C^(p − m) becomes
    C^min(p − m, q − 1))."""
    out = np.maximum(np.asarray(m, np.int64) - (degree - to), 1)
    out[[0, -1]] = to + 1
    return out


def _lowered(g: Row, source: Row, axis: int, budget: float) -> tuple[Row, float]:
    """``g`` (``source`` lowered so far) with the degree of direction ``axis``
    lowered as far as keeps it within ``budget`` of ``source``
    (:func:`knots.moved`, certified), one degree at a time while it fits;
    the poles of each try fitted in least squares to ``g``'s in their Bezier
    form at ``g``'s degree (:func:`bspline.elevation`: the quantity the bound
    measures), the end poles held (clamped ends: corners and vertices stay)."""
    kn, mn, p = knots.directions(g)[axis]
    inner = len(kn) > 2
    lowest = 2 if inner else 1  # a polyline's corners at inner knots: not made
    d0 = 0.0 if g is source else knots.moved(g, source)
    if p <= lowest or p < LOWER_FROM:
        return g, d0
    to_bezier = bspline.elevation(kn, mn, p, p)
    if len(to_bezier) > LOWER_MAX:
        return g, d0
    target = np.tensordot(to_bezier, np.swapaxes(g.poles, 0, axis), axes=(1, 0))
    flat = target.reshape(target.shape[0], -1)
    best = (g, d0)
    for q in range(p - 1, lowest - 1, -1):  # down while it fits: a lower degree rarely fits then
        mq = lowered_mults(mn, p, q)
        e = bspline.elevation(kn, mq, q, p)
        x = np.empty((e.shape[1], flat.shape[1]))
        x[0], x[-1] = flat[0], flat[-1]
        if e.shape[1] > 2:
            rhs = flat - np.outer(e[:, 0], x[0]) - np.outer(e[:, -1], x[-1])
            x[1:-1] = np.linalg.lstsq(e[:, 1:-1], rhs, rcond=None)[0]
        poles = np.swapaxes(x.reshape((e.shape[1], *target.shape[1:])), 0, axis)
        cand = replace(_with_degree(g, axis, q, kn, mq), poles=poles)
        d = knots.moved(cand, source)
        if d > budget:
            break
        best = (cand, d)
    return best


def removed(g: Row, budget: float, axes: tuple[int, ...] = (0, 1)) -> tuple[Row, float] | None:
    """``g`` with the degree of the directions ``axes`` (0: u) lowered
    (:func:`_lowered`, where ``LOWER``; non-rational rows) and then as many
    of their inner knots removed as keep it within ``budget`` of itself
    (:func:`knots.moved`, certified), and that move; None where nothing
    changes or ``g`` is not a row this applies to (module docstring)."""
    if budget <= 0:
        return None
    dirs = (0,) if isinstance(g, BSplineCurve) else axes
    tries = [(g, 0.0)]
    if LOWER and g.weights is None and knots.clamped(g):
        out, d = g, 0.0
        for axis in dirs:
            out, d = _lowered(out, g, axis, LOWER_SHARE * budget)
        if out is not g:
            tries.append((out, d))
    best: tuple[Row, float] | None = None
    for out, d in tries:  # knots removed from the row as it is, and from it lowered
        if knots.codable(g):
            for axis in dirs:
                out, d = _direction(out, g, axis, budget)
        if out is not g and (best is None or out.poles.size < best[0].poles.size):
            best = (out, d)
    return best
