"""Edge-range rules (docs/format.md §2.7): how each curve representation's
parameter range is stored, predicted bit for bit where a rule gives it (the
curve's own range, the edge's 3-D curve's, the projections of its vertices),
and filled back in by the decoder."""

from __future__ import annotations

from typing import Any

import numpy as np

from ..errors import BadReferenceError, SectionError
from ..model import EC, BRepModel, BSplineCurve, Derived, Geometry, Kind, RepKind
from ..serialize import (
    MAX_COORD,
    RANGE_NATURAL,
    RANGE_OF_3D,
    RANGE_STORED,
    RANGE_VERTICES,
    RANGE_ZERO,
    finite,
)
from . import joins


def natural_range(g: Geometry | None) -> tuple[float, float] | None:
    """The parameter range a curve record carries in itself, if any."""
    if isinstance(g, BSplineCurve):
        return (0.0, 1.0) if g.bezier else (float(g.knots[0]), float(g.knots[-1]))
    if isinstance(g, Derived) and g.kind == Kind.TRIMMED_CURVE:
        return float(g.params[0]), float(g.params[1])
    return None


def _curve_of(m: BRepModel, q: int) -> Geometry | None:
    kind, c = int(m.edge_reps[q, EC.KIND]), int(m.edge_reps[q, EC.CURVE])
    table = m.curves3d if kind == RepKind.CURVE3D else m.curves2d
    return table[c] if 0 <= c < len(table) else None


def _range_of_3d(m: BRepModel) -> dict[int, int]:
    """Per edge, its first 3-D curve representation's row."""
    out: dict[int, int] = {}
    for q in np.flatnonzero(m.edge_reps[:, EC.KIND] == RepKind.CURVE3D).tolist():
        out.setdefault(int(m.edge_reps[q, EC.EDGE]), q)
    return out


def range_kinds(m: BRepModel) -> np.ndarray:
    """Per representation, how its range is stored: the curve's own range
    (``RANGE_NATURAL``), the same as the edge's 3-D curve (``RANGE_OF_3D``),
    zeros (a pcurve the decoder computes), the projections of its vertices
    on its line or circle (``RANGE_VERTICES``, :func:`joins.vertex_ranges`), or the two
    floats.  Only a bit for bit equal prediction is used, so the format stays
    lossless."""
    reps = m.edge_reps

    def words(pair: Any) -> list[int]:  # a range's two floats as integers, bit for bit
        return np.asarray(pair, np.float64).view(np.int64).tolist()

    of3d = _range_of_3d(m)
    by_vertices = joins.vertex_ranges(m)
    out = np.full(len(reps), RANGE_STORED, np.int64)
    two, c3d = int(RepKind.ON_TWO_SURFACES), int(RepKind.CURVE3D)
    stored = words(m.edge_rep_range)
    for q, (edge, kind) in enumerate(reps[:, :2].tolist()):
        if kind == two:
            continue
        mine = stored[q]
        if mine == [0, 0]:
            out[q] = RANGE_ZERO
            continue
        nat = natural_range(_curve_of(m, q))
        if nat is not None and words(nat) == mine:
            out[q] = RANGE_NATURAL
            continue
        r3 = of3d.get(edge)
        if kind != c3d and r3 is not None and stored[r3] == mine:
            out[q] = RANGE_OF_3D
        elif q in by_vertices and words(by_vertices[q]) == mine:
            out[q] = RANGE_VERTICES
    return out


def resolve_ranges(m: BRepModel, how: np.ndarray) -> None:
    """Fill the ranges :func:`range_kinds` left out (needs the curve tables)."""
    for q in np.flatnonzero(how == RANGE_NATURAL).tolist():
        nat = natural_range(_curve_of(m, q))
        if nat is None:
            raise SectionError(f"EDGE: representation {q} has a curve without a range of its own")
        m.edge_rep_range[q] = nat
    by_vertices = joins.vertex_ranges(m) if (how == RANGE_VERTICES).any() else {}
    for q in np.flatnonzero(how == RANGE_VERTICES).tolist():
        if q not in by_vertices:
            raise BadReferenceError("EDGE: a range from vertices on an edge on no line or circle")
        m.edge_rep_range[q] = by_vertices[q]
    finite(m.edge_rep_range[how == RANGE_VERTICES], "EDGE: ranges from vertices", MAX_COORD)
    of3d = _range_of_3d(m)
    for q in np.flatnonzero(how == RANGE_OF_3D).tolist():
        r3 = of3d.get(int(m.edge_reps[q, EC.EDGE]))
        if r3 is None or how[r3] == RANGE_OF_3D:
            raise BadReferenceError(
                f"EDGE: representation {q}'s range refers to a missing 3-D curve"
            )
        m.edge_rep_range[q] = m.edge_rep_range[r3]
