"""The model the decoder will rebuild from a model's codes (docs/design.md §2, ``encode/``).

:func:`assemble` puts the *decoded* poles of every coded record into the
model's tables, leaving a chosen set of records exact, and does what the
decoder does after it: vertices snapped to the vertex grid, curve ends and net
corners pinned to them, copies of coincident curves and joined sides made, and
edge and vertex tolerances widened by the coding error around them.
"""

from __future__ import annotations

import collections
import functools
import math
from collections.abc import Set
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from .. import codec
from ..model import (
    EC,
    REBUILD,
    VC,
    Analytic,
    BRepModel,
    BSplineCurve,
    BSplineSurface,
    Derived,
    Geometry,
    Kind,
    PointRepKind,
    Rec,
    RepKind,
    ShapeType,
    Table,
    below,
    faces_around,
    first_row,
    records,
)
from ..rules import joins
from ..serialize import SWEPT
from ..serialize.vertices import TWIN_EXP, twin_offset
from . import analytic, coincide, knots, nets, offsets
from .nets import TRIM_C, TRIM_S, Coded, feature_limit, first_rows, poles_of, resolve_row


@dataclass
class LossyReport:
    """What the search chose.

    Attributes
    ----------
    face_method : list of str
        Per face (model order): ``"spatial"``, ``"boundary"`` (the paper's "no
        difference data"), ``"ddmap"``, ``"dmap"``, ``"boundary3"`` and
        ``"ddmap3"`` (with the bicubic Coons net), ``"swept"`` (a swept surface whose
        curve was coded), or ``"exact"``.
    face_bound : ndarray, shape (F,)
        Certified bound per face (0 for exact faces).
    edge_bound : ndarray, shape (E,)
        Certified bound of each edge's 3-D curve.
    surface_bits, curve_bits : float
        Estimated bits of the coded nets (before the entropy stage).
    surface_poles, curve_poles : int
        Poles of the coded nets.
    """

    face_method: list[str]
    face_bound: np.ndarray
    edge_bound: np.ndarray
    surface_bits: float
    surface_poles: int
    curve_bits: float
    curve_poles: int
    #: the analytic records put on their grids (:func:`_snap_analytic`)
    gridded: frozenset[Rec] = frozenset()
    #: vertices snapped beside a curve kept exact (``SNAP_ON_EXACT``): the
    #: first to stay where they were when a face around them faults
    loose_v: frozenset[int] = frozenset()
    #: the planes and cylinders through a vertex (:func:`_surfaces_through`)
    through_s: frozenset[Rec] = frozenset()
    #: edges whose stored pcurves were re-approximated (``pcurves.compact_kept``)
    compacted: frozenset[int] = frozenset()

    def method_counts(self) -> dict[str, int]:
        return dict(collections.Counter(self.face_method))


def assemble(
    m: BRepModel,
    coded: Coded,
    exact: set[Rec | None] = frozenset(),  # type: ignore[assignment]
    still: set[int] = frozenset(),  # type: ignore[assignment]
    grid: bool = True,
    plain: Set[Rec] = frozenset(),
) -> tuple[BRepModel, dict[Rec, codec.NetCode], LossyReport]:
    """:func:`_assembled`; where a pin or a joined side took a row coded to
    the refined bound past its limit (:func:`_past_limits`), the rows to
    blame are coded again with the pole bound (:func:`nets.rigid`, in
    ``coded``, so later candidates start from them) and the model is
    assembled again; where the pole bound still leaves a row past tol,
    tighter (:func:`_closer`).  (A row held to a feature's limit below tol
    that ends past that limit but within tol is left so.)"""
    while True:
        out = _assembled(m, coded, exact | coded.held, still, grid, plain)
        if nets.rigid(coded, m, _past_limits(m, coded, out[1])):
            continue
        if not _closer(m, coded, _past_limits(m, coded, out[1], coded.tol)):
            return out


#: A row still past tol once coded with the pole bound is coded
#: ``nets.TIGHTER`` times tighter, up to this many times (:func:`nets.tighten`'s
#: levels), and then held exact (``coded.held``).
PAST_TIGHTER = 2


def _closer(m: BRepModel, coded: Coded, past: set[Rec]) -> bool:
    """The rows of ``past`` (past tol) already coded with the pole bound,
    coded tighter (their vertices then stay where they are), else held
    exact; whether any changed.

    A pin sets a net's corner to a vertex within its grid step, and the
    vertex may itself move by its snap: a plain code (:func:`nets.plain`)
    of a net whose first code was clear of a vertex can reach it, and the
    pole bound does not cover that.  A tighter code has a finer grid, and
    its corners no longer reach a vertex past its limit.
    """
    changed = False
    for k in sorted(past - coded.held, key=lambda r: (r.table, r.row)):
        done = coded.surfaces if k.table == Table.SURFACE else coded.curves
        if k not in done or k not in coded.rigid:
            continue
        level = coded.tight.get(k, 0) + 1
        if level <= PAST_TIGHTER:
            nets.tighten(coded, m, [k], level)
            if coded.tight.get(k, 0) == level:
                changed = True
                continue
        coded.held.add(k)
        changed = True
    return changed


def _past_limits(
    m: BRepModel, coded: Coded, codes: dict[Rec, codec.NetCode], cap: float | None = None
) -> set[Rec]:
    """The coded records to code again with the pole bound: those whose
    final bound is past the limit they were coded to (a copy's: its own
    :func:`feature_limit`; with ``cap``, past ``cap`` instead), or for a
    copy (an iso-boundary curve, a twin curve) and a surface with joined
    sides, the rows it copies."""
    srec, crec = records(m.surfaces, Table.SURFACE), records(m.curves3d, Table.CURVE3D)
    leaders: dict[Rec, list[Rec]] = collections.defaultdict(list)
    for (b, _), ((a, _), _) in coded.sides.items():
        leaders[srec[b]].append(srec[a])
    out: set[Rec] = set()
    for k, code in codes.items():
        g = (m.surfaces if k.table == Table.SURFACE else m.curves3d)[k.row]
        if cap is not None:
            limit = cap
        elif code.limit is not None:
            limit = code.limit
        else:
            limit = feature_limit(poles_of(g), coded.tol)
        if not code.bound > limit:
            continue
        if code.method == codec.Method.ISO:
            out.add(srec[coded.iso[k][0]])
        elif code.method == codec.Method.COPY:
            out.add(crec[coded.twins[k][0]])
        else:
            out.add(k)
            out.update(leaders.get(k, ()))
    return out


def _assembled(
    m: BRepModel,
    coded: Coded,
    exact: set[Rec | None],
    still: set[int],
    grid: bool,
    plain: Set[Rec],
) -> tuple[BRepModel, dict[Rec, codec.NetCode], LossyReport]:
    """The model the decoder will rebuild when every coded record but ``exact`` is used,
    and every vertex that may move (:func:`_snap_vertices`) but the rows in ``still``;
    with ``grid``, analytic records on their grids (:func:`_snap_analytic`), and
    planes and cylinders but ``plain`` through a vertex (:func:`_surfaces_through`).

    Returns
    -------
    decoded : BRepModel
        Shares unchanged tables with ``m``; tolerances widened.
    codes : dict
        ``record -> NetCode`` for the container (the records of ``decoded``'s
        tables, which are those of ``m``'s: a row is replaced where its
        record's first row is).
    report : LossyReport
    """
    codes: dict[Rec, codec.NetCode] = {}
    srec, crec = records(m.surfaces, Table.SURFACE), records(m.curves3d, Table.CURVE3D)

    def swap(
        table: list[Geometry], recs: list[Rec], done: dict[Rec, tuple[codec.NetCode, Geometry]]
    ) -> list[Geometry]:
        out = []
        for k, g in zip(recs, table):
            hit = done.get(k) if k not in exact else None
            if hit is None:
                out.append(g)
            else:
                codes[k] = hit[0]
                out.append(hit[1])
        return out

    # a boundary coded once is exact on every side or on none: an exact copy's
    # leader is exact too
    exact = exact | {crec[r] for k, (r, _) in coded.twins.items() if k in exact}
    while True:
        more = {srec[a] for (b, _), ((a, _), _) in coded.sides.items() if srec[b] in exact}
        more -= exact
        if not more:
            break
        exact = exact | more
    surfaces = swap(m.surfaces, srec, coded.surfaces)
    curves = swap(m.curves3d, crec, coded.curves)
    at_vertex = frozenset(m.vertex_point.reshape(-1).tolist()) if grid else None
    if coded.reach is None:
        coded.reach = analytic.reaches(m)
    reach_s, reach_c = coded.reach
    if coded.same is None:
        coded.same = analytic.same_directions((m.surfaces, m.curves3d))
    snap = functools.partial(_snap_analytic, tol=coded.tol, at_vertex=at_vertex, same=coded.same)
    snapped, gridded = snap(surfaces, srec, exact, reach=reach_s)
    curve_moves, curves_gridded = snap(curves, crec, exact, reach=reach_c)
    snapped.update(curve_moves)
    gridded |= curves_gridded
    source = m
    m, moved_v, loose_v, bound_v = _snap_vertices(m, coded, surfaces, curves, codes, exact, still)
    _anchor_curves(source, m, coded, curves, codes)
    # planes and cylinders first: a circle through a vertex takes its cylinder's axis
    threaded = _surfaces_through(
        source, m, surfaces, srec, exact | set(plain), coded.tol, reach_s, coded.same
    )
    through_s = frozenset(threaded)
    threaded.update(_thread(source, m, surfaces, curves, crec, exact, coded.tol, coded.vlead))
    snapped.update(threaded)  # the record's bound replaces its grid's: it is a new record
    gridded |= set(threaded)  # the validity ladder's first rung leaves it as it was
    _pin_surfaces(m, surfaces, codes, coded.tol)
    side_joins = _join_sides(m, coded, surfaces, codes)
    _copy_iso(m, coded, surfaces, curves, codes, exact)
    _pin_curves(m, curves, codes, coded.tol)
    _copy_twins(m, coded, curves, codes, exact)
    bound_of = {k: c.bound for k, c in codes.items()}
    bound_of.update(snapped)

    def curve_bound(i: int) -> float:
        return 0.0 if i < 0 else bound_of.get(crec[resolve_row(curves, i, TRIM_C)], 0.0)

    face_bound = np.zeros(len(m.face_surface))
    face_method = []
    for f, row in enumerate(m.face_surface.tolist()):
        r = resolve_row(surfaces, row, TRIM_S)
        b = surfaces[r]
        if srec[r] in codes:
            face_bound[f] = codes[srec[r]].bound
            face_method.append(codes[srec[r]].method.name.lower())
        elif srec[r] in snapped:
            face_bound[f] = snapped[srec[r]]
            face_method.append("analytic")
        elif isinstance(b, Derived) and b.kind in SWEPT:
            # sweeping is an isometry of each curve point: the surface moves as the curve
            face_bound[f] = curve_bound(b.basis)
            face_method.append("swept" if face_bound[f] > 0 else "exact")
        elif isinstance(b, Derived) and b.kind == Kind.OFFSET_SURFACE and srec[b.basis] in codes:
            # an offset moves by more than its basis's poles (encode.offsets)
            d = float(b.params[0])
            box = offsets.face_box(source, b.basis)
            face_bound[f] = offsets.moved(source.surfaces[b.basis], surfaces[b.basis], d, box)
            face_method.append(codes[srec[b.basis]].method.name.lower())
        else:
            face_method.append("exact")
    reps = m.edge_reps
    edge_bound = np.zeros(len(m.edge_tol))
    for q in np.flatnonzero(reps[:, EC.KIND] == RepKind.CURVE3D).tolist():
        edge_bound[reps[q, EC.EDGE]] = max(
            edge_bound[reps[q, EC.EDGE]], curve_bound(int(reps[q, EC.CURVE]))
        )
    # a snapped vertex's tolerance covers the grid's bound, not its own move:
    # one value for all (their codes repeat), and the same at every vertex
    # (tol/2 on the vertex grid, far less on the fine grid of _fine_points)
    cover = np.where(moved_v > 0, np.maximum(moved_v, bound_v), 0.0)
    out = _widen_tolerances(m, face_bound, edge_bound, cover)
    out.surfaces, out.curves3d = surfaces, curves
    out.side_joins = side_joins
    sc = [codes[k] for k in dict.fromkeys(srec) if k in codes]
    cc = [codes[k] for k in dict.fromkeys(crec) if k in codes]
    report = LossyReport(
        face_method,
        face_bound,
        edge_bound,
        sum(c.bits for c in sc),
        sum(int(np.prod(poles_of(g).shape[:-1])) for k, g in zip(srec, surfaces) if k in codes),
        sum(c.bits for c in cc),
        sum(len(poles_of(g)) for k, g in zip(crec, curves) if k in codes),
        frozenset(gridded),
        frozenset(np.flatnonzero(loose_v & (moved_v > 0)).tolist()),
        through_s,
    )
    return out, codes, report


def _snap_analytic(
    table: list[Geometry],
    recs: list[Rec],
    exact: set[Rec | None],
    tol: float,
    at_vertex: frozenset[float] | None,
    reach: dict[int, float],
    same: dict[bytes, np.ndarray],
) -> tuple[dict[Rec, float], set[Rec]]:
    """Straighten every analytic record of ``table`` but ``exact`` whose rows
    all have a ``reach`` (:func:`.analytic.straighten`, its directions made
    the ones ``same`` maps them to), and with
    ``at_vertex`` put it on its grid (:func:`.analytic.quantize`), in place
    at every row of it; per record moved, its bound (the sum), and the records
    put on a grid.  Straightening alone does not make a record gridded (the
    validity ladder's first rung takes gridded records off their grids;
    straightened ones go exact only with their faces).  An origin
    coordinate in ``at_vertex`` (a vertex's coordinate, bit for bit) stays
    as it is: the container holds that value anyway (VERT), and its entropy
    coder finds the repeat (on featuretype at 0.01 mm, 413 of the 438
    coordinates of line origins are; snapping them cost 270 bytes)."""
    out: dict[Rec, float] = {}
    gridded: set[Rec] = set()
    if tol <= 0:
        return out, gridded
    rows = _Rows(table)
    far: dict[Rec, float] = {}
    for i, k in enumerate(recs):
        far[k] = max(far.get(k, 0.0), reach.get(i, math.inf))
    for i, k in enumerate(recs):
        if k.row != i or k in exact:
            continue
        g, bound = table[i], 0.0
        line = analytic.straighten(g, far[k], tol, same) if math.isfinite(far[k]) else None
        if line is not None:
            g, bound = line
        hit = None if at_vertex is None else analytic.quantize(g, tol, at_vertex)
        if hit is not None:
            g, bound = hit[0], bound + hit[1]
            gridded.add(k)
        if g is not table[i]:
            rows.replace(i, g)
            out[k] = bound
    return out, gridded


#: Seam lines go through their vertices too (a hole's cylinder or a cone: the
#: decoder computes both pcurves on the closed surface).  Nine generated
#: plates at 0.01 mm: 17,190 -> 15,362 bytes; 153 generated seam parts -0.6%.
SEAM_LINES = True

#: Lines go through twin vertices too where every vertex of each cluster is at
#: one point to within 2**(TWIN_EXP - 1) mm (OCCT's own IGES surface models,
#: whose faces each have their own edges): the twin lines then lie on one
#: another within that distance, and sewing keeps them joined.  Circles, and
#: clusters further apart (bearing.iges's twins, 1e-9 to 7e-8 mm apart, which
#: opened free edges), stay as they are: circles through such vertices made a
#: filleted box's surface model lose its joins in the STEP re-read.  67 IGES
#: surface models (stress seed 7 and generated parts): 57,893 -> 54,846 bytes
#: at 0.1 mm, none larger by more than a byte.
TWIN_LINES = True


def _apart_twins(p: np.ndarray, lead: np.ndarray, twin: np.ndarray) -> np.ndarray:
    """The ``twin`` vertices whose cluster (``lead``) has a vertex at
    2**(TWIN_EXP - 1) mm or more from its first, in some coordinate."""
    if not twin.any():
        return twin
    off = np.abs(p - p[lead]).max(1, initial=0.0)
    split = np.zeros(len(p), bool)
    split[lead[off >= 2.0 ** (TWIN_EXP - 1)]] = True
    return twin & split[lead]


def _thread(
    source: BRepModel,
    m: BRepModel,
    surfaces: list[Geometry],
    curves: list[Geometry],
    crec: list[Rec],
    exact: set[Rec | None],
    tol: float,
    lead: np.ndarray,
) -> dict[Rec, float]:
    """Lines that go through their edge's vertices (format 2.2) and circles
    through their edge's vertex about their face's axis (2.4), which the
    container holds as a kind code alone (``joins.through_vertices`` makes
    them from the decoded vertices and surfaces), in place in ``curves``,
    with their edges' ranges set to what the vertices give on them (a range
    rule); per record, its bound.

    A curve qualifies where it is an unlocated 3-D curve of its edges (a
    line: of one edge), its record has no other row, no other record (a
    swept surface, a trimmed or offset curve) and no vertex's point
    representation refers to it, its edges are no seams (a line's may be:
    ``SEAM_LINES``) and have a FORWARD
    and a REVERSED unlocated vertex (a line's distinct), none of them a twin
    (a vertex of a cluster ``lead``: a surface model whose faces each have
    their own edges, where the coincident curve of the next face is a record
    of its own; on bearing.iges such lines opened free edges in the STEP
    re-read and made the file grow with the tolerance; a line's may be twins
    where each cluster is at one point: ``TWIN_LINES``), their faces lie on
    planes, quadrics or B-spline surfaces, and the new curve stays within
    tol of the source's (the bounds of :func:`_line_through` and
    :func:`_circle_through`).  A
    pcurve the candidate keeps is parameterized on the source curve:
    :func:`unthread` puts such a curve back."""
    out: dict[Rec, float] = {}
    if not tol > 0:
        return out
    reps = m.edge_reps
    use = joins.curve_uses(m)
    based = {g.basis for g in source.curves3d if isinstance(g, Derived)}
    based |= {g.basis for g in source.surfaces if isinstance(g, Derived) and g.kind in SWEPT}
    vr = source.vertex_reps
    based |= set(vr[vr[:, VC.KIND] == PointRepKind.ON_CURVE, VC.CURVE].tolist())
    seams = set(reps[reps[:, EC.KIND] == RepKind.ON_CLOSED_SURFACE, EC.EDGE].tolist())
    nv = len(m.vertex_tol)
    twin = np.bincount(lead, minlength=nv)[lead] > 1 if len(lead) == nv else np.zeros(nv, bool)
    line_twin = _apart_twins(source.vertex_point, lead, twin) if TWIN_LINES else twin
    # faces on a plane, quadric or B-spline surface (an offset or swept one
    # projects the new line's pcurves less well: analytic_offset_cylinder_17 of
    # the stress corpus faulted in BRepCheck and fell back to exact)
    plain = {
        f
        for f, r in enumerate(m.face_surface.tolist())
        if isinstance(m.surfaces[r], Analytic | BSplineSurface)
    }
    faces_of = faces_around(m, ShapeType.EDGE)
    table = joins.end_vertices(m)
    rows = _Rows(curves)
    axes: dict[int, int] | None = None
    copied = False
    for i, k in enumerate(crec):
        g, was = curves[i], source.curves3d[i]
        if k.row != i or k in exact or len(rows.rows[rows.first[i]]) != 1 or i in based:
            continue
        if not (isinstance(g, Analytic) and isinstance(was, Analytic) and g.kind == was.kind):
            continue
        if g.kind not in (Kind.LINE, Kind.CIRCLE) or was.frame.shape[1:] != (3,):
            continue
        qs = use.get(i, [])
        if not qs or (g.kind == Kind.LINE and len(qs) != 1):
            continue
        ends = []
        for q in qs:
            e = int(reps[q, EC.EDGE])
            seam = e in seams and (g.kind != Kind.LINE or not SEAM_LINES)
            if reps[q, EC.LOC] != 0 or seam or any(f not in plain for f in faces_of[e]):
                break
            two = joins.edge_ends(table, e)
            held = line_twin if g.kind == Kind.LINE else twin
            if len(two) != 2 or held[[two[joins.FORWARD], two[joins.REVERSED]]].any():
                break
            ends.append((two[joins.FORWARD], two[joins.REVERSED]))
        if len(ends) != len(qs):
            continue
        if g.kind == Kind.LINE:
            made = _line_through(m, was, source.edge_rep_range[qs[0]], ends[0])
        else:
            if axes is None:
                axes = joins.axis_faces(m, surfaces)
            f = axes.get(int(reps[qs[0], EC.EDGE]))
            if f is None:
                continue
            made = _circle_through(m, was, surfaces[int(m.face_surface[f])], qs, ends, source)
        if made is None or not made[1] <= tol or not joins.within_reach(made[0]):
            continue
        new, bound, spans = made
        rows.replace(i, new)
        if not copied:  # the candidate's own ranges from here on
            m.edge_rep_range, copied = m.edge_rep_range.copy(), True
        for q, span in zip(qs, spans):
            m.edge_rep_range[q] = span
        out[k] = bound
    return out


def _surfaces_through(
    source: BRepModel,
    m: BRepModel,
    surfaces: list[Geometry],
    srec: list[Rec],
    exact: set[Rec | None],
    tol: float,
    reach: dict[int, float],
    same: dict[bytes, np.ndarray],
) -> dict[Rec, float]:
    """Planes and cylinders whose origin comes from a vertex of their first
    face (format 2.7, ``joins.face_points``, ``joins.surface_origin``),
    which the container holds as a kind code, the directions and a
    cylinder's radius, in place in ``surfaces``; per record, its bound.

    A record qualifies where no other record (an offset or trimmed surface)
    and no vertex's (u, v) refers to any row of it, its first face gives a
    vertex, and the bound (over every face on it: ``reach``) is within tol.
    Moving the origin within a plane, or along a cylinder's axis, changes only the surface's
    parameters, which no pcurve the decoder computes depends on; a pcurve
    the candidate keeps does, and :func:`unthread` puts the source's record
    back under it.  The directions are the straightened ones
    (:func:`.analytic.straighten`), the vertex is as decoded, a cylinder's
    radius the source's, and its axis is taken against the one of its X, Y,
    −X, −Y directions nearest the vertex.  The bound, R bounding |p − o|
    over the face (``reach``): a plane's point p is |n'·(p − v')| from the
    new plane, at most R·|n' − n| (within the straightening's bound) plus
    |n'·(o − v')|; a cylinder's point is as far from the new surface as the
    axes are apart near it, at most the part of o' − o across d, plus
    |o' − o|·|d' − d| and R·|d' − d| (within the straightening's bound)."""
    out: dict[Rec, float] = {}
    if not tol > 0:
        return out
    based = {g.basis for g in source.surfaces if isinstance(g, Derived) and g.kind not in SWEPT}
    vr = source.vertex_reps
    based |= set(vr[vr[:, VC.KIND] != PointRepKind.ON_CURVE, VC.SURFACE].tolist())
    at = joins.face_points(m)
    rows = _Rows(surfaces)
    for i, k in enumerate(srec):
        was = source.surfaces[i]
        if k.row != i or k in exact or i not in at or set(rows.rows[i]) & based:
            continue
        if not (isinstance(was, Analytic) and was.kind in joins.THROUGH_SURFACES):
            continue
        if was.through or was.frame.shape != (4, 3) or not np.isfinite(was.frame).all():
            continue
        r = max(reach.get(j, math.inf) for j in rows.rows[i])
        st = analytic.straighten(was, r, tol, same) if math.isfinite(r) else None
        g, bound = st if st is not None else (was, 0.0)
        v = m.vertex_point[at[i]]
        o, d = was.frame[0], was.frame[1]
        if was.kind == Kind.PLANE:
            new = Analytic(Kind.PLANE, g.frame.copy(), np.zeros(0), through=1)
        else:
            w = v - o
            w = w - float(w @ d) * d
            q = int(np.argmax([w @ g.frame[2], w @ g.frame[3], -w @ g.frame[2], -w @ g.frame[3]]))
            new = Analytic(Kind.CYLINDER, g.frame.copy(), was.params.copy(), through=q + 1)
        new.frame[0] = joins.surface_origin(new, v)
        if not joins.within_reach(new):
            continue  # the reader would refuse it
        shift = new.frame[0] - o
        if was.kind == Kind.PLANE:
            bound += abs(float(new.frame[1] @ shift))
        else:
            across = shift - float(shift @ d) * d
            bound += float(np.linalg.norm(across))
            bound += float(np.linalg.norm(shift)) * float(np.linalg.norm(new.frame[1] - d))
        if not bound <= tol:
            continue
        rows.replace(i, new)
        out[k] = bound
    return out


def _line_through(
    m: BRepModel, was: Analytic, t: np.ndarray, ends: tuple[int, int]
) -> tuple[Analytic, float, list[tuple[float, float]]] | None:
    """The line through an edge's (snapped) vertices, its bound and the
    edge's range on it: the larger distance, at either end, from the vertex
    to the source line's point at the edge's range end (the segments between
    match point for point within that)."""
    a, b = m.vertex_point[ends[0]], m.vertex_point[ends[1]]
    frame = joins.line_through(a, b)
    if frame is None:
        return None
    was_ends = was.frame[0] + np.outer(t, was.frame[1])
    dev = float(np.sqrt(((np.array([a, b]) - was_ends) ** 2).sum(-1)).max())
    new = Analytic(Kind.LINE, frame, np.zeros(0), through=1)
    return new, dev, [(joins.on_line(new, a), joins.on_line(new, b))]


def _circle_through(
    m: BRepModel,
    was: Analytic,
    axis: Geometry,
    qs: list[int],
    ends: list[tuple[int, int]],
    source: BRepModel,
) -> tuple[Analytic, float, list[tuple[float, float]]] | None:
    """The circle through the first edge's FORWARD (snapped) vertex about
    ``axis`` (``joins.circle_through``), its normal on the source's side, its
    bound and the edges' ranges on it.

    The bound: map each point c' + r'u' of the new circle to c + r·ũ on the
    source circle, ũ the unit projection of u' on the source's plane. That
    moves it by at most sqrt(a² + (p + |r' - r|)²) + 2r'·|n - n'| (a and p
    the axial and radial parts of the centres' distance, n and n' the
    normals; |u' - ũ| ≤ |n - n'|, counted twice for the projection), and
    takes each new arc onto an arc of the source circle whose ends the
    bound adds, measured (the arcs run the same way, and their angles
    differ by under 0.5 rad, so neither is the other's complement)."""
    assert isinstance(axis, Analytic)
    c, n, x = was.frame[0], was.frame[1], was.frame[2]
    sense = 1 if float(n @ axis.frame[1]) > 0 else -1
    new = joins.circle_through(axis, m.vertex_point[ends[0][0]], sense)
    if new is None:
        return None
    r, r2 = float(was.params[0]), float(new.params[0])
    c2, n2 = new.frame[0], new.frame[1]
    d = c2 - c
    axial = float(d @ n)
    radial = float(np.linalg.norm(d - axial * n))
    move = math.hypot(axial, radial + abs(r2 - r)) + 2 * r2 * float(np.linalg.norm(n - n2))
    y = np.array(joins.cross(n.tolist(), x.tolist()))
    y2 = np.array(joins.cross(n2.tolist(), new.frame[2].tolist()))
    y2 /= np.linalg.norm(y2)

    def on_source(t: float) -> np.ndarray:
        return c + r * (math.cos(t) * x + math.sin(t) * y)

    def mapped(t: float) -> np.ndarray:
        u = math.cos(t) * new.frame[2] + math.sin(t) * y2
        u = u - float(u @ n) * n
        return c + r * u / np.linalg.norm(u)

    spans, gap = [], 0.0
    for q, (fa, fb) in zip(qs, ends):
        t0, t1 = (float(t) for t in source.edge_rep_range[q])
        span = joins.circle_range(new, m.vertex_point[fa], m.vertex_point[fb], fa == fb)
        if not abs((span[1] - span[0]) - (t1 - t0)) < 0.5:
            return None
        gap = max(
            gap,
            float(np.linalg.norm(mapped(span[0]) - on_source(t0))),
            float(np.linalg.norm(mapped(span[1]) - on_source(t1))),
        )
        spans.append(span)
    return new, move + gap, spans


def unthread(cand: BRepModel, source: BRepModel) -> BRepModel:
    """``cand`` with the source's record back wherever a plane or cylinder
    through a vertex (:func:`_surfaces_through`) holds a stored pcurve, and
    the source's curve and its edges' 3-D ranges back wherever a curve
    through vertices (:func:`_thread`) is on an edge that keeps a stored
    pcurve (parameterized on the source curve) or, for a circle, takes its
    axis from a cylinder put back (the decoder would make it about the
    source's axis)."""
    reps = cand.edge_reps
    pcurve = np.isin(reps[:, EC.KIND], (RepKind.ON_SURFACE, RepKind.ON_CLOSED_SURFACE))
    stored = pcurve & (reps[:, EC.CURVE] != REBUILD)
    held = set(reps[stored, EC.SURFACE].tolist())
    put = [
        i
        for i, g in enumerate(cand.surfaces)
        if i in held and isinstance(g, Analytic) and g.through
    ]
    if put:
        cand = replace(cand)
        cand.surfaces = list(cand.surfaces)
        for i in put:
            cand.surfaces[i] = source.surfaces[i]
    kept = set(reps[stored, EC.EDGE].tolist())
    moved = {i for i in put if cand.surfaces[i].kind == Kind.CYLINDER}
    axes = joins.axis_faces(cand) if moved else {}

    def axis_moved(q: int) -> bool:
        """Whether the circle on representation ``q`` takes a cylinder put back."""
        f = axes.get(int(reps[q, EC.EDGE]))
        return f is not None and int(cand.face_surface[f]) in moved

    back = [
        q
        for i, qs in joins.curve_uses(cand).items()
        if i >= 0 and isinstance(g := cand.curves3d[i], Analytic) and g.through
        if any(int(reps[q, EC.EDGE]) in kept for q in qs)
        or (g.kind == Kind.CIRCLE and axis_moved(qs[0]))
        for q in qs  # every edge on it: their ranges are on the new curve
    ]
    if not back:
        return cand
    out: Any = replace(cand)
    out.curves3d = list(cand.curves3d)
    out.edge_rep_range = cand.edge_rep_range.copy()
    for q in back:
        i = int(reps[q, EC.CURVE])
        out.curves3d[i] = source.curves3d[i]
        out.edge_rep_range[q] = source.edge_rep_range[q]
    return out


#: Vertices on exact curves (lines, circles, B-splines kept exact) snap too:
#: such a curve does not follow its vertex, and the vertex's tolerance is
#: widened by how far it moved (:func:`_widen_tolerances`).
SNAP_ON_EXACT = True


def _snap_vertices(
    m: BRepModel,
    coded: Coded,
    surfaces: list[Geometry],
    curves: list[Geometry],
    codes: dict[Rec, codec.NetCode],
    exact: set[Rec | None],
    still: set[int],
) -> tuple[BRepModel, np.ndarray, np.ndarray, np.ndarray]:
    """``m`` with its vertices on the vertex grid where every edge at the vertex
    has an unlocated 3-D curve, the others on a fine grid (:func:`_fine_points`),
    how far each vertex moved, which may go back (loose), and the bound its
    tolerance covers.

    The coded (or iso-copied) curves are then pinned to the snapped vertex,
    and so are the corners of the nets around it, so everything that meets
    there still meets; a curve kept exact (a line, a circle, an exact
    B-spline; with ``SNAP_ON_EXACT``) stays, and the vertex's tolerance
    covers the gap, unless its point is short (:func:`_short`).  A vertex
    on a degenerated edge or a located curve, on a
    feature smaller than tol (``coded.fine``), or that would land where
    another vertex lands (:func:`_merging`) stays.  Last, per vertex,
    whether a curve at it stays exact.
    """
    loose = np.zeros(len(m.vertex_tol), bool)
    if not len(coded.vgrid):
        return m, np.zeros(len(m.vertex_tol)), loose, np.zeros(len(m.vertex_tol))
    tidx = m.type_index()
    curve_of: dict[int, int] = {}
    reps = m.edge_reps
    for q in np.flatnonzero(reps[:, EC.KIND] == RepKind.CURVE3D).tolist():
        curve_of[int(reps[q, EC.EDGE])] = int(reps[q, EC.CURVE]) if reps[q, EC.LOC] == 0 else -1
    srec, crec = records(m.surfaces, Table.SURFACE), records(m.curves3d, Table.CURVE3D)
    ok = np.ones(len(m.vertex_tol), bool)
    trails = np.zeros(len(m.vertex_tol), bool)  # beside a curve that stays where it is
    scale = np.full(len(m.vertex_tol), coded.tol)  # the finest feature limit at each vertex
    for e, s in enumerate(np.flatnonzero(m.shape_type == ShapeType.EDGE).tolist()):
        c = curve_of.get(e, -1)
        follows = c >= 0 and (
            crec[c] in codes
            or (
                crec[c] in coded.iso
                and crec[c] not in exact
                and srec[coded.iso[crec[c]].surface] in codes
            )
        )
        # a copy of a coded coincident curve follows its leader's vertices,
        # which a twin cluster's move takes along (each twin at its offset)
        leader = coded.twins.get(crec[c]) if c >= 0 else None
        copy = leader is not None and crec[c] not in exact and crec[leader[0]] in codes
        moving = follows or copy or (c >= 0 and SNAP_ON_EXACT and leader is None)
        if c >= 0 and not follows:
            for v in below(m, s, ShapeType.VERTEX):
                loose[tidx[v]] = True
                trails[tidx[v]] |= not copy
        if not moving or crec[c] in coded.fine:
            for v in below(m, s, ShapeType.VERTEX):
                ok[tidx[v]] = False
        if c >= 0 and crec[c] in coded.fine:
            lim = feature_limit(poles_of(m.curves3d[c]), coded.tol)
            for v in below(m, s, ShapeType.VERTEX):
                scale[tidx[v]] = min(scale[tidx[v]], lim)
    for f, s in enumerate(np.flatnonzero(m.shape_type == ShapeType.FACE).tolist()):
        r = resolve_row(m.surfaces, int(m.face_surface[f]), TRIM_S)
        if srec[r] in coded.fine:
            lim = feature_limit(poles_of(m.surfaces[r]), coded.tol)
            for v in below(m, s, ShapeType.VERTEX):
                ok[tidx[v]] = False
                scale[tidx[v]] = min(scale[tidx[v]], lim)
    held = np.zeros(len(ok), bool)  # kept where they are by the validity ladder
    held[sorted(still)] = True
    ok &= ~held
    ok &= ~(loose & _short(m.vertex_point))
    if (ok & loose).sum() < MIN_LOOSE:  # too few to pay for their grid integers
        ok &= ~loose
    lead = coded.vlead if len(coded.vlead) == len(ok) else np.arange(len(ok))
    snaps = ok.copy()
    ok &= ~_merging(m.vertex_point[lead], coded.vgrid)
    at_grid = _twin_points(m.vertex_point, lead, coded.vgrid)
    ok &= _kept_apart(m.vertex_point, at_grid, lead)
    ok &= ~np.isin(lead, lead[~ok])  # a cluster moves as one or stays
    p = m.vertex_point
    fine, at_fine, fine_bound = _fine_levels(p, lead, ~ok & ~trails & ~held, scale, coded.tol)
    # Those that would snap but for a vertex they would land on (a sliver
    # edge where a chamfer meets a fillet) round finer instead, however few
    # and beside whatever curve: snapped they would have moved further.
    crowded = snaps & ~ok & ~fine & ~held
    if crowded.any():
        moved_fine = np.where(fine[:, None], at_fine, p)
        more, at_more, more_bound = _fine_levels(moved_fine, lead, crowded, scale, coded.tol, 1)
        fine, at_fine = fine | more, np.where(more[:, None], at_more, at_fine)
        fine_bound = np.where(more, more_bound, fine_bound)
    # Not the validity ladder's held vertices, nor the twins at their point
    # (moved even this little, bearing.iges fell back to every record exact,
    # 75 kB, and ec_turbine and trj7 at 0.1 mm too); the rest of a held
    # vertex's cluster moves about its first where that is not held.
    stay = held | np.isin(_point_ids(p), _point_ids(p)[held])
    micro, at_micro, micro_bound = _fine_points(
        p, lead, ~ok & ~fine & ~(stay & (lead == np.arange(len(p)))), coded.tol, MICRO_BITS
    )
    micro &= ~stay
    at_micro = np.where(micro[:, None], at_micro, p)
    micro &= _kept_apart(p, at_micro, lead)
    at_micro = np.where(micro[:, None], at_micro, p)
    # the other clusters stay, their twins' offsets rounded to what format 2.5 stores
    at_twin = _twin_points(p, lead, p)
    # (a twin that stays stays bit for bit; the others of its cluster need not)
    twin = ~ok & ~fine & ~micro & ~stay & _kept_apart(p, at_twin, lead)
    out: Any = replace(m)
    out.vertex_point = p
    bound = np.zeros(len(p))
    for which, at, b in (
        (twin, at_twin, _twin_slack(at_twin)),
        (micro, at_micro, micro_bound),
        (fine, at_fine, fine_bound),
        (ok, at_grid, coded.tol / 2 + _twin_slack(at_grid)),
    ):
        out.vertex_point = np.where(which[:, None], at, out.vertex_point)
        bound = np.where(which, b, bound)
    moved = np.sqrt(((out.vertex_point - p) ** 2).sum(-1))
    return out, moved, loose | fine | micro | twin, bound


#: A vertex that stays off the vertex grid is rounded to the binary grid
#: 2**(floor(log2 tol) - FINE_BITS) instead (:func:`_fine_points`).
FINE_BITS = 10
#: Where the finest feature at a vertex leaves room (:func:`_fine_levels`),
#: the grid is 2**(floor(log2 tol) - COARSE_BITS): 4 bits a coordinate fewer.
COARSE_BITS = 6
#: ... room: the features' limits (``nets.feature_limit``) at the vertex are
#: at least this many times the coarse grid's bound.
COARSE_ROOM = 16.0
#: A vertex that would stay where it is (beside a curve kept exact, or
#: below a finer feature) is rounded to 2**(floor(log2 tol) - MICRO_BITS)
#: still: a move under tol·5e-8 (below OCCT's confusion distance, 1e-7 mm,
#: for any tol up to 1 mm) that leaves 24 zero bits.  Not the vertices the
#: validity ladder holds (:func:`_snap_vertices`).
MICRO_BITS = 24
#: Fewer vertices than this to round stay where they are all: each saves a
#: few bytes, and what follows them (pinned ends, widened tolerances) can
#: cost as much (bearing.iges, 5 of them: 0.1 mm came out 2 bytes above
#: 0.01 mm).
MIN_FINE = 16


def _fine_levels(
    p: np.ndarray,
    lead: np.ndarray,
    may: np.ndarray,
    scale: np.ndarray,
    tol: float,
    least: int = MIN_FINE,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Which vertices of ``may`` move to a binary grid (:func:`_fine_points`),
    the points there, and each one's bound: the coarse grid of
    :data:`COARSE_BITS` where ``scale`` (per vertex, the finest feature limit
    of the coded rows at it, at most tol) is at least :data:`COARSE_ROOM`
    times that grid's bound, the fine grid of :data:`FINE_BITS` for the rest
    (a part whose features are all finer than tol, as a bearing 0.1 mm
    across, keeps today's grid).  The fine pass sees the coarse vertices
    where they went, so no vertex lands on another."""
    coarse = 2.0 ** (np.floor(np.log2(tol)) - COARSE_BITS) * np.sqrt(3.0) / 2
    room = may & (scale >= COARSE_ROOM * coarse)
    fine, at, b = _fine_points(p, lead, room, tol, COARSE_BITS, least)
    moved = np.where(fine[:, None], at, p)
    finer, at_finer, b_finer = _fine_points(moved, lead, may & ~fine, tol, FINE_BITS, least)
    at = np.where(finer[:, None], at_finer, moved)
    return fine | finer, at, np.where(fine, b, np.where(finer, b_finer, 0.0))


def _fine_points(
    p: np.ndarray,
    lead: np.ndarray,
    may: np.ndarray,
    tol: float,
    bits: int = FINE_BITS,
    least: int = MIN_FINE,
) -> tuple[np.ndarray, np.ndarray, float]:
    """Which vertices of ``may`` move to a fine binary grid, the points there,
    and the bound on the move.

    A vertex that stays off the vertex grid (on a feature finer than tol, or
    beside a neighbour it would land on) still need not keep all 52 bits:
    its coordinates rounded to a multiple of ``2**k``, ``k = floor(log2 tol)
    - bits``, move it by at most ``2**k * sqrt(3) / 2``
    (under tol/1000 for :data:`FINE_BITS`), which its tolerance covers like a snapped vertex's
    move (the curves pinned to it follow; for ``FINE_BITS`` the caller leaves out a vertex
    beside a curve that does not follow, whose tolerance alone would cover the
    gap: a filleted box lost 1.6e-6 mm³ of volume at 0.001 mm; for
    :data:`MICRO_BITS`, a move under tol·5e-8, it need not), and end
    in zero bits that the entropy stage codes for next to nothing (the reader
    takes the floats as they are: no format change).

    Twin vertices (a cluster of ``lead``: faces-mode IGES gives every face its
    own) move as one: the cluster's first vertex to the grid, the others by
    the same translation, so that they keep their offsets (rounded apart they
    would open gaps; rounded together, a STEP reader takes them for one
    vertex), each rounded to what format 2.5 stores (:func:`_twin_points`).
    A cluster moves only
    if every vertex of it may, it lands on no other cluster's point, the
    clusters within TWIN_VERTEX of each other stay the same, and its twins
    stay distinct or equal as they were; none moves where fewer than
    ``least`` (:data:`MIN_FINE`) would, or where a coordinate is past ``2**52`` steps.
    """
    none = np.zeros(len(p), bool)
    if not (tol > 0) or not may.any():
        return none, p, 0.0
    step = 2.0 ** (np.floor(np.log2(tol)) - bits)
    first = p[lead]
    grid = np.rint(first / step) * step
    at = _twin_points(p, lead, grid)
    fine = may & (np.abs(first) < 2.0**52 * step).all(-1)
    fine &= ~_merging(first, grid)  # clusters that land on one point from different places
    fine &= ~np.isin(lead, lead[~fine])  # a cluster moves as one or stays
    # twins equal before are equal after, distinct stay distinct
    same = (p == first).all(-1)
    fine &= ~np.isin(lead, lead[same != (at == grid).all(-1)])
    fine &= _kept_apart(p, at, lead)
    was = coincide.vertex_clusters(p, coincide.TWIN_VERTEX)
    for _ in range(3):  # the points within TWIN_VERTEX of each other stay so
        q = np.where(fine[:, None], at, p)
        moved_to = coincide.vertex_clusters(q, coincide.TWIN_VERTEX)
        changed = moved_to != was
        if not changed.any():
            break
        fine &= ~np.isin(lead, lead[changed | np.isin(moved_to, moved_to[changed])])
    else:
        return none, p, 0.0
    if fine.sum() < least or _distinct(p[fine]) != _distinct(at[fine]):
        return none, p, 0.0
    return fine, at, float(step * np.sqrt(3.0) / 2 + _twin_slack(at[fine]))


def _twin_points(p: np.ndarray, lead: np.ndarray, base: np.ndarray) -> np.ndarray:
    """Where the vertices go when each cluster's first vertex goes to its
    row of ``base``: each twin at its offset from the first, rounded to a
    multiple of 2**TWIN_EXP (format 2.5 stores it as that multiple, a few
    bits where a float offset cost six bytes: ``serialize.vertices``), and
    never rounded onto its first if it was apart from it."""
    off = p - p[lead]
    k = np.rint(np.ldexp(off, -TWIN_EXP))
    lost = (k == 0).all(-1) & (off != 0).any(-1)
    if lost.any():  # apart it stays: one step along its largest component
        big = np.argmax(np.abs(off[lost]), axis=1)
        k[np.flatnonzero(lost), big] = np.sign(off[lost, big])
    k[~np.isfinite(k) | (np.abs(k) >= 2.0**52)] = 0
    home = base[lead]
    return np.where((k == 0).all(-1)[:, None], home, twin_offset(home, k.astype(np.int64)))


def _twin_slack(at: np.ndarray) -> float:
    """What :func:`_twin_points` adds to a cluster's move: the offset's
    rounding to 2**TWIN_EXP, and an ulp of the sum."""
    ulp = float(np.spacing(np.abs(at).max())) if len(at) else 0.0
    return float(2.0**TWIN_EXP * np.sqrt(3.0) / 2 + 2 * ulp)


def _kept_apart(p: np.ndarray, at: np.ndarray, lead: np.ndarray) -> np.ndarray:
    """Per vertex, whether its cluster has as many distinct points at ``at``
    as at ``p`` (no two twins rounded onto one point)."""
    if not len(p):
        return np.zeros(0, bool)
    before = np.unique(np.column_stack([lead, p]), axis=0)[:, 0]
    after = np.unique(np.column_stack([lead, at]), axis=0)[:, 0]
    n = int(lead.max()) + 1
    same = np.bincount(before.astype(np.int64), minlength=n) == np.bincount(
        after.astype(np.int64), minlength=n
    )
    return same[lead]


def _point_ids(points: np.ndarray) -> np.ndarray:
    """Per row of ``points``, an id shared by the rows at the same point, bit for bit."""
    if not len(points):
        return np.zeros(0, np.int64)
    _, inv = np.unique(points.view(np.int64), axis=0, return_inverse=True)
    return inv.ravel().astype(np.int64)


def _distinct(points: np.ndarray) -> int:
    """The number of distinct rows of ``points``."""
    return len(np.unique(points, axis=0)) if len(points) else 0


#: Fewer vertices than this snapped beside exact curves stay where they are
#: all: their grid integers cost more than the floats they replace (trj5 at
#: 0.01 mm, 6 of them: +27 bytes).
MIN_LOOSE = 32

#: A coordinate with at least this many trailing zero bits (of 52) is short:
#: a float that costs less than its grid integer once compressed.
SHORT_BITS = 24


def _short(p: np.ndarray) -> np.ndarray:
    """Per point (rows of ``p``), whether every coordinate is a short float
    (``SHORT_BITS`` trailing zero bits or more: 25.0, 31.75; not 0.1), which
    costs less than its grid integer.  A vertex at such a point beside a
    curve kept exact stays where it is (on bracket.step every vertex is;
    snapped, the file grew by 8%)."""
    bits = p.view(np.int64) & ((1 << SHORT_BITS) - 1)
    return (bits == 0).all(-1)


def _merging(exact: np.ndarray, snapped: np.ndarray) -> np.ndarray:
    """Vertices that would land on the same grid point as a vertex at another place.

    Distinct vertices at one point are one vertex to a STEP reader (measured on
    an IGES file of one shell per face: 925 vertices came back as 678), so
    such vertices keep their place.
    """
    out = np.zeros(len(exact), bool)
    if not len(exact):
        return out
    _, group = np.unique(snapped, axis=0, return_inverse=True)
    group = group.ravel()
    _, first = np.unique(group, return_index=True)
    differs = (exact != exact[first[group]]).any(-1)  # not where its group's first vertex is
    bad_groups = np.unique(group[differs])
    out[np.isin(group, bad_groups)] = True
    return out


class _Rows:
    """A geometry table whose records are replaced everywhere they are used
    (the rows that share a record keep sharing its replacement, so the
    table's records keep their first rows), with an index of the rows of
    each record: one pass over the table, not one per replacement."""

    def __init__(self, table: list[Geometry]) -> None:
        self.table = table
        self.first = first_row(table)
        self.rows: dict[int, list[int]] = {}
        for i, r in enumerate(self.first):
            self.rows.setdefault(r, []).append(i)

    def replace(self, row: int, new: Geometry) -> None:
        """Put ``new`` at every row of the record at ``row``."""
        for i in self.rows[self.first[row]]:
            self.table[i] = new


def _pin_surfaces(
    m: BRepModel, surfaces: list[Geometry], codes: dict[Rec, codec.NetCode], tol: float
) -> None:
    """Apply :func:`joins.surface_corner_pins` as the decoder will, raising bounds."""
    rows = _Rows(surfaces)
    recs = records(surfaces, Table.SURFACE)
    radius = joins.pin_radii(recs, codes, tol)
    for r, pins in joins.surface_corner_pins(
        m, surfaces, first_rows(codes, Table.SURFACE), tol, radius
    ).items():
        old, original = surfaces[r], m.surfaces[r]
        assert isinstance(old, BSplineSurface) and isinstance(original, BSplineSurface)
        new, moved = _certified(
            replace(old, poles=joins.pinned_corners(m, old, pins)), original, tol
        )
        code = codes.pop(recs[r])
        codes[recs[r]] = replace(code, bound=max(code.bound, moved))
        rows.replace(r, new)


def _copy_iso(
    m: BRepModel,
    coded: Coded,
    surfaces: list[Geometry],
    curves: list[Geometry],
    codes: dict[Rec, codec.NetCode],
    exact: set[Rec | None],
) -> None:
    """Curves that are a coded surface's boundary become copies of the decoded boundary."""
    rows = _Rows(curves)
    srec, crec = records(surfaces, Table.SURFACE), records(curves, Table.CURVE3D)
    for c, g in enumerate(m.curves3d):
        src = coded.iso.get(crec[c])
        if src is None or crec[c] in exact or curves[c] is not g:
            continue
        r, side, rev, _ = src
        if srec[r] not in codes:
            continue  # the surface is exact, and so is its boundary: the curve as it is
        assert isinstance(g, BSplineCurve)
        lead = surfaces[r]
        assert isinstance(lead, BSplineSurface)
        poles = joins.boundary(lead.poles, side, bool(rev)).copy()
        w = (
            None
            if lead.weights is None
            else joins.boundary(lead.weights[..., None], side, bool(rev))
        )
        degree = lead.udegree if side >= 2 else lead.vdegree
        if not g.bezier:  # the side's knots and degree, rounded, removed or lowered
            kn, mu = joins.side_knots(lead, side, bool(rev))  # with the surface's
            g = replace(g, knots=kn, mults=mu, degree=degree)
        elif degree != g.degree:  # a Bezier side of a lowered surface
            g = replace(g, degree=degree, mults=np.array([degree + 1, degree + 1]))
        source = m.curves3d[c]
        assert isinstance(source, BSplineCurve)
        new, bound = _follow(source, poles, None if w is None else w[:, 0], coded.tol, g)
        ints = np.array([r, side, rev], np.int64)
        code = codec.NetCode(codec.Method.ISO, codec.Quant.TOL, 0, 0, ints, np.zeros(0), bound, 0.0)
        codes[crec[c]] = replace(code, first=poles[0].copy())
        rows.replace(c, new)


def _certified(new: Any, original: Any, tol: float) -> tuple[Any, float]:
    """``new`` (a row of ``original``, its poles moved) and its certified bound
    (:func:`knots.moved`); with ``original``'s weights back where its rounded
    ones would take it past its limit (a pin or a joined side moved its
    poles further than its code did)."""
    bound = knots.moved(new, original)
    if (
        original.weights is not None
        and new.poles.shape == original.poles.shape
        and bound > feature_limit(original.poles, tol)
    ):
        new = replace(new, weights=original.weights)
        bound = knots.moved(new, original)
    return new, bound


def _follow(
    g: BSplineCurve,
    poles: np.ndarray,
    w: np.ndarray | None,
    tol: float,
    like: BSplineCurve | None = None,
) -> tuple[BSplineCurve, float]:
    """Curve ``g`` (the source's) with ``poles`` copied from what it follows, and
    the weights of what it follows, ``w``, when they are ``g``'s rounded
    (:mod:`.weights`) and leave it within its limit, so that the two stay one
    curve; else its own weights (:func:`_certified`).  With its certified bound.
    ``like`` is ``g`` with the knots of what it follows (:mod:`.knots`)."""
    new = replace(like if like is not None else g, poles=poles)
    if w is not None and g.weights is not None and len(w) == len(poles):
        new = replace(new, weights=w.copy())  # a side with knots removed: its weights
    return _certified(new, g, tol)


def _join_sides(
    m: BRepModel, coded: Coded, surfaces: list[Geometry], codes: dict[Rec, codec.NetCode]
) -> np.ndarray:
    """Set each coded net's twin sides to their leaders' (as the decoder does after
    the corner pins); the rows of ``BRepModel.side_joins``, shape (J, 5)."""
    rows, table = [], _Rows(surfaces)
    recs = records(surfaces, Table.SURFACE)
    for (b, j), ((a, i), rev) in sorted(coded.sides.items()):
        old, original = surfaces[b], m.surfaces[b]
        if recs[b] not in codes:
            continue  # exact: its leader is exact too (see assemble)
        assert isinstance(old, BSplineSurface) and isinstance(original, BSplineSurface)
        row = np.array([b, j, a, i, rev], np.int64)
        joined = replace(old, poles=joins.joined_sides(old, surfaces[a], row))  # type: ignore[arg-type]
        new, moved = _certified(joined, original, coded.tol)
        code = codes.pop(recs[b])
        codes[recs[b]] = replace(code, bound=max(code.bound, moved))
        table.replace(b, new)
        rows.append(row)
    return np.array(rows, np.int64).reshape(-1, 5)


#: How far (in ulps of the vector's span) a copy's knots may be from its
#: leader's mapped onto its ends for the copy to take the mapped ones.
NEAR_KNOTS = 64


def _near_knots(k: np.ndarray, mults: np.ndarray, g: BSplineCurve) -> bool:
    """Whether the knots ``k`` and multiplicities ``mults`` are ``g``'s own
    within :data:`NEAR_KNOTS` ulps of its span (and not bit for bit)."""
    if len(k) != len(g.knots) or not np.array_equal(mults, g.mults):
        return False
    span = float(g.knots[-1] - g.knots[0])
    gap = float(np.abs(k - g.knots).max(initial=0.0))
    return 0.0 < gap <= NEAR_KNOTS * float(np.finfo(float).eps) * span


def _copy_twins(
    m: BRepModel,
    coded: Coded,
    curves: list[Geometry],
    codes: dict[Rec, codec.NetCode],
    exact: set[Rec | None],
) -> None:
    """Curves coincident with a coded curve become copies of its final (decoded
    and pinned) poles (``Method.COPY``; :func:`coincide.twin_curves`), as the
    decoder makes them after the pins.  A copy is not pinned itself: it
    coincides with its leader, ends included.  A copy that would move further
    than its limit (a leader that is a coded surface's boundary, coded to the
    surface's limit) stays exact."""
    rows = _Rows(curves)
    crec = records(curves, Table.CURVE3D)
    for c, g in enumerate(m.curves3d):
        twin = coded.twins.get(crec[c])
        if twin is None or crec[c] in exact or curves[c] is not g:
            continue
        r, rev = twin
        if crec[r] not in codes:
            continue  # the leader is exact: so is this curve, as it is
        assert isinstance(g, BSplineCurve)
        leader = curves[r]
        assert isinstance(leader, BSplineCurve)
        poles = (leader.poles[::-1] if rev else leader.poles).copy()
        t = joins.copy_matrix(coded.where, c, r)
        if t is not None:  # the two edges sit in frames of their own
            poles = joins.placed(poles, t)
        w = None if leader.weights is None else leader.weights[::-1] if rev else leader.weights
        was = m.curves3d[r]
        assert isinstance(was, BSplineCurve)
        like = None
        if not (g.bezier or leader.bezier):
            # the leader's knots were rounded (:mod:`.knots`) or, where it is a
            # surface's side, removed with the surface's (:mod:`.removal`), or
            # they map onto the copy's within a few ulps (an IGES surface
            # model's twin running the other way): the copy takes them,
            # mapped onto its own ends as the two were in the source, with
            # their multiplicities (a mapped knot vector, format 2.17)
            mults = leader.mults[::-1] if rev else leader.mults
            lk = knots.mapped(leader.knots, g.knots, bool(rev))
            if not _same_knots(leader, was) or _near_knots(lk, mults, g):
                like = replace(g, knots=lk, mults=mults.copy())
        new, bound = _follow(g, poles, w, coded.tol, like)
        if bound > feature_limit(g.poles, coded.tol):
            continue
        ints = np.array([c - r, rev], np.int64)  # the leader as an offset from this row
        code = codec.NetCode(
            codec.Method.COPY, codec.Quant.TOL, 0, 0, ints, np.zeros(0), bound, 0.0
        )
        codes[crec[c]] = code
        rows.replace(c, new)


def _pin_curves(
    m: BRepModel, curves: list[Geometry], codes: dict[Rec, codec.NetCode], tol: float
) -> None:
    """Apply :func:`joins.curve_end_pins` as the decoder will, raising each pinned curve's bound."""
    pins = joins.curve_end_pins(m, curves, first_rows(codes, Table.CURVE3D), tol)
    rows = _Rows(curves)
    recs = records(curves, Table.CURVE3D)
    for c, places in pins.items():
        old = curves[c]
        assert isinstance(old, BSplineCurve)
        original = m.curves3d[c]
        assert isinstance(original, BSplineCurve)
        new, moved = _certified(
            replace(old, poles=joins.pinned_poles(m, old, places)), original, tol
        )
        code = codes.pop(recs[c])
        codes[recs[c]] = replace(code, bound=max(code.bound, moved))
        rows.replace(c, new)


#: Whether curves are coded between their vertices where that is cheaper
#: (format 2.10, :func:`_anchor_curves`).
ANCHOR_CURVES = True


def _anchor_curves(
    source: BRepModel,
    m: BRepModel,
    coded: Coded,
    curves: list[Geometry],
    codes: dict[Rec, codec.NetCode],
) -> None:
    """Code again between its two anchors (``codec.Method.ANCHORED``, format
    2.10), in place in ``curves`` and ``codes``, each coded curve whose ends
    the decoder pins to its edge's two vertices (:func:`joins.anchors` on
    ``m``, whose vertices are where the container puts them), where that
    costs fewer bits (:func:`codec.cost_bits`) than its code, re-based on the
    same vertices as the container will store it.

    A ``CHORD`` code's ends are on its grid, coded against the vertices: a
    vertex snapped to the vertex grid (or rounded) is a grid point of another
    step, so they cost bits, and the pins then move them onto the vertices
    anyway.  An ``ANCHORED`` code's ends are the vertices: no integers (a
    2-pole curve costs nothing), its bound counting the vertices' moves.  Its
    limit is the code's own (``NetCode.limit``), and ``source`` (the model
    before any vertex moved) gives the row it is coded from.  The codes are
    kept in ``coded.anchored`` by the anchors' bits: later candidates whose
    vertices stay reuse them.
    """
    if not ANCHOR_CURVES:
        return
    rows_of: dict[Rec, list[int]] = collections.defaultdict(list)
    for i, k in enumerate(records(curves, Table.CURVE3D)):
        rows_of[k].append(i)
    mine = {k.row: k for k in codes if k.table == Table.CURVE3D}
    rows = {r for r, k in mine.items() if codes[k].method in codec.CURVE_METHODS}
    for row, a in joins.anchors(m, curves, rows).items():
        if a.ndim != 2:
            continue
        k = mine[row]
        code = codes[k]
        if code.limit is None:
            continue
        key = (k, a.tobytes(), code.limit)
        if key not in coded.anchored:
            g = source.curves3d[row]
            assert isinstance(g, BSplineCurve)
            try:
                hit = nets.recode(coded, k, g, (codec.Method.ANCHORED,), a, code.limit)
            except codec.NoCodeError:
                hit = None
            coded.anchored[key] = hit
        hit = coded.anchored[key]
        if hit is None or not _same_knots(hit[1], curves[row]):
            continue
        if hit[0].bits < codec.cost_bits(codec.reorigin(code, a, coded.tol).ints):
            codes[k] = hit[0]
            for i in rows_of[k]:
                curves[i] = hit[1]


def _same_knots(a: Geometry, b: Geometry) -> bool:
    """Whether two B-spline curves have the same knots and multiplicities
    (the anchors of :func:`joins.anchors` follow from them)."""
    assert isinstance(a, BSplineCurve) and isinstance(b, BSplineCurve)
    return np.array_equal(a.knots, b.knots) and np.array_equal(a.mults, b.mults)


#: BRepCheck measures an edge's distance to its surfaces with a 5% margin
#: (BRepLib_ValidateEdge); tolerances are widened by the bound times this.
MARGIN = 1.1


def _widen_tolerances(
    m: BRepModel, face_bound: np.ndarray, edge_bound: np.ndarray, moved_v: np.ndarray
) -> BRepModel:
    """A copy of ``m`` whose edge and vertex tolerances cover the coding errors.

    An edge's 3-D curve moved by its curve's bound and each of its surfaces by
    their faces' bounds, so its curve-to-surface distances grow by at most their
    sum; a vertex's distance to the ends of its curves and pcurves by at most
    the largest of them.
    """
    tidx = m.type_index()
    faces = np.flatnonzero(m.shape_type == ShapeType.FACE)
    edges = np.flatnonzero(m.shape_type == ShapeType.EDGE)
    extra_e = np.zeros(len(m.edge_tol))
    extra_v = np.zeros(len(m.vertex_tol))
    for f, s in enumerate(faces.tolist()):
        b = face_bound[f]
        if b <= 0:
            continue
        for e in below(m, s, ShapeType.EDGE):
            extra_e[tidx[e]] = max(extra_e[tidx[e]], b)
    for k, s in enumerate(edges.tolist()):
        reach = max(extra_e[k], edge_bound[k])
        extra_e[k] += edge_bound[k]
        if reach > 0:
            for v in below(m, s, ShapeType.VERTEX):
                extra_v[tidx[v]] = max(extra_v[tidx[v]], reach)
    extra_v += moved_v  # a snapped vertex is that much further from what it sat on
    out: Any = replace(m)
    out.edge_tol = np.where(extra_e > 0, round_up(m.edge_tol + MARGIN * extra_e), m.edge_tol)
    out.vertex_tol = np.where(extra_v > 0, round_up(m.vertex_tol + MARGIN * extra_v), m.vertex_tol)
    return out


def round_up(x: np.ndarray) -> np.ndarray:
    """The smallest power of 2 ≥ x (x > 0): a widened tolerance needs no more
    precision than that, and a few distinct values cost next to nothing (on
    the corpus at 0.01 mm, EDGE's and VERT's tolerance codes took
    some 1,800 bytes less than as powers of 2^(1/4))."""
    k = np.ceil(np.log2(x))
    y = np.exp2(k)
    return np.where(y >= x, y, np.exp2(k + 1))
