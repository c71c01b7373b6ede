"""Planes, quadrics, lines and conics within tol (issue 28 §1; docs/format.md §2.3).

A record's origin and lengths (radii, focal length; not a cone's semi-angle)
are snapped to a grid of step 2^(g - 64), a power of two at most
``SHARE`` x tol, and at most ``FEATURE`` x the smallest length, so that a
small fillet keeps its shape.  Every point
of the surface or curve then moves by at most the origin's move plus the
lengths' moves (a translation, then radii changed by that much: the
certified bound, whatever the extent of the face or edge), which
:func:`nurbscomp.encode.assembly.assemble` counts like a coded net's bound:
edge and vertex tolerances are widened by it, and the validity ladder leaves
the record exact where the moved record fails a check.  A grid shared by
every record of a file (the world's axes) keeps coplanar and coaxial records
that the source has equal equal.

Directions are straightened (:func:`straighten`): a component within
``NOISE`` of 0 (an axis-aligned frame written with 1e-13 of noise) is set to
0, the bound coming from how far the record's points in use are from its
origin (:func:`reaches`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Iterator
from dataclasses import replace

import numpy as np

from ..model import (
    EC,
    Analytic,
    BRepModel,
    BSplineCurve,
    Derived,
    Geometry,
    Kind,
    RepKind,
    ShapeType,
)
from ..rules import joins
from ..serialize import GRID_LENGTHS, GRID_MAX, GRID_MIN, MAX_GRID_INT
from ..serialize import SWEPT as SWEPT_KINDS
from .nets import resolve_row

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


# ------------------------------------------------------------ directions

#: A direction's component at most this large is noise (the sine of an angle of
#: 1e-10 rad or less to a coordinate plane): it is set to 0 (:func:`straighten`).
NOISE = 1e-10
#: Straightened directions whose components are all within this of each other
#: are one direction (:func:`same_directions`): 1e-9 rad, a move of 1e-7 mm
#: at 100 mm from the frame's origin.
SAME = 1e-9
#: ... where the record moves by at most this share of tol.
STRAIGHT_SHARE = 1 / 64
#: The kinds whose directions are straightened: every point's distance to the
#: frame's origin is bounded (:func:`reaches`), and their frames are 3-D.
STRAIGHT_KINDS = frozenset(
    {
        Kind.PLANE,
        Kind.CYLINDER,
        Kind.CONE,
        Kind.SPHERE,
        Kind.TORUS,
        Kind.LINE,
        Kind.CIRCLE,
        Kind.ELLIPSE,
    }
)


def _straight(d: np.ndarray) -> np.ndarray | None:
    """Direction rows ``d`` with their components within ``NOISE`` of 0 set to
    0, each scaled back to unit length where that changed it (None where a
    row would vanish)."""
    s = np.where(np.abs(d) <= NOISE, 0.0, d)
    norm = np.sqrt((s**2).sum(-1, keepdims=True))
    if not (norm > 0).all():
        return None
    return np.where(norm == 1.0, s, s / norm)


def _frames(tables: Iterable[list[Geometry]]) -> Iterator[np.ndarray]:
    """The direction rows of every record :func:`straighten` may move."""
    for table in tables:
        for g in table:
            if isinstance(g, Analytic) and g.kind in STRAIGHT_KINDS and g.frame.shape[1] == 3:
                if np.isfinite(g.frame).all():
                    yield g.frame[1:]


def same_directions(tables: Iterable[list[Geometry]]) -> dict[bytes, np.ndarray]:
    """Directions that are one within the source's precision, and the one each
    becomes (issue 28 §1: "directions that the source has equal within its
    precision coded once and kept equal").

    Every direction row of the analytic records of ``tables`` (SURF and CRV3:
    a circle shares its cylinder's axis) is straightened (:func:`_straight`)
    and compared with the directions kept so far, in table order: one whose
    components are all within ``SAME`` of a kept one's (or of its negation)
    becomes that one (negated), bit for bit; otherwise it is kept.  A part
    rotated off the world's axes holds each of its few directions in a dozen
    variants some 1e-12 apart (the rounding of STEP's text and of OCCT's
    frames), which LZMA codes as different floats.  Keys are the straightened
    rows' bytes; a row not in the map stays."""
    kept = np.zeros((0, 3))
    out: dict[bytes, np.ndarray] = {}
    for d in _frames(tables):
        s = _straight(d)
        if s is None:
            continue
        for row in s + 0.0:
            key = row.tobytes()
            if key in out:
                continue
            near = np.flatnonzero(np.abs(kept - row).max(-1, initial=0.0) <= SAME)
            flip = np.flatnonzero(np.abs(kept + row).max(-1, initial=0.0) <= SAME)
            if len(near):
                hit = kept[near[0]]
            elif len(flip):
                hit = -kept[flip[0]]
            else:
                kept = np.vstack([kept, row])
                hit = row
            out[key] = hit + 0.0
            out[(-row + 0.0).tobytes()] = -hit + 0.0
    return out


def straighten(
    g: Geometry, reach: float, tol: float, same: dict[bytes, np.ndarray] | None = None
) -> tuple[Analytic, float] | None:
    """``g`` with the components of its directions (every frame row but the
    origin) of magnitude at most ``NOISE`` set to 0 and each direction scaled
    back to unit length, then each made the direction ``same`` maps it to
    (:func:`same_directions`), and the bound of that move; None where nothing
    changes or the bound passes ``STRAIGHT_SHARE`` x tol.

    A point of the record is o + Σ c_k d_k with |c_k| ≤ |p − o| (the d_k
    orthonormal), so it moves by at most |p − o| · Σ |Δd_k| for fixed
    parameters; OCCT rebuilds a frame's Y direction from its main and X
    directions (and an X direction off the plane normal to the main one onto
    that plane), which moves it by at most their two moves: twice the sum of
    the stored rows' moves covers it.  ``reach`` bounds |p − o| over the
    faces or edges the record bounds (:func:`reaches`)."""
    if not isinstance(g, Analytic) or g.kind not in STRAIGHT_KINDS or g.frame.shape[1] != 3:
        return None
    d = g.frame[1:]
    s = _straight(d)
    if s is None:
        return None
    s = s + 0.0  # never -0.0
    if same:
        s = np.array([same.get(row.tobytes(), row) for row in s])
    if np.array_equal(s, d):
        return None
    bound = 2.0 * reach * float(np.sqrt(((s - d) ** 2).sum(-1)).sum())
    if not bound <= STRAIGHT_SHARE * tol:
        return None
    frame = g.frame.copy()
    frame[1:] = s
    return replace(g, frame=frame), bound


def _far_curve(g: Geometry, o: np.ndarray, t: np.ndarray, curves: list[Geometry]) -> float:
    """The largest distance from ``o`` of a point of 3-D curve ``g`` over the
    parameters ``t`` = (first, last) (inf where unknown)."""
    if isinstance(g, Derived) and g.kind == Kind.TRIMMED_CURVE:
        return _far_curve(curves[g.basis], o, t, curves)
    if isinstance(g, BSplineCurve) and g.poles.shape[1] == 3:
        return float(np.sqrt(((g.poles - o) ** 2).sum(-1)).max())  # in the poles' hull
    if isinstance(g, Analytic) and g.frame.shape[1] == 3:
        if g.kind == Kind.LINE:
            ends = g.frame[0] + np.outer(t, g.frame[1])
            return float(np.sqrt(((ends - o) ** 2).sum(-1)).max())
        if g.kind in (Kind.CIRCLE, Kind.ELLIPSE):
            return float(np.sqrt(((g.frame[0] - o) ** 2).sum()) + g.params[0])
    return math.inf


def _boundary_reach(
    m: BRepModel,
    s: int,
    mat: Callable[[int], np.ndarray],
    o: np.ndarray,
    curve_of: dict[int, tuple[int, np.ndarray, int]],
    tidx: list[int],
    types: list[int],
) -> float:
    """The largest distance from ``o`` (homogeneous, in face shape ``s``'s own
    frame) of a point of the face's boundary (inf where unknown); ``tidx``
    and ``types`` are ``m.type_index()`` and ``m.shape_type`` as lists."""
    start, child, loc = m.child_start, m.child_shape, m.child_loc
    far, seen = 0.0, False
    wire, edge = int(ShapeType.WIRE), int(ShapeType.EDGE)
    for i in range(start[s], start[s + 1]):
        w = int(child[i])
        if types[w] != wire:
            continue
        for j in range(start[w], start[w + 1]):
            e = int(child[j])
            k = tidx[e]
            if types[e] != edge:
                continue
            seen = True
            place = mat(int(loc[i])) @ mat(int(loc[j]))  # the edge in the face
            hit = curve_of.get(k)
            if hit is not None and hit[0] >= 0:  # o where the curve's points are
                at = np.linalg.solve(place @ mat(hit[2]), o)[:3]
                far = max(far, _far_curve(m.curves3d[hit[0]], at, hit[1], m.curves3d))
            elif hit is not None and m.edge_flags[k] & 1:  # degenerated: its vertices
                for a in range(start[e], start[e + 1]):
                    v = int(child[a])
                    at = np.linalg.solve(place @ mat(int(loc[a])), o)[:3]
                    far = max(far, float(np.sqrt(((m.vertex_point[tidx[v]] - at) ** 2).sum())))
            else:
                return math.inf
    return far if seen else math.inf  # no boundary: nothing bounds the face


def reaches(m: BRepModel) -> tuple[dict[int, float], dict[int, float]]:
    """Per analytic surface row and 3-D curve row of ``m`` that
    :func:`straighten` may move, a bound of |p − o| over its points in use (o
    its origin): ``(surface rows, curve rows)``.

    A circle's or ellipse's is its (major) radius.  A line's is the largest
    |t| over the edge ranges that use it.  A surface's is three times the
    largest distance from o of its faces' boundaries (each edge's 3-D curve:
    a line's segment, a conic's circle around its centre, a B-spline's poles):
    a plane face lies in the hull of its boundary; on a cylinder, cone, sphere
    or torus a face's points are at most two radii further out than its
    boundary's, and a radius there is at most the boundary's distance from o.
    A face's edges are measured in its surface's frame (through the locations
    of the face and of the curves; none may lie between the face and its
    edges).  Rows used in any other way (a basis of a derived record, an edge
    without a 3-D curve) are left out.
    """
    kinds = STRAIGHT_KINDS

    # the analytic rows under offsets and sweeps, through trims (an offset's
    # basis may be an offset too)
    under_s = (Kind.TRIMMED_SURFACE, Kind.OFFSET_SURFACE)
    under_c = (Kind.TRIMMED_CURVE, Kind.OFFSET_CURVE)
    used_s: set[int] = set()
    used_c: set[int] = set()
    lines: dict[int, float] = {}
    for g in m.surfaces:
        if isinstance(g, Derived) and g.kind == Kind.OFFSET_SURFACE:
            used_s.add(resolve_row(m.surfaces, g.basis, under_s))
        elif isinstance(g, Derived) and g.kind in SWEPT_KINDS:
            used_c.add(resolve_row(m.curves3d, g.basis, under_c))
    for g in m.curves3d:
        if isinstance(g, Derived) and g.kind == Kind.TRIMMED_CURVE:  # points of its basis
            lines[g.basis] = max(lines.get(g.basis, 0.0), float(np.abs(g.params[:2]).max()))
        elif isinstance(g, Derived):
            used_c.add(resolve_row(m.curves3d, g.basis, under_c))
    reps = m.edge_reps
    curve_of: dict[int, tuple[int, np.ndarray, int]] = {}
    for q in np.flatnonzero(reps[:, EC.KIND] == RepKind.CURVE3D).tolist():
        c, e = int(reps[q, EC.CURVE]), int(reps[q, EC.EDGE])
        t = m.edge_rep_range[q]
        curve_of[e] = (c, t, int(reps[q, EC.LOC]))
        if c >= 0:  # a line's points are |t| from its origin, wherever it is placed
            lines[c] = max(lines.get(c, 0.0), float(np.abs(t).max()))
    curves: dict[int, float] = {}
    for c, g in enumerate(m.curves3d):
        if c in used_c or not isinstance(g, Analytic) or g.kind not in kinds:
            continue
        if g.kind == Kind.LINE:
            if c in lines:
                curves[c] = lines[c]
        else:
            curves[c] = float(g.params[0])
    far_s: dict[int, float] = {}
    mats: dict[int, np.ndarray] = {}

    def mat(i: int) -> np.ndarray:
        if i not in mats:
            mats[i] = joins.location_matrix(m, i)
        return mats[i]

    tidx, types = m.type_index().tolist(), m.shape_type.tolist()
    for f, s in enumerate(np.flatnonzero(m.shape_type == ShapeType.FACE).tolist()):
        r = resolve_row(m.surfaces, int(m.face_surface[f]), (Kind.TRIMMED_SURFACE,))
        base = m.surfaces[r]
        if not isinstance(base, Analytic) or base.kind not in kinds or r in used_s:
            continue
        if base.kind == Kind.SPHERE:  # every point is one radius from the centre
            far = float(base.params[0])
        else:
            far = 3.0 * _boundary_reach(
                m,
                s,
                mat,
                mat(int(m.face_loc[f])) @ np.r_[base.frame[0], 1.0],  # o in the face's frame
                curve_of,
                tidx,
                types,
            )
        far_s[r] = max(far_s.get(r, 0.0), far)
    surfaces = {r: x for r, x in far_s.items() if math.isfinite(x)}
    return surfaces, curves
