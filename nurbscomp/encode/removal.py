"""Inner knots of coded surfaces removed within tol (issue 28: a ratio that grows
with the tolerance).

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

**Which rows.**  Clamped B-spline surfaces (not periodic, not Bezier) whose
sides no other net copies (``coincide.twin_sides``).  Clamped ends keep
their poles exactly (the least-squares fit holds the first and last row of
poles of each direction), so corners and the boundaries across the reduced
direction do not move: vertex pins and iso-boundary curves see the same
corners.  An iso-boundary curve takes the reduced side's knots with its
poles (``assembly._copy_iso``).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from .. import bspline
from ..model import BSplineSurface
from . import knots

#: Passes over a vector's inner knots (each pass tries every knot once).
PASSES = 2


def _matrix(sub: np.ndarray, full: np.ndarray, degree: int) -> np.ndarray:
    """The dense knot-insertion matrix from the expanded vector ``sub`` to
    ``full`` (:func:`bspline.refinement`): poles on ``full`` = A @ poles on ``sub``."""
    first, w = bspline.refinement(sub, full, degree)
    a = np.zeros((len(full) - degree - 1, len(sub) - degree - 1))
    rows = np.arange(len(first))[:, None]
    a[rows, first[:, None] + np.arange(w.shape[1])[None, :]] = w
    return a


def _fit(h: np.ndarray, a: np.ndarray) -> np.ndarray:
    """Poles x (along axis 0) on the smaller vector with ``a @ x`` nearest ``h``
    in least squares, its first and last pole ``h``'s (clamped ends)."""
    flat = h.reshape(h.shape[0], -1)
    x = np.empty((a.shape[1], flat.shape[1]))
    x[0], x[-1] = flat[0], flat[-1]
    rhs = flat - np.outer(a[:, 0], x[0]) - np.outer(a[:, -1], x[-1])
    inner = a[:, 1:-1]
    if inner.shape[1]:
        x[1:-1] = np.linalg.lstsq(inner, rhs, rcond=None)[0]
    return x.reshape((a.shape[1], *h.shape[1:]))


def _from_homogeneous(g: BSplineSurface, h: np.ndarray) -> BSplineSurface | None:
    if g.weights is None:
        return replace(g, poles=h)
    w = h[..., 3]
    if not (w > 0).all():
        return None
    return replace(g, poles=h[..., :3] / w[..., None], weights=w)


def _direction(
    g: BSplineSurface, source: BSplineSurface, axis: int, budget: float
) -> tuple[BSplineSurface, float]:
    """``g`` (``source`` reduced so far) with inner knots of direction ``axis``
    (0: u) removed, one multiplicity at a time, while its move from
    ``source`` (:func:`knots.moved`) stays within ``budget``."""
    degree = g.udegree if axis == 0 else g.vdegree
    full_k, full_m = (g.uknots, g.umults) if axis == 0 else (g.vknots, g.vmults)
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
            a = _matrix(np.repeat(tk, tm), flat_full, degree)
            h = np.swapaxes(_fit(target, a), 0, axis)
            base = (
                replace(best, uknots=tk, umults=tm)
                if axis == 0
                else replace(best, vknots=tk, vmults=tm)
            )
            cand = _from_homogeneous(base, h)
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


def removed(
    g: BSplineSurface, budget: float, axes: tuple[int, ...] = (0, 1)
) -> tuple[BSplineSurface, float] | None:
    """``g`` with as many inner knots of the directions ``axes`` (0: u)
    removed as keep it within ``budget`` of itself (:func:`knots.moved`,
    certified), and that move; None where no knot goes or ``g`` is not a row
    this applies to (module docstring)."""
    if not knots.codable(g) or not isinstance(g, BSplineSurface) or budget <= 0:
        return None
    out, d = g, 0.0
    for axis in axes:
        out, d = _direction(out, g, axis, budget)
    if out is g:
        return None
    return out, d
