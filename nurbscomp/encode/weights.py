"""Weights of rational nets within tol (issue 28 §5): rounded, with a certified bound.

A coded rational net (eq. 2) keeps its knots and degrees; its poles move by
the code's bound.  Its weights may move too: rounded to a few significant
bits, a row of weights that the source wrote with noise in its last digits
(0.716857553444, 0.716857566945 … on one arc's middle row) becomes one value
repeated, which the entropy stage codes for nearly nothing.

**The bound.**  With S = Σ w_i N_i P_i / Σ w_i N_i the source point and
S' = Σ w'_i N_i P'_i / Σ w'_i N_i the decoded one, w'_i = w_i (1 + ε_i),
|ε_i| ≤ ε < 1 and |P'_i − P_i| ≤ b:

    S' − S = Σ a'_i (P'_i − P_i) + Σ a'_i (P_i − S),   a'_i = w'_i N_i / Σ w'_j N_j

The first sum is a convex combination: at most b.  Since Σ w_i N_i (P_i − S)
= 0, the second is Σ ε_i w_i N_i (P_i − S) / Σ w'_j N_j, at most
ε / (1 − ε) · max |P_i − S| over the poles whose basis functions are not zero
at the point.  Those are a block of (degree + 1) consecutive poles (per
direction), and S lies in their convex hull, so |P_i − S| is at most the
diagonal of the block's bounding box (:func:`support_diameter`).  Hence

    |S' − S| ≤ b + ε / (1 − ε) · D                         (:func:`moved`)

which is what the encoder certifies for the row, in place of b.

**How far weights move.**  One precision per file (:func:`file_bits`), so
that weights the source has equal stay equal after rounding (a boundary
copied from its surface, coincident curves: :mod:`.coincide` pairs rows whose
weights are equal bit for bit).  It is the least precision that keeps every
candidate row's weight term within ``SHARE`` of its limit, and it is used only
where the rounded weights compress to less than the exact ones.
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np

from .. import entropy
from ..model import BSplineCurve, BSplineSurface
from . import deviation

#: The share of a row's limit its rounded weights may take.  (1/16 saved
#: 159 bytes on ec_turbine at 0.01 mm but cost it 2.4 kB at 0.1 mm: 14,557
#: against 12,198 bytes, in the validity stage's rounds.)
SHARE = 1.0 / 32

#: The file's rounded weights must save at least this many bytes (LZMA of the
#: weights alone) to be used: the nets' limits shrink by up to ``SHARE``.
MIN_SAVING = 64

Net = BSplineSurface | BSplineCurve


def rounded(w: np.ndarray, bits: int) -> np.ndarray:
    """``w`` rounded to ``bits`` bits after the leading one (ties to even): each
    weight moves by at most 2^-(bits + 1) of itself."""
    m, e = np.frexp(np.asarray(w, float))  # w = m · 2^e, m in [0.5, 1)
    return np.ldexp(np.rint(np.ldexp(m, bits + 1)), e - bits - 1)


def _windows(p: np.ndarray, size: int, periodic: bool, axis: int) -> np.ndarray:
    """Per block of ``size`` consecutive poles along ``axis`` (wrapping when
    ``periodic``), the least and largest coordinates: shape (2, blocks, ...)."""
    n = p.shape[axis]
    size = min(size, n)
    starts = range(n if periodic else n - size + 1)
    idx = np.array([[(s + k) % n for k in range(size)] for s in starts])
    blocks = np.take(p, idx, axis=axis)  # (…, blocks, size, …) at axis
    return np.stack([blocks.min(axis=axis + 1), blocks.max(axis=axis + 1)])


def support_diameter(g: Net) -> float:
    """The largest bounding-box diagonal of a block of poles that the basis
    functions non-zero at one parameter can span: (degree + 1) consecutive
    poles per direction, wrapping around a periodic direction."""
    if isinstance(g, BSplineCurve):
        lo, hi = _windows(g.poles, g.degree + 1, g.periodic, 0)
    else:
        lo, hi = _windows(g.poles, g.udegree + 1, g.uperiodic, 0)
        lo = _windows(lo, g.vdegree + 1, g.vperiodic, 1)[0]
        hi = _windows(hi, g.vdegree + 1, g.vperiodic, 1)[1]
    return float(np.sqrt(((hi - lo) ** 2).sum(-1)).max())


def weight_bound(g: Net, w: np.ndarray | None) -> float:
    """How far the rational row ``g`` moves when its weights become ``w``, its
    poles unchanged: ε / (1 − ε) · D (module docstring)."""
    if g.weights is None and w is None:
        return 0.0
    if w is None or g.weights is None or w.shape != g.weights.shape:
        return float("inf")  # rational to non-rational, or the other way: no bound here
    if np.array_equal(w, g.weights):
        return 0.0
    eps = float(np.abs(w / g.weights - 1.0).max())
    if eps >= 0.5:
        return float("inf")
    return eps / (1.0 - eps) * support_diameter(g)


def moved(new: Net, original: Net) -> float:
    """Certified distance between ``new`` and ``original`` (the same row on the
    same knots, its poles and weights moved): the poles' move, measured on the
    refined error net with ``new``'s weights (:func:`deviation.moved`; at most
    the largest pole move), plus :func:`weight_bound` (``knots.moved`` adds
    what moved knots add)."""
    return deviation.moved(new, original) + weight_bound(original, new.weights)


def _bits_for(g: Net, limit: float) -> int:
    """The least bits after the leading one that keep ``g``'s weight term
    within ``SHARE`` · ``limit`` (52: the weights as they are)."""
    d = support_diameter(g)
    if d <= 0:
        return 0
    r = SHARE * limit / d  # ε / (1 − ε) ≤ r  <=>  ε ≤ r / (1 + r)
    eps = r / (1.0 + r)
    return int(min(52, max(0, np.ceil(-np.log2(eps)) - 1)))


def _packed(ws: Iterable[np.ndarray]) -> int:
    return entropy.lzma_size(b"".join(np.ascontiguousarray(w, "<f8").tobytes() for w in ws))


def file_bits(rows: Iterable[tuple[Net, float]]) -> int | None:
    """One precision for the rational rows of a file, given as (row, limit):
    the least that keeps each row's weight term within ``SHARE`` of its
    limit, or None (weights exact) where rounding would not save
    ``MIN_SAVING`` bytes of the weights, LZMA-compressed alone."""
    rational = [(g, lim) for g, lim in rows if g.weights is not None]
    if not rational:
        return None
    bits = max(_bits_for(g, lim) for g, lim in rational)
    if bits >= 52:
        return None
    exact = [g.weights for g, _ in rational]
    if _packed(exact) - _packed(rounded(w, bits) for w in exact) < MIN_SAVING:  # type: ignore[arg-type]
        return None
    return bits
