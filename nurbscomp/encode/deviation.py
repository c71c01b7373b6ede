"""How far a coded row moved, certified on its refined error net (issue 28 §4).

A row S (poles P, weights w) coded as S' (poles P' = P + e, weights w') moves
by S' − S = Σ a'_i e_i + (what the weights alone move, :mod:`.weights`), with
a'_i = w'_i N_i / Σ_j w'_j N_j (eq. 1-2).  The first term is a rational
B-spline whose poles are the errors e_i.  It lies in the convex hull of its
poles, so it is at most max_i |e_i|: the bound the codec used to certify.

That bound is reached only where the errors of a block of (degree + 1)
poles per direction point the same way.  A quantizer's errors do not: they
are spread over a cell of the grid, and the basis averages them.  So the
error row is refined first (:func:`bspline.subdivision`: every span cut into
``PIECES`` parts by knot insertion, eq. 1, in homogeneous coordinates for a
rational row: refined poles A(w'e)/(Aw') with weights Aw'), and the largest
of its refined poles is the bound.  It is still an upper bound of the move at
every parameter (the same convex hull argument, on the refined knots), and
it converges to the true largest move as the spans shrink.  At a clamped
corner the refined net keeps the corner's own error, so the bound is never
below the corners' moves.

The codec's search takes it as the measure of a trial (``codec.encode_net``'s
``measure``), so a coarser grid step passes where its errors average out;
:func:`moved` is the same measure for a whole row (``weights.moved``, and
through it ``knots.moved``: the encoder's pins and copies, and verify).
Periodic and unclamped rows, and nets too large to refine within
``MAX_REFINED`` poles even by one cut, keep the pole bound.
"""

from __future__ import annotations

import functools
from collections.abc import Callable

import numpy as np

from .. import bspline, codec
from ..model import BSplineCurve, BSplineSurface
from ..rules.joins import clamped_curve, clamped_surface

Net = BSplineSurface | BSplineCurve

#: Parts every span is cut into for the bound (the refined net's gap to the
#: true largest move shrinks as 1/PIECES²).
PIECES = 8
#: Most refined poles a bound is computed on; fewer parts where a net needs it.
MAX_REFINED = 40_000
#: Relative slack added for the rounding of the refinement in binary64 (each
#: refined pole is a sum of at most 16 × 16 non-negative terms of weights
#: summing to one).
ROUNDING = 2.0**-40


@functools.lru_cache(maxsize=4096)
def _subdivision(knots: bytes, mults: bytes, degree: int, pieces: int) -> np.ndarray:
    """:func:`bspline.subdivision` of the vectors whose bytes are given
    (rows of one knot vector share it: read-only)."""
    a = bspline.subdivision(np.frombuffer(knots), np.frombuffer(mults, np.int64), degree, pieces)
    a.flags.writeable = False
    return a


def _matrix(knots: np.ndarray, mults: np.ndarray, degree: int, pieces: int) -> np.ndarray:
    k = np.asarray(knots, float).tobytes()
    return _subdivision(k, np.asarray(mults, np.int64).tobytes(), degree, pieces)


def matrices(g: Net) -> list[np.ndarray] | None:
    """Per direction (u, v; or the curve's), the refinement matrix of the
    row's errors; None where the pole bound stands (periodic or unclamped
    rows)."""
    if isinstance(g, BSplineSurface):
        if not clamped_surface(g):
            return None
        spans = [
            (g.uknots, g.umults, g.udegree, int(g.poles.shape[0])),
            (g.vknots, g.vmults, g.vdegree, int(g.poles.shape[1])),
        ]
    else:
        if not clamped_curve(g):
            return None
        spans = [(g.knots, g.mults, g.degree, len(g.poles))]
    for pieces in range(PIECES, 1, -1):
        size = 1
        for knots, _, _, n in spans:
            size *= n + (len(knots) - 1) * (pieces - 1)
        if size <= MAX_REFINED:
            return [_matrix(k, m, d, pieces) for k, m, d, _ in spans]
    return None


def _refined(err: np.ndarray, mats: list[np.ndarray], w: np.ndarray | None) -> np.ndarray:
    """Largest refined pole of each error net of ``err`` (R, *poles.shape),
    or its largest pole where that is smaller (at a corner the two are one
    value, and the refined one carries the rounding slack)."""
    we = err if w is None else err * w[None, ..., None]
    if len(mats) == 2:
        a, b = mats
        n, i, j, c = we.shape
        # r[k, a, b] = Σ_ij A[a, i] we[k, i, j] B[b, j]: two matrix products
        # (einsum's path search cost more than the products on small nets)
        r = b @ (a @ we.reshape(n, i, j * c)).reshape(n, len(a), j, c)
        if w is not None:
            r = r / (a @ w @ b.T)[None, ..., None]
    else:
        r = mats[0] @ we
        if w is not None:
            r = r / (mats[0] @ w)[None, :, None]
    refined = codec.largest_norms(r) * (1.0 + ROUNDING)
    return np.minimum(refined, codec.pole_bounds(err))  # each is a bound: the smaller


def measure(g: Net) -> Callable[[np.ndarray], np.ndarray]:
    """The certified bound of error nets (R, *g.poles.shape) added to
    ``g``'s poles, ``g``'s weights kept: for ``codec.encode_net``."""
    mats = matrices(g)
    if mats is None:
        return codec.pole_bounds
    w = g.weights

    def bound(err: np.ndarray) -> np.ndarray:
        return _refined(err, mats, w)

    return bound


def moved(new: Net, original: Net) -> float:
    """How far ``new`` (``original``'s poles moved, on ``new``'s knots and
    with ``new``'s weights) is from ``original`` with ``new``'s weights: the
    first term of ``weights.moved``."""
    err = (new.poles - original.poles)[None]
    mats = matrices(new)
    if mats is None:
        return float(codec.pole_bounds(err)[0])
    return float(_refined(err, mats, new.weights)[0])
