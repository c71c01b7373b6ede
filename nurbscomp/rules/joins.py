"""Where decoded neighbours must meet exactly: curve ends pinned to their vertices.

Coding moves every pole of a B-spline curve by up to its bound, end poles
included, and two edges meeting at a vertex are coded independently.  Their
decoded ends then miss each other by up to twice the bound.  OCCT accepts
that within the widened tolerances, but a STEP file carries no per-edge
tolerance: OCCT's STEP reader projects each edge's 3-D curve onto its face
again, finds the two projected ends apart in (u, v), and "repairs" the gap
with a new degenerated edge, changing the topology.

Vertices are decoded before the nets (exactly, or on the vertex grid of
docs/format.md §2.6), and the end poles of a clamped curve *are* its end
points.  So after the nets are decoded, both the encoder and the decoder
run :func:`pin_curve_ends`: every coded curve that an edge uses over its whole
parameter range gets its end poles set to that edge's vertices.  The move is
at most the vertex's distance from the original end (its tolerance, usually
1e-7 mm) plus nothing else, and the encoder adds it to the curve's bound.
This costs no bits: it is a rule both sides apply to the same tables.
"""

from __future__ import annotations

import collections
import math
from collections.abc import Iterable, Sequence
from typing import Any, cast

import numpy as np

from ..errors import BadReferenceError
from ..model import (
    EC,
    Analytic,
    BRepModel,
    BSplineCurve,
    BSplineSurface,
    Geometry,
    Kind,
    Rec,
    RepKind,
    ShapeType,
    first_row,
)

FORWARD, REVERSED = 0, 1


def clamped_curve(g: BSplineCurve) -> bool:
    """Whether a B-spline curve's end poles are its end points (not periodic;
    a Bezier curve, or end knots of multiplicity degree + 1)."""
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
    vertex tolerance) stays where it is.  Where pinning would move a pole
    further than ``tol`` from the original, the encoder codes the curve tighter
    (``encode.nets._ends_closer``), or else keeps it exact.
    With ``tol`` None, the poles are not looked at (they may not be decoded yet).
    """
    tidx = m.type_index().tolist()
    edge_shapes = np.flatnonzero(m.shape_type == ShapeType.EDGE).tolist()
    out: dict[int, list[tuple[int, int]]] = {}
    reps = m.edge_reps
    # plain lists and ints: numpy scalars and enum lookups cost more than the work here
    start, child = m.child_start.tolist(), m.child_shape.tolist()
    orient, cloc, stype = m.child_orient.tolist(), m.child_loc.tolist(), m.shape_type.tolist()
    vertex = int(ShapeType.VERTEX)
    for q in np.flatnonzero(reps[:, EC.KIND] == RepKind.CURVE3D).tolist():
        _, _, c, _, _, _, located = reps[q, :7].tolist()
        if c not in coded_rows or c in out or located != 0:
            continue
        g = curves[c]
        if not isinstance(g, BSplineCurve) or not clamped_curve(g):
            continue
        lo, hi = m.edge_rep_range[q].tolist()
        first, last = (0.0, 1.0) if g.bezier else (float(g.knots[0]), float(g.knots[-1]))
        if lo != first or hi != last:
            continue
        s = edge_shapes[reps[q, EC.EDGE]]
        pins = []
        for k in range(start[s], start[s + 1]):
            o, v = orient[k], child[k]
            if stype[v] != vertex or cloc[k] != 0 or o not in (FORWARD, REVERSED):
                continue
            i, row = (0 if o == FORWARD else len(g.poles) - 1), tidx[v]
            if tol is None or np.sqrt(((g.poles[i] - m.vertex_point[row]) ** 2).sum()) <= tol:
                pins.append((i, row))
        if pins:
            out[c] = pins
    return out


def _dot(p: np.ndarray, d: np.ndarray) -> float:
    """``p·d`` written out, so that every reader computes the same bits."""
    return float((p[0] * d[0] + p[1] * d[1]) + p[2] * d[2])


def on_line(g: Analytic, p: np.ndarray) -> float:
    """The parameter of the point of line ``g`` nearest ``p``."""
    return _dot(p - g.frame[0], g.frame[1])


def cross(a: Sequence[float], b: Sequence[float]) -> tuple[float, float, float]:
    """``a × b`` of two 3-vectors in Python floats: each product and
    difference rounds as ``np.cross``'s do (the same bits), at a tenth of
    its cost for one pair."""
    (a0, a1, a2), (b0, b1, b2) = a, b
    return a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0


def _on_circle(g: Analytic, p: np.ndarray) -> float:
    """The angle of ``p`` about a circle's axis (frame: origin, axis, X
    direction) from its X direction, in [0, 2π); within 1e-9 below 0 is 0."""
    # in Python floats: each operation rounds as numpy's would, at a tenth of the cost
    (o0, o1, o2), n, (x0, x1, x2) = g.frame[:3].tolist()
    p0, p1, p2 = (float(c) for c in p)
    q0, q1, q2 = p0 - o0, p1 - o1, p2 - o2
    y0, y1, y2 = cross(n, (x0, x1, x2))
    norm = math.sqrt((y0 * y0 + y1 * y1) + y2 * y2)
    if not norm > 0:  # no frame (only a damaged file has one): no angle
        return 0.0
    y0, y1, y2 = y0 / norm, y1 / norm, y2 / norm  # gp_Ax2's Y direction: N × X, normalised
    t = math.atan2((q0 * y0 + q1 * y1) + q2 * y2, (q0 * x0 + q1 * x1) + q2 * x2)
    if t < 0:  # just below the X axis is the start of the turn, not its end
        t = 0.0 if t > -1e-9 else t + 2 * math.pi
    return t


def curve_uses(m: BRepModel) -> dict[int, list[int]]:
    """Per 3-D curve row, the edge representations (3-D curves) that use it."""
    reps = m.edge_reps
    use: dict[int, list[int]] = {}
    for q in np.flatnonzero(reps[:, EC.KIND] == RepKind.CURVE3D).tolist():
        use.setdefault(int(reps[q, EC.CURVE]), []).append(q)
    return use


def end_vertices(m: BRepModel) -> np.ndarray:
    """Per edge row, the vertex rows of its first FORWARD and first REVERSED
    direct children with reference location 0, shape (E, 2) (column 0
    FORWARD, 1 REVERSED); -1 where it has none.  One vectorised pass over
    the child references (references outside the shapes table are no
    vertices), where a loop per edge cost a tenth of compressing a part of
    lines and circles."""
    types = np.asarray(m.shape_type)
    start = np.asarray(m.child_start, np.int64)
    kids = np.asarray(m.child_shape, np.int64)
    orient = np.asarray(m.child_orient, np.int64)
    n, nref = len(types), len(kids)
    tidx = m.type_index()
    edges = types == ShapeType.EDGE
    out = np.full((int(edges.sum()), 2), -1, np.int64)
    if not nref or len(start) != n + 1:
        return out
    # the shape whose child list holds each reference (start is nondecreasing
    # and ends at nref in every model the readers build)
    parent = np.searchsorted(start, np.arange(nref), side="right") - 1
    inside = (kids >= 0) & (kids < n) & (parent >= 0) & (parent < n)
    ktype = np.full(nref, -1, np.int64)
    ktype[inside] = types[kids[inside]]
    ptype = np.full(nref, -1, np.int64)
    ptype[inside] = types[parent[inside]]
    refs = np.flatnonzero(
        (ptype == ShapeType.EDGE)
        & (ktype == ShapeType.VERTEX)
        & (np.asarray(m.child_loc) == 0)
        & ((orient == FORWARD) | (orient == REVERSED))
    )
    key = tidx[parent[refs]] * 2 + orient[refs]
    keys, first = np.unique(key, return_index=True)  # the first reference of each
    out.reshape(-1)[keys] = tidx[kids[refs[first]]]
    return out


def edge_ends(ends: np.ndarray, e: int) -> dict[int, int]:
    """Edge row ``e``'s end vertex rows by orientation (FORWARD, REVERSED),
    where it has them; ``ends`` is :func:`end_vertices`'s table."""
    fwd, rev = ends[e].tolist()
    out = {}
    if fwd >= 0:
        out[FORWARD] = fwd
    if rev >= 0:
        out[REVERSED] = rev
    return out


def line_through(a: np.ndarray, b: np.ndarray) -> np.ndarray | None:
    """The frame (origin, direction) of the line from point ``a`` to point
    ``b``, as docs/format.md §2.3 computes it (2.2): None where they coincide
    or the length is not finite."""
    ax, ay, az = (float(x) for x in a)
    dx, dy, dz = float(b[0]) - ax, float(b[1]) - ay, float(b[2]) - az
    n = math.sqrt((dx * dx + dy * dy) + dz * dz)
    if not (n > 0 and math.isfinite(n)):
        return None
    return np.array([[ax, ay, az], [dx / n, dy / n, dz / n]])


#: Surfaces whose axis a circle through a vertex takes (2.4, docs/format.md §2.3).
REVOLVED = (Kind.CYLINDER, Kind.CONE, Kind.SPHERE, Kind.TORUS)


def axis_faces(m: BRepModel, surfaces: list[Geometry] | None = None) -> dict[int, int]:
    """Per edge (its row), the first face (model order) that can give a circle
    on it an axis (2.4): of face location 0, on a CYLINDER, CONE, SPHERE or
    TORUS row of ``surfaces`` (``m.surfaces`` by default), holding the edge as a
    direct child of location 0 of one of its wires of location 0."""
    table = m.surfaces if surfaces is None else surfaces
    types, children, start, locs = m.shape_type, m.child_shape, m.child_start, m.child_loc
    tidx = m.type_index()
    wire, edge = int(ShapeType.WIRE), int(ShapeType.EDGE)
    out: dict[int, int] = {}
    faces = np.flatnonzero(types == ShapeType.FACE).tolist()
    for f, s in enumerate(faces):
        g = table[int(m.face_surface[f])]
        if m.face_loc[f] != 0 or not (isinstance(g, Analytic) and g.kind in REVOLVED):
            continue
        for k in range(start[s], start[s + 1]):
            w = int(children[k])
            if types[w] != wire or locs[k] != 0:
                continue
            for j in range(start[w], start[w + 1]):
                e = int(children[j])
                if types[e] == edge and locs[j] == 0:
                    out.setdefault(int(tidx[e]), f)
    return out


def circle_through(axis: Analytic, p: np.ndarray, sense: int) -> Analytic | None:
    """The circle about ``axis``'s axis (a surface's origin and main
    direction) through point ``p``, as docs/format.md §2.3 computes it (2.4):
    its centre the foot of ``p`` on the axis, its radius the distance from
    there, its normal the axis's direction (``sense`` 1) or its opposite
    (-1), its X direction the surface's.  None where ``p`` is on the axis or
    the radius is not finite."""
    (ox, oy, oz), (dx, dy, dz), x = ([float(c) for c in r] for r in axis.frame[:3])
    px, py, pz = (float(c) for c in p)
    wx, wy, wz = px - ox, py - oy, pz - oz
    h = (wx * dx + wy * dy) + wz * dz
    cx, cy, cz = ox + h * dx, oy + h * dy, oz + h * dz
    vx, vy, vz = px - cx, py - cy, pz - cz
    r = math.sqrt((vx * vx + vy * vy) + vz * vz)
    if not (r > 0 and math.isfinite(r)):
        return None
    s = 1.0 if sense > 0 else -1.0
    frame = np.array([[cx, cy, cz], [s * dx, s * dy, s * dz], x])
    return Analytic(Kind.CIRCLE, frame, np.array([r]), through=sense)


def face_points(m: BRepModel) -> dict[int, int]:
    """Per surface record (by its first row), the vertex row a plane or
    cylinder on it may go through (2.7, docs/format.md §2.3): the record's
    first face (model order, on its row or a copy of it) must have location
    0; in it, the first wire of location 0; in that, the first edge of
    location 0 with a FORWARD vertex of location 0 (:func:`edge_ends`).
    Records whose first face has no such vertex are left out."""
    types, children, start, locs = m.shape_type, m.child_shape, m.child_start, m.child_loc
    tidx = m.type_index()
    table = end_vertices(m)
    first = first_row(m.surfaces)
    wire, edge = int(ShapeType.WIRE), int(ShapeType.EDGE)
    out: dict[int, int] = {}
    seen: set[int] = set()
    for f, s in enumerate(np.flatnonzero(types == ShapeType.FACE).tolist()):
        row = first[int(m.face_surface[f])]
        if row in seen:
            continue
        seen.add(row)
        if m.face_loc[f] != 0:
            continue
        w = next(
            (int(children[k]) for k in range(start[s], start[s + 1])
             if types[children[k]] == wire and locs[k] == 0),
            None,
        )  # fmt: skip
        if w is None:
            continue
        for j in range(start[w], start[w + 1]):
            e = int(children[j])
            if types[e] == edge and locs[j] == 0:
                v = edge_ends(table, int(tidx[e])).get(FORWARD)
                if v is not None:
                    out[row] = v
                    break
    return out


def surface_origin(g: Analytic, p: np.ndarray) -> np.ndarray:
    """The origin of a plane or cylinder through point ``p`` (2.7,
    docs/format.md §2.3): a plane's is ``p``; a cylinder whose ``through`` is
    q + 1 has its axis at its radius r from ``p``, against the unit ``u``
    (X, Y, −X, −Y direction for q = 0 … 3): per coordinate
    ``p_j − r·u_j`` (the product rounded, then the difference)."""
    if g.kind == Kind.PLANE:
        return np.array(p, dtype=np.float64)
    q = g.through - 1
    u = g.frame[2 + q % 2] * (1.0 if q < 2 else -1.0)
    r = float(g.params[0])
    return np.array([float(p[j]) - r * float(u[j]) for j in range(3)])


#: Surface kinds that may go through a vertex of their first face (2.7).
THROUGH_SURFACES = (Kind.PLANE, Kind.CYLINDER)
#: A frame or radius made from a vertex (a line, circle, plane or cylinder
#: through it) must stay below this in magnitude (mm): a hostile container's
#: vertex at 1e100 made a line there on which OCCT's pcurve projection
#: crashed the process (found by ``tests.fuzz --structure``).
THROUGH_MAX = 1e15


def within_reach(g: Analytic) -> bool:
    """Whether a record made through a vertex has its frame and params below
    :data:`THROUGH_MAX` (the writer makes no other: the reader refuses it)."""
    return bool((np.abs(g.frame) < THROUGH_MAX).all() and (np.abs(g.params) < THROUGH_MAX).all())


def _made(where: str, *values: np.ndarray) -> None:
    """Refuse a made frame or radius at or past :data:`THROUGH_MAX` (or not finite)."""
    for v in values:
        if not (np.abs(v) < THROUGH_MAX).all():
            raise BadReferenceError(f"{where} through a vertex at or past {THROUGH_MAX:g} mm")


def through_vertices(m: BRepModel) -> None:
    """Make the frame of every 3-D line that goes through its edge's
    vertices (``Analytic.through``, format 2.2), of every circle through
    its edge's vertex about its face's axis (2.4) and the origin of every
    plane or cylinder through its face's vertex (2.7, before the circles,
    which take a cylinder's axis), in place, from the decoded vertices and
    surfaces (docs/format.md §2.3).

    Raises
    ------
    BadReferenceError
        Such a line that is not the one unlocated 3-D curve of one edge with
        distinct FORWARD and REVERSED unlocated vertices; such a circle used
        by no edge or by a located one, whose first edge has no unlocated
        FORWARD vertex or no face to take an axis from, or whose vertex is on that
        axis; such a plane or cylinder on no face or without the vertex of
        :func:`face_points`; a line or circle copied by another row.
    """
    first = first_row(m.surfaces)
    through = [
        i
        for i, g in enumerate(m.surfaces)
        if isinstance(g, Analytic) and g.through and first[i] == i
    ]
    if through:
        at = face_points(m)
        for i in through:
            g = m.surfaces[i]
            assert isinstance(g, Analytic)
            if i not in at:
                name = g.kind.name.lower()
                raise BadReferenceError(f"SURF row {i}: a {name} through a vertex has no vertex")
            g.frame[0] = surface_origin(g, m.vertex_point[at[i]])
            _made(f"SURF row {i}: a {g.kind.name.lower()}", g.frame[0])
    rows = [i for i, g in enumerate(m.curves3d) if isinstance(g, Analytic) and g.through]
    if not rows:
        return
    reps = m.edge_reps
    use = curve_uses(m)
    table = end_vertices(m)
    held = collections.Counter(id(h) for h in m.curves3d)
    axes: dict[int, int] | None = None
    for i in rows:
        g = m.curves3d[i]
        assert isinstance(g, Analytic)
        qs = use.get(i, [])
        if held[id(g)] != 1:
            raise BadReferenceError(f"CRV3 row {i}: a curve through vertices is copied")
        if g.kind == Kind.LINE:
            _line_through_edge(m, i, qs, table)
            continue
        if not qs or any(reps[q, EC.LOC] != 0 for q in qs):
            raise BadReferenceError(f"CRV3 row {i}: a circle through a vertex on no unlocated edge")
        e = int(reps[qs[0], EC.EDGE])
        ends = edge_ends(table, e)
        if FORWARD not in ends:
            raise BadReferenceError(f"CRV3 row {i}: its edge has no unlocated FORWARD vertex")
        if axes is None:
            axes = axis_faces(m)
        f = axes.get(e)
        if f is None:
            raise BadReferenceError(f"CRV3 row {i}: its edge is on no face to take an axis from")
        s = m.surfaces[int(m.face_surface[f])]
        assert isinstance(s, Analytic)
        made = circle_through(s, m.vertex_point[ends[FORWARD]], g.through)
        if made is None:
            raise BadReferenceError(f"CRV3 row {i}: a circle through a vertex on its axis")
        _made(f"CRV3 row {i}: a circle", made.frame, made.params)
        g.frame[...] = made.frame
        g.params[...] = made.params


def _line_through_edge(m: BRepModel, i: int, qs: list[int], table: np.ndarray) -> None:
    """The frame of line row ``i`` (2.2) from its one edge's vertices, in place."""
    g = m.curves3d[i]
    assert isinstance(g, Analytic)
    reps = m.edge_reps
    if len(qs) != 1 or reps[qs[0], EC.LOC] != 0:
        raise BadReferenceError(f"CRV3 row {i}: a line through vertices used by {len(qs)} edges")
    ends = edge_ends(table, int(reps[qs[0], EC.EDGE]))
    if len(ends) != 2:
        raise BadReferenceError(f"CRV3 row {i}: its edge has no two unlocated vertices")
    a, b = (m.vertex_point[ends[o]] for o in (FORWARD, REVERSED))
    frame = line_through(a, b)
    if frame is None:
        raise BadReferenceError(f"CRV3 row {i}: a line through two vertices at one point")
    _made(f"CRV3 row {i}: a line", frame)
    g.frame[...] = frame


def vertex_ranges(m: BRepModel) -> dict[int, tuple[float, float]]:
    """Per 3-D representation of an edge on a line or circle, the range its
    vertices give.

    A line's parameter is the projection on its direction; a circle's, the
    angle from its X axis in [0, 2π), the end one turn or less after the
    start (a whole turn when both vertices are one).  Only edges with a
    FORWARD and a REVERSED vertex, both unlocated, on an unlocated curve.
    """
    reps = m.edge_reps
    curves = m.curves3d
    qs = np.flatnonzero((reps[:, EC.KIND] == RepKind.CURVE3D) & (reps[:, EC.LOC] == 0))
    ends = end_vertices(m)
    line, circle = int(Kind.LINE), int(Kind.CIRCLE)
    lines: list[tuple[int, int, int, int]] = []  # (representation, curve, start, end vertex)
    out: dict[int, tuple[float, float]] = {}
    points = m.vertex_point
    for q, c, e in zip(qs.tolist(), reps[qs, EC.CURVE].tolist(), reps[qs, EC.EDGE].tolist()):
        if c < 0 or c >= len(curves) or not 0 <= e < len(ends):
            continue
        g = curves[c]
        if not isinstance(g, Analytic) or g.kind not in (line, circle):
            continue
        a, b = ends[e].tolist()
        if a < 0 or b < 0:
            continue
        if g.kind == line:
            lines.append((q, c, a, b))
            continue
        out[q] = circle_range(g, points[a], points[b], a == b)
    if lines:  # on_line's sums in its order, elementwise: the same bits
        at = np.array(lines, np.int64)
        frames = np.array([cast(Analytic, curves[i]).frame[:2] for i in at[:, 1].tolist()])
        o, d = frames[:, 0], frames[:, 1]

        def along(v: np.ndarray) -> list[float]:
            p = points[v] - o
            return cast(
                list[float], ((p[:, 0] * d[:, 0] + p[:, 1] * d[:, 1]) + p[:, 2] * d[:, 2]).tolist()
            )

        out.update(zip(at[:, 0].tolist(), zip(along(at[:, 2]), along(at[:, 3]))))
    return dict(sorted(out.items()))


def circle_range(g: Analytic, a: np.ndarray, b: np.ndarray, closed: bool) -> tuple[float, float]:
    """The range of an edge from point ``a`` to point ``b`` on circle ``g``:
    from ``a``'s angle, the end one turn or less after it (a whole turn where
    the edge is ``closed`` or both angles are one)."""
    t0, t1 = _on_circle(g, a), _on_circle(g, b)
    if closed or t1 == t0:
        t1 = t0 + 2 * math.pi
    elif t1 < t0:
        t1 += 2 * math.pi
    return t0, t1


def _pinned(m: BRepModel, poles: np.ndarray, places: list[tuple[Any, int]]) -> np.ndarray:
    """A copy of ``poles`` with each ``(index, vertex row)`` place set to the vertex."""
    out = poles.copy()
    for index, v in places:
        out[index] = m.vertex_point[v]
    return out


def pinned_poles(m: BRepModel, g: BSplineCurve, pins: list[tuple[int, int]]) -> np.ndarray:
    """A copy of ``g``'s poles with the pinned ones set to their vertices."""
    return _pinned(m, g.poles, pins)


def overreaching(
    m: BRepModel, decoded: list[Geometry], coded_rows: set[int], tol: float
) -> set[int]:
    """Rows whose pinned ends would move further than ``tol`` from ``m``'s poles."""
    out = set()
    for c, pins in curve_end_pins(m, decoded, coded_rows, tol).items():
        g = m.curves3d[c]
        assert isinstance(g, BSplineCurve)
        # a pin's index is the decoded row's (0 or its last): knots removed leave fewer poles
        ends = [(0 if i == 0 else -1, v) for i, v in pins]
        if any(np.sqrt(((g.poles[i] - m.vertex_point[v]) ** 2).sum()) > tol for i, v in ends):
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


# ------------------------------------------------------------ surfaces: corners, iso-boundaries

#: The four boundaries of a net (nu, nv): row u=0, row u=1, column v=0, column v=1.
SIDES = 4
#: Corner poles (i, j) of a net, in the order P00, P0m, Pn0, Pnm.
CORNERS = ((0, 0), (0, -1), (-1, 0), (-1, -1))


def boundary(poles: np.ndarray, side: int, reverse: bool) -> np.ndarray:
    """One boundary row or column of a net (see ``SIDES``), optionally reversed."""
    row = (poles[0], poles[-1], poles[:, 0], poles[:, -1])[side]
    return row[::-1] if reverse else row


def side_knots(s: BSplineSurface, side: int, reverse: bool) -> tuple[np.ndarray, np.ndarray]:
    """The knots and multiplicities of side ``side`` of a B-spline net (see
    ``SIDES``) as a curve's, optionally reversed: mirrored as
    ``k[-1] + k[0] - k[::-1]``."""
    kn, mu = (s.uknots, s.umults) if side >= 2 else (s.vknots, s.vmults)
    if reverse:
        kn, mu = kn[-1] + kn[0] - kn[::-1], mu[::-1]
    return kn, mu


def clamped_surface(g: Geometry) -> bool:
    """A non-periodic B-spline (or Bezier) surface whose corner poles are its corners."""
    if not isinstance(g, BSplineSurface) or g.uperiodic or g.vperiodic:
        return False
    if g.bezier:
        return True
    return bool(
        (g.umults[[0, -1]] == g.udegree + 1).all() and (g.vmults[[0, -1]] == g.vdegree + 1).all()
    )


def face_vertices(m: BRepModel) -> list[list[int]]:
    """Per face, the vertex rows reached from it through unlocated sub-shapes only.

    Each face's walk visits a shape once (a visited set), so shared wires or
    edges cost nothing more, and it keeps its own stack (no recursion)."""
    tidx = m.type_index().tolist()
    types = m.shape_type.tolist()
    start, kids = m.child_start.tolist(), m.child_shape.tolist()
    unlocated = (m.child_loc == 0).tolist()
    out = []
    for f, s in enumerate(np.flatnonzero(m.shape_type == ShapeType.FACE).tolist()):
        found: set[int] = set()
        seen = {s}
        stack = [s] if m.face_loc[f] == 0 else []
        while stack:
            x = stack.pop()
            for k in range(start[x], start[x + 1]):
                c = kids[k]
                if not unlocated[k] or c in seen:
                    continue
                seen.add(c)
                if types[c] == ShapeType.VERTEX:
                    found.add(tidx[c])
                elif types[c] < ShapeType.VERTEX:
                    stack.append(c)
        out.append(sorted(found))
    return out


def surface_anchor_candidates(m: BRepModel, rows: Iterable[int]) -> dict[int, list[int]]:
    """Per surface row of ``rows`` that a face stands on, the vertex rows a
    format 2.1 ``SNET`` may code its first pole against (docs/format.md §2.4):
    the vertices of the first face on it (:func:`face_vertices`: reached
    through unlocated sub-shapes, in increasing row order).  A net's first
    pole is often a corner of its face: against that vertex its grid
    residual is near zero, where against the previous net's first pole it
    costs some 30 bits."""
    want = set(rows)
    verts = face_vertices(m)
    out: dict[int, list[int]] = {}
    for f, r in enumerate(m.face_surface.tolist()):
        if r in want and r not in out:
            out[r] = verts[f]
    return out


def surface_corner_pins(
    m: BRepModel,
    surfaces: list[Geometry],
    coded_rows: set[int],
    tol: float,
    radius: dict[int, float] | None = None,
) -> dict[int, list[tuple[int, int]]]:
    """Per coded surface row (``m``'s surface table, decoded), the ``(corner, vertex row)``
    pairs to pin: each corner pole of a clamped net (a corner of the surface)
    goes to the nearest vertex of the first face on it, if within ``tol``, or
    within ``radius[row]`` where given (format 1.2: :func:`pin_radius`).

    Pinned corners make the decoded surface pass through its face's
    vertices, so that edge curves pinned to the same vertices and the iso
    boundaries copied from it (:func:`iso_sources`) meet it there exactly.
    """
    out: dict[int, list[tuple[int, int]]] = {}
    verts = face_vertices(m)
    for f, r in enumerate(m.face_surface.tolist()):
        if r not in coded_rows or r in out or not verts[f] or not clamped_surface(surfaces[r]):
            continue
        g = surfaces[r]
        assert isinstance(g, BSplineSurface)
        pts = m.vertex_point[verts[f]]
        pins = []
        near = tol if radius is None else radius.get(r, tol)
        for k, (i, j) in enumerate(CORNERS):
            d = np.sqrt(((pts - g.poles[i, j]) ** 2).sum(-1))
            if d.min() <= near:
                pins.append((k, verts[f][int(d.argmin())]))
        if pins:
            out[r] = pins
    return out


def pin_radius(tol: float, quant: int, level: int) -> float:
    """How far a net's decoded corner may be from a vertex it is pinned to
    (format 1.2): the step of the grid its corners are coded on, at most tol.

    A corner that is at a vertex moved by at most √3/2 of that step.  Before
    1.2 the radius was tol, and a trimmed face's corner that lies at no vertex
    was pulled to the nearest one within tol: on an IGES model of 10 µm faces,
    at 0.1 mm, by up to 13 µm where the net was held to 1.7 µm (and OCCT's
    STEP reader then split the face).
    """
    return min(tol, tol * 2.0 ** (level / 4)) if quant == 0 else tol


def pin_radii(recs: list[Rec], codes: dict[Rec, Any], tol: float) -> dict[int, float]:
    """:func:`pin_radius` of each row of a table whose record has a net code
    in ``codes`` (record -> ``codec.NetCode``); ``recs``: per row, its record
    (:func:`model.records`)."""
    out = {}
    for r, k in enumerate(recs):
        code = codes.get(k)
        if code is not None:
            out[r] = pin_radius(tol, int(code.quant), int(code.level))
    return out


def pinned_corners(m: BRepModel, g: BSplineSurface, pins: list[tuple[int, int]]) -> np.ndarray:
    """A copy of ``g``'s poles with the pinned corners set to their vertices."""
    return _pinned(m, g.poles, [(CORNERS[k], v) for k, v in pins])


def location_matrix(m: BRepModel, loc: int) -> np.ndarray:
    """The 4 x 4 matrix of location ``loc``: its datums' matrices raised to their
    powers, multiplied first factor first (OCCT's ``TopLoc_Location``)."""
    out = np.eye(4)
    item = m.locations[loc]
    for d, p in zip(item.datums, item.powers):
        t = np.eye(4)
        t[:3] = m.datums[d]
        out = (
            out @ np.linalg.matrix_power(t, p)
            if p >= 0
            else out @ np.linalg.matrix_power(np.linalg.inv(t), -p)
        )
    return out


def curve_placements(m: BRepModel) -> dict[int, np.ndarray]:
    """Per 3-D curve row used in one place only, where: the 4 x 4 matrix that
    takes its poles into the model's frame (the locations from the root down
    to its edge, then its representation's).  A curve used under two different
    placements (an instanced part) has none.

    Each shape's placement is found once, parents before children (the shapes
    table lists sub-shapes first, so it is walked backwards from the root):
    the one matrix every path from the root gives it, or none where two paths
    differ.  No path is walked twice, however much the shapes are shared."""
    mats = {k: location_matrix(m, k) for k in range(len(m.locations))}
    n = len(m.shape_type)
    types = m.shape_type.tolist()
    start, kids, locs = m.child_start.tolist(), m.child_shape.tolist(), m.child_loc.tolist()
    place: list[np.ndarray | None] = [None] * n
    many = [False] * n  # reached with two different matrices
    reached = [False] * n
    if 0 <= m.root_shape < n:
        place[m.root_shape], reached[m.root_shape] = mats[m.root_loc], True
    edge_at: dict[int, np.ndarray | None] = {}
    tidx = m.type_index().tolist()
    for s in range(n - 1, -1, -1):
        if not reached[s]:
            continue
        t = None if many[s] else place[s]
        if types[s] == ShapeType.EDGE:
            edge_at[tidx[s]] = t
            continue
        for k in range(start[s], start[s + 1]):
            c = kids[k]
            if types[c] == ShapeType.VERTEX:
                continue
            tc = None if t is None else t @ mats[locs[k]]
            if not reached[c]:
                reached[c], place[c], many[c] = True, tc, tc is None
            elif not many[c] and (tc is None or not np.array_equal(place[c], tc)):
                many[c] = True
    at: dict[int, list[np.ndarray | None]] = {}
    reps = m.edge_reps
    for q in np.flatnonzero(reps[:, EC.KIND] == RepKind.CURVE3D).tolist():
        c = int(reps[q, EC.CURVE])
        e = int(reps[q, EC.EDGE])
        if e in edge_at:
            t = edge_at[e]
            at.setdefault(c, []).append(None if t is None else t @ mats[int(reps[q, EC.LOC])])
    return {
        c: ts[0]
        for c, ts in at.items()
        if ts[0] is not None and all(x is not None and np.array_equal(x, ts[0]) for x in ts)
    }


def placed(poles: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Points (n, 3) moved by the 4 x 4 matrix ``t``."""
    return poles @ t[:3, :3].T + t[:3, 3]


def copy_matrix(where: dict[int, np.ndarray], row: int, leader: int) -> np.ndarray | None:
    """The matrix taking the leader's poles to a copy's own frame
    (inverse of the copy's placement times the leader's), or None where the
    two placements are equal (the poles are copied as they are)."""
    a, b = where.get(row, np.eye(4)), where.get(leader, np.eye(4))
    if np.array_equal(a, b):
        return None
    return np.linalg.inv(a) @ b


def joined_sides(g: BSplineSurface, lead: BSplineSurface, join: np.ndarray) -> np.ndarray:
    """A copy of ``g``'s poles with side ``join[1]`` set to ``lead``'s side
    ``join[3]`` (reversed if ``join[4]``); one row of ``BRepModel.side_joins``."""
    _, side, _, lside, rev = (int(x) for x in join)
    src = boundary(lead.poles, lside, bool(rev))
    out = g.poles.copy()
    dst = boundary(out, side, False)
    if dst.shape != src.shape:
        raise ValueError("a side join between sides of different lengths")
    dst[...] = src
    return out
