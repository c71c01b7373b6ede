"""Pcurves and parameter ranges the container need not store (docs/design.md §4a, ``encode/``).

:func:`drop_pcurves` leaves pcurves for the decoder to compute (OCCT projects
the 3-D curve); :func:`unit_surfaces` and :func:`unit_curves` then move the
parameters nothing else holds where they compress smaller (knots onto
[0, 1], an axis plane's origin onto its axis); :func:`vertex_ranges` stores
the ranges of edges on lines and circles as the rule "what the vertices give".
"""

from __future__ import annotations

import collections
import functools
import math
from collections.abc import Callable, Set
from dataclasses import fields, replace
from typing import Any

import numpy as np

from .. import budget, codec, entropy
from ..memo import Memo, digest
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
    RepKind,
    ShapeType,
    Table,
    below,
    first_row,
    kept_rows,
    records,
)
from ..rules import joins, ranges
from ..rules.nets import net_abscissae
from ..serialize import SWEPT
from . import analytic, weights
from .assembly import MARGIN, round_up


def drop_pcurves(m: BRepModel, keep_edges: set[int], keep_faces: set[int]) -> BRepModel:
    """A copy of ``m`` whose pcurves are left for the decoder to compute, where it can.

    A pcurve is dropped (its curve index set to ``REBUILD``) when its edge is
    not degenerated, has a 3-D curve, is not in ``keep_edges``, every face
    on its surface is outside ``keep_faces``, and the surface has an area
    (a reader refuses to project onto one whose poles lie on one line:
    ``budget.degenerate_rows``); and as long as what is dropped stays within
    the pcurves and projection work a reader computes whatever the
    container's size (``budget.DEFAULT``'s floors: the costliest
    projections are kept first, :func:`_within_budget`).  The pair of
    pcurves of an edge between two faces that lie on one trimmed surface
    (a surface of revolution cut into two half-turns that share it) is kept
    too: its two pcurves lie a period of the basis apart, which the trimmed
    surface, not periodic itself, does not tell the projection, and
    ``FixShifted`` does not move them.  Projected, both landed on one side
    and the two faces' wires came out open (bug32596, an ABC part, at every
    tolerance).  Pcurves no longer referenced leave the 2-D curve table.
    The caller checks the rebuilt B-rep and keeps what fails
    (:func:`nurbscomp.pipeline.compress_file`).
    """
    reps = m.edge_reps.copy()
    kind = reps[:, EC.KIND]
    has3d = np.zeros(len(m.edge_tol), bool)
    c3 = kind == RepKind.CURVE3D
    has3d[reps[c3, EC.EDGE]] = reps[c3, EC.CURVE] >= 0
    faces_on: dict[tuple[int, int], list[int]] = collections.defaultdict(list)
    for f, key in enumerate(zip(m.face_surface.tolist(), m.face_loc.tolist())):
        faces_on[key].append(f)
    degenerated = (m.edge_flags & 1).astype(bool)
    flat = budget.degenerate_rows(m.surfaces)
    closed = kind == RepKind.ON_CLOSED_SURFACE
    pc = (kind == RepKind.ON_SURFACE) | closed
    skip = degenerated | ~has3d
    iso = iso_lines(m) if STORE_ISO_LINES else np.zeros(len(reps), bool)
    trimmed = [isinstance(g, Derived) and g.kind == Kind.TRIMMED_SURFACE for g in m.surfaces]
    for q in np.flatnonzero(pc).tolist():
        e, _, _, _, surface, _, loc, _ = reps[q].tolist()
        if skip[e] or e in keep_edges or flat[surface] or iso[q]:
            continue
        if closed[q] and trimmed[surface] and KEEP_TRIMMED_PAIRS:
            continue  # two sheets of one trimmed surface: see the docstring
        on = faces_on.get((surface, loc), [])
        if not on or any(f in keep_faces for f in on):
            continue
        reps[q, EC.CURVE] = REBUILD
        if closed[q]:
            reps[q, EC.CURVE2] = REBUILD
    for q in _within_budget(m, reps, budget.DEFAULT):
        reps[q, EC.CURVE : EC.CURVE2 + 1] = m.edge_reps[q, EC.CURVE : EC.CURVE2 + 1]
    out: Any = replace(m)
    out.edge_reps = reps
    dropped = reps[:, EC.CURVE] == REBUILD
    out.edge_rep_range = np.where(dropped[:, None], 0.0, m.edge_rep_range)
    out.edge_rep_uv = np.where(dropped[:, None], 0.0, m.edge_rep_uv)
    return prune_curves2d(out)


#: Whether :func:`drop_pcurves` keeps the pcurve pairs of edges on a trimmed
#: surface (bug32596 at 0.001 / 0.01 / 0.1 mm: 10,986 / 8,721 / 7,488 bytes
#: without, 10,092 / 8,009 / 6,774 with; no other corpus file has one).
KEEP_TRIMMED_PAIRS = True

#: Whether :func:`drop_pcurves` stores the pcurves that are lines along a
#: parameter direction of their surface (``iso_lines``) instead of leaving
#: them to a projection (docs/decode-speed.md measures both).
STORE_ISO_LINES = False


def iso_lines(m: BRepModel) -> np.ndarray:
    """Per edge representation: whether it is a pcurve (both, on a seam) that
    is a 2-D line along u or v (a direction with a zero coordinate): four
    numbers in the container, and a projection (some 0.5 ms) saved."""
    out = np.zeros(len(m.edge_reps), bool)
    line = [
        isinstance(g, Analytic) and g.kind == Kind.LINE and (g.frame[1] == 0).any()
        for g in m.curves2d
    ]
    reps = m.edge_reps
    pc = (reps[:, EC.KIND] == RepKind.ON_SURFACE) | (reps[:, EC.KIND] == RepKind.ON_CLOSED_SURFACE)
    for q in np.flatnonzero(pc).tolist():
        c1, c2 = int(reps[q, EC.CURVE]), int(reps[q, EC.CURVE2])
        ok = 0 <= c1 < len(line) and line[c1]
        if reps[q, EC.KIND] == RepKind.ON_CLOSED_SURFACE:
            ok = ok and 0 <= c2 < len(line) and line[c2]
        out[q] = ok
    return out


def _within_budget(m: BRepModel, reps: np.ndarray, limits: budget.Limits) -> list[int]:
    """Rows of ``reps`` (``m``'s representations, some left to compute) that
    must be stored after all so that the rest stays within ``limits.pcurves``
    and ``limits.projection`` (the floor, which a reader allows whatever the
    container's size; counted as ``budget.pcurves_to_compute`` does): the
    costliest first, then by row."""
    cand: Any = replace(m)
    cand.edge_reps = reps
    todo = budget.projections(cand)
    count = sum(n for _, n, _ in todo)
    total = sum(w for _, _, w in todo)
    keep = []
    for q, n, w in sorted(todo, key=lambda x: (-x[2], x[0])):
        if count <= limits.pcurves and total <= limits.projection:
            break
        keep.append(q)
        count -= n
        total -= w
    return keep


def prune_curves2d(m: BRepModel) -> BRepModel:
    """Drop 2-D curves nothing refers to, renumbering the references."""
    used = np.zeros(len(m.curves2d), bool)
    reps = m.edge_reps
    pc = (reps[:, EC.KIND] == RepKind.ON_SURFACE) | (reps[:, EC.KIND] == RepKind.ON_CLOSED_SURFACE)
    for col in (2, 3):
        idx = reps[pc, col]
        used[idx[idx >= 0]] = True
    vr = m.vertex_reps
    idx = vr[vr[:, VC.KIND] == PointRepKind.ON_CURVE_ON_SURFACE, VC.CURVE]
    used[idx[idx >= 0]] = True
    table, new_index = kept_rows(m.curves2d, used)
    out: Any = replace(m)
    out.curves2d = table
    reps = reps.copy()
    for col in (2, 3):
        sel = pc & (reps[:, col] >= 0)
        reps[sel, col] = new_index[reps[sel, col]]
    out.edge_reps = reps
    vr = vr.copy()
    sel = (vr[:, VC.KIND] == PointRepKind.ON_CURVE_ON_SURFACE) & (vr[:, VC.CURVE] >= 0)
    vr[sel, VC.CURVE] = new_index[vr[sel, VC.CURVE]]
    out.vertex_reps = vr
    return out


def _mantissa_bits(x: np.ndarray) -> int:
    """Significant mantissa bits of float64 values, summed: how dear they are to store."""
    frac = x.astype(np.float64).view(np.uint64) & np.uint64((1 << 52) - 1)
    nz = frac[frac != 0]
    low = nz & (~nz + np.uint64(1))  # the lowest set bit: a power of two below 2**52
    trailing = np.frexp(low.astype(np.float64))[1] - 1  # exact for powers of two
    return int((52 - trailing).sum())


#: A knot map: the ends (a, b) of a vector that becomes (k − a)/(b − a).
Ends = tuple[float, float]


def _unit(k: np.ndarray, ab: Ends | None) -> np.ndarray:
    """``k`` mapped onto [0, 1] by ``ab`` (its ends exactly 0 and 1); ``k`` for None."""
    if ab is None:
        return k
    out = (k - ab[0]) / (ab[1] - ab[0])
    out[0], out[-1] = 0.0, 1.0
    return out


def _cheaper(
    m: BRepModel,
    maps: dict[int, Ends],
    memo: dict[tuple[Any, ...], bool] | None = None,
    surface_maps: dict[int, tuple[Ends | None, Ends | None]] | None = None,
) -> bool:
    """Whether the model's knots, surfaces' and curves', compress smaller with
    ``maps`` (by a curve record's first row) applied to the curves' and
    ``surface_maps`` (by a surface record's first row: u's and v's) to the
    surfaces' (a curve's knots may repeat a surface's) than with neither.

    ``memo`` keeps answers by the maps and the knots themselves: the validity
    stage's candidates share their knots (coding moves poles only) and mostly
    their maps, and the two LZMA passes are a third of :func:`unit_curves`.
    """
    import hashlib

    smaps = surface_maps or {}
    sfirst = first_row(m.surfaces)
    surfaces = [
        (sfirst[i], g)
        for i, g in enumerate(m.surfaces)
        if isinstance(g, BSplineSurface) and not g.bezier
    ]
    curves = [
        (i, g)
        for i, (first, g) in enumerate(zip(first_row(m.curves3d), m.curves3d))
        if first == i and isinstance(g, BSplineCurve) and not g.bezier
    ]

    def joined(mapped: bool) -> bytes:
        parts = []
        for i, g in surfaces:
            uv = smaps.get(i, (None, None)) if mapped else (None, None)
            parts += [_unit(g.uknots, uv[0]), _unit(g.vknots, uv[1])]
        for i, c in curves:
            parts.append(_unit(c.knots, maps.get(i) if mapped else None))
        return np.concatenate(parts).tobytes() if parts else b""

    plain = joined(False)
    key = (tuple(sorted(maps.items())), tuple(sorted(smaps.items())), hashlib.sha1(plain).digest())
    if memo is not None and key in memo:
        return memo[key]
    answer = entropy.xz_size(joined(True)) < entropy.xz_size(plain)
    if memo is not None:
        memo[key] = answer
    return answer


def _surfaces_held(m: BRepModel) -> set[int]:
    """Surface records (first rows) whose parameters something else holds: a
    stored pcurve on it, a vertex's (u, v) on it, a record built on it."""
    reps = m.edge_reps
    pc = np.isin(reps[:, EC.KIND], (RepKind.ON_SURFACE, RepKind.ON_CLOSED_SURFACE))
    rows = set(reps[pc & (reps[:, EC.CURVE] != REBUILD), EC.SURFACE].tolist())
    vr = m.vertex_reps
    rows |= set(vr[vr[:, VC.KIND] != PointRepKind.ON_CURVE, VC.SURFACE].tolist())
    rows |= {g.basis for g in m.surfaces if isinstance(g, Derived) and g.kind not in SWEPT}
    first = first_row(m.surfaces)
    return {first[i] for i in rows if 0 <= i < len(m.surfaces)}


#: Surface codes that do not depend on the knots (the grid predictors): the
#: boundary and map methods sample the surface at its Greville abscissae.
KNOTLESS_CODES = codec.KNOTLESS


def unit_surfaces(
    m: BRepModel,
    codes: dict[Any, Any],
    memo: dict[tuple[Any, ...], bool] | None = None,
) -> BRepModel:
    """``m`` with its free surfaces' parameters moved where they cost least:
    a B-spline's knots mapped onto [0, 1] in u and v, a plane's origin to
    where its normal's axis meets it.  The same surfaces, point for point.

    Free means no stored pcurve, no vertex's (u, v) and no other record
    (an offset or trimmed surface) holds the surface's parameters: the
    decoder computes every pcurve on it (:func:`drop_pcurves`).

    * A B-spline is mapped where it is kept exact or coded by a grid
      predictor (``codes``, by record: ``KNOTLESS_CODES``; the other methods
      sample it at its knots' Greville abscissae, so their decoded poles
      would change; a lifted code where its weights stay the same bit for
      bit, :func:`_same_weights`), a vector only where that makes its knots cheaper
      (:func:`_mantissa_bits`), and all of them only where the model's
      knots then compress smaller (:func:`_cheaper`, the curves' as they
      are).  That test is a proxy.  Counting in both arms the curves that
      :func:`unit_curves` maps next (copies of the surfaces' sides) said
      yes more often, but on the corpus it mapped ec_turbine's rational
      surfaces, after which OCCT's checks blamed other faces and the file
      came out 157 and 347 bytes larger at 0.01 and 0.001 mm; no other
      file changed.  The mapped knots differ from an
      affine image of the source's by a few ulps of the span, which the
      verify step's bound takes (``knots.term``).
    * A plane whose normal is along a coordinate axis gets the origin
      (0, …, o_a, …, 0): only the in-plane part of the origin changes, so
      the plane does not move at all.  (Keeping the in-plane coordinates
      that are some vertex's, as ``assembly._snap_analytic`` keeps a
      frame's, made the corpus 88 bytes larger at 0.01 mm and the stress
      corpus 61 bytes smaller: not done.)
    """
    held = _surfaces_held(m)
    first = first_row(m.surfaces)
    recs = records(m.surfaces, Table.SURFACE)
    maps: dict[int, tuple[Ends | None, Ends | None]] = {}
    planes: dict[int, Analytic] = {}
    for i, g in enumerate(m.surfaces):
        if first[i] != i or i in held:
            continue
        if isinstance(g, BSplineSurface) and not g.bezier:
            code = codes.get(recs[i])
            lifted = code is not None and code.method in codec.LIFTED
            if code is not None and code.method not in KNOTLESS_CODES and not lifted:
                continue
            uv: tuple[Ends | None, Ends | None] = (_unit_map(g.uknots), _unit_map(g.vknots))
            if uv == (None, None):
                continue
            if code is not None and lifted and not _same_weights(code.method, g, _mapped(g, uv)):
                continue
            maps[i] = uv
        elif isinstance(g, Analytic) and g.kind == Kind.PLANE and not g.through:
            n, o = g.frame[1], g.frame[0]
            axis = np.flatnonzero(n != 0)
            if len(axis) == 1 and np.count_nonzero(o) > 1:
                f = g.frame.copy()
                f[0] = 0.0
                f[0, axis[0]] = o[axis[0]]
                planes[i] = replace(g, frame=f)
    if maps and not _cheaper(m, {}, memo, maps):
        maps = {}
    if not maps and not planes:
        return m
    table: list[Geometry] = []
    for i, g in enumerate(m.surfaces):
        if first[i] != i:
            table.append(table[first[i]])  # the rows of a record share it
        elif i in maps:
            assert isinstance(g, BSplineSurface)
            table.append(_mapped(g, maps[i]))
        else:
            table.append(planes.get(i, g))
    out: Any = replace(m)
    out.surfaces = table
    return out


def _mapped(g: BSplineSurface, uv: tuple[Ends | None, Ends | None]) -> BSplineSurface:
    """``g`` with its knots mapped by ``uv`` (:func:`_unit_map` of u and v)."""
    return replace(g, uknots=_unit(g.uknots, uv[0]), vknots=_unit(g.vknots, uv[1]))


def _same_weights(method: codec.Method, g: BSplineSurface, moved: BSplineSurface) -> bool:
    """Whether a lifted code (``codec.LIFTED``) predicts ``moved``'s net
    with the weights it predicts ``g``'s with, bit for bit: they depend on
    the knots only through ratios of the normalised abscissae, which an
    affine map of the knots keeps but for a few ulps; where those ulps
    change no weight, the decoded net is the same."""
    a = codec.lifted_weights(method, *net_abscissae(g))
    b = codec.lifted_weights(method, *net_abscissae(moved))
    return all(np.array_equal(x, y) for x, y in zip(a, b))


def _unit_map(k: np.ndarray) -> Ends | None:
    """The map of ``k`` onto [0, 1], where that makes it cheaper."""
    if (k[0] == 0.0 and k[-1] == 1.0) or not k[-1] > k[0]:
        return None
    ab = (float(k[0]), float(k[-1]))
    return ab if _mantissa_bits(_unit(k, ab)) < _mantissa_bits(k) else None


def unit_curves(m: BRepModel, memo: dict[tuple[Any, ...], bool] | None = None) -> BRepModel:
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
    not depend on the knots, and the records keep their rows: the codes of
    ``m``'s records (:func:`assembly.assemble`) stand as they are.
    ``memo`` keeps the size test's answers across calls (:func:`_cheaper`).
    """
    maps = _curve_maps(m)
    if not maps or not _cheaper(m, maps, memo):
        return m
    first = first_row(m.curves3d)
    table: list[Geometry] = []
    for i, g in enumerate(m.curves3d):
        if first[i] in maps and first[i] == i:
            assert isinstance(g, BSplineCurve)
            g = replace(g, knots=_unit(g.knots, maps[i]))
        table.append(g if first[i] == i else table[first[i]])  # the rows of a record share it
    out: Any = replace(m)
    out.curves3d = table
    reps = m.edge_reps
    rng = m.edge_rep_range.copy()
    for q in np.flatnonzero((reps[:, EC.KIND] == RepKind.CURVE3D) & (reps[:, EC.CURVE] >= 0)):
        if first[int(reps[q, EC.CURVE])] in maps:
            rng[q] = (0.0, 1.0)
    out.edge_rep_range = rng
    return out


def _curve_maps(m: BRepModel) -> dict[int, Ends]:
    """The maps :func:`unit_curves` would make, by a curve record's first row
    (before its size test)."""
    reps = m.edge_reps
    kind = reps[:, EC.KIND]
    on3d = kind == RepKind.CURVE3D
    busy: set[int] = set()
    pc = (kind == RepKind.ON_SURFACE) | (kind == RepKind.ON_CLOSED_SURFACE)
    kept_pc_edges = set(reps[pc & (reps[:, EC.CURVE] != REBUILD), EC.EDGE].tolist())
    for q in np.flatnonzero(on3d).tolist():
        if int(reps[q, EC.EDGE]) in kept_pc_edges:
            busy.add(int(reps[q, EC.CURVE]))
    vr = m.vertex_reps
    busy |= set(vr[vr[:, VC.KIND] == PointRepKind.ON_CURVE, VC.CURVE].tolist())
    for g in m.curves3d:
        if isinstance(g, Derived):
            busy.add(g.basis)
    for g in m.surfaces:
        if isinstance(g, Derived) and g.kind in SWEPT:
            busy.add(g.basis)
    first = first_row(m.curves3d)  # a curve record by its first row
    busy_recs = {first[i] for i in busy if 0 <= i < len(m.curves3d)}
    maps: dict[int, Ends] = {}
    for i, g in enumerate(m.curves3d):
        if (
            isinstance(g, BSplineCurve)
            and not g.bezier
            and first[i] not in busy_recs
            and (g.knots[0] != 0.0 or g.knots[-1] != 1.0)
            and g.knots[-1] > g.knots[0]
        ):
            ends = (float(g.knots[0]), float(g.knots[-1]))
            if _mantissa_bits(_unit(g.knots, ends)) < _mantissa_bits(g.knots):
                maps[first[i]] = ends
    for q in np.flatnonzero(on3d & (reps[:, EC.CURVE] >= 0)).tolist():
        ab = maps.get(first[int(reps[q, EC.CURVE])])
        if ab is not None and not (m.edge_rep_range[q] == ab).all():
            # a partial range would cost more as a mapped float than the knots save
            maps.pop(first[int(reps[q, EC.CURVE])], None)
    return maps


#: An edge on a line or circle takes the range its vertices give when that
#: moves its ends by at most this fraction of tol (:func:`vertex_ranges`).
RANGE_SLACK = 1e-3


def vertex_ranges(
    m: BRepModel, tol: float, keep: Set[int] = frozenset(), source: np.ndarray | None = None
) -> BRepModel:
    """``m`` with the ranges of edges on lines and circles set to what their
    vertices give, but for the edges in ``keep``.

    Such a range is then stored as a rule, not as two floats
    (:func:`joins.vertex_ranges`, ``serialize.RANGE_VERTICES``).  The ends
    move along the curve by at most ``RANGE_SLACK``·tol (in the corpus, by
    the 1e-7 mm a CAD system leaves between a vertex and its curve), each to
    the point of the curve nearest its vertex, plus how far the edge's
    vertices moved from ``source`` (the vertex points before snapping: an end
    follows its snapped vertex, and the nearest point moves by no more than
    the vertex).  The edge's pcurve ranges that were the same follow (same
    range).
    """
    rng = m.edge_rep_range
    out_rng = rng.copy()
    moved = np.zeros(len(m.edge_tol))
    if source is not None and len(source):
        by_vertex = np.sqrt(((m.vertex_point - source) ** 2).sum(-1))
        if by_vertex.any():
            tidx = m.type_index()
            edges = np.flatnonzero(m.shape_type == ShapeType.EDGE).tolist()
            for e, s in enumerate(edges):
                vs = [tidx[v] for v in below(m, s, ShapeType.VERTEX)]
                moved[e] = by_vertex[vs].max() if vs else 0.0
    for q, t in joins.vertex_ranges(m).items():
        e = int(m.edge_reps[q, EC.EDGE])
        if e in keep:
            continue
        g = m.curves3d[int(m.edge_reps[q, EC.CURVE])]
        speed = float(g.params[0]) if g.kind == Kind.CIRCLE else 1.0  # type: ignore[union-attr]
        d = np.abs(np.array(t) - rng[q])
        # a curve on its grid moved by up to its grid's bound, and its vertices'
        # projections along it by as much; a point moved by δ, at ρ ≥ r/2 from a
        # circle's axis, turns by at most 2δ/r
        slack = RANGE_SLACK * tol + analytic.grid_bound(g)  # type: ignore[arg-type]
        reach = moved[e] * (2.0 if g.kind == Kind.CIRCLE and moved[e] <= speed / 2 else 1.0)
        if (d > 0).any() and d.max() * speed <= slack + reach:
            same = (m.edge_reps[:, EC.EDGE] == m.edge_reps[q, EC.EDGE]) & (rng == rng[q]).all(-1)
            out_rng[same] = t
    if np.array_equal(out_rng, rng):
        return m
    out: Any = replace(m)
    out.edge_rep_range = out_rng
    return out


PCURVE_KINDS = (RepKind.ON_SURFACE, RepKind.ON_CLOSED_SURFACE)

#: A stored 3-D range's end this close to its curve's own end (along the
#: curve, as a fraction of tol) goes to that end (:func:`natural_ends`).
RANGE_ROUND = 1 / 64


def curve_speed(g: Geometry) -> float:
    """An upper bound of |C'(t)| over 3-D curve ``g`` (inf where none is known):
    a line's 1, a circle's radius, an ellipse's major radius; for a
    non-rational, non-periodic B-spline the largest derivative control point
    p·(P[i+1] − P[i]) / (t[i+p+1] − t[i+1]) (C' is the B-spline of those, and
    lies in their hull).  For a rational one (weights w > 0):
    C' = Σ w_i N_i' (P_i − C) / Σ w_i N_i (eq. 2 differentiated, Σ R_i' = 0),
    so |C'| ≤ 2p · (max w / min w) · D / h, with D the largest bounding-box
    diagonal of p + 1 consecutive poles (C lies in the hull of the active
    ones), h the shortest non-zero t[j+p] − t[j] (Σ |N_i'| ≤ 2p Σ N_(j,p−1) /
    (t[j+p] − t[j]))."""
    if isinstance(g, Analytic) and g.frame.shape[1] == 3:
        if g.kind == Kind.LINE:
            return float(np.sqrt((g.frame[1] ** 2).sum()))
        if g.kind in (Kind.CIRCLE, Kind.ELLIPSE):
            return float(g.params[0])
    if isinstance(g, BSplineCurve) and not g.periodic and g.poles.shape[1] == 3:
        p = g.degree
        n = len(g.poles)
        t = np.repeat(np.array([0.0, 1.0]), n) if g.bezier else np.repeat(g.knots, g.mults)
        if p < 1 or len(t) != n + p + 1:
            return math.inf
        if g.weights is not None:
            return _rational_speed(g, t)
        span = t[p + 1 : n + p] - t[1:n]
        d = np.sqrt((np.diff(g.poles, axis=0) ** 2).sum(-1))
        with np.errstate(divide="ignore", invalid="ignore"):
            q = np.where(d > 0, p * d / span, 0.0)
        return float(q.max(initial=0.0)) if np.isfinite(q).all() else math.inf
    return math.inf


def _rational_speed(g: BSplineCurve, t: np.ndarray) -> float:
    """:func:`curve_speed`'s bound for a rational B-spline ``g`` on its flat
    knots ``t``."""
    w = np.asarray(g.weights, float)
    h = t[g.degree :] - t[: len(t) - g.degree]
    h = h[h > 0]
    if not (w > 0).all() or not len(h) or not np.isfinite(w).all():
        return math.inf
    d = weights.support_diameter(g)
    out = 2 * g.degree * float(w.max() / w.min()) * d / float(h.min())
    return out if math.isfinite(out) else math.inf


def natural_ends(m: BRepModel, tol: float) -> BRepModel:
    """``m`` with each stored 3-D range end that lies within
    ``RANGE_ROUND``·tol (along the curve, :func:`curve_speed`) of its curve's
    own end set to that end, and the edge's pcurve ranges that were the same
    with it (where their curves reach that far); the edge's vertices get that
    much more tolerance.  A CAD system often trims an edge 1e-7 of its length
    short of its curve's end (trj7: 379 of 415 stored ranges): at the end, the
    range is a rule and the curve's end is pinned to its vertex, which costs
    less than two floats and an end coded apart."""

    def to_end(t: np.ndarray, nat: tuple[float, float] | None, speed: float) -> np.ndarray:
        if nat is None:
            return t
        near = (t != nat) & (np.abs(t - nat) * speed <= RANGE_ROUND * tol)
        return np.where(near, nat, t)

    return _moved_ranges(m, to_end)


#: How far :func:`rounded_ranges` moves a range end along its curve, as a
#: fraction of tol (trj7 at 0.01 mm: 29,586 bytes with tol/64, 29,535 with
#: tol/16, 29,525 with tol/4; the vertices' tolerances grow by as much).
RANGE_STEP = 1 / 16


def rounded_ranges(m: BRepModel, tol: float, keep: Set[int] = frozenset()) -> BRepModel:
    """``m`` (a candidate: :func:`drop_pcurves` has said which pcurves are
    stored) with each stored 3-D range, but those of the edges in ``keep``,
    rounded inwards (its first end up, its last down) to multiples of a
    power of two ``q``, the largest with ``q`` · speed ≤ ``RANGE_STEP``·tol
    (:func:`curve_speed`), so that each end moves by at most
    ``RANGE_STEP``·tol along the curve.  The pcurve ranges that were the
    same follow (inwards, every pcurve still reaches them; a stored pcurve
    over its own range keeps the edge as it is, since its range would then
    be stored), and the edge's vertices get that much more tolerance, as in
    :func:`natural_ends`.

    A range cut anywhere along its curve is two floats of 52 bits (trj7:
    163 stored 3-D ranges); rounded, they end in zero bits that the entropy
    stage codes for next to nothing (trj7 at 0.01 mm: 31,046 → 30,123
    bytes).  The reader takes the floats as they are: no format change.  (A
    STEP file holds no ranges: its reader projects the vertices onto the
    curve, so what it reads back does not change.)"""

    def rounded(t: np.ndarray, nat: tuple[float, float] | None, speed: float) -> np.ndarray:
        q = 2.0 ** math.floor(math.log2(RANGE_STEP * tol / speed))
        if not (np.abs(t) < 2.0**52 * q).all():
            return t
        out = np.array([math.ceil(t[0] / q), math.floor(t[1] / q)]) * q
        return out if out[0] < out[1] else t

    return _moved_ranges(m, rounded, keep, stored_only=True)


def _moved_ranges(
    m: BRepModel,
    move: Callable[[np.ndarray, tuple[float, float] | None, float], np.ndarray],
    keep: Set[int] = frozenset(),
    stored_only: bool = False,
) -> BRepModel:
    """``m`` with each stored 3-D range ``t`` of a curve with a speed bound
    (:func:`curve_speed`) set to ``move(t, the curve's own range, speed)``,
    but on the edges in ``keep``, where the edge's pcurves all had that
    range and reach the new one; the edge's vertices get the tolerance that
    the move along the curve takes.  With ``stored_only`` the pcurves the
    decoder computes (``REBUILD``) follow whatever the range is, and an edge
    with a stored pcurve over its own range stays."""
    kinds = ranges.range_kinds(m)
    reps = m.edge_reps
    rng = m.edge_rep_range
    out_rng = rng.copy()
    shift = np.zeros(len(m.edge_tol))
    stored = (reps[:, EC.KIND] == RepKind.CURVE3D) & (kinds == ranges.RANGE_STORED)
    by_edge = collections.defaultdict(list)
    for q in range(len(reps)):
        by_edge[int(reps[q, EC.EDGE])].append(q)
    for q in np.flatnonzero(stored).tolist():
        e, c = int(reps[q, EC.EDGE]), int(reps[q, EC.CURVE])
        if not 0 <= c < len(m.curves3d) or e in keep:
            continue
        g = m.curves3d[c]
        nat, speed = ranges.natural_range(g), curve_speed(g)
        if not 0 < speed < math.inf or not np.isfinite(rng[q]).all():
            continue
        t = move(rng[q].copy(), nat, speed)
        if np.array_equal(t, rng[q]):
            continue
        same = [p for p in by_edge[e] if p != q and np.array_equal(rng[p], rng[q])]
        onsurf = [
            p
            for p in by_edge[e]
            if reps[p, EC.KIND] in PCURVE_KINDS
            and not (stored_only and reps[p, EC.CURVE] == REBUILD)
        ]
        if not set(onsurf) <= set(same) or not all(_reaches(m, p, t) for p in same):
            continue  # every pcurve follows, or none moves (BRepCheck compares them)
        if stored_only and any(kinds[p] == ranges.RANGE_NATURAL for p in same):
            continue
        out_rng[q] = t
        out_rng[same] = t
        shift[e] = float(np.abs(t - rng[q]).max()) * speed
    if not shift.any():
        return m
    out: Any = replace(m)
    out.edge_rep_range = out_rng
    tidx = m.type_index()
    extra = np.zeros(len(m.vertex_tol))
    for e, s in enumerate(np.flatnonzero(m.shape_type == ShapeType.EDGE).tolist()):
        if shift[e] > 0:
            for v in below(m, s, ShapeType.VERTEX):
                extra[tidx[v]] = max(extra[tidx[v]], shift[e])
    out.vertex_tol = np.where(extra > 0, round_up(m.vertex_tol + MARGIN * extra), m.vertex_tol)
    return out


def _reaches(m: BRepModel, q: int, t: np.ndarray) -> bool:
    """Whether representation ``q``'s curve (a pcurve, or any) is defined over ``t``."""
    kind, c = int(m.edge_reps[q, EC.KIND]), int(m.edge_reps[q, EC.CURVE])
    if kind not in (*PCURVE_KINDS, RepKind.CURVE3D):
        return False
    table = m.curves3d if kind == RepKind.CURVE3D else m.curves2d
    if not 0 <= c < len(table) or (
        kind == RepKind.ON_CLOSED_SURFACE and m.edge_reps[q, EC.CURVE2] < 0
    ):
        return False
    for i in (c, int(m.edge_reps[q, EC.CURVE2])) if kind == RepKind.ON_CLOSED_SURFACE else (c,):
        g = table[i]
        nat = ranges.natural_range(g)
        if isinstance(g, BSplineCurve) and g.periodic:
            continue
        slack = REACH_SLACK * (nat[1] - nat[0]) if nat is not None else 0.0
        if nat is not None and (t[0] < nat[0] - slack or t[1] > nat[1] + slack):
            return False
    return True


#: A pcurve may be used this fraction of its own range past its ends (OCCT
#: evaluates a B-spline past its ends by its end span; STEP files carry such
#: pcurves, cut 1e-7 short like their edges' curves).  That holds for a
#: pcurve the decoder computes again; a stored one is stretched onto its
#: range (:func:`stretch_short`).
REACH_SLACK = 1e-6
#: How far BRepCheck lets a range pass the ends of a curve that is not
#: periodic (``Precision::PConfusion``; ``BRepCheck_Edge``'s InvalidRange).
PCONFUSION = 1e-9


def stretch_short(m: BRepModel) -> BRepModel:
    """``m`` (a candidate: :func:`drop_pcurves` has said which pcurves are
    stored) with each stored B-spline pcurve whose edge's range passes its
    ends by more than :data:`PCONFUSION` reparametrized onto that range, and
    the edge's tolerance widened to cover it.

    :func:`natural_ends` moves a range end onto its 3-D curve's end with the
    pcurves that reach it within :data:`REACH_SLACK`.  A pcurve the decoder
    computes is then made over the new range, but a stored one keeps its
    own ends, and BRepCheck rejects a range past them (InvalidRange): on
    trj7 at 0.1 mm a pcurve cut 4e-7 short, stored by the validity stage,
    faulted in every round, its records exact or not, and the fallback that
    stores every pcurve faulted on some 100 edges.

    The knots are mapped by the affine map of [d0, d1] (its ends) onto
    [min(d0, t0), max(d1, t1)] (with the range's): the same curve, point
    for point, at parameters that move by at most ``s`` = the larger end
    move, so the 3-D curve and the pcurve part by at most ``s`` times the
    3-D curve's speed (:func:`curve_speed`), added to the edge's tolerance
    (its vertices took that much when :func:`natural_ends` moved the end).
    A 2-D row that anything else uses is copied first.  Where the 3-D curve's
    speed has no bound, the pcurve stays as it is."""
    reps = m.edge_reps.copy()
    kind = reps[:, EC.KIND]
    rng = m.edge_rep_range
    stored = np.isin(kind, PCURVE_KINDS) & (reps[:, EC.CURVE] >= 0)
    speed: dict[int, float] = {}
    for q in np.flatnonzero((kind == RepKind.CURVE3D) & (reps[:, EC.CURVE] >= 0)).tolist():
        c = int(reps[q, EC.CURVE])
        if 0 <= c < len(m.curves3d):
            speed.setdefault(int(reps[q, EC.EDGE]), curve_speed(m.curves3d[c]))
    uses = collections.Counter(reps[stored, EC.CURVE].tolist())
    uses.update(reps[stored & (kind == RepKind.ON_CLOSED_SURFACE), EC.CURVE2].tolist())
    vr = m.vertex_reps
    held = set(vr[vr[:, VC.KIND] == PointRepKind.ON_CURVE_ON_SURFACE, VC.CURVE].tolist())
    table = list(m.curves2d)
    widen = np.zeros(len(m.edge_tol))
    for q in np.flatnonzero(stored).tolist():
        t0, t1 = float(rng[q, 0]), float(rng[q, 1])
        e = int(reps[q, EC.EDGE])
        cols = (EC.CURVE, EC.CURVE2) if kind[q] == RepKind.ON_CLOSED_SURFACE else (EC.CURVE,)
        for col in cols:
            i = int(reps[q, col])
            g = table[i] if 0 <= i < len(table) else None
            if not isinstance(g, BSplineCurve) or g.bezier or g.periodic:
                continue
            d0, d1 = float(g.knots[0]), float(g.knots[-1])
            if t0 >= d0 - PCONFUSION and t1 <= d1 + PCONFUSION:
                continue
            n0, n1 = min(d0, t0), max(d1, t1)
            s = max(d0 - n0, n1 - d1)
            if not (
                d1 > d0
                and math.isfinite(speed.get(e, math.inf))
                and s < REACH_SLACK * (d1 - d0) + PCONFUSION
            ):
                continue
            knots = n0 + (g.knots - d0) * ((n1 - n0) / (d1 - d0))
            knots[0], knots[-1] = n0, n1
            if not (np.diff(knots) > 0).all():
                continue
            new = replace(g, knots=knots)
            if uses[i] > 1 or i in held:
                uses[i] -= 1
                table.append(new)
                reps[q, col] = len(table) - 1
            else:
                table[i] = new
            widen[e] = max(widen[e], s * speed[e])
    if not widen.any():
        return m
    out: Any = replace(m)
    out.curves2d = table
    out.edge_reps = reps
    out.edge_tol = np.where(widen > 0, round_up(m.edge_tol + MARGIN * widen), m.edge_tol)
    return out


#: A stored B-spline pcurve of at least this many poles is offered to
#: :func:`compact_kept`.
COMPACT_MIN_POLES = 12
#: How far on its surface a re-approximated pcurve may move, as a share of
#: tol: the edge's and its vertices' tolerances grow by as much.
COMPACT_SHARE = 0.25

#: What :func:`compact_kept` asks the approximation: (surfaces, curves3d,
#: curves2d, curve row, surface row, first, last, within) -> (record, uv ends,
#: moved) or None (``occ.compact_pcurve``).
Approximate = Callable[
    [list[Geometry], list[Geometry], list[Geometry], int, int, float, float, float],
    "tuple[BSplineCurve, np.ndarray, float] | None",
]
#: Its answers by a digest of all they read (the rounds ask again for the
#: same rows: 0.1 s for a pcurve of 2,000 poles).
_COMPACTED: Memo[Any] = Memo(10_000)


def _record_parts(m: BRepModel, which: str, i: int) -> list[Any]:
    """Every field of row ``i`` of ``m``'s table ``which`` ("surface",
    "curve3d", "curve2d") and of the rows it derives from (a swept surface's
    curve is a 3-D curve row)."""
    out: list[Any] = []
    while True:
        g = {"surface": m.surfaces, "curve3d": m.curves3d, "curve2d": m.curves2d}[which][i]
        out.extend((which, type(g).__name__))
        out.extend(getattr(g, f.name) for f in fields(g))
        if not isinstance(g, Derived):
            return out
        if which == "surface" and g.kind in SWEPT:
            which = "curve3d"
        i = g.basis


def compact_kept(
    m: BRepModel, tol: float, whole: Set[int], approximate: Approximate
) -> tuple[BRepModel, frozenset[int]]:
    """``m`` (a candidate, its ranges final) with each stored B-spline pcurve
    of ``COMPACT_MIN_POLES`` or more replaced by ``approximate``'s curve of at
    most half its poles that stays within ``COMPACT_SHARE``·tol of it on its
    surface, where there is one; and the edges whose pcurves were replaced.

    The stored pcurves are those the validity stage keeps (OCCT's projection
    of the coded edge failed a check), as the source was read: an offset
    face's trimming curves can have 2,000 poles of degree 11 where the edge's
    3-D curve has 26 (a shelled loft written by OCCT: 26 of its 34 kB at
    0.1 mm).  The pcurve moves by the measured distance on the surface, so
    the edge's tolerance and its vertices' grow by it (``MARGIN``, rounded
    up to a power of two, as ``assembly`` widens them); its uv end points
    are the new curve's.  Edges in ``whole`` keep their pcurves as they are
    (a rung of the validity stage); so do pcurves another edge, a vertex or
    a derived curve refers to."""
    reps = m.edge_reps
    kind = reps[:, EC.KIND]
    closed = kind == RepKind.ON_CLOSED_SURFACE
    pc = (kind == RepKind.ON_SURFACE) | closed
    refs = collections.Counter(reps[pc, EC.CURVE].tolist() + reps[closed, EC.CURVE2].tolist())
    vr = m.vertex_reps
    held = set(vr[vr[:, VC.KIND] == PointRepKind.ON_CURVE_ON_SURFACE, VC.CURVE].tolist())
    held |= {g.basis for g in m.curves2d if isinstance(g, Derived)}
    within = COMPACT_SHARE * tol
    curves2d, uv = list(m.curves2d), m.edge_rep_uv.copy()
    moved_e = np.zeros(len(m.edge_tol))
    for q in np.flatnonzero(pc).tolist():
        e, surface = int(reps[q, EC.EDGE]), int(reps[q, EC.SURFACE])
        if e in whole:
            continue
        first, last = m.edge_rep_range[q].tolist()
        for col, at in ((EC.CURVE, 0), (EC.CURVE2, 4)):
            c = int(reps[q, col])
            g = m.curves2d[c] if c >= 0 and (col == EC.CURVE or closed[q]) else None
            if not isinstance(g, BSplineCurve) or len(g.poles) < COMPACT_MIN_POLES:
                continue
            if refs[c] != 1 or c in held:
                continue
            key = digest(
                *_record_parts(m, "curve2d", c),
                *_record_parts(m, "surface", surface),
                first,
                last,
                within,
            )
            ask = functools.partial(
                approximate, m.surfaces, m.curves3d, m.curves2d, c, surface, first, last
            )
            got = _COMPACTED.get(key, functools.partial(ask, within))
            if got is None:
                continue
            curves2d[c], uv[q, at : at + 4] = got[0], got[1]
            moved_e[e] = max(moved_e[e], got[2])
    if not moved_e.any():
        return m, frozenset()
    tidx = m.type_index()
    edge_shape = np.flatnonzero(m.shape_type == ShapeType.EDGE)
    moved_v = np.zeros(len(m.vertex_tol))
    for e in np.flatnonzero(moved_e).tolist():
        for v in below(m, int(edge_shape[e]), ShapeType.VERTEX):
            moved_v[tidx[v]] = max(moved_v[tidx[v]], moved_e[e])
    out: Any = replace(m)
    out.curves2d, out.edge_rep_uv = curves2d, uv
    out.edge_tol = np.where(moved_e > 0, round_up(m.edge_tol + MARGIN * moved_e), m.edge_tol)
    out.vertex_tol = np.where(moved_v > 0, round_up(m.vertex_tol + MARGIN * moved_v), m.vertex_tol)
    return out, frozenset(np.flatnonzero(moved_e).tolist())
