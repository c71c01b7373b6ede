"""Planes, quadrics, lines and conics within tol (issue 28 §1; docs/format.md §2.3).

A record's origin and lengths (radii, focal length; not a cone's semi-angle)
are snapped to a grid of step 2^(g - 64), a power of two at most
``SHARE`` x tol, and at most ``FEATURE`` x the smallest length, so that a
small fillet keeps its shape; its directions stay as they are.  Every point
of the surface or curve then moves by at most the origin's move plus the
lengths' moves (a translation, then radii changed by that much: the
certified bound, whatever the extent of the face or edge), which
:func:`nurbscomp.encode.assembly.assemble` counts like a coded net's bound:
edge and vertex tolerances are widened by it, and the validity ladder leaves
the record exact where the moved record fails a check.  A grid shared by
every record of a file (the world's axes) keeps coplanar and coaxial records
that the source has equal equal.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from ..model import Analytic, Geometry, Kind
from ..serialize import GRID_LENGTHS, GRID_MAX, GRID_MIN, MAX_GRID_INT

#: The grid step is at most this share of tol.
SHARE = 0.5
#: ... and at most this fraction of the record's smallest length.
FEATURE = 1 / 64


def grid_bound(g: Analytic) -> float:
    """How far a record on its grid may have moved: half a step on each
    coordinate of its origin and on each length (0 off the grid)."""
    if not g.grid:
        return 0.0
    on = bin(g.mask).count("1")
    return 2.0 ** (g.grid - 64) * (math.sqrt(on) / 2 + len(GRID_LENGTHS[g.kind]) / 2)


def grid_of(g: Analytic, tol: float) -> int:
    """The grid of ``g`` at ``tol`` (0: none fits)."""
    step = SHARE * tol
    lengths = g.params[list(GRID_LENGTHS[g.kind])]
    lengths = np.abs(lengths[lengths != 0])
    if len(lengths):
        step = min(step, FEATURE * float(lengths.min()))
    if not step > 0 or not math.isfinite(step):
        return 0
    e = math.floor(math.log2(step))
    return min(max(e + 64, 0), GRID_MAX) if e + 64 >= GRID_MIN else 0


def quantize(
    g: Geometry, tol: float, keep: frozenset[float] = frozenset()
) -> tuple[Analytic, float] | None:
    """``g`` on its grid and its bound; None where it is not an analytic
    record of a kind that has a grid, or does not fit one (values past 2^53
    steps, a length that would change sign or order).  Origin coordinates
    in ``keep`` stay as they are (a vertex's coordinate, bit for bit: the
    container holds it anyway, and its entropy coder finds the repeat)."""
    if not isinstance(g, Analytic) or g.kind not in GRID_LENGTHS or g.frame.shape[1] != 3:
        return None
    grid = grid_of(g, tol)
    if grid == 0:
        return None
    q = 2.0 ** (grid - 64)
    idx = list(GRID_LENGTHS[g.kind])
    mask = sum(1 << j for j, x in enumerate(g.frame[0].tolist()) if x not in keep)
    on = [bool(mask >> j & 1) for j in range(3)]
    origin = np.round(g.frame[0] / q) + 0.0  # never -0.0: the reader makes +0.0
    lengths = np.round(g.params[idx] / q) + 0.0
    if np.abs(np.concatenate([origin[on], lengths])).max(initial=0) >= MAX_GRID_INT:
        return None
    if mask == 0 and not idx:
        return None  # nothing to snap
    frame = g.frame.copy()
    frame[0] = np.where(on, origin * q, g.frame[0])
    params = g.params.copy()
    params[idx] = lengths * q
    old = g.params[idx]
    if ((params[idx] > 0) != (old > 0)).any():
        return None
    if len(idx) == 2 and (params[idx[0]] >= params[idx[1]]) != (old[0] >= old[1]):
        return None  # a torus or ellipse keeps which radius is larger
    if g.kind == Kind.TORUS and params[idx[0]] == params[idx[1]]:
        return None
    out = replace(g, frame=frame, params=params, grid=grid, mask=mask)
    moved = float(np.sqrt(((frame[0] - g.frame[0]) ** 2).sum()))
    moved += float(np.abs(params[idx] - old).sum())
    assert moved <= grid_bound(out)
    # the grid's bound, not the move: one widening for every record of a grid
    # that moved (a tolerance of its own per edge costs EDGE more than the
    # grid saves); none for one already on it
    return out, grid_bound(out) if moved > 0 else 0.0
