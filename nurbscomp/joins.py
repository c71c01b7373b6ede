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

import math
from collections.abc import Iterable
from dataclasses import dataclass, replace
from typing import Any, NamedTuple, cast

import numpy as np

from . import bspline
from .model import (
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
    faces_around,
)

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
        if not isinstance(g, BSplineCurve) or not _clamped(g):
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


def _on_line(g: Analytic, p: np.ndarray) -> float:
    return _dot(p - g.frame[0], g.frame[1])


def _on_circle(g: Analytic, p: np.ndarray) -> float:
    """The angle of ``p`` about a circle's axis (frame: origin, axis, X
    direction) from its X direction, in [0, 2π); within 1e-9 below 0 is 0."""
    q, (n, x) = p - g.frame[0], g.frame[1:3]
    y = np.array([n[1] * x[2] - n[2] * x[1], n[2] * x[0] - n[0] * x[2], n[0] * x[1] - n[1] * x[0]])
    norm = math.sqrt(_dot(y, y))
    if not norm > 0:  # no frame (only a damaged file has one): no angle
        return 0.0
    y = y / norm  # gp_Ax2's Y direction: N × X, normalised
    t = math.atan2(_dot(q, y), _dot(q, x))
    if t < 0:  # just below the X axis is the start of the turn, not its end
        t = 0.0 if t > -1e-9 else t + 2 * math.pi
    return t


def vertex_ranges(m: BRepModel) -> dict[int, tuple[float, float]]:
    """Per 3-D representation of an edge on a line or circle, the range its
    vertices give.

    A line's parameter is the projection on its direction; a circle's, the
    angle from its X axis in [0, 2π), the end one turn or less after the
    start (a whole turn when both vertices are one).  Only edges with a
    FORWARD and a REVERSED vertex, both unlocated, on an unlocated curve.
    """
    tidx = m.type_index()
    edge_shapes = np.flatnonzero(m.shape_type == ShapeType.EDGE)
    reps = m.edge_reps
    out: dict[int, tuple[float, float]] = {}
    for q in np.flatnonzero(reps[:, EC.KIND] == RepKind.CURVE3D).tolist():
        c = int(reps[q, EC.CURVE])
        if c < 0 or c >= len(m.curves3d) or reps[q, EC.LOC] != 0:
            continue
        g = m.curves3d[c]
        if not isinstance(g, Analytic) or g.kind not in (Kind.LINE, Kind.CIRCLE):
            continue
        s = int(edge_shapes[reps[q, EC.EDGE]])
        ends: dict[int, int] = {}
        for k in range(m.child_start[s], m.child_start[s + 1]):
            v, o = int(m.child_shape[k]), int(m.child_orient[k])
            if m.shape_type[v] == ShapeType.VERTEX and m.child_loc[k] == 0 and o in (0, 1):
                ends.setdefault(o, int(tidx[v]))
        if len(ends) != 2:
            continue
        a, b = (m.vertex_point[ends[e]] for e in (FORWARD, REVERSED))
        if g.kind == Kind.LINE:
            out[q] = (_on_line(g, a), _on_line(g, b))
            continue
        t0, t1 = _on_circle(g, a), _on_circle(g, b)
        if ends[FORWARD] == ends[REVERSED] or t1 == t0:
            t1 = t0 + 2 * math.pi
        elif t1 < t0:
            t1 += 2 * math.pi
        out[q] = (t0, t1)
    return out


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


# ------------------------------------------------------------ surfaces: corners, iso-boundaries

#: The four boundaries of a net (nu, nv): row u=0, row u=1, column v=0, column v=1.
SIDES = 4
#: Corner poles (i, j) of a net, in the order P00, P0m, Pn0, Pnm.
CORNERS = ((0, 0), (0, -1), (-1, 0), (-1, -1))


def boundary(poles: np.ndarray, side: int, reverse: bool) -> np.ndarray:
    """One boundary row or column of a net (see ``SIDES``), optionally reversed."""
    row = (poles[0], poles[-1], poles[:, 0], poles[:, -1])[side]
    return row[::-1] if reverse else row


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


class IsoSource(NamedTuple):
    """Where an iso-boundary curve comes from (:func:`iso_sources`): side
    ``side`` of the net of surface row ``surface``, reversed if ``reversed``."""

    surface: int
    side: int
    reversed: int


class Twin(NamedTuple):
    """A member of a twin pair (:func:`twin_curves`, :func:`twin_sides`): it is
    its ``leader`` (a curve row, or a (surface row, side)), reversed if
    ``reversed``, up to ``distance``."""

    leader: Any
    reversed: int
    distance: float


def iso_sources(m: BRepModel, curve_rows: set[int], surface_rows: set[int]) -> dict[int, IsoSource]:
    """Curves that are a boundary of a surface on the same edge, bit for bit.

    Returns ``{curve row: (surface row, side, reversed)}`` for each curve row in
    ``curve_rows`` that an unlocated edge uses over its whole range, whose
    degree, knots and weights are those of the boundary, and whose poles are
    those of ``boundary(surface poles, side, reversed)``, for the surface (in
    ``surface_rows``, clamped, unlocated face) of a face on that edge.  Such a
    curve is not coded: the decoder copies it from the decoded surface, so
    the two meet exactly (docs/design.md §4, "shared iso-boundaries coded once").
    """
    faces_of = faces_around(m, ShapeType.EDGE)
    out: dict[int, IsoSource] = {}
    reps = m.edge_reps
    for q in np.flatnonzero(reps[:, EC.KIND] == RepKind.CURVE3D).tolist():
        c = int(reps[q, EC.CURVE])
        if c not in curve_rows or c in out or reps[q, EC.LOC] != 0:
            continue
        g = m.curves3d[c]
        if not isinstance(g, BSplineCurve) or not _clamped(g):
            continue
        first, last = (0.0, 1.0) if g.bezier else (g.knots[0], g.knots[-1])
        if (m.edge_rep_range[q] != (first, last)).any():
            continue
        e = int(reps[q, EC.EDGE])
        for f in faces_of[e]:
            r = int(m.face_surface[f])
            hit = _boundary_match(g, m.surfaces[r]) if r in surface_rows else None
            if hit is not None and m.face_loc[f] == 0:
                out[c] = IsoSource(r, *hit)
                break
    return out


def _boundary_match(g: BSplineCurve, s: Geometry) -> tuple[int, int] | None:
    """(side, reversed) where curve ``g`` is bit for bit a boundary of ``s``, or None."""
    if not clamped_surface(s):
        return None
    assert isinstance(s, BSplineSurface)
    for side in range(SIDES):
        along_u = side >= 2  # columns run along u
        deg = s.udegree if along_u else s.vdegree
        knots = (s.uknots, s.umults) if along_u else (s.vknots, s.vmults)
        w = s.weights
        wrow = None if w is None else boundary(w[..., None], side, False)[:, 0]
        for rev in (0, 1):
            p = boundary(s.poles, side, bool(rev))
            if p.shape != g.poles.shape or not np.array_equal(p, g.poles):
                continue
            wr = None if wrow is None else (wrow[::-1] if rev else wrow)
            if (wr is None) != (g.weights is None):
                continue
            if wr is not None and not np.array_equal(wr, cast(np.ndarray, g.weights)):
                continue
            if g.bezier != s.bezier or (not g.bezier and g.degree != deg):
                continue
            if not g.bezier:
                kn, mu = knots
                if rev:
                    kn, mu = kn[-1] + kn[0] - kn[::-1], mu[::-1]
                if not (np.array_equal(kn, g.knots) and np.array_equal(mu, g.mults)):
                    continue
            return side, rev
    return None


# ------------------------------------------------------------ coincident curves and vertices

#: Vertices closer than this (mm; OCCT's Precision::Confusion, the sewing
#: tolerance of the free-edge measure) are one point to the encoder: they
#: move together or stay together (:func:`vertex_clusters`).
TWIN_VERTEX = 1e-7


#: Relative slack of :func:`close_pairs` over the distance asked: far above
#: the few ulps by which two ways of summing squared differences can differ.
_SLACK = 1e-9
#: :func:`close_pairs` sweeps piled-up points too while it has at most this
#: many pairs to look at, and no row more than :data:`_SWEEP_RUN` of them.
_SWEEP_MAX = 1 << 22
_SWEEP_RUN = 1024


def close_pairs(points: np.ndarray, r: float, budget: int = 64) -> np.ndarray | None:
    """Pairs (i, j), i < j, sorted, of rows of ``points`` (shape (n, d)) that
    are within ``r`` of each other: every pair within ``r`` as scipy's
    ``cKDTree.query_pairs(r)`` finds it, and perhaps pairs a hair beyond
    (``_SLACK``); shape (k, 2).  None when the points pile up (more than
    ``budget`` per point within ``r`` along every axis, and more than
    :data:`_SWEEP_MAX` in all or :data:`_SWEEP_RUN` for one point: the
    sweep's numpy passes grow with those) or are not finite: then ask a k-d
    tree.  (bearing.iges at 0.01 mm: 925 vertices, 100 a point.)

    A sweep in numpy along the axis with the fewest pairs within ``r``: no
    import of scipy.spatial (0.1 to 0.3 s, most of a small file's compress).
    """
    n = len(points)
    if n < 2:
        return np.zeros((0, 2), np.int64)
    pts = np.asarray(points, np.float64).reshape(n, -1)
    if not np.isfinite(pts).all():
        return None  # as the tree takes them (or refuses them)
    lim = r * (1 + _SLACK)
    lim2 = lim * lim
    # (pairs to look at, the most for one row, axis, order)
    best: tuple[int, int, int, np.ndarray] | None = None
    for axis in range(pts.shape[1]):
        order = np.argsort(pts[:, axis], kind="stable")
        xs = pts[order, axis]
        ahead = np.searchsorted(xs, xs + lim, side="right") - np.arange(n) - 1
        work = int(ahead.sum())
        if best is None or work < best[0]:
            best = (work, int(ahead.max()), axis, order)
    assert best is not None
    work, run, axis, order = best
    if work > budget * n and (work > _SWEEP_MAX or run > _SWEEP_RUN):
        return None
    p = pts[order]
    xs = p[:, axis]
    found = []
    live = np.arange(n)
    k = 1
    while True:  # row i and row i + k of the sorted rows; a row out of reach stays out
        live = live[live + k < n]
        live = live[xs[live + k] - xs[live] <= lim]
        if not len(live):
            break
        d2 = ((p[live + k] - p[live]) ** 2).sum(-1)
        near = live[d2 <= lim2]
        found.append(np.stack([order[near], order[near + k]], 1))
        k += 1
    if not found:
        return np.zeros((0, 2), np.int64)
    pairs = np.sort(np.concatenate(found), axis=1).astype(np.int64)
    return pairs[np.lexsort((pairs[:, 1], pairs[:, 0]))]


def vertex_clusters(points: np.ndarray, eps: float) -> np.ndarray:
    """Per point, the first point of its cluster (points linked by distances ≤ eps).

    Separate vertices at one place (the corners of an IGES surface model's
    faces, of a STEP file's unshared edges) must land at one place again, or
    the faces part there.
    """
    n = len(points)
    if n == 0:
        return np.zeros(0, np.int64)
    return first_of_components(n, pairs_within(points, eps))


def pairs_within(points: np.ndarray, r: float) -> np.ndarray:
    """Pairs (i, j), i < j, sorted, of rows of ``points`` within ``r`` of each
    other: :func:`close_pairs` cut to ``r`` (:func:`within`), or a k-d tree's
    where the points pile up."""
    near = close_pairs(points, r)
    if near is not None:
        return within(points, near, r)
    from scipy.spatial import cKDTree

    near = cKDTree(points).query_pairs(r, output_type="ndarray")
    return near[np.lexsort((near[:, 1], near[:, 0]))] if len(near) else near.reshape(0, 2)


def within(points: np.ndarray, pairs: np.ndarray, r: float) -> np.ndarray:
    """The rows of ``pairs`` (of :func:`close_pairs`) whose points are within ``r``."""
    p = np.asarray(points, np.float64).reshape(len(points), -1)
    d2 = ((p[pairs[:, 0]] - p[pairs[:, 1]]) ** 2).sum(-1)
    return pairs[d2 <= r * r]


def first_of_components(n: int, pairs: np.ndarray) -> np.ndarray:
    """Per node of a graph of ``n`` nodes and edges ``pairs`` (k, 2), the
    smallest node of its connected component."""
    first = np.arange(n, dtype=np.int64)
    if not len(pairs):
        return first
    a, b = pairs[:, 0].astype(np.int64), pairs[:, 1].astype(np.int64)
    while True:  # each pass takes every edge's smaller label to both ends
        low = np.minimum(first[a], first[b])
        before = first.copy()
        np.minimum.at(first, a, low)
        np.minimum.at(first, b, low)
        first = first[first]  # and follows labels to their own labels
        if np.array_equal(first, before):
            return first


#: :func:`nearest` compares every pair up to this many (points x queries).
_NEAREST_MAX = 1 << 21


def nearest(points: np.ndarray, queries: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per row of ``queries``, the distance to the nearest row of ``points`` and
    its index, as a k-d tree's ``query`` gives them.  Up to
    :data:`_NEAREST_MAX` pairs by brute force, in blocks (no import of
    scipy.spatial; of equal distances, the first point); beyond, by scipy's
    k-d tree (a model of thousands of faces, where its import is cheap)."""
    p = np.asarray(points, np.float64)
    q = np.asarray(queries, np.float64)
    if len(p) * len(q) > _NEAREST_MAX:
        from scipy.spatial import cKDTree

        d, i = cKDTree(p).query(q)
        return np.asarray(d, np.float64), np.asarray(i, np.int64)
    dist, idx = np.empty(len(q)), np.empty(len(q), np.int64)
    step = max(1, (1 << 20) // max(1, len(p)))
    for i in range(0, len(q), step):
        d2 = ((q[i : i + step, None, :] - p[None, :, :]) ** 2).sum(-1)
        k = d2.argmin(axis=1)
        idx[i : i + step] = k
        dist[i : i + step] = np.sqrt(d2[np.arange(len(k)), k])
    return dist, idx


#: Curves whose poles agree within this (mm) are one boundary, coded once
#: (:func:`twin_curves`); capped at tol/64 so the copy costs little of tol.
TWIN_EPS = 1e-6


@dataclass(frozen=True)
class _Run:
    """A row of poles with what makes it a curve: a B-spline curve, or one side of a net."""

    poles: np.ndarray  # (n, 3)
    weights: np.ndarray | None  # (n,)
    knots: np.ndarray  # flat knot vector mapped onto [0, 1]
    degree: int


def _flat_unit(knots: np.ndarray, mults: np.ndarray) -> np.ndarray:
    """A flat knot vector mapped onto [0, 1]."""
    k = np.repeat(np.asarray(knots, float), np.asarray(mults, int))
    span = k[-1] - k[0]
    return (k - k[0]) / span if span > 0 else k * 0.0


def _curve_run(g: BSplineCurve) -> _Run:
    n = len(g.poles)
    ends = (np.array([0.0, 1.0]), np.array([n, n])) if g.bezier else (g.knots, g.mults)
    return _Run(g.poles, g.weights, _flat_unit(*ends), g.degree)


def _side_run(g: BSplineSurface, side: int) -> _Run:
    """Side ``side`` of a clamped net (``SIDES``) as a curve of its own."""
    nu, nv = g.poles.shape[:2]
    if side < 2:  # a row: along v
        n, knots, mults, degree = nv, g.vknots, g.vmults, g.vdegree
    else:
        n, knots, mults, degree = nu, g.uknots, g.umults, g.udegree
    if g.bezier:
        knots, mults, degree = np.array([0.0, 1.0]), np.array([n, n]), n - 1
    w = None if g.weights is None else boundary(g.weights[..., None], side, False)[:, 0]
    return _Run(boundary(g.poles, side, False), w, _flat_unit(knots, mults), degree)


def _twins(a: _Run, b: _Run, eps: float) -> tuple[int, float] | None:
    """(reversed, distance) when ``b`` is ``a``'s point set up to ``eps``: same
    degree, pole count and weights, knots equal (or mirrored) up to an affine
    map, poles within ``eps`` in the same (or reversed) order; else None."""
    if a.degree != b.degree or a.poles.shape != b.poles.shape or len(a.knots) != len(b.knots):
        return None
    if (a.weights is None) != (b.weights is None):
        return None
    for rev in (0, 1):
        pb = b.poles[::-1] if rev else b.poles
        kb = (1.0 - b.knots[::-1]) if rev else b.knots
        # knots as far apart as a text file's digits leave them (IGES writes
        # ~1e-10): then the two curves are compared point by point
        gap = np.abs(kb - a.knots).max(initial=0.0)
        if gap > 1e-8:
            continue
        if b.weights is not None and not np.array_equal(
            b.weights[::-1] if rev else b.weights, cast(np.ndarray, a.weights)
        ):
            continue
        d = float(np.sqrt(((pb - a.poles) ** 2).sum(-1)).max())
        if d <= eps and (gap == 0 or _apart(a, replace(b, poles=pb, knots=kb)) <= eps):
            return rev, d
    return None


def _apart(a: _Run, b: _Run) -> float:
    """Largest distance between two runs of the same size and weights at points
    spread over [0, 1] (rational ones evaluated in homogeneous form)."""
    t = np.linspace(0.0, 1.0, 4 * len(a.poles) + 8)

    def points(r: _Run) -> np.ndarray:
        c = r.poles if r.weights is None else np.c_[r.poles * r.weights[:, None], r.weights]
        return bspline.points(r.knots, c, r.degree, t)

    pa, pb = points(a), points(b)
    if a.weights is not None:
        pa, pb = pa[:, :3] / pa[:, 3:], pb[:, :3] / pb[:, 3:]
    d = np.sqrt(((pa - pb) ** 2).sum(-1))
    return float(np.nanmax(d)) if np.isfinite(d).any() else np.inf


def _pair_up(
    runs: list[tuple[Any, _Run]],
    eps: float,
    leaders_only: set[Any] = frozenset(),  # type: ignore[assignment]
) -> dict[Any, Twin]:
    """``{member key: Twin(leader key, reversed, distance)}`` over ``runs`` (in key
    order): each run that is an earlier run up to ``eps`` (:func:`_twins`),
    the earlier being the first of its kind and no member itself.  Keys in
    ``leaders_only`` are never members."""
    if len(runs) < 2:
        return {}
    ends = np.array([np.concatenate([r.poles[0], r.poles[-1]]) for _, r in runs])
    # candidates: runs whose ends (or swapped ends) are within 2 eps, a superset
    # of the twins (ends within eps each: sqrt(2) eps), which _twins sorts out
    nearby = _near_ends(ends, 2 * eps)
    out: dict[Any, Twin] = {}
    for i, (key, a) in enumerate(runs):
        if key in out:
            continue
        for j in nearby[i]:
            other, b = runs[j]
            if j <= i or other in out or other in leaders_only:
                continue
            hit = _twins(a, b, eps)
            if hit is not None:
                out[other] = Twin(key, *hit)
    return out


def _near_ends(ends: np.ndarray, r: float) -> list[list[int]]:
    """Per row of ``ends`` (a curve's two end points, shape (n, 6)), the rows
    within ``r`` of it or of it with its ends swapped, in order (itself among
    them): all that a k-d tree's two ball queries find, perhaps more."""
    n = len(ends)
    both = np.concatenate([ends, np.concatenate([ends[:, 3:], ends[:, :3]], 1)])
    pairs = close_pairs(both, r)
    if pairs is None:
        from scipy.spatial import cKDTree

        tree = cKDTree(ends)
        return [
            sorted(set(tree.query_ball_point(e, r)) | set(tree.query_ball_point(both[n + i], r)))
            for i, e in enumerate(ends)
        ]
    # a pair of swapped rows is the pair of the rows; a row and a swapped row
    # are within r when the row and the other swapped are
    out: list[set[int]] = [{i} for i in range(n)]
    for a, b in (pairs % n).tolist():
        out[a].add(b)
        out[b].add(a)
    return [sorted(x) for x in out]


def coincident_edges(points: np.ndarray, eps: float) -> list[tuple[int, int]]:
    """Pairs (i, j), i < j, of rows of ``points`` (edges sampled along their
    ranges, :func:`occ.edge_points`, shape (E, n, 3)) that run through the same
    points within ``eps``, in the same or the opposite direction."""
    ok = np.isfinite(points).all(axis=(1, 2))
    rows = np.flatnonzero(ok)
    if len(rows) < 2:
        return []
    mid = points[rows, points.shape[1] // 2]
    # candidates: middles within 2 eps (a pair within eps everywhere, either
    # way round, has them within sqrt(3) eps when the middle sample is one
    # point of both directions: an odd number of samples)
    near = close_pairs(mid, 2 * eps) if points.shape[1] % 2 else None
    if near is None:
        from scipy.spatial import cKDTree

        candidates = sorted(cKDTree(mid).query_pairs(2 * eps))
    else:
        candidates = [(a, b) for a, b in near.tolist()]
    out = []
    for a, b in candidates:
        i, j = int(rows[a]), int(rows[b])
        pi, pj = points[i], points[j]
        if np.abs(pi - pj).max() <= eps or np.abs(pi - pj[::-1]).max() <= eps:
            out.append((i, j))
    return out


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


def twin_curves(
    curves: list[Geometry],
    rows: set[int],
    eps: float,
    iso: set[int] = frozenset(),  # type: ignore[assignment]
    where: dict[int, np.ndarray] | None = None,
) -> dict[int, Twin]:
    """Rows of ``rows`` whose B-spline curve is another row's up to ``eps``, in
    the model's frame.

    Returns ``{member row: Twin(leader row, reversed, distance)}``.  Faces of an
    IGES surface model (and of many STEP files) meet along separate edges
    whose curves coincide, often with their poles reversed, and each face may
    have a frame of its own: coded independently, they would part by up to
    tol, opening the gap the paper's shared boundaries prevent.  A member is
    decoded as a copy of its leader's final poles (``Method.COPY``), moved by
    the two placements (:func:`copy_matrix`).  Rows in ``iso`` (copies of a
    surface's boundary, :func:`iso_sources`) lead first and are never members.
    ``where`` is :func:`curve_placements`; rows without one are left out
    (with ``where`` None, every curve is where its poles are).
    """
    order = sorted(rows, key=lambda r: (r not in iso, r))
    runs = []
    for r in order:
        g = curves[r]
        if not isinstance(g, BSplineCurve) or g.periodic or g.poles.shape[1] != 3:
            continue
        if where is not None and r not in where:
            continue
        run = _curve_run(g)
        if where is not None:
            run = replace(run, poles=placed(run.poles, where[r]))
        runs.append((r, run))
    return _pair_up(runs, eps, iso)


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


def twin_sides(
    surfaces: list[Geometry], rows: list[int], eps: float
) -> dict[tuple[int, int], Twin]:
    """Sides of clamped nets in ``rows`` that are an earlier side up to ``eps``.

    Returns ``{(member row, side): Twin((leader row, side), reversed, distance)}``.
    Untrimmed patches of a surface model meet along their natural boundaries;
    each side is then set to its leader's decoded side (the SIDE section), so
    neighbouring nets, and the iso-boundary curves copied from them, meet
    exactly.  A degenerate side (all poles at one point) is left alone.
    """
    runs = []
    for r in sorted(rows):
        g = surfaces[r]
        if not clamped_surface(g):
            continue
        assert isinstance(g, BSplineSurface)
        for side in range(SIDES):
            run = _side_run(g, side)
            if np.ptp(run.poles, axis=0).max() > eps:
                runs.append(((r, side), run))
    return _pair_up(runs, eps)
