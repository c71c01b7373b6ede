"""Tables -> model: the decoder's geometric steps, in the documented order.

:mod:`nurbscomp.serialize` turns a container's bytes into tables and back and
does no geometry.  This module does what those tables mean (docs/format.md
§2.4, §2.7, §2.9, §2.10), in the order :func:`apply` runs them:

0. every location's matrix checked (finite, within ``MAX_COORD``), then
   (2.2) the frames of the lines that go through their edge's vertices and
   (2.4) of the circles through their edge's vertex about their face's axis
   made (:func:`joins.through_vertices`);
1. edge ranges the EDGE section left to rules (the curve's own range, the
   edge's 3-D curve's, the projections of its vertices: ``rules.ranges``);
2. SNET: every coded surface net, each first pole against the previous net's
   (:func:`codec.decode_net`, the one closed-loop function the encoder uses);
3. net corners pinned to their vertices (:func:`joins.surface_corner_pins`;
   from format 1.2, a corner within its net's grid step of one: :func:`joins.pin_radius`);
4. SIDE: net sides set to another net's decoded side;
5. CNET: every coded curve, anchored at its vertices (:func:`joins.anchors`),
   its ends then pinned to them, and the copies of other curves last.

:mod:`nurbscomp.writer` is the writer's side of the same steps: the range
rules that predict each range bit for bit, and the net codes in the order and
on the origins these steps will use (:func:`codec.reorigin`).  The rules
both take are in :mod:`nurbscomp.rules`.
"""

from __future__ import annotations

from typing import Any, cast

import numpy as np

from . import budget, codec, container, serialize
from .errors import SectionError
from .model import (
    BRepModel,
    BSplineCurve,
    BSplineSurface,
    Geometry,
)
from .rules import joins
from .rules.nets import net_abscissae, net_basis
from .rules.ranges import resolve_ranges
from .serialize import (
    MAX_COORD,
    MAX_LEVEL,
    NetTable,
    Tables,
    coded_rows,
    finite,
)

# ---------------------------------------------------------------- the reader's side


def _iso_copy(code: codec.NetCode, g: Geometry, surfaces: list[Geometry]) -> np.ndarray:
    """The poles of a curve coded as a decoded surface's boundary (``Method.ISO``)."""
    if len(code.ints) != 3:
        raise ValueError("an ISO code holds three integers")
    r, side, rev = (int(x) for x in code.ints)
    if not 0 <= r < len(surfaces) or not isinstance(surfaces[r], BSplineSurface):
        raise ValueError("an ISO code refers to a missing B-spline surface")
    if not 0 <= side < joins.SIDES or rev not in (0, 1):
        raise ValueError("an ISO code names no boundary")
    poles = joins.boundary(surfaces[r].poles, side, bool(rev))  # type: ignore[union-attr]
    if poles.shape != g.poles.shape:  # type: ignore[union-attr]
        raise ValueError("an ISO code's boundary has another number of poles")
    return poles.copy()


def twin_copy(
    code: codec.NetCode, row: int, curves: list[Geometry], copies: set[int]
) -> np.ndarray:
    """The poles of a curve row coded as a copy of another row's (``Method.COPY``,
    ints: this row minus the other, reversed flag): the other row's final
    poles (decoded and pinned), reversed if the flag says so.  The other row
    is a B-spline curve that is not a copy itself."""
    g = curves[row]
    if len(code.ints) != 2:
        raise ValueError("a COPY code holds two integers")
    back, rev = (int(x) for x in code.ints)
    r = row - back
    if not 0 <= r < len(curves) or r in copies or not isinstance(curves[r], BSplineCurve):
        raise ValueError("a COPY code refers to no B-spline curve that is not a copy")
    if rev not in (0, 1):
        raise ValueError("a COPY code's reversed flag is not 0 or 1")
    poles = curves[r].poles  # type: ignore[union-attr]
    if poles.shape != g.poles.shape:  # type: ignore[union-attr]
        raise ValueError("a COPY code's curve has another number of poles")
    return (poles[::-1] if rev else poles).copy()


def _check_headers(t: NetTable, tag: str, tol: float, revision: int = container.REVISION) -> None:
    """The quantizer settings and methods of a net table (docs/format.md §2.4):
    surface method 10 (``SPATIAL2``) from revision 3 (format 2.0) only, curve
    method 11 (``ANCHORED``) from format 2.10 only, surface methods 12 to 22
    (``ARCS_V``, ``ARCS_U``, the ``ORDERS_*``) from format 2.14 only."""
    n = len(t.method)
    if n and not 0 < tol < MAX_COORD:
        raise SectionError(f"{tag}: coded nets need a positive, finite tolerance")
    if (t.quant != codec.Quant.TOL).any():
        # quantizer 1 (the paper's, eq. 10 and 27) is reserved: no writer ever
        # wrote it (docs/format.md §2.4), and no reader decodes it
        raise SectionError(f"{tag}: quantizer {int(t.quant[t.quant != 0][0])} is reserved")
    if (t.slope < 0).any() or (t.slope >= len(codec.SLOPES)).any():
        raise SectionError(f"{tag}: bad quantizer slope")
    if n and np.abs(t.level).max() > MAX_LEVEL:
        raise SectionError(f"{tag}: quantizer level out of range")
    surface: tuple[codec.Method, ...] = codec.SURFACE_METHODS
    if revision >= ARC_ROWS:
        surface = codec.SURFACE_METHODS_14
    elif revision >= 3:
        surface = codec.SURFACE_METHODS_2
    curve: tuple[codec.Method, ...] = codec.CURVE_COPIES
    if revision < ANCHORED_CURVES:
        curve = tuple(m for m in curve if m != codec.Method.ANCHORED)
    allowed = surface if tag == "SNET" else curve
    if n and not np.isin(t.method, [int(x) for x in allowed]).all():
        raise SectionError(f"{tag}: a coding method that does not apply to this table")


def _decode_nets(
    t: NetTable,
    records: list[Geometry],
    tol: float,
    tag: str,
    anchors: dict[int, np.ndarray] | None = None,
    surfaces: list[Geometry] | None = None,
    revision: int = container.REVISION,
    corners: dict[int, dict[int, np.ndarray]] | None = None,
) -> list[tuple[int, int, codec.NetCode]]:
    """Decode a net table into the poles of the coded rows, in row order.

    ``Method.COPY`` rows are left for :func:`_fill_copies` and returned as
    (net number, row, code).

    Each net's first pole is coded against the previous net's decoded first
    pole (the origin chain of :func:`codec.encode_net`), or its anchor;
    ``corners`` (format 2.10): per row, corners coded against vertices.
    """
    _check_headers(t, tag, tol, revision)
    rows = coded_rows(records)
    origin = None
    dpos = 0
    copies: list[tuple[int, int, codec.NetCode]] = []
    for k, row in enumerate(rows):
        g = records[row]
        try:
            code = codec.NetCode(
                codec.Method(int(t.method[k])),
                codec.Quant(int(t.quant[k])),
                int(t.level[k]),
                int(t.slope[k]),
                t.ints[k],
                t.dcs[dpos:],
                0.0,
                0.0,
            )
            s, u = net_abscissae(g)
            if code.method == codec.Method.COPY:
                copies.append((k, row, code))
                continue
            if code.method == codec.Method.ISO:
                net, used = _iso_copy(code, g, surfaces or []), 0
            else:
                at = (anchors or {}).get(row, origin)
                shape = cast(BSplineCurve | BSplineSurface, g).poles.shape
                at_corners = (corners or {}).get(row)
                net, used = codec.decode_net(code, shape, s, u, tol, at, net_basis(g), at_corners)
        except (ValueError, ArithmeticError) as e:  # LinAlgError is a ValueError
            raise SectionError(f"{tag}: net {k} (table row {row}): {e}") from None
        finite(net, f"{tag}: net {k} (table row {row})", MAX_COORD)
        dpos += used
        cast(BSplineCurve | BSplineSurface, g).poles[...] = net
        origin = net.reshape(-1, net.shape[-1])[0]
    if dpos != len(t.dcs):
        raise SectionError(f"{tag}: unread DC coefficients from value {dpos}")
    return copies


def _fill_copies(copies: list[tuple[int, int, codec.NetCode]], m: BRepModel) -> None:
    """Set the poles of ``Method.COPY`` rows (CNET), after every other row is
    decoded and pinned: each is its leader row's final poles, moved by
    :func:`joins.copy_matrix` where the two sit in frames of their own."""
    if not copies:
        return
    records = m.curves3d
    where = joins.curve_placements(m)
    leaders = {row for _, row, _ in copies}
    for k, row, code in copies:
        try:
            net = twin_copy(code, row, records, leaders)
            t = joins.copy_matrix(where, row, row - int(code.ints[0]))
            if t is not None:
                net = joins.placed(net, t)
        except ValueError as e:
            raise SectionError(f"CNET: net {k} (table row {row}): {e}") from None
        records[row].poles[...] = net  # type: ignore[union-attr]


def _join_sides(m: BRepModel) -> None:
    """Apply each row of ``m.side_joins``, in order, to the decoded nets (after
    SNET and the corner pins, before CNET)."""
    for k, (b, side, a, lside, rev) in enumerate(m.side_joins.tolist()):
        where = f"SIDE row {k}"
        if not (0 <= side < joins.SIDES and 0 <= lside < joins.SIDES and rev in (0, 1)):
            raise SectionError(f"{where}: no such side")
        g, lead = m.surfaces[b], m.surfaces[a]
        if not (joins.clamped_surface(g) and joins.clamped_surface(lead)):
            raise SectionError(f"{where}: joins a surface that is not a clamped B-spline")
        assert isinstance(g, BSplineSurface) and isinstance(lead, BSplineSurface)
        try:
            g.poles[...] = joins.joined_sides(g, lead, np.array([b, side, a, lside, rev]))
        except ValueError as e:
            raise SectionError(f"{where}: {e}") from None


def check_location_matrices(m: BRepModel) -> None:
    """Raise ``SectionError`` unless every location's matrix (its datums raised
    to their powers, :func:`joins.location_matrix`) is finite and within
    ``MAX_COORD``: OCCT's STEP writer crashes on an overflowed one (found by
    the structure-aware fuzzer: a 1e100 scale raised to the power 2^31 - 1),
    and no singular matrix is raised to a negative power (it has no inverse)."""
    for k in range(1, len(m.locations)):
        try:
            t = joins.location_matrix(m, k)
        except np.linalg.LinAlgError:
            raise SectionError(
                f"LOCS: location {k} raises a singular matrix to a negative power"
            ) from None
        if not (np.abs(t) < MAX_COORD).all():
            raise SectionError(f"LOCS: location {k}'s matrix is not finite or out of range")


def _surface_anchors(
    m: BRepModel, t: NetTable, rows: list[int]
) -> tuple[dict[int, np.ndarray], dict[int, dict[int, np.ndarray]]]:
    """The points a format 2.1 ``SNET`` codes first poles against: per row
    whose anchor k > 0, the k-th vertex of :func:`joins.surface_anchor_candidates`;
    and (format 2.10) per row, its corners coded against such a vertex (corner
    1-3 -> point).  A k past them, or below 0, is a ``SectionError``."""
    if t.anchor is None:
        return {}, {}
    cands = joins.surface_anchor_candidates(m, rows)

    def vertex(k: int, row: int, a: int) -> np.ndarray:
        verts = cands.get(row, [])
        if not 0 < a <= len(verts):
            raise SectionError(f"SNET: net {k} (table row {row}): no anchor vertex {a}")
        return m.vertex_point[verts[a - 1]]

    out = {}
    for k, (row, a) in enumerate(zip(rows, t.anchor.tolist(), strict=True)):
        if a != 0:
            out[row] = vertex(k, row, a)
    corners: dict[int, dict[int, np.ndarray]] = {}
    if t.corners is not None:
        for k, (row, picks) in enumerate(zip(rows, t.corners.tolist(), strict=True)):
            at = {c: vertex(k, row, a) for c, a in enumerate(picks, 1) if a != 0}
            if at:
                corners[row] = at
    return out, corners


def apply(m: BRepModel, t: Tables, tol: float, revision: int) -> None:
    """Run the decoder's geometric steps (module docstring) on ``m``, in place,
    as the file's version (``container.VERSIONS[revision]``) defines them (from
    1.2 a net's corners are pinned only to a vertex within its own grid step:
    :func:`joins.pin_radius`)."""
    check_location_matrices(m)
    joins.through_vertices(m)  # 2.2, 2.4: before the ranges from vertices on them
    resolve_ranges(m, t.range_how)
    srows = coded_rows(m.surfaces)
    coded_surfaces = set(srows)
    anchors, corners = _surface_anchors(m, t.snet, srows)
    _decode_nets(t.snet, m.surfaces, tol, "SNET", anchors, None, revision, corners)
    radius = None  # before 1.2: every corner within tol of a vertex of its face
    if revision >= 2:
        radius = {
            row: joins.pin_radius(tol, int(t.snet.quant[k]), int(t.snet.level[k]))
            for k, row in enumerate(srows)
        }
    for r, pins in joins.surface_corner_pins(m, m.surfaces, coded_surfaces, tol, radius).items():
        g = m.surfaces[r]
        g.poles[...] = joins.pinned_corners(m, g, pins)  # type: ignore[union-attr,arg-type]
    _join_sides(m)
    coded_curves = set(coded_rows(m.curves3d))
    anchors = joins.anchors(m, m.curves3d, coded_curves)
    copies = _decode_nets(t.cnet, m.curves3d, tol, "CNET", anchors, m.surfaces)
    pinned = coded_curves - {row for _, row, _ in copies}
    for c, pins in joins.curve_end_pins(m, m.curves3d, pinned, tol).items():
        g = cast(BSplineCurve, m.curves3d[c])
        g.poles[...] = joins.pinned_poles(m, g, pins)
    _fill_copies(copies, m)


#: Format 2.8: the first revision whose degenerated edges' pcurves follow
#: their computed neighbours (docs/format.md §2.8).
POLES_FOLLOW = container.VERSIONS.index((2, 8))
#: Format 2.9: the first revision whose computed pcurves on a trimmed
#: surface of a periodic basis are moved into its bounds (docs/format.md §2.8, *(2.9)*).
PERIODS_IN_RANGE = container.VERSIONS.index((2, 9))
#: Format 2.10: the first revision whose ``CNET`` may hold curves coded between
#: their anchors (method 11, docs/format.md §2.4, *(2.10)*).
ANCHORED_CURVES = container.VERSIONS.index((2, 10))
#: Format 2.14: surface methods 12 to 22 (``ARCS_V``, ``ARCS_U``, the ``ORDERS_*``).
ARC_ROWS = container.VERSIONS.index((2, 14))
#: Format 2.15: the first revision whose left-out pcurves are projected face
#: by face, the projector's end points carried along each face's wires
#: (docs/format.md §3, *(2.15)*).
PCURVES_BY_FACE = container.VERSIONS.index((2, 15))
#: Format 2.16: the first revision whose computed seams that ``FixShifted``
#: put onto one another are set again (docs/format.md §2.8, *(2.16)*).
SEAMS_SET = container.VERSIONS.index((2, 16))


def sections_to_model(
    get: Any,
    revision: int | None = None,
    limits: budget.Limits | None = budget.DEFAULT,
) -> tuple[BRepModel, dict[str, Any]]:
    """Rebuild a model from a section lookup ``get(tag) -> bytes``: the tables
    (:func:`serialize.read_sections`, every reference and the decoding budget
    checked), then :func:`apply`.  Raises what :func:`serialize.read_sections`
    raises, and ``SectionError`` or ``BadReferenceError`` where a net, a range
    rule or a side join does not decode.
    """
    revision = container.REVISION if revision is None else revision
    m, meta, t = serialize.read_sections(get, revision, limits)
    m.poles_follow = revision >= POLES_FOLLOW
    m.periods_in_range = revision >= PERIODS_IN_RANGE
    m.pcurves_by_face = revision >= PCURVES_BY_FACE
    m.seams_set = revision >= SEAMS_SET
    with np.errstate(all="ignore"):  # overflows become non-finite values, refused by name
        apply(m, t, serialize.tolerance(meta), revision)
    if limits is not None:
        budget.check_projections(m)
    return m, meta
