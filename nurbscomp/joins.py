"""Where decoded neighbours must meet exactly: curve ends pinned to their vertices.

Coding moves every pole of a B-spline curve by up to its bound, end poles
included, and two edges meeting at a vertex are coded independently.  Their
decoded ends then miss each other by up to twice the bound.  OCCT accepts
that within the widened tolerances, but a STEP file carries no per-edge
tolerance: OCCT's STEP reader projects each edge's 3-D curve onto its face
again, finds the two projected ends apart in (u, v), and "repairs" the gap
with a new degenerated edge, changing the topology.

Vertices are stored exactly, and the end poles of a clamped curve *are* its
end points.  So after the nets are decoded, both the encoder and the decoder
run :func:`pin_curve_ends`: every coded curve that an edge uses over its whole
parameter range gets its end poles set to that edge's vertices.  The move is
at most the vertex's distance from the original end (its tolerance, usually
1e-7 mm) plus nothing else, and the encoder adds it to the curve's bound.
This costs no bits: it is a rule both sides apply to the same tables.
"""

from __future__ import annotations

import numpy as np

from .model import BRepModel, BSplineCurve, Geometry, RepKind, ShapeType

FORWARD, REVERSED = 0, 1


def _clamped(g: BSplineCurve) -> bool:
    if g.periodic:
        return False
    return g.bezier or (int(g.mults[0]) == g.degree + 1 and int(g.mults[-1]) == g.degree + 1)


def curve_end_pins(
    m: BRepModel, curves: list[Geometry], coded_rows: set[int], tol: float | None
) -> dict[int, list[tuple[int, int]]]:
    """Per coded row of ``curves`` (``m``'s 3-D curve table, decoded), the
    ``(pole index, vertex row)`` pairs to pin.

    An edge pins its curve when the curve is a clamped B-spline used untrimmed
    and unlocated over its whole knot range, and its vertices sit on the edge
    without a location.  A curve shared by several edges is pinned by the first.
    An end is pinned only if the decoded pole is within ``tol`` of the vertex:
    a vertex far from its curve's end (a gap the source closes with a large
    vertex tolerance) stays where it is.  The encoder keeps such a curve exact
    if pinning would move a pole further than ``tol`` from the original.
    With ``tol`` None, the poles are not looked at (they may not be decoded yet).
    """
    tidx = m.type_index()
    edge_shapes = np.flatnonzero(m.shape_type == ShapeType.EDGE)
    out: dict[int, list[tuple[int, int]]] = {}
    reps = m.edge_reps
    for q in np.flatnonzero(reps[:, 1] == RepKind.CURVE3D).tolist():
        c = int(reps[q, 2])
        if c not in coded_rows or c in out or reps[q, 6] != 0:
            continue
        g = curves[c]
        if not isinstance(g, BSplineCurve) or not _clamped(g):
            continue
        lo, hi = m.edge_rep_range[q]
        first, last = (0.0, 1.0) if g.bezier else (g.knots[0], g.knots[-1])
        if lo != first or hi != last:
            continue
        s = int(edge_shapes[reps[q, 0]])
        pins = []
        for k in range(m.child_start[s], m.child_start[s + 1]):
            o, v = int(m.child_orient[k]), int(m.child_shape[k])
            if m.shape_type[v] != ShapeType.VERTEX or m.child_loc[k] != 0:
                continue
            if o not in (FORWARD, REVERSED):
                continue
            i, row = (0 if o == FORWARD else len(g.poles) - 1), int(tidx[v])
            if tol is None or np.sqrt(((g.poles[i] - m.vertex_point[row]) ** 2).sum()) <= tol:
                pins.append((i, row))
        if pins:
            out[c] = pins
    return out


def pinned_poles(m: BRepModel, g: BSplineCurve, pins: list[tuple[int, int]]) -> np.ndarray:
    """A copy of ``g``'s poles with the pinned ones set to their vertices."""
    poles = g.poles.copy()
    for i, v in pins:
        poles[i] = m.vertex_point[v]
    return poles


def overreaching(
    m: BRepModel, decoded: list[Geometry], coded_rows: set[int], tol: float
) -> set[int]:
    """Rows whose pinned ends would move further than ``tol`` from ``m``'s poles."""
    out = set()
    for c, pins in curve_end_pins(m, decoded, coded_rows, tol).items():
        g = m.curves3d[c]
        assert isinstance(g, BSplineCurve)
        if any(np.sqrt(((g.poles[i] - m.vertex_point[v]) ** 2).sum()) > tol for i, v in pins):
            out.add(c)
    return out


def anchors(m: BRepModel, curves: list[Geometry], coded_rows: set[int]) -> dict[int, np.ndarray]:
    """Per coded curve row whose first pole may be pinned: that vertex's point,
    shape (3,), or with the last pole's vertex too, shape (2, 3).

    The first pole of such a net is coded against the first point instead of
    the previous net's first pole (the SNET/CNET origin chain), and the chord
    method codes the last pole against the second: the poles are within the
    vertex tolerance of them, so the grid residuals are almost always zero.
    """
    out = {}
    for c, pins in curve_end_pins(m, curves, coded_rows, None).items():
        ends = dict(pins)
        last = len(curves[c].poles) - 1  # type: ignore[union-attr]
        if 0 in ends and last in ends and last > 0:
            out[c] = m.vertex_point[[ends[0], ends[last]]]
        elif 0 in ends:
            out[c] = m.vertex_point[ends[0]]
    return out
