"""Tables -> model: the decoder's geometric steps, in the documented order.

:mod:`nurbscomp.serialize` turns a container's bytes into tables and back and
does no geometry.  This module does what those tables mean (docs/format.md
§2.4, §2.7, §2.9, §2.10), in the order :func:`apply` runs them:

0. every location's matrix checked (finite, within ``MAX_COORD``);
1. edge ranges the EDGE section left to rules (the curve's own range, the
   edge's 3-D curve's, the projections of its vertices: :func:`range_kinds`);
2. SNET: every coded surface net, each first pole against the previous net's
   (:func:`codec.decode_net`, the one closed-loop function the encoder uses);
3. net corners pinned to their vertices (:func:`joins.surface_corner_pins`;
   from format 1.2, a corner within its net's grid step of one: :func:`joins.pin_radius`);
4. SIDE: net sides set to another net's decoded side;
5. CNET: every coded curve, anchored at its vertices (:func:`joins.anchors`),
   its ends then pinned to them, and the copies of other curves last.

:func:`tables` is the writer's side of the same steps: the range rules that
predict each range bit for bit, and the net codes in the order and on the
origins these steps will use (:func:`codec.reorigin`).
"""

from __future__ import annotations

from collections.abc import Collection
from typing import Any, cast

import numpy as np

from . import budget, codec, container, coons, dmap, joins, serialize, spatial
from .errors import BadReferenceError, SectionError
from .model import (
    EC,
    BRepModel,
    BSplineCurve,
    BSplineSurface,
    Derived,
    Geometry,
    Kind,
    Rec,
    RepKind,
    Table,
    first_row,
)
from .serialize import (
    MAX_COORD,
    MAX_LEVEL,
    RANGE_NATURAL,
    RANGE_OF_3D,
    RANGE_STORED,
    RANGE_VERTICES,
    RANGE_ZERO,
    NetTable,
    Tables,
    coded_rows,
    finite,
)

# ---------------------------------------------------------------- net geometry


def net_basis(g: Geometry) -> dmap.Basis | None:
    """What the D-map needs of a surface record: clamped, non-periodic B-splines only."""
    if not joins.clamped_surface(g):
        return None
    assert isinstance(g, BSplineSurface)
    if g.bezier:
        nu, nv = g.poles.shape[:2]
        ends = np.array([0.0, 1.0])
        nus, nvs = np.array([nu, nu]), np.array([nv, nv])
        return dmap.Basis.of(ends, nus, ends, nvs, nu - 1, nv - 1, g.weights)
    return dmap.Basis.of(g.uknots, g.umults, g.vknots, g.vmults, g.udegree, g.vdegree, g.weights)


def net_abscissae(g: Geometry) -> tuple[np.ndarray | None, np.ndarray | None]:
    """Normalised Greville abscissae of a surface's net (Coons blending); None for curves."""
    if not isinstance(g, BSplineSurface):
        return None, None
    nu, nv = g.poles.shape[:2]
    s = coons.unit_abscissae(coons.greville(g.uknots, g.umults, g.udegree, nu))
    t = coons.unit_abscissae(coons.greville(g.vknots, g.vmults, g.vdegree, nv))
    return s, t


# ---------------------------------------------------------------- edge ranges


def _natural_range(g: Geometry | None) -> tuple[float, float] | None:
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
        nat = _natural_range(_curve_of(m, q))
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
        nat = _natural_range(_curve_of(m, q))
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


# ---------------------------------------------------------------- the writer's side


def _net_table(
    records: list[Geometry],
    which: Table,
    codes: dict[Rec, codec.NetCode],
    tol: float,
    anchors: dict[int, np.ndarray] | None = None,
    choices: dict[int, np.ndarray] | None = None,
) -> NetTable:
    """The codes of the coded records of a table (the model's ``which`` table),
    in the order of their first rows.

    Each code is re-based on the origin the decoder will use: the previous
    coded row's decoded first pole (:func:`codec.reorigin`), or the row's
    anchor point where it has one (:func:`joins.anchors`).  With ``choices``
    (``SNET`` from format 2.1: per row, the points of
    :func:`joins.surface_anchor_candidates`), a row is coded against the one
    of them, or the previous pole, whose first integers cost the fewest
    bits (:func:`_anchor_choice`), and the table gets an anchor column.
    """
    anchors = anchors or {}
    order = []
    picked = []
    origin = None
    for row, first in enumerate(first_row(records)):
        if row == first and Rec(which, row) in codes:
            g = records[row]
            code = codes[Rec(which, row)]
            if code.method == codec.Method.COPY:  # filled last: not on the origin chain
                order.append(code)
                picked.append(0)
                continue
            k = 0
            if code.method != codec.Method.ISO:  # an ISO code holds references, no point
                code = codec.reorigin(code, anchors.get(row, origin), tol)
                if choices is not None and len(choices.get(row, ())):
                    k = _anchor_choice(code, choices[row], tol)
                    if k:
                        code = codec.reorigin(code, choices[row][k - 1], tol)
            order.append(code)
            picked.append(k)
            poles = cast(BSplineCurve | BSplineSurface, g).poles
            origin = poles.reshape(-1, poles.shape[-1])[0] if code.first is None else code.first

    def col(name: str) -> np.ndarray:
        return np.array([int(getattr(c, name)) for c in order], np.int64)

    return NetTable(
        col("method"),
        col("quant"),
        col("level"),
        col("slope"),
        [c.ints for c in order],
        np.concatenate([c.dcs for c in order]) if order else np.zeros(0),
        None if choices is None else np.array(picked, np.int64),
    )


def _anchor_choice(code: codec.NetCode, points: np.ndarray, tol: float) -> int:
    """0, or k > 0 for the k-th of ``points`` (k, 3): the origin that costs
    ``code``'s first pole the fewest bits (:func:`codec.cost_bits` of its
    first three integers, plus the anchor's own: the previous net's first
    pole on a tie)."""
    h = tol * code.grid
    old = np.zeros(3) if code.origin is None else code.origin
    head = code.ints[:3] + spatial.snap(old, h)
    best, pick = codec.cost_bits(code.ints[:3]) + 1, 0
    for k, pt in enumerate(points, 1):
        bits = codec.cost_bits(head - spatial.snap(pt, h)) + codec.cost_bits(np.array([k]))
        if bits < best:
            best, pick = bits, k
    return pick


def _surface_choices(m: BRepModel, codes: dict[Rec, codec.NetCode]) -> dict[int, np.ndarray]:
    """Per coded surface row, the points of its anchor candidates (format 2.1)."""
    rows = [k.row for k in codes if k.table == Table.SURFACE]
    cands = joins.surface_anchor_candidates(m, rows)
    return {r: m.vertex_point[v] for r, v in cands.items()}


def _curve_anchors(m: BRepModel, codes: dict[Rec, codec.NetCode]) -> dict[int, np.ndarray]:
    rows = {k.row for k in codes if k.table == Table.CURVE3D}
    return joins.anchors(m, m.curves3d, rows)


def tables(m: BRepModel, codes: dict[Rec, codec.NetCode] | None, tol: float) -> Tables:
    """What the writer stores besides ``m``'s own tables so that :func:`apply`
    rebuilds ``m``: the range rules, and the net codes (``codes`` maps
    B-spline records, :class:`model.Rec`, to their codes; ``m`` holds their
    *decoded* poles)."""
    codes = codes or {}
    return Tables(
        _net_table(m.surfaces, Table.SURFACE, codes, tol, None, _surface_choices(m, codes)),
        _net_table(m.curves3d, Table.CURVE3D, codes, tol, _curve_anchors(m, codes)),
        range_kinds(m),
        frozenset(codes),
    )


def model_to_sections(
    m: BRepModel,
    meta: dict[str, Any],
    codes: dict[Rec, codec.NetCode] | None = None,
    only: Collection[str] | None = None,
) -> list[tuple[str, bytes]]:
    """The sections of a container holding ``m`` (:func:`serialize.model_to_sections`
    of ``m`` and its :func:`tables`; ``only``: just the sections of these tags)."""
    tol = float(meta.get("tolerance_mm") or 0.0)
    return serialize.model_to_sections(m, meta, tables(m, codes, tol), only)


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
    surface method 10 (``SPATIAL2``) from revision 3 (format 2.0) only."""
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
    surface = codec.SURFACE_METHODS_2 if revision >= 3 else codec.SURFACE_METHODS
    allowed = surface if tag == "SNET" else codec.CURVE_COPIES
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
) -> list[tuple[int, int, codec.NetCode]]:
    """Decode a net table into the poles of the coded rows, in row order.

    ``Method.COPY`` rows are left for :func:`_fill_copies` and returned as
    (net number, row, code).

    Each net's first pole is coded against the previous net's decoded first
    pole (the origin chain of :func:`codec.encode_net`).
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
                net, used = codec.decode_net(code, shape, s, u, tol, at, net_basis(g))
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


def _surface_anchors(m: BRepModel, t: NetTable, rows: list[int]) -> dict[int, np.ndarray]:
    """The points a format 2.1 ``SNET`` codes first poles against: per row
    whose anchor k > 0, the k-th vertex of :func:`joins.surface_anchor_candidates`
    (a k past them, or below 0, is a ``SectionError``)."""
    if t.anchor is None:
        return {}
    cands = joins.surface_anchor_candidates(m, rows)
    out = {}
    for k, (row, a) in enumerate(zip(rows, t.anchor.tolist(), strict=True)):
        if a == 0:
            continue
        verts = cands.get(row, [])
        if not 0 < a <= len(verts):
            raise SectionError(f"SNET: net {k} (table row {row}): no anchor vertex {a}")
        out[row] = m.vertex_point[verts[a - 1]]
    return out


def apply(m: BRepModel, t: Tables, tol: float, revision: int) -> None:
    """Run the decoder's geometric steps (module docstring) on ``m``, in place,
    as the file's version (``container.VERSIONS[revision]``) defines them (from
    1.2 a net's corners are pinned only to a vertex within its own grid step:
    :func:`joins.pin_radius`)."""
    check_location_matrices(m)
    resolve_ranges(m, t.range_how)
    srows = coded_rows(m.surfaces)
    coded_surfaces = set(srows)
    _decode_nets(
        t.snet, m.surfaces, tol, "SNET", _surface_anchors(m, t.snet, srows), None, revision
    )
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
    with np.errstate(all="ignore"):  # overflows become non-finite values, refused by name
        apply(m, t, serialize.tolerance(meta), revision)
    if limits is not None:
        budget.check_projections(m)
    return m, meta
