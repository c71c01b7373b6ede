"""Tolerance mode on a whole model: code every B-spline net and curve, keep the B-rep valid.

:func:`code_model` runs the per-net search of :mod:`nurbscomp.codec` once on
each distinct B-spline surface and 3-D B-spline curve.  :func:`assemble`
builds the model the decoder will rebuild from those codes, leaving a chosen
set of records exact: the same tables with the *decoded* poles, and edge and
vertex tolerances widened by the coding error of the curves and faces around
them.  :func:`drop_pcurves` leaves pcurves for the decoder to compute.  The
loop that decides what stays exact, checking the rebuilt B-rep with OCCT, is
``pipeline._lossy_target``.

Still exact in this version: vertices, analytic geometry, the pcurves the
decoder cannot rebuild, and B-splines under an offset (an offset of a moved
geometry can move by more than its poles did).
"""

from __future__ import annotations

import collections
from dataclasses import dataclass, field, replace
from typing import Any, cast

import numpy as np

from . import codec, joins, serialize
from .model import (
    REBUILD,
    BRepModel,
    BSplineCurve,
    BSplineSurface,
    Derived,
    Geometry,
    Kind,
    RepKind,
    ShapeType,
    below,
    faces_around,
)
from .serialize import SWEPT, net_abscissae, net_basis


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

    def method_counts(self) -> dict[str, int]:
        return dict(collections.Counter(self.face_method))


def _resolve(table: list[Geometry], i: int, through: tuple[Kind, ...]) -> Geometry:
    """The record under row ``i``, following the bases of ``through`` kinds."""
    g = table[i]
    while isinstance(g, Derived) and g.kind in through:
        g = table[g.basis]
    return g


def _offset_bases(table: list[Geometry], offset: Kind, through: tuple[Kind, ...]) -> set[int]:
    """Ids of records under an offset: they must stay exact (an offset of a
    moved geometry moves by more than the poles did)."""
    out: set[int] = set()
    for g in table:
        if isinstance(g, Derived) and g.kind == offset:
            b = table[g.basis]
            while True:
                out.add(id(b))
                if isinstance(b, Derived) and b.kind in (*through, offset):
                    b = table[b.basis]
                else:
                    break
    return out


@dataclass
class Coded:
    """Every codable record of a model, coded once: ``id(original) -> (code, decoded)``."""

    surfaces: dict[int, tuple[codec.NetCode, Geometry]]
    curves: dict[int, tuple[codec.NetCode, Geometry]]
    tol: float
    #: id(curve) -> (surface row, side, reversed): copied from a decoded surface
    iso: dict[int, tuple[int, int, int]] = field(default_factory=dict)
    #: every vertex snapped to the vertex grid (used where all its edges' curves are
    #: coded): its cluster's first vertex's grid point (:func:`joins.vertex_clusters`)
    vgrid: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    #: ids of coded records held to a limit below tol (:func:`feature_limit`, :func:`tighten`)
    fine: set[int] = field(default_factory=set)
    #: ids of records coded again, tighter, and how many times (:func:`tighten`)
    tight: dict[int, int] = field(default_factory=dict)
    #: id(curve) -> (leader row, reversed): a copy of a coincident curve
    #: (:func:`joins.twin_curves`), not coded itself
    twins: dict[int, tuple[int, int]] = field(default_factory=dict)
    #: (surface row, side) -> ((leader row, side), reversed): a side set to the
    #: leader's decoded side (:func:`joins.twin_sides`)
    sides: dict[tuple[int, int], tuple[tuple[int, int], int]] = field(default_factory=dict)
    #: curve row -> its placement in the model's frame (:func:`joins.curve_placements`)
    where: dict[int, np.ndarray] = field(default_factory=dict)
    #: per vertex, the first vertex of its cluster
    vlead: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))


#: A coded net moves by at most this fraction of its size (:func:`feature_limit`).
FEATURE_FRACTION = 0.25


def _polyline(p: np.ndarray) -> np.ndarray:
    """Lengths of the polylines along the first axis of ``p`` (..., n, dim) -> (...)."""
    return np.sqrt((np.diff(p, axis=-2) ** 2).sum(-1)).sum(-1)


def feature_limit(poles: np.ndarray, tol: float) -> float:
    """The bound a net is coded to: tol, or less on a feature smaller than tol.

    A curve's size is its control polygon's length; a surface's, the shorter of
    its longest u- and v-rows of poles.  A net moves by at most
    ``FEATURE_FRACTION`` of its size (and at least tol/1024): a face whose
    edges are shorter than tol would otherwise be coded out of shape, and a
    STEP reader re-projecting its edges adds or drops edges there (measured
    on an IGES file whose 213 faces have edges of 2-10 µm, at tol 10 µm).
    """
    if poles.ndim == 3:
        size = min(_polyline(np.swapaxes(poles, 0, 1)).max(), _polyline(poles).max())
    else:
        size = float(_polyline(poles))
    return float(np.clip(FEATURE_FRACTION * size, tol / 1024, tol))


def _code_one(
    g: BSplineSurface | BSplineCurve,
    tol: float,
    methods: tuple[codec.Method, ...],
    paper: bool,
    origin: np.ndarray | None,
    limit: float,
) -> tuple[codec.NetCode, Geometry]:
    """One record's code (:func:`codec.encode_net`) and the record as decoded."""
    s, t = net_abscissae(g)
    basis = net_basis(g)
    code = codec.encode_net(
        g.poles,
        s,
        t,
        tol,
        methods,
        paper=paper,
        origin=origin,
        basis=basis,
        limit=limit,
    )
    net, _ = codec.decode_net(code, g.poles.shape, s, t, tol, origin, basis)
    return replace(code, first=net.reshape(-1, net.shape[-1])[0]), replace(g, poles=net)


def _code_table(
    table: list[Geometry],
    tol: float,
    keep: set[int],
    methods: tuple[codec.Method, ...],
    paper: bool,
    anchors: dict[int, np.ndarray] | None = None,
    limits: dict[int, float] | None = None,
) -> dict[int, tuple[codec.NetCode, Geometry]]:
    """Code each distinct B-spline record of ``table`` (see :func:`code_model`);
    ``anchors`` maps record ids to :func:`joins.anchors` points, ``limits``
    to a limit below :func:`feature_limit`'s."""
    out: dict[int, tuple[codec.NetCode, Geometry]] = {}
    origin = None
    for g in table:
        if id(g) in out or id(g) in keep or not isinstance(g, (BSplineSurface, BSplineCurve)):
            continue
        at = (anchors or {}).get(id(g), origin)
        limit = feature_limit(g.poles, tol)
        limit = min(limit, (limits or {}).get(id(g), limit))
        out[id(g)] = _code_one(g, tol, methods, paper, at, limit)
        origin = out[id(g)][0].first
    return out


#: A record a STEP reader mends (``pipeline._lossy_target``) is coded again,
#: this many times tighter, before it is kept exact.
TIGHTER = 8


def tighten(coded: Coded, records: list[Geometry], level: int = 1) -> None:
    """Code ``records`` (originals) again to 1/``TIGHTER``^``level`` of their limit,
    in place (those already that tight are left).

    Their vertices then stay where they are (``coded.fine``).  A record's
    first pole is coded against the origin it had; the container re-bases it
    on the chain as written (:func:`codec.reorigin`).
    """
    for g in records:
        for done, methods in (
            (coded.surfaces, codec.SURFACE_METHODS),
            (coded.curves, codec.CURVE_METHODS),
        ):
            if id(g) in done and coded.tight.get(id(g), 0) < level:
                assert isinstance(g, (BSplineSurface, BSplineCurve))
                code = done[id(g)][0]
                # never looser than it is (a twin leader may be held below its own limit)
                floor = max(code.bound, coded.tol / 1024)
                limit = min(feature_limit(g.poles, coded.tol) / TIGHTER**level, floor)
                done[id(g)] = _code_one(g, coded.tol, methods, False, code.origin, limit)
                coded.fine.add(id(g))
                coded.tight[id(g)] = level


_TRIM_S = (Kind.TRIMMED_SURFACE,)
_TRIM_C = (Kind.TRIMMED_CURVE,)


def code_model(
    m: BRepModel, tol: float, paper: bool = False, points: np.ndarray | None = None
) -> Coded:
    """Run the per-net search (:func:`codec.encode_net`) on every B-spline surface
    and 3-D curve of ``m`` that may move (not under an offset).

    A curve whose ends the decoder would pin to vertices too far from the
    original ends (:func:`joins.overreaching`) is left exact.

    Boundaries that coincide within ``joins.TWIN_EPS`` (or tol/64) are coded
    once: a side of a net shared with an earlier net's side
    (:func:`joins.twin_sides`) becomes that side after decoding, and a curve
    that is an earlier curve (:func:`joins.twin_curves`) a copy of it.  The
    first of each is coded to a limit that leaves its copies within theirs.
    ``points`` (edges sampled along their ranges, :func:`occ.edge_points`)
    finds coincident edges no copy covers (another representation of the
    same curve): their curves stay exact (:func:`_lonely_curves`).
    """
    eps = min(joins.TWIN_EPS, tol / 64)
    keep_s = _offset_bases(m.surfaces, Kind.OFFSET_SURFACE, _TRIM_S)
    srows0 = _first_rows(
        m.surfaces, {id(g) for g in m.surfaces if isinstance(g, BSplineSurface)} - keep_s
    )
    sides = _affordable(m.surfaces, joins.twin_sides(m.surfaces, sorted(srows0), eps), tol)
    # where faces share an edge, its tolerance covers their coding errors: no
    # side needs joining there (joining would only move them off their other edges)
    on = _edges_by_surface(m)
    sides = {k: v for k, v in sides.items() if not on[k[0]] & on[v[0][0]]}
    surfaces = _code_table(
        m.surfaces,
        tol,
        keep_s,
        codec.SURFACE_METHODS,
        paper,
        limits=_leader_limits(m.surfaces, sides, tol),
    )
    h = serialize.vertex_grid(tol)
    # vertices at one point (within TWIN_VERTEX) snap as one: to their first's grid point
    lead = joins.vertex_clusters(m.vertex_point, joins.TWIN_VERTEX)
    vgrid = np.rint(m.vertex_point[lead] / h).astype(np.int64) * h  # as the decoder reads it
    snapped: Any = replace(m)
    snapped.vertex_point = vgrid
    decoded_s = [surfaces[id(g)][1] if id(g) in surfaces else g for g in m.surfaces]
    srows = _first_rows(m.surfaces, surfaces)
    for mm in (m, snapped):  # a pin may go to the exact or to the snapped vertex
        for r, pins in joins.surface_corner_pins(mm, decoded_s, srows, tol).items():
            g = m.surfaces[r]
            assert isinstance(g, BSplineSurface)
            if any(
                np.sqrt(((g.poles[joins.CORNERS[k]] - mm.vertex_point[v]) ** 2).sum()) > tol
                for k, v in pins
            ):
                surfaces.pop(id(g), None)
    keep_c = _offset_bases(m.curves3d, Kind.OFFSET_CURVE, _TRIM_C)
    candidates = {id(g): g for g in m.curves3d if isinstance(g, BSplineCurve)}
    crows = _first_rows(m.curves3d, {k: v for k, v in candidates.items() if k not in keep_c})
    iso = joins.iso_sources(m, crows, _first_rows(m.surfaces, surfaces))
    iso_ids = {id(m.curves3d[c]): src for c, src in iso.items()}
    where = joins.curve_placements(m)
    twins = joins.twin_curves(m.curves3d, crows, eps, set(iso), where)
    twins = _affordable(m.curves3d, twins, tol)
    if points is not None:  # coincident edges no copy covers: their curves stay exact
        lonely = _lonely_curves(m, points, twins, iso, sides)
        keep_c = keep_c | {id(m.curves3d[r]) for r in lonely}
        iso = {c: v for c, v in iso.items() if c not in lonely}
        iso_ids = {id(m.curves3d[c]): src for c, src in iso.items()}
        twins = {c: v for c, v in twins.items() if c not in lonely}
    twin_ids = {id(m.curves3d[c]): (r, rev) for c, (r, rev, _) in twins.items()}
    limits = _leader_limits(m.curves3d, twins, tol)
    for c, (r, _, d) in twins.items():  # a surface whose boundary leads is coded to suit
        if r in iso:
            sg = m.surfaces[iso[r][0]]
            need = feature_limit(cast(BSplineCurve, m.curves3d[c]).poles, tol) - d
            code = surfaces[id(sg)][0] if id(sg) in surfaces else None
            if code is not None and code.bound > need:
                assert isinstance(sg, BSplineSurface)
                surfaces[id(sg)] = _code_one(
                    sg, tol, codec.SURFACE_METHODS, paper, code.origin, need
                )
    at = joins.anchors(m, m.curves3d, crows)
    coded = Coded(
        surfaces,
        _code_table(
            m.curves3d,
            tol,
            keep_c | set(iso_ids) | set(twin_ids),
            codec.CURVE_METHODS,
            paper,
            {id(m.curves3d[r]): a for r, a in at.items()},
            limits,
        ),
        tol,
        iso_ids,
        vgrid,
        twins=twin_ids,
        where=where,
        vlead=lead,
        sides={k: (lead_side, rev) for k, (lead_side, rev, _) in sides.items()},
    )
    decoded = [coded.curves[id(g)][1] if id(g) in coded.curves else g for g in m.curves3d]
    rows = {i for i, g in enumerate(m.curves3d) if id(g) in coded.curves}
    for c in joins.overreaching(m, decoded, rows, tol) | joins.overreaching(
        snapped, decoded, rows, tol
    ):
        coded.curves.pop(id(m.curves3d[c]), None)
    for table in (m.surfaces, m.curves3d):
        for g in table:
            if isinstance(g, (BSplineSurface, BSplineCurve)) and feature_limit(g.poles, tol) < tol:
                coded.fine.add(id(g))
    return coded


#: Edges whose points agree within this (mm) meet in the source: the sewing
#: tolerance of the free-edge measure, with room for the sampling.
COINCIDENT = 1e-6


def _lonely_curves(
    m: BRepModel,
    points: np.ndarray,
    twins: dict[int, tuple[int, int, float]],
    iso: dict[int, tuple[int, int, int]],
    sides: dict[tuple[int, int], tuple[tuple[int, int], int, float]],
) -> set[int]:
    """3-D curve rows of coincident edges (:func:`joins.coincident_edges`) that
    would be coded apart: neither one curve, nor a copy and its leader (or
    two copies of one), nor the iso-boundaries of two joined sides.  Kept
    exact, they keep meeting (trj3 at 0.1: a closed curve given twice, with
    its poles in another order)."""
    curve_of: dict[int, int] = {}
    reps = m.edge_reps
    for q in np.flatnonzero(reps[:, 1] == RepKind.CURVE3D).tolist():
        curve_of.setdefault(int(reps[q, 0]), int(reps[q, 2]))
    lead = {c: r for c, (r, _, _) in twins.items()}
    side_lead = {k: v[0] for k, v in sides.items()}

    def root(c: int) -> tuple[str, Any]:
        """What a curve's decoded poles come from: a copy's leader's source,
        an iso-boundary's (joined) side, or the curve itself."""
        c = lead.get(c, c)
        if c in iso:
            k = iso[c][:2]
            return ("side", side_lead.get(k, k))
        return ("curve", c)

    out: set[int] = set()
    for e1, e2 in joins.coincident_edges(points, COINCIDENT):
        r1, r2 = curve_of.get(e1, -1), curve_of.get(e2, -1)
        if r1 < 0 or r2 < 0 or r1 == r2:
            continue
        g1, g2 = m.curves3d[r1], m.curves3d[r2]
        if not (isinstance(g1, BSplineCurve) or isinstance(g2, BSplineCurve)):
            continue  # analytic curves are exact
        if root(r1) == root(r2):
            continue
        out |= {r for r, g in ((r1, g1), (r2, g2)) if isinstance(g, BSplineCurve)}
    return out


def _edges_by_surface(m: BRepModel) -> dict[int, set[int]]:
    """Per surface row, the edges of the faces on it."""
    out: dict[int, set[int]] = collections.defaultdict(set)
    for e, fs in enumerate(faces_around(m, ShapeType.EDGE)):
        for f in fs:
            out[int(m.face_surface[f])].add(e)
    return out


def _affordable(table: list[Geometry], pairs: dict[Any, Any], tol: float) -> dict[Any, Any]:
    """The twin pairs (``{member: (leader, reversed, distance)}``, keys a row or
    (row, side)) whose distance is at most half the member's limit: the
    leader is coded to the rest (:func:`_leader_limits`)."""
    return {
        k: v for k, v in pairs.items() if v[2] <= feature_limit(_poles(table[_row(k)]), tol) / 2
    }


def _leader_limits(table: list[Geometry], pairs: dict[Any, Any], tol: float) -> dict[int, float]:
    """``{id(leader): limit}``: a leader coded to this leaves each copy of it,
    which moves by the leader's bound plus their distance, within the copy's limit."""
    out: dict[int, float] = {}
    for k, (lead, _, d) in pairs.items():
        key = id(table[_row(lead)])
        own = out.get(key, feature_limit(_poles(table[_row(lead)]), tol))
        out[key] = min(own, feature_limit(_poles(table[_row(k)]), tol) - d)
    return out


def _row(key: int | tuple[int, int]) -> int:
    """The table row of a twin key: a curve row, or a (surface row, side)."""
    return key[0] if isinstance(key, tuple) else key


def _poles(g: Geometry) -> np.ndarray:
    """The poles of a coded record (a B-spline curve or surface)."""
    return cast(BSplineCurve | BSplineSurface, g).poles


def _first_rows(table: list[Geometry], ids: dict[int, Any] | set[int]) -> set[int]:
    """Rows where records whose id is in ``ids`` first occur."""
    first: dict[int, int] = {}
    for i, g in enumerate(table):
        if id(g) in ids:
            first.setdefault(id(g), i)
    return set(first.values())


def face_records(m: BRepModel) -> list[int]:
    """Per face, the id of the record it moves with: its surface (trimmed ->
    basis), or for a swept surface the swept curve (trimmed -> basis)."""
    out = []
    for r in m.face_surface.tolist():
        g = _resolve(m.surfaces, r, _TRIM_S)
        if isinstance(g, Derived) and g.kind in SWEPT:
            g = _resolve(m.curves3d, g.basis, _TRIM_C)
        out.append(id(g))
    return out


def edge_records(m: BRepModel) -> list[int]:
    """Per edge, the id of its 3-D curve record (trimmed -> basis), or 0."""
    out = [0] * len(m.edge_tol)
    reps = m.edge_reps
    for q in np.flatnonzero(reps[:, 1] == RepKind.CURVE3D).tolist():
        if reps[q, 2] >= 0:
            out[reps[q, 0]] = id(_resolve(m.curves3d, int(reps[q, 2]), _TRIM_C))
    return out


def kinked_records(m: BRepModel) -> set[int]:
    """Ids of B-splines with an interior knot of multiplicity ≥ degree.

    Such a knot is only C0 by its knots; the original's poles around it are
    usually aligned (G1).  Coding breaks the alignment, and a STEP reader then
    splits the edge or face there, changing the topology.
    """
    out = set()
    for g in [*m.surfaces, *m.curves3d]:
        if isinstance(g, BSplineCurve) and not g.bezier:
            if (g.mults[1:-1] >= g.degree).any():
                out.add(id(g))
        elif isinstance(g, BSplineSurface) and not g.bezier:
            if (g.umults[1:-1] >= g.udegree).any() or (g.vmults[1:-1] >= g.vdegree).any():
                out.add(id(g))
    return out


def assemble(
    m: BRepModel,
    coded: Coded,
    exact: set[int] = frozenset(),  # type: ignore[assignment]
    still: set[int] = frozenset(),  # type: ignore[assignment]
) -> tuple[BRepModel, dict[int, codec.NetCode], LossyReport]:
    """The model the decoder will rebuild when every coded record but ``exact`` is used,
    and every vertex that may move (:func:`_snap_vertices`) but the rows in ``still``.

    Returns
    -------
    decoded : BRepModel
        Shares unchanged tables with ``m``; tolerances widened.
    codes : dict
        ``id(record in decoded) -> NetCode`` for the container.
    report : LossyReport
    """
    codes: dict[int, codec.NetCode] = {}

    def swap(
        table: list[Geometry], done: dict[int, tuple[codec.NetCode, Geometry]]
    ) -> list[Geometry]:
        out = []
        for g in table:
            hit = done.get(id(g)) if id(g) not in exact else None
            if hit is None:
                out.append(g)
            else:
                codes[id(hit[1])] = hit[0]
                out.append(hit[1])
        return out

    # a boundary coded once is exact on every side or on none: an exact copy's
    # leader is exact too
    exact = exact | {id(m.curves3d[r]) for k, (r, _) in coded.twins.items() if k in exact}
    while True:
        more = {
            id(m.surfaces[a])
            for (b, _), ((a, _), _) in coded.sides.items()
            if id(m.surfaces[b]) in exact
        } - exact
        if not more:
            break
        exact = exact | more
    surfaces = swap(m.surfaces, coded.surfaces)
    curves = swap(m.curves3d, coded.curves)
    m, moved_v = _snap_vertices(m, coded, surfaces, curves, codes, exact, still)
    _pin_surfaces(m, surfaces, codes, coded.tol)
    side_joins = _join_sides(m, coded, surfaces, codes)
    _copy_iso(m, coded, surfaces, curves, codes, exact)
    _pin_curves(m, curves, codes, coded.tol)
    _copy_twins(m, coded, curves, codes, exact)
    bound_of = {k: c.bound for k, c in codes.items()}

    def curve_bound(i: int) -> float:
        return 0.0 if i < 0 else bound_of.get(id(_resolve(curves, i, _TRIM_C)), 0.0)

    face_bound = np.zeros(len(m.face_surface))
    face_method = []
    for f, row in enumerate(m.face_surface.tolist()):
        b = _resolve(surfaces, row, _TRIM_S)
        if id(b) in codes:
            face_bound[f] = codes[id(b)].bound
            face_method.append(codes[id(b)].method.name.lower())
        elif isinstance(b, Derived) and b.kind in SWEPT:
            # sweeping is an isometry of each curve point: the surface moves as the curve
            face_bound[f] = curve_bound(b.basis)
            face_method.append("swept" if face_bound[f] > 0 else "exact")
        else:
            face_method.append("exact")
    reps = m.edge_reps
    edge_bound = np.zeros(len(m.edge_tol))
    for q in np.flatnonzero(reps[:, 1] == RepKind.CURVE3D).tolist():
        edge_bound[reps[q, 0]] = max(edge_bound[reps[q, 0]], curve_bound(int(reps[q, 2])))
    out = _widen_tolerances(m, face_bound, edge_bound, moved_v)
    out.surfaces, out.curves3d = surfaces, curves
    out.side_joins = side_joins
    sc = [codes[id(g)] for g in {id(g): g for g in surfaces if id(g) in codes}.values()]
    cc = [codes[id(g)] for g in {id(g): g for g in curves if id(g) in codes}.values()]
    report = LossyReport(
        face_method,
        face_bound,
        edge_bound,
        sum(c.bits for c in sc),
        sum(int(np.prod(_poles(g).shape[:-1])) for g in surfaces if id(g) in codes),
        sum(c.bits for c in cc),
        sum(len(_poles(g)) for g in curves if id(g) in codes),
    )
    return out, codes, report


def _snap_vertices(
    m: BRepModel,
    coded: Coded,
    surfaces: list[Geometry],
    curves: list[Geometry],
    codes: dict[int, codec.NetCode],
    exact: set[int],
    still: set[int],
) -> tuple[BRepModel, np.ndarray]:
    """``m`` with its vertices on the vertex grid where every edge at the vertex
    has a coded (or iso-copied) 3-D curve, and how far each vertex moved.

    Those curves are then pinned to the snapped vertex, and so are the corners
    of the nets around it, so everything that meets there still meets.  A
    vertex on an exact curve (a line, a circle, a degenerated edge), on a
    feature smaller than tol (``coded.fine``), or that would land where
    another vertex lands (:func:`_merging`) stays.
    """
    if not len(coded.vgrid):
        return m, np.zeros(len(m.vertex_tol))
    tidx = m.type_index()
    curve_of: dict[int, int] = {}
    reps = m.edge_reps
    for q in np.flatnonzero(reps[:, 1] == RepKind.CURVE3D).tolist():
        curve_of[int(reps[q, 0])] = int(reps[q, 2]) if reps[q, 6] == 0 else -1
    ok = np.ones(len(m.vertex_tol), bool)
    for e, s in enumerate(np.flatnonzero(m.shape_type == ShapeType.EDGE).tolist()):
        c = curve_of.get(e, -1)
        moving = c >= 0 and (
            id(curves[c]) in codes
            or (
                id(m.curves3d[c]) in coded.iso
                and id(m.curves3d[c]) not in exact
                and id(surfaces[coded.iso[id(m.curves3d[c])][0]]) in codes
            )
        )
        if not moving or id(m.curves3d[c]) in coded.fine:
            for v in below(m, s, ShapeType.VERTEX):
                ok[tidx[v]] = False
    for f, s in enumerate(np.flatnonzero(m.shape_type == ShapeType.FACE).tolist()):
        if id(_resolve(m.surfaces, int(m.face_surface[f]), _TRIM_S)) in coded.fine:
            for v in below(m, s, ShapeType.VERTEX):
                ok[tidx[v]] = False
    ok[sorted(still)] = False
    lead = coded.vlead if len(coded.vlead) == len(ok) else np.arange(len(ok))
    ok &= ~_merging(m.vertex_point[lead], coded.vgrid)
    ok &= ~np.isin(lead, lead[~ok])  # a cluster moves as one or stays
    out: Any = replace(m)
    out.vertex_point = np.where(ok[:, None], coded.vgrid, m.vertex_point)
    moved = np.sqrt(((out.vertex_point - m.vertex_point) ** 2).sum(-1))
    return out, moved


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


def _replace_all(table: list[Geometry], old: Geometry, new: Geometry) -> None:
    for i, g in enumerate(table):
        if g is old:
            table[i] = new


def _moved(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.sqrt(((a - b) ** 2).sum(-1)).max())


def _pin_surfaces(
    m: BRepModel, surfaces: list[Geometry], codes: dict[int, codec.NetCode], tol: float
) -> None:
    """Apply :func:`joins.surface_corner_pins` as the decoder will, raising bounds."""
    for r, pins in joins.surface_corner_pins(
        m, surfaces, _first_rows(surfaces, codes), tol
    ).items():
        old, original = surfaces[r], m.surfaces[r]
        assert isinstance(old, BSplineSurface) and isinstance(original, BSplineSurface)
        new = replace(old, poles=joins.pinned_corners(m, old, pins))
        code = codes.pop(id(old))
        codes[id(new)] = replace(code, bound=max(code.bound, _moved(new.poles, original.poles)))
        _replace_all(surfaces, old, new)


def _copy_iso(
    m: BRepModel,
    coded: Coded,
    surfaces: list[Geometry],
    curves: list[Geometry],
    codes: dict[int, codec.NetCode],
    exact: set[int],
) -> None:
    """Curves that are a coded surface's boundary become copies of the decoded boundary."""
    for c, g in enumerate(m.curves3d):
        src = coded.iso.get(id(g))
        if src is None or id(g) in exact or curves[c] is not g:
            continue
        r, side, rev = src
        if id(surfaces[r]) not in codes:
            continue  # the surface is exact, and so is its boundary: the curve as it is
        assert isinstance(g, BSplineCurve)
        poles = joins.boundary(surfaces[r].poles, side, bool(rev)).copy()  # type: ignore[union-attr]
        new = replace(g, poles=poles)
        ints = np.array([r, side, rev], np.int64)
        bound = _moved(poles, g.poles)
        code = codec.NetCode(codec.Method.ISO, codec.Quant.TOL, 0, 0, ints, np.zeros(0), bound, 0.0)
        codes[id(new)] = replace(code, first=poles[0].copy())
        _replace_all(curves, g, new)


def _join_sides(
    m: BRepModel, coded: Coded, surfaces: list[Geometry], codes: dict[int, codec.NetCode]
) -> np.ndarray:
    """Set each coded net's twin sides to their leaders' (as the decoder does after
    the corner pins); the rows of ``BRepModel.side_joins``, shape (J, 5)."""
    rows = []
    for (b, j), ((a, i), rev) in sorted(coded.sides.items()):
        old, original = surfaces[b], m.surfaces[b]
        if id(old) not in codes:
            continue  # exact: its leader is exact too (see assemble)
        assert isinstance(old, BSplineSurface) and isinstance(original, BSplineSurface)
        row = np.array([b, j, a, i, rev], np.int64)
        new = replace(old, poles=joins.joined_sides(old, surfaces[a], row))  # type: ignore[arg-type]
        code = codes.pop(id(old))
        codes[id(new)] = replace(code, bound=max(code.bound, _moved(new.poles, original.poles)))
        _replace_all(surfaces, old, new)
        rows.append(row)
    return np.array(rows, np.int64).reshape(-1, 5)


def _copy_twins(
    m: BRepModel,
    coded: Coded,
    curves: list[Geometry],
    codes: dict[int, codec.NetCode],
    exact: set[int],
) -> None:
    """Curves coincident with a coded curve become copies of its final (decoded
    and pinned) poles (``Method.COPY``; :func:`joins.twin_curves`), as the
    decoder makes them after the pins.  A copy is not pinned itself: it
    coincides with its leader, ends included.  A copy that would move further
    than its limit (a leader that is a coded surface's boundary, coded to the
    surface's limit) stays exact."""
    for c, g in enumerate(m.curves3d):
        twin = coded.twins.get(id(g))
        if twin is None or id(g) in exact or curves[c] is not g:
            continue
        r, rev = twin
        if id(curves[r]) not in codes:
            continue  # the leader is exact: so is this curve, as it is
        assert isinstance(g, BSplineCurve)
        lead = _poles(curves[r])
        poles = (lead[::-1] if rev else lead).copy()
        t = joins.copy_matrix(coded.where, c, r)
        if t is not None:  # the two edges sit in frames of their own
            poles = joins.placed(poles, t)
        bound = _moved(poles, g.poles)
        if bound > feature_limit(g.poles, coded.tol):
            continue
        ints = np.array([c - r, rev], np.int64)  # the leader as an offset from this row
        code = codec.NetCode(
            codec.Method.COPY, codec.Quant.TOL, 0, 0, ints, np.zeros(0), bound, 0.0
        )
        new = replace(g, poles=poles)
        codes[id(new)] = code
        _replace_all(curves, g, new)


def _pin_curves(
    m: BRepModel, curves: list[Geometry], codes: dict[int, codec.NetCode], tol: float
) -> None:
    """Apply :func:`joins.curve_end_pins` as the decoder will, raising each pinned curve's bound."""
    pins = joins.curve_end_pins(m, curves, _first_rows(curves, codes), tol)
    for c, places in pins.items():
        old = curves[c]
        assert isinstance(old, BSplineCurve)
        new = replace(old, poles=joins.pinned_poles(m, old, places))
        original = m.curves3d[c]
        assert isinstance(original, BSplineCurve)
        moved = float(np.sqrt(((new.poles - original.poles) ** 2).sum(-1)).max())
        code = codes.pop(id(old))
        codes[id(new)] = replace(code, bound=max(code.bound, moved))
        _replace_all(curves, old, new)


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
    """The smallest power of 2^(1/4) ≥ x (x > 0): a widened tolerance needs no
    more precision than that, and a few distinct values cost next to nothing."""
    k = np.ceil(4 * np.log2(x))
    y = np.exp2(k / 4)
    return np.where(y >= x, y, np.exp2((k + 1) / 4))


def drop_pcurves(m: BRepModel, keep_edges: set[int], keep_faces: set[int]) -> BRepModel:
    """A copy of ``m`` whose pcurves are left for the decoder to compute, where it can.

    A pcurve is dropped (its curve index set to ``REBUILD``) when its edge is
    not degenerated, has a 3-D curve, is not in ``keep_edges``, and every face
    on its surface is outside ``keep_faces``.  Pcurves no longer referenced
    leave the 2-D curve table.  The caller checks the rebuilt B-rep and keeps
    what fails (:func:`nurbscomp.pipeline.compress_file`).
    """
    reps = m.edge_reps.copy()
    kind = reps[:, 1]
    has3d = np.zeros(len(m.edge_tol), bool)
    c3 = kind == RepKind.CURVE3D
    has3d[reps[c3, 0]] = reps[c3, 2] >= 0
    faces_on: dict[tuple[int, int], list[int]] = collections.defaultdict(list)
    for f, key in enumerate(zip(m.face_surface.tolist(), m.face_loc.tolist())):
        faces_on[key].append(f)
    degenerated = (m.edge_flags & 1).astype(bool)
    pc = (kind == RepKind.ON_SURFACE) | (kind == RepKind.ON_CLOSED_SURFACE)
    for q in np.flatnonzero(pc).tolist():
        e = int(reps[q, 0])
        if degenerated[e] or not has3d[e] or e in keep_edges:
            continue
        on = faces_on.get((int(reps[q, 4]), int(reps[q, 6])), [])
        if not on or any(f in keep_faces for f in on):
            continue
        reps[q, 2] = REBUILD
        if kind[q] == RepKind.ON_CLOSED_SURFACE:
            reps[q, 3] = REBUILD
    out: Any = replace(m)
    out.edge_reps = reps
    dropped = reps[:, 2] == REBUILD
    out.edge_rep_range = np.where(dropped[:, None], 0.0, m.edge_rep_range)
    out.edge_rep_uv = np.where(dropped[:, None], 0.0, m.edge_rep_uv)
    return prune_curves2d(out)


def prune_curves2d(m: BRepModel) -> BRepModel:
    """Drop 2-D curves nothing refers to, renumbering the references."""
    used = np.zeros(len(m.curves2d), bool)
    reps = m.edge_reps
    pc = (reps[:, 1] == RepKind.ON_SURFACE) | (reps[:, 1] == RepKind.ON_CLOSED_SURFACE)
    for col in (2, 3):
        idx = reps[pc, col]
        used[idx[idx >= 0]] = True
    vr = m.vertex_reps
    idx = vr[vr[:, 1] == 1, 2]
    used[idx[idx >= 0]] = True
    for i in range(len(m.curves2d) - 1, -1, -1):  # bases precede their curves
        g = m.curves2d[i]
        if used[i] and isinstance(g, Derived):
            used[g.basis] = True
    new_index = np.cumsum(used) - 1
    table: list[Geometry] = []
    for i, g in enumerate(m.curves2d):
        if used[i]:
            if isinstance(g, Derived):
                g = replace(g, basis=int(new_index[g.basis]))
            table.append(g)
    out: Any = replace(m)
    out.curves2d = table
    reps = reps.copy()
    for col in (2, 3):
        sel = pc & (reps[:, col] >= 0)
        reps[sel, col] = new_index[reps[sel, col]]
    out.edge_reps = reps
    vr = vr.copy()
    sel = (vr[:, 1] == 1) & (vr[:, 2] >= 0)
    vr[sel, 2] = new_index[vr[sel, 2]]
    out.vertex_reps = vr
    return out


def _mantissa_bits(x: np.ndarray) -> int:
    """Significant mantissa bits of float64 values, summed: how dear they are to store."""
    frac = x.astype(np.float64).view(np.uint64) & np.uint64((1 << 52) - 1)
    nz = frac[frac != 0]
    trailing = np.zeros(len(nz), np.int64)
    for _ in range(52):  # count trailing zero bits
        even = (nz & np.uint64(1)) == 0
        if not even.any():
            break
        trailing += even & (nz != 0)
        nz = np.where(even, nz >> np.uint64(1), nz)
    return int((52 - trailing).sum())


def _cheaper(m: BRepModel, maps: dict[int, tuple[float, float]]) -> bool:
    """Whether the model's knots, surfaces' and curves', compress smaller with
    ``maps`` applied to the curves' (a curve's knots may repeat a surface's)."""
    import lzma

    def packed(mapped: bool) -> int:
        parts = [
            k
            for g in m.surfaces
            if isinstance(g, BSplineSurface) and not g.bezier
            for k in (g.uknots, g.vknots)
        ]
        for g in {id(g): g for g in m.curves3d}.values():
            if isinstance(g, BSplineCurve) and not g.bezier:
                ab = maps.get(id(g)) if mapped else None
                parts.append(g.knots if ab is None else (g.knots - ab[0]) / (ab[1] - ab[0]))
        return len(lzma.compress(np.concatenate(parts).tobytes() if parts else b""))

    return packed(True) < packed(False)


def unit_curves(m: BRepModel, codes: dict[int, codec.NetCode]) -> BRepModel:
    """``m`` with its free 3-D B-spline curves reparametrized onto [0, 1].

    A curve's knots are only its parametrization when nothing else holds its
    parameter: t -> (t - a)/(b - a) maps its knots onto [0, 1] (the same
    curve, point for point) and its edges' ranges with them.  Free means: its
    edges all run over the whole curve (a partial range, mapped, would cost
    more than the knots save), none keeps a stored pcurve (a pcurve shares
    its edge's parameter), no vertex holds a parameter on it, and no other
    record is built on it.
    On the corpus most curves have two knots, the ends of an arbitrary
    parameter range: as 0 and 1 they cost next to nothing.  Knots that are
    simpler as they are (0, 1, 2, 3 against 0, 1/3, 2/3, 1) stay.  Curve codes do
    not depend on the knots, so ``codes`` is only re-keyed (in place).
    """
    reps = m.edge_reps
    kind = reps[:, 1]
    on3d = kind == RepKind.CURVE3D
    busy: set[int] = set()
    pc = (kind == RepKind.ON_SURFACE) | (kind == RepKind.ON_CLOSED_SURFACE)
    kept_pc_edges = set(reps[pc & (reps[:, 2] != REBUILD), 0].tolist())
    for q in np.flatnonzero(on3d).tolist():
        if int(reps[q, 0]) in kept_pc_edges:
            busy.add(int(reps[q, 2]))
    vr = m.vertex_reps
    busy |= set(vr[vr[:, 1] == 0, 2].tolist())
    for g in m.curves3d:
        if isinstance(g, Derived):
            busy.add(g.basis)
    for g in m.surfaces:
        if isinstance(g, Derived) and g.kind in SWEPT:
            busy.add(g.basis)
    busy_ids = {id(m.curves3d[i]) for i in busy if 0 <= i < len(m.curves3d)}
    maps: dict[int, tuple[float, float]] = {}
    for g in m.curves3d:
        if (
            isinstance(g, BSplineCurve)
            and not g.bezier
            and id(g) not in busy_ids
            and (g.knots[0] != 0.0 or g.knots[-1] != 1.0)
            and g.knots[-1] > g.knots[0]
        ):
            a, b = float(g.knots[0]), float(g.knots[-1])
            if _mantissa_bits((g.knots - a) / (b - a)) < _mantissa_bits(g.knots):
                maps[id(g)] = (a, b)
    rng = m.edge_rep_range.copy()
    rows = np.flatnonzero(on3d & (reps[:, 2] >= 0)).tolist()
    for q in rows:
        ab = maps.get(id(m.curves3d[int(reps[q, 2])]))
        if ab is not None:
            if (m.edge_rep_range[q] == ab).all():
                rng[q] = (0.0, 1.0)
            else:  # a partial range would cost more as a mapped float than the knots save
                maps.pop(id(m.curves3d[int(reps[q, 2])]), None)
    if not maps or not _cheaper(m, maps):
        return m
    new: dict[int, Geometry] = {}
    table: list[Geometry] = []
    for g in m.curves3d:
        if id(g) in maps and id(g) not in new:
            assert isinstance(g, BSplineCurve)
            a, b = maps[id(g)]
            k = (g.knots - a) / (b - a)
            k[0], k[-1] = 0.0, 1.0
            new[id(g)] = replace(g, knots=k)
            if id(g) in codes:
                codes[id(new[id(g)])] = codes.pop(id(g))
        table.append(new.get(id(g), g))
    out: Any = replace(m)
    out.curves3d = table
    for q in rows:
        if id(m.curves3d[int(reps[q, 2])]) not in maps:
            rng[q] = m.edge_rep_range[q]
    out.edge_rep_range = rng
    return out


#: An edge on a line or circle takes the range its vertices give when that
#: moves its ends by at most this fraction of tol (:func:`vertex_ranges`).
RANGE_SLACK = 1e-3


def vertex_ranges(m: BRepModel, tol: float) -> BRepModel:
    """``m`` with the ranges of edges on lines and circles set to what their
    vertices give.

    Such a range is then stored as a rule, not as two floats
    (:func:`joins.vertex_ranges`, ``serialize.RANGE_VERTICES``).  The ends
    move along the curve by at most ``RANGE_SLACK``·tol (in the corpus, by
    the 1e-7 mm a CAD system leaves between a vertex and its curve), each to
    the point of the curve nearest its vertex.  The edge's pcurve ranges that
    were the same follow (same range).
    """
    rng = m.edge_rep_range
    out_rng = rng.copy()
    for q, t in joins.vertex_ranges(m).items():
        g = m.curves3d[int(m.edge_reps[q, 2])]
        speed = float(g.params[0]) if g.kind == Kind.CIRCLE else 1.0  # type: ignore[union-attr]
        d = np.abs(np.array(t) - rng[q])
        if (d > 0).any() and d.max() * speed <= RANGE_SLACK * tol:
            same = (m.edge_reps[:, 0] == m.edge_reps[q, 0]) & (rng == rng[q]).all(-1)
            out_rng[same] = t
    if np.array_equal(out_rng, rng):
        return m
    out: Any = replace(m)
    out.edge_rep_range = out_rng
    return out
