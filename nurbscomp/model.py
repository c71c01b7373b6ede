"""The B-rep model: geometry records and topology tables as plain numpy data.

The layout follows OCCT's own ``BRepTools_ShapeSet``: a table of locations, tables
of surfaces, 3-D curves and 2-D curves, and one table of shapes in which every
shape refers to its sub-shapes by index, with an orientation and a location.
A sub-shape shared by several parents (an edge between two faces) is stored once.

Nothing here imports OCP: ``nurbscomp.occ`` converts at the door, and the codec
and the container see only these records.
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields, replace
from enum import IntEnum
from typing import Any, NamedTuple

import numpy as np


class Kind(IntEnum):
    """Geometry kinds.  Values are part of the container format: never renumber."""

    # surfaces
    PLANE = 0
    CYLINDER = 1
    CONE = 2
    SPHERE = 3
    TORUS = 4
    REVOLUTION = 5
    EXTRUSION = 6
    OFFSET_SURFACE = 7
    TRIMMED_SURFACE = 8
    BEZIER_SURFACE = 9
    BSPLINE_SURFACE = 10
    # curves, 2-D or 3-D
    LINE = 16
    CIRCLE = 17
    ELLIPSE = 18
    HYPERBOLA = 19
    PARABOLA = 20
    BEZIER_CURVE = 21
    BSPLINE_CURVE = 22
    TRIMMED_CURVE = 23
    OFFSET_CURVE = 24


SURFACE_KINDS = frozenset(k for k in Kind if k < 16)


class Table(IntEnum):
    """The geometry tables whose records the encoder codes (not part of the container format)."""

    SURFACE = 0
    CURVE3D = 1


class Rec(NamedTuple):
    """A geometry record of a model, by table and row: the distinct object of
    ``table`` first held at ``row`` (:func:`first_row`).

    Rows that hold one object share its record (the container writes the later
    ones as COPY rows), so a record is named by its first row, and a table
    whose objects are replaced (a coded record by its decoded version, every
    row of it alike) keeps its records' names.
    """

    table: Table
    row: int


def first_row(table: list[Any]) -> list[int]:
    """Per row of a geometry table, the first row holding the same object
    (the row itself when it is the first)."""
    seen: dict[int, int] = {}
    return [seen.setdefault(id(g), i) for i, g in enumerate(table)]


def rows_by_owner(owner: np.ndarray, n: int) -> list[list[int]]:
    """Rows of a representation table (``owner``: its owner column), grouped
    by owner row 0 … n − 1, each group in table order."""
    out: list[list[int]] = [[] for _ in range(n)]
    for q, o in enumerate(owner.tolist()):
        out[o].append(q)
    return out


def records(table: list[Any], which: Table) -> list[Rec]:
    """Per row of ``table`` (the ``which`` table of a model), its record."""
    return [Rec(which, r) for r in first_row(table)]


class ShapeType(IntEnum):
    """Shape types, numbered as OCCT's ``TopAbs_ShapeEnum``."""

    COMPOUND = 0
    COMPSOLID = 1
    SOLID = 2
    SHELL = 3
    FACE = 4
    WIRE = 5
    EDGE = 6
    VERTEX = 7


class RepKind(IntEnum):
    """Curve representations on an edge (``BRep_CurveRepresentation`` subclasses)."""

    CURVE3D = 0  # curve, location, range
    ON_SURFACE = 1  # pcurve, surface, location, range, uv end points
    ON_CLOSED_SURFACE = 2  # two pcurves (seam), surface, location, range, uv points, continuity
    ON_TWO_SURFACES = 3  # regularity: surface, surface2, location, location2, continuity


class EdgeCol(IntEnum):
    """Columns of ``BRepModel.edge_reps``: one row per curve representation of
    an edge; -1 where a column does not apply to the row's kind."""

    EDGE = 0  # the edge's row
    KIND = 1  # RepKind
    CURVE = 2  # 3-D curve (CURVE3D) or pcurve (ON_SURFACE, ON_CLOSED_SURFACE); REBUILD
    CURVE2 = 3  # the seam's second pcurve (ON_CLOSED_SURFACE)
    SURFACE = 4  # the pcurve's surface, or the first of ON_TWO_SURFACES
    SURFACE2 = 5  # the second surface of ON_TWO_SURFACES
    LOC = 6  # location of the curve or surface
    LOC2 = 7  # location of SURFACE2


class VertexCol(IntEnum):
    """Columns of ``BRepModel.vertex_reps``: one row per point representation
    of a vertex."""

    VERTEX = 0  # the vertex's row
    KIND = 1  # PointRepKind
    CURVE = 2  # 3-D curve (ON_CURVE) or pcurve (ON_CURVE_ON_SURFACE)
    SURFACE = 3  # surface (ON_CURVE_ON_SURFACE, ON_SURFACE)
    LOC = 4  # location


#: Short names of :class:`EdgeCol` and :class:`VertexCol`, for indexing.
EC, VC = EdgeCol, VertexCol


#: Curve index of a pcurve representation that the decoder computes itself
#: (projection of the edge's 3-D curve onto the face's surface).
REBUILD = -2


class PointRepKind(IntEnum):
    """Point representations on a vertex (``BRep_PointRepresentation`` subclasses)."""

    ON_CURVE = 0  # parameter, 3-D curve, location
    ON_CURVE_ON_SURFACE = 1  # parameter, pcurve, surface, location
    ON_SURFACE = 2  # u, v, surface, location


@dataclass(frozen=True, eq=False)
class Analytic:
    """A plane, quadric, line or conic: a frame plus a few scalars.

    Parameters
    ----------
    kind : Kind
    frame : ndarray, shape (k, dim)
        Row 0 is the origin; the other rows are the axis directions as OCCT
        stores them (``gp_Ax3``: main, X, Y; ``gp_Ax2``: main, X, Y;
        ``gp_Ax22d``: X, Y; ``gp_Ax1``/``gp_Ax2d``: direction).
    params : ndarray, shape (m,)
        Radii, semi-angle, focal length, in OCCT's constructor order.
    grid : int
        0, or (tolerance mode, format 2.0) g in 1 ... 127: the origin's
        coordinates in ``mask`` and the lengths among ``params`` (every one
        but a cone's semi-angle) are integers times 2^(g - 64), and are
        written as those integers.
    mask : int
        Bit j set: the origin's coordinate j is on the grid (7 when all are).
    through : int
        0, or (tolerance mode) the container holds no value of the record, or
        not its origin: a LINE (``CRV3``, 1, format 2.2) goes through its
        edge's vertices; a CIRCLE (``CRV3``, format 2.4) goes through its
        first edge's FORWARD vertex about the axis of a face of that edge, its
        normal along that axis (1) or against it (-1); a PLANE (``SURF``, 1,
        format 2.7) has its origin at a vertex of its first face, a CYLINDER
        (``SURF``, q + 1, 2.7) its axis at its radius from that vertex against
        its X, Y, −X or −Y direction (q = 0 … 3).  The decoder
        makes them from the decoded vertices and surfaces
        (``rules.joins.through_vertices``).
    """

    kind: Kind
    frame: np.ndarray
    params: np.ndarray
    grid: int = 0
    mask: int = 0
    through: int = 0


@dataclass(frozen=True, eq=False)
class BSplineCurve:
    """A B-spline or Bezier curve (eq. 3), 2-D or 3-D.

    Parameters
    ----------
    poles : ndarray, shape (n, dim)
    weights : ndarray, shape (n,), or None when non-rational
    knots : ndarray, shape (k,)
    mults : ndarray of int, shape (k,)
    degree : int
    periodic : bool
    bezier : bool
        Rebuild as ``Geom_BezierCurve`` (knots are then [0, 1]).
    """

    poles: np.ndarray
    weights: np.ndarray | None
    knots: np.ndarray
    mults: np.ndarray
    degree: int
    periodic: bool
    bezier: bool = False

    @property
    def kind(self) -> Kind:
        return Kind.BEZIER_CURVE if self.bezier else Kind.BSPLINE_CURVE


@dataclass(frozen=True, eq=False)
class BSplineSurface:
    """A B-spline or Bezier surface (eq. 1-2).

    Parameters
    ----------
    poles : ndarray, shape (nu, nv, 3)
    weights : ndarray, shape (nu, nv), or None when non-rational
    uknots, vknots : ndarray, shapes (ku,), (kv,)
    umults, vmults : ndarray of int, shapes (ku,), (kv,)
    udegree, vdegree : int
    uperiodic, vperiodic : bool
    bezier : bool
        Rebuild as ``Geom_BezierSurface``.
    """

    poles: np.ndarray
    weights: np.ndarray | None
    uknots: np.ndarray
    vknots: np.ndarray
    umults: np.ndarray
    vmults: np.ndarray
    udegree: int
    vdegree: int
    uperiodic: bool
    vperiodic: bool
    bezier: bool = False

    @property
    def kind(self) -> Kind:
        return Kind.BEZIER_SURFACE if self.bezier else Kind.BSPLINE_SURFACE


@dataclass(frozen=True, eq=False)
class Derived:
    """A geometry built on another one.

    ``basis`` indexes the 3-D curve table for REVOLUTION and EXTRUSION, the
    surface table for OFFSET_SURFACE and TRIMMED_SURFACE, and the curve table of
    the same dimension for TRIMMED_CURVE and OFFSET_CURVE.

    Parameters
    ----------
    kind : Kind
    basis : int
    frame : ndarray, shape (k, 3)
        REVOLUTION: axis origin and direction; EXTRUSION: direction;
        3-D OFFSET_CURVE: reference direction; otherwise empty.
    params : ndarray, shape (m,)
        OFFSET_*: the offset; TRIMMED_SURFACE: u1, u2, v1, v2;
        TRIMMED_CURVE: u1, u2.
    """

    kind: Kind
    basis: int
    frame: np.ndarray
    params: np.ndarray


Geometry = Analytic | BSplineCurve | BSplineSurface | Derived


def kept_rows(table: list[Geometry], used: np.ndarray) -> tuple[list[Geometry], np.ndarray]:
    """The rows of a curve table that are ``used`` (a bool per row, changed
    in place) or are the bases of used rows (a trimmed or offset curve's:
    bases precede their curves), those bases renumbered; and each old row's
    new index (``cumsum(used) - 1``), to renumber what refers to the table."""
    for i in range(len(table) - 1, -1, -1):
        g = table[i]
        if used[i] and isinstance(g, Derived):
            used[g.basis] = True
    new_index = np.cumsum(used) - 1
    kept = [
        replace(g, basis=int(new_index[g.basis])) if isinstance(g, Derived) else g
        for g, u in zip(table, used.tolist())
        if u
    ]
    return kept, new_index


@dataclass(frozen=True, eq=False)
class Location:
    """A ``TopLoc_Location``: a product of elementary transforms raised to powers.

    Parameters
    ----------
    datums : tuple of int
        Indices into ``BRepModel.datums``, first factor first.
    powers : tuple of int
    """

    datums: tuple[int, ...]
    powers: tuple[int, ...]


IDENTITY = Location((), ())


@dataclass(eq=False)
class BRepModel:
    """A whole B-rep as tables.

    Shapes are numbered in post-order: a shape's sub-shapes all come before it,
    so a decoder can build the table front to back.  Index 0 of ``locations``
    is always the identity.

    Attributes
    ----------
    datums : ndarray, shape (D, 3, 4)
        Elementary transforms (``gp_Trsf`` as its 3x4 matrix).
    datum_forms : ndarray of uint8, shape (D,)
        ``gp_TrsfForm`` of each datum.
    locations : list of Location
    surfaces, curves3d, curves2d : list of Geometry
    shape_type : ndarray of uint8, shape (S,)
    shape_flags : ndarray of uint8, shape (S,)
        TShape flags, bit 0..7: free, modified, checked, orientable, closed,
        infinite, convex, locked.
    child_start : ndarray of int64, shape (S + 1,)
        Children of shape ``s`` are rows ``child_start[s]:child_start[s+1]`` of
        ``child_shape``, ``child_orient``, ``child_loc``.
    child_shape, child_orient, child_loc : ndarray, shape (C,)
    vertex_point : ndarray, shape (V, 3)
    vertex_tol : ndarray, shape (V,)
    vertex_reps : ndarray of int64, shape (R, 5)
        Rows (vertex, PointRepKind, curve or pcurve, surface, location), grouped
        by vertex in the order of the vertex's representation list; columns
        named by :class:`VertexCol`.
    vertex_rep_params : ndarray, shape (R, 2)
        The curve parameter, or the surface (u, v).
    edge_tol : ndarray, shape (E,)
    edge_flags : ndarray of uint8, shape (E,)
        Bit 0 degenerated, bit 1 same parameter, bit 2 same range.
    edge_reps : ndarray of int64, shape (Q, 8)
        Rows (edge, RepKind, curve, curve2, surface, surface2, location, location2),
        grouped by edge in the order of the edge's representation list; -1
        where a column does not apply (and for a degenerated edge's null curve);
        columns named by :class:`EdgeCol`.
    edge_rep_cont : ndarray of uint8, shape (Q,)
        ``GeomAbs_Shape`` continuity of seam and two-surface representations.
    edge_rep_range : ndarray, shape (Q, 2)
    edge_rep_uv : ndarray, shape (Q, 8)
        UV end points of the first and (seam) second pcurve.
    face_surface, face_loc : ndarray of int64, shape (F,)
    face_tol : ndarray, shape (F,)
    face_natural : ndarray of bool, shape (F,)
    side_joins : ndarray of int64, shape (J, 5)
        Tolerance mode: rows (surface, side, leader surface, leader side,
        reversed), applied in order after the nets are decoded: that side of
        the surface's net becomes the leader's side (``encode.coincide.twin_sides``).
    root_shape, root_orient, root_loc : int
    unit : str
        The source file's length unit name (``"MM"``, ``"CM"``, ``"INCH"``...).
    source_format : str
        ``"STEP"`` or ``"IGES"``.
    product : ProductData or None
        Format 1.2: the product data (``nurbscomp.product``): assembly tree,
        names, colours, layers, STEP header; None where the file has none.
    """

    datums: np.ndarray = field(default_factory=lambda: np.zeros((0, 3, 4)))
    datum_forms: np.ndarray = field(default_factory=lambda: np.zeros(0, np.uint8))
    locations: list[Location] = field(default_factory=lambda: [IDENTITY])
    surfaces: list[Geometry] = field(default_factory=list)
    curves3d: list[Geometry] = field(default_factory=list)
    curves2d: list[Geometry] = field(default_factory=list)
    shape_type: np.ndarray = field(default_factory=lambda: np.zeros(0, np.uint8))
    shape_flags: np.ndarray = field(default_factory=lambda: np.zeros(0, np.uint8))
    child_start: np.ndarray = field(default_factory=lambda: np.zeros(1, np.int64))
    child_shape: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    child_orient: np.ndarray = field(default_factory=lambda: np.zeros(0, np.uint8))
    child_loc: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    vertex_point: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    vertex_tol: np.ndarray = field(default_factory=lambda: np.zeros(0))
    vertex_reps: np.ndarray = field(default_factory=lambda: np.zeros((0, 5), np.int64))
    vertex_rep_params: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    edge_tol: np.ndarray = field(default_factory=lambda: np.zeros(0))
    edge_flags: np.ndarray = field(default_factory=lambda: np.zeros(0, np.uint8))
    edge_reps: np.ndarray = field(default_factory=lambda: np.zeros((0, 8), np.int64))
    edge_rep_cont: np.ndarray = field(default_factory=lambda: np.zeros(0, np.uint8))
    edge_rep_range: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    edge_rep_uv: np.ndarray = field(default_factory=lambda: np.zeros((0, 8)))
    face_surface: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    face_loc: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    face_tol: np.ndarray = field(default_factory=lambda: np.zeros(0))
    face_natural: np.ndarray = field(default_factory=lambda: np.zeros(0, bool))
    side_joins: np.ndarray = field(default_factory=lambda: np.zeros((0, 5), np.int64))
    root_shape: int = -1
    root_orient: int = 0
    root_loc: int = 0
    unit: str = "MM"
    source_format: str = "STEP"
    product: Any = None
    #: Whether the pcurves of degenerated edges follow their computed
    #: neighbours (``occ.topology.align_degenerated``, format 2.8): a
    #: container an earlier writer made is built without, as it was.
    poles_follow: bool = True
    #: Whether the computed pcurves on a trimmed surface of a periodic basis
    #: are moved into its bounds (``occ.topology.into_range``, format 2.9).
    periods_in_range: bool = True
    #: Whether the pcurves left out are projected face by face, edges in
    #: wire order, the projector's end points carried from edge to edge
    #: (``occ.topology.rebuild_pcurves``, format 2.15).
    pcurves_by_face: bool = True
    #: Whether a computed seam whose two pcurves ``FixShifted`` put onto one
    #: another is set as OCCT's readers set it (``occ.topology.shift_wire``,
    #: format 2.16).
    seams_set: bool = True

    def type_index(self) -> np.ndarray:
        """Position of each shape within the rows of its own type, shape (S,).

        The ``k``-th vertex in the shapes table owns row ``k`` of the vertex
        arrays, and likewise for edges and faces.
        """
        out = np.zeros(len(self.shape_type), np.int64)
        for t in (ShapeType.VERTEX, ShapeType.EDGE, ShapeType.FACE):
            sel = self.shape_type == t
            out[sel] = np.arange(int(sel.sum()))
        return out

    def counts(self) -> dict[str, int]:
        """Number of distinct shapes of each type."""
        return {t.name.lower(): int((self.shape_type == t).sum()) for t in ShapeType}


_ARRAY_FIELDS = (
    "datums",
    "datum_forms",
    "shape_type",
    "shape_flags",
    "child_start",
    "child_shape",
    "child_orient",
    "child_loc",
    "vertex_point",
    "vertex_tol",
    "vertex_reps",
    "vertex_rep_params",
    "edge_tol",
    "edge_flags",
    "edge_reps",
    "edge_rep_cont",
    "edge_rep_range",
    "edge_rep_uv",
    "face_surface",
    "face_loc",
    "face_tol",
    "face_natural",
    "side_joins",
)


#: The section each geometry table is written to, for messages.
_TABLE_TAGS = (("surfaces", "SURF"), ("curves3d", "CRV3"), ("curves2d", "CRV2"))
#: Per-model arrays of floats, with the section and name messages give them.
_FLOAT_FIELDS = (
    ("datums", "LOCS datums"),
    ("vertex_point", "VERT points"),
    ("vertex_tol", "VERT tolerances"),
    ("vertex_rep_params", "VERT parameters"),
    ("edge_tol", "EDGE tolerances"),
    ("edge_rep_uv", "EDGE uv"),
    ("face_tol", "FACE tolerances"),
)


def nonfinite(m: BRepModel, bound: float) -> str | None:
    """Where ``m`` holds a number that is not finite or not below ``bound`` in
    magnitude (a geometry's ``params``: above it), as ``"SURF poles"``,
    ``"VERT points"`` …, the first such place; None if none.  A reader
    refuses such values (``serialize.finite``); the encoder asks first, so
    that lossless and tolerance modes refuse the same source with the same
    words."""

    def bad(a: np.ndarray | None, at_most: bool = False) -> bool:
        if a is None or not a.size:
            return False
        with np.errstate(invalid="ignore"):
            ok = np.abs(a) <= bound if at_most else np.abs(a) < bound
            return not bool(ok.all())

    for name, where in _FLOAT_FIELDS:
        if bad(getattr(m, name)):
            return where
    # an edge without a 3-D curve (degenerated) has OCCT's default range, ±DBL_MAX
    curveless = (m.edge_reps[:, EC.KIND] == RepKind.CURVE3D) & (m.edge_reps[:, EC.CURVE] == -1)
    if not np.isfinite(m.edge_rep_range).all() or bad(m.edge_rep_range[~curveless]):
        return "EDGE ranges"
    for name, tag in _TABLE_TAGS:
        for g in getattr(m, name):
            for f in fields(g):
                v = getattr(g, f.name)
                # params may be ±bound itself (serialize.geometry: a trimmed
                # surface's untrimmed direction keeps ±Precision::Infinite())
                if isinstance(v, np.ndarray) and v.dtype.kind == "f" and bad(v, f.name == "params"):
                    return f"{tag} {f.name}"
    return None


def _same(a: object, b: object) -> bool:
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        if not (isinstance(a, np.ndarray) and isinstance(b, np.ndarray)):
            return False
        return a.shape == b.shape and a.astype(b.dtype).tobytes() == b.tobytes()
    return a == b


def differences(a: BRepModel, b: BRepModel) -> list[str]:
    """Names of the parts in which two models differ, bit for bit; empty if equal."""
    out = [f for f in _ARRAY_FIELDS if not _same(getattr(a, f), getattr(b, f))]
    for f in ("root_shape", "root_orient", "root_loc", "unit", "source_format"):
        if getattr(a, f) != getattr(b, f):
            out.append(f)
    if [(x.datums, x.powers) for x in a.locations] != [(x.datums, x.powers) for x in b.locations]:
        out.append("locations")
    for name in ("surfaces", "curves3d", "curves2d"):
        ta, tb = getattr(a, name), getattr(b, name)
        if len(ta) != len(tb):
            out.append(f"{name}: {len(ta)} != {len(tb)} records")
            continue
        bad = [
            i
            for i, (x, y) in enumerate(zip(ta, tb))
            if type(x) is not type(y)
            or any(not _same(v, getattr(y, k)) for k, v in vars(x).items())
        ]
        if bad:
            out.append(f"{name}: {len(bad)} records differ (first {bad[0]})")
    return out


def below(m: BRepModel, s: int, kind: ShapeType) -> set[int]:
    """Shape indices of type ``kind`` reachable below shape ``s`` (each shape
    visited once, with a stack of its own: no recursion)."""
    out, stack, seen = set(), [s], {s}
    types, children, start = m.shape_type, m.child_shape, m.child_start
    k = int(kind)  # a plain int: comparing numpy scalars with an enum is slow
    while stack:
        x = stack.pop()
        for c in children[start[x] : start[x + 1]].tolist():
            if c in seen:
                continue
            seen.add(c)
            t = int(types[c])
            if t == k:
                out.add(c)
            elif t < k:
                stack.append(c)
    return out


def faces_around(m: BRepModel, kind: ShapeType) -> list[list[int]]:
    """Per edge (or vertex), the faces it bounds (indices in model order)."""
    tidx = m.type_index()
    out: list[list[int]] = [[] for _ in range(int((m.shape_type == kind).sum()))]
    for f, s in enumerate(np.flatnonzero(m.shape_type == ShapeType.FACE).tolist()):
        for e in below(m, s, kind):
            out[tidx[e]].append(f)
    return out
