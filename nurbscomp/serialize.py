"""The B-rep model <-> the payloads of a container's sections.

Sections, in the order they are written and read (docs/format.md gives the
array-by-array layout of each):

====  ==========================================================
META  JSON: unit, source format, mode, tolerance, source name/size
LOCS  datums (3x4 matrices) and locations (datum, power chains)
SURF  surface table
SNET  coded B-spline surface nets (tolerance mode; empty when lossless)
CRV3  3-D curve table
CNET  coded B-spline 3-D curve poles (tolerance mode; empty when lossless)
CRV2  2-D curve table (pcurves)
SHAP  shape types, flags, and sub-shape references
VERT  vertex points, tolerances, point representations
EDGE  edge tolerances, flags, curve representations
FACE  face surface, location, tolerance, natural-restriction flag
====  ==========================================================
"""

from __future__ import annotations

import json
from typing import Any, cast

import numpy as np

from . import budget, codec, coons, dmap, joins
from .errors import BadReferenceError, CorruptError, LimitError, SectionError
from .model import (
    REBUILD,
    Analytic,
    BRepModel,
    BSplineCurve,
    BSplineSurface,
    Derived,
    Geometry,
    Kind,
    Location,
    RepKind,
)
from .streams import BlockReader, BlockWriter
from .units import UNITS_MM

#: Kind code of a table row that repeats an earlier row's record.
COPY = 255

# rows of `frame` and length of `params`, by kind, for (3-D, 2-D)
_ANALYTIC_SHAPE: dict[Kind, tuple[tuple[int, int], tuple[int, int]]] = {
    Kind.PLANE: ((4, 0), (0, 0)),
    Kind.CYLINDER: ((4, 1), (0, 0)),
    Kind.CONE: ((4, 2), (0, 0)),
    Kind.SPHERE: ((4, 1), (0, 0)),
    Kind.TORUS: ((4, 2), (0, 0)),
    Kind.LINE: ((2, 0), (2, 0)),
    Kind.CIRCLE: ((3, 1), (3, 1)),
    Kind.ELLIPSE: ((3, 2), (3, 2)),
    Kind.HYPERBOLA: ((3, 2), (3, 2)),
    Kind.PARABOLA: ((3, 1), (3, 1)),
}
_DERIVED_SHAPE: dict[Kind, tuple[tuple[int, int], tuple[int, int]]] = {
    Kind.REVOLUTION: ((2, 0), (0, 0)),
    Kind.EXTRUSION: ((1, 0), (0, 0)),
    Kind.OFFSET_SURFACE: ((0, 1), (0, 0)),
    Kind.TRIMMED_SURFACE: ((0, 4), (0, 0)),
    Kind.TRIMMED_CURVE: ((0, 2), (0, 2)),
    Kind.OFFSET_CURVE: ((1, 1), (0, 1)),
}
#: Surfaces swept from a 3-D curve (their basis is in the 3-D curve table).
SWEPT = (Kind.REVOLUTION, Kind.EXTRUSION)

# ---------------------------------------------------------------- reader limits
#
# The reader trusts nothing: every count is checked against the bytes that
# remain before anything is allocated from it, every index against its table,
# and every B-spline against OCCT's own rules, so that what reaches OCCT is
# something OCCT's constructors accept.

#: OCCT's largest B-spline degree (``Geom_BSplineSurface::MaxDegree``).
MAX_DEGREE = 25
#: Most poles one coded net may have.  A coded net's poles are not backed by
#: bytes (a boundary-coded n x m net holds O(n + m) integers), so its size is bounded here.
MAX_NET_POLES = 1 << 20
#: Most poles all coded nets of one table may have together.
MAX_CODED_POLES = 1 << 23
#: Largest magnitude of a decoded coordinate (OCCT's ``Precision::Infinite()``).
MAX_COORD = 2e100
#: Largest |level| of a net code's quantizer (steps tol·2^(level/4)).
MAX_LEVEL = 96


def _finite(a: np.ndarray, where: str, bound: float = np.inf) -> None:
    """Raise ``SectionError`` unless every value of ``a`` is finite (and below ``bound``)."""
    with np.errstate(invalid="ignore"):
        if a.size and not (np.abs(a) < bound).all():
            raise SectionError(f"{where}: a value is not finite or out of range")


def _tolerances(a: np.ndarray, where: str) -> None:
    """Raise ``SectionError`` unless every tolerance is finite and not negative."""
    _finite(a, where, MAX_COORD)
    if a.size and a.min() < 0:
        raise SectionError(f"{where}: a tolerance is negative")


def _counts(per: np.ndarray, r: BlockReader, where: str) -> int:
    """The exact total of per-row counts, each checked against the bytes that remain.

    Every counted value is read from an array of at least one byte per value, so
    a total above ``r.remaining`` cannot be right; it is refused before any
    array of that size is made.
    """
    if len(per) and (per.min() < 0 or per.max() > r.remaining):
        raise SectionError(f"{where}: a count is negative or larger than the section")
    total = sum(per.tolist())  # Python ints: no wrap-around
    if total > r.remaining:
        raise SectionError(f"{where}: counts add up to more than the section holds")
    return int(total)


def _check_bspline(
    where: str, n: int, degree: int, knots: np.ndarray, mults: np.ndarray, periodic: bool
) -> None:
    """OCCT's rules for a B-spline's knots (``BSplCLib::NbPoles``, ``CheckCurveData``).

    Raises
    ------
    SectionError
        The degree, multiplicities or knots do not make a B-spline of ``n`` poles.
    """
    if not 1 <= degree <= MAX_DEGREE:
        raise SectionError(f"{where}: degree {degree} is out of range")
    if len(knots) < 2 or len(mults) != len(knots):
        raise SectionError(f"{where}: too few knots")
    _finite(knots, where, MAX_COORD)
    if not (np.diff(knots) > 0).all():
        raise SectionError(f"{where}: knots do not increase")
    inner = mults[1:-1]
    ends = mults[[0, -1]]
    if (mults < 1).any() or (inner > degree).any():
        raise SectionError(f"{where}: bad knot multiplicity")
    if periodic:
        if (ends > degree).any() or ends[0] != ends[1]:
            raise SectionError(f"{where}: bad end multiplicities of a periodic B-spline")
        poles = int(mults.sum()) - int(ends[1])
    else:
        if (ends > degree + 1).any():
            raise SectionError(f"{where}: bad end multiplicities")
        poles = int(mults.sum()) - degree - 1
    if poles != n:
        raise SectionError(f"{where}: knots make {poles} poles, the header says {n}")


# ---------------------------------------------------------------- geometry tables


def _write_geometry(
    records: list[Geometry], dim: int, coded: frozenset[int] = frozenset()
) -> bytes:
    """Write one geometry table.  ``dim`` is 3 for surfaces and 3-D curves, 2 for pcurves.

    B-spline rows whose record id is in ``coded`` carry a flag (bit 3 for
    surfaces, bit 2 for curves) and no poles: those are in SNET / CNET.
    """
    kinds, copies, hdr, basis, mults = [], [], [], [], []
    frames: list[np.ndarray] = []
    params: list[np.ndarray] = []
    poles: list[np.ndarray] = []
    weights: list[np.ndarray] = []
    knots: list[np.ndarray] = []
    seen: dict[int, int] = {}
    for i, r in enumerate(records):
        if id(r) in seen:
            kinds.append(COPY)
            copies.append(i - seen[id(r)])
            continue
        seen[id(r)] = i
        kinds.append(int(r.kind))
        if isinstance(r, Analytic):
            frames.append(r.frame.reshape(-1))
            params.append(r.params)
        elif isinstance(r, Derived):
            # a swept surface's basis is in the 3-D curve table: absolute index;
            # other bases precede their row in the same table: distance back
            basis.append(r.basis if r.kind in SWEPT else i - r.basis)
            frames.append(r.frame.reshape(-1))
            params.append(r.params)
        elif isinstance(r, BSplineSurface):
            nu, nv = r.poles.shape[:2]
            flags = int(r.weights is not None) | int(r.uperiodic) << 1 | int(r.vperiodic) << 2
            flags |= int(id(r) in coded) << 3
            hdr += [nu, nv, flags]
            if not r.bezier:
                hdr += [r.udegree, r.vdegree, len(r.uknots), len(r.vknots)]
                knots += [r.uknots, r.vknots]
                mults += [*r.umults.tolist(), *r.vmults.tolist()]
            if id(r) not in coded:
                poles.append(r.poles.reshape(-1))
            if r.weights is not None:
                weights.append(r.weights.reshape(-1))
        elif isinstance(r, BSplineCurve):
            flags = int(r.weights is not None) | int(r.periodic) << 1 | int(id(r) in coded) << 2
            hdr += [len(r.poles), flags]
            if not r.bezier:
                hdr += [r.degree, len(r.knots)]
                knots.append(r.knots)
                mults += r.mults.tolist()
            if id(r) not in coded:
                poles.append(r.poles.reshape(-1))
            if r.weights is not None:
                weights.append(r.weights)
    w = BlockWriter()
    w.ints(kinds)
    w.ints(copies)
    w.ints(hdr)
    w.ints(basis)
    w.ints(mults)
    for group in (frames, params, poles, weights, knots):
        w.floats(np.concatenate(group) if group else np.zeros(0))
    return bytes(w)


class _Cursor:
    """Hands out consecutive slices of one decoded array, checking bounds."""

    def __init__(self, a: np.ndarray, name: str) -> None:
        self.a, self.pos, self.name = a, 0, name

    def take(self, n: int) -> np.ndarray:
        if n < 0 or self.pos + n > len(self.a):
            raise SectionError(f"{self.name} stream is too short at value {self.pos}")
        out = self.a[self.pos : self.pos + n]
        self.pos += n
        return out

    def one(self) -> int:
        return int(self.take(1)[0])

    def done(self) -> None:
        if self.pos != len(self.a):
            raise SectionError(f"{self.name} stream has unread values from value {self.pos}")


def _read_geometry(data: bytes, tag: str, dim: int) -> list[Geometry]:
    """Read one geometry table (see :func:`_write_geometry`), checking every row.

    Raises
    ------
    SectionError
        A row's kind, header, knots or values do not make a geometry OCCT accepts.
    LimitError
        Coded nets declare more poles than a reader allocates.
    """
    r = BlockReader(data, tag)
    kinds = r.ints()
    copies, hdr, basis, mults = (
        _Cursor(r.ints(), f"{tag} {n}") for n in ("copy", "hdr", "basis", "mults")
    )
    frames, params, poles, weights, knots = (
        _Cursor(r.floats(), f"{tag} {n}") for n in ("frame", "param", "pole", "weight", "knot")
    )
    r.done()
    _finite(frames.a, f"{tag} frames", MAX_COORD)
    _finite(params.a, f"{tag} params", MAX_COORD)
    _finite(poles.a, f"{tag} poles", MAX_COORD)
    out: list[Geometry] = []
    surface = tag == "SURF"
    coded_poles = 0
    for i, k in enumerate(kinds.tolist()):
        where = f"{tag} row {i}"
        if k == COPY:
            j = i - copies.one()
            if not 0 <= j < i:
                raise SectionError(f"{where} copies a row that does not exist")
            out.append(out[j])
            continue
        try:
            kind = Kind(k)
        except ValueError:
            raise SectionError(f"{where}: unknown geometry kind {k}") from None
        if (kind < 16) != surface:
            raise SectionError(f"{where}: kind {kind.name} in the wrong table")
        if kind in _ANALYTIC_SHAPE:
            nf, npar = _ANALYTIC_SHAPE[kind][dim == 2]
            out.append(Analytic(kind, frames.take(nf * dim).reshape(nf, dim), params.take(npar)))
        elif kind in _DERIVED_SHAPE:
            nf, npar = _DERIVED_SHAPE[kind][dim == 2]
            b = basis.one()
            if kind not in SWEPT:
                b = i - b
            if not (b >= 0 if kind in SWEPT else 0 <= b < i):
                raise SectionError(f"{where} refers to a missing basis")
            out.append(Derived(kind, b, frames.take(nf * 3).reshape(nf, 3), params.take(npar)))
        elif kind in (Kind.BSPLINE_SURFACE, Kind.BEZIER_SURFACE):
            nu, nv, flags = (hdr.one() for _ in range(3))
            bez = kind == Kind.BEZIER_SURFACE
            if bez:
                ud, vd, ku, kv = nu - 1, nv - 1, 2, 2
            else:
                ud, vd, ku, kv = (hdr.one() for _ in range(4))
            if min(nu, nv, ku, kv) < 2 or not (1 <= ud and 1 <= vd) or not 0 <= flags < 16:
                raise SectionError(f"{where} has a bad B-spline header")
            if nu > ku * (MAX_DEGREE + 1) or nv > kv * (MAX_DEGREE + 1):
                raise SectionError(f"{where} has more poles than its knots allow")
            if bez:
                if max(ud, vd) > MAX_DEGREE:
                    raise SectionError(f"{where}: degree is out of range")
                uk, vk = np.array([0.0, 1.0]), np.array([0.0, 1.0])
                um, vm = np.array([nu, nu]), np.array([nv, nv])
            else:
                uk, vk = knots.take(ku), knots.take(kv)
                um, vm = mults.take(ku).copy(), mults.take(kv).copy()
                _check_bspline(f"{where} (u)", nu, ud, uk, um, bool(flags & 2))
                _check_bspline(f"{where} (v)", nv, vd, vk, vm, bool(flags & 4))
            if flags & 8:  # coded net: filled in from SNET
                if nu * nv > MAX_NET_POLES or coded_poles + nu * nv > MAX_CODED_POLES:
                    raise LimitError(f"{where}: a coded net of {nu} x {nv} poles is too large")
                coded_poles += nu * nv
                p = np.full((nu, nv, 3), np.nan)
            else:
                p = poles.take(nu * nv * 3).reshape(nu, nv, 3)
            wts = weights.take(nu * nv).reshape(nu, nv) if flags & 1 else None
            if wts is not None and not _weights_ok(wts):
                raise SectionError(
                    f"{where}: weights must be within [{1 / MAX_COORD:g}, {MAX_COORD:g}]"
                )
            out.append(
                BSplineSurface(
                    p, wts, uk, vk, um, vm, ud, vd, bool(flags & 2), bool(flags & 4), bez
                )
            )
        else:  # BSPLINE_CURVE / BEZIER_CURVE
            n, flags = hdr.one(), hdr.one()
            bez = kind == Kind.BEZIER_CURVE
            deg, nk = (n - 1, 2) if bez else (hdr.one(), hdr.one())
            if n < 2 or nk < 2 or deg < 1 or not 0 <= flags < 8:
                raise SectionError(f"{where} has a bad B-spline header")
            if n > nk * (MAX_DEGREE + 1) or (bez and deg > MAX_DEGREE):
                raise SectionError(f"{where} has more poles than its knots allow")
            kn = np.array([0.0, 1.0]) if bez else knots.take(nk)
            mu = np.array([n, n]) if bez else mults.take(nk).copy()
            if not bez:
                _check_bspline(where, n, deg, kn, mu, bool(flags & 2))
            if flags & 4:  # coded net: filled in from CNET
                if n > MAX_NET_POLES or coded_poles + n > MAX_CODED_POLES:
                    raise LimitError(f"{where}: a coded curve of {n} poles is too large")
                coded_poles += n
                cp = np.full((n, dim), np.nan)
            else:
                cp = poles.take(n * dim).reshape(n, dim)
            wts = weights.take(n) if flags & 1 else None
            if wts is not None and not _weights_ok(wts):
                raise SectionError(
                    f"{where}: weights must be within [{1 / MAX_COORD:g}, {MAX_COORD:g}]"
                )
            out.append(BSplineCurve(cp, wts, kn, mu, deg, bool(flags & 2), bez))
    for c in (copies, hdr, basis, mults, frames, params, poles, weights, knots):
        c.done()
    return out


def _ok(a: np.ndarray) -> bool:
    """Every value finite."""
    return bool(np.isfinite(a).all())


def _weights_ok(w: np.ndarray) -> bool:
    """Every weight within [1/MAX_COORD, MAX_COORD]: OCCT's rational
    evaluation multiplies weights by coordinates (up to MAX_COORD) and sums
    them, and crashes on the overflow (found by the structure-aware fuzzer:
    weights of 1e-300 and 1e300 on poles at 2e100)."""
    with np.errstate(invalid="ignore"):
        return bool(((w >= 1.0 / MAX_COORD) & (w <= MAX_COORD)).all())


# ---------------------------------------------------------------- topology


def _write_locations(m: BRepModel) -> bytes:
    w = BlockWriter()
    w.ints(m.datum_forms)
    w.floats(m.datums.reshape(-1))
    locs = m.locations[1:]
    w.ints([len(loc.datums) for loc in locs])
    w.ints([d for loc in locs for d in loc.datums])
    w.ints([p for loc in locs for p in loc.powers])
    return bytes(w)


def _read_locations(data: bytes, m: BRepModel) -> None:
    r = BlockReader(data, "LOCS")
    forms = r.ints()
    if len(forms) and (forms.min() < 0 or forms.max() > _MAX_TRSF_FORM):
        raise SectionError("LOCS: unknown transformation form")
    m.datum_forms = forms.astype(np.uint8)
    nd = len(m.datum_forms)
    m.datums = r.floats(nd * 12).reshape(nd, 3, 4)
    _finite(m.datums, "LOCS datums", MAX_COORD)
    lengths = r.ints()
    total = _counts(lengths, r, "LOCS lengths")
    datums, powers = r.ints(total), r.ints(total)
    r.done()
    if len(datums) and (datums.min() < 0 or datums.max() >= nd):
        raise BadReferenceError("LOCS: a location refers to a missing datum")
    if len(powers) and (np.abs(powers).max() > _MAX_POWER or (powers == 0).any()):
        raise SectionError("LOCS: a location power is zero or out of range")
    ends = np.cumsum(lengths)
    m.locations = [Location((), ())] + [
        Location(tuple(datums[e - n : e].tolist()), tuple(powers[e - n : e].tolist()))
        for n, e in zip(lengths.tolist(), ends.tolist())
    ]


def _check_location_matrices(m: BRepModel) -> None:
    """Raise ``SectionError`` unless every location's matrix (its datums raised
    to their powers, ``joins.location_matrix``) is finite and within
    ``MAX_COORD``: OCCT's STEP writer crashes on an overflowed one (found by
    the structure-aware fuzzer: a 1e100 scale raised to the power 2^31 - 1)."""
    for k in range(1, len(m.locations)):
        t = joins.location_matrix(m, k)
        if not (np.abs(t) < MAX_COORD).all():
            raise SectionError(f"LOCS: location {k}'s matrix is not finite or out of range")


#: Largest ``gp_TrsfForm`` value (``gp_Other``).
_MAX_TRSF_FORM = 8
#: Largest |power| of a location factor (OCCT stores it as a 32-bit integer).
_MAX_POWER = 2**31 - 1


def _write_shapes(m: BRepModel) -> bytes:
    w = BlockWriter()
    w.ints(m.shape_type)
    w.ints(m.shape_flags)
    nkids = np.diff(m.child_start)
    w.ints(nkids)
    parent = np.repeat(np.arange(len(m.shape_type)), nkids)
    w.ints(parent - m.child_shape)
    w.ints(m.child_orient)
    w.ints(m.child_loc)
    w.ints([m.root_shape, m.root_orient, m.root_loc])
    return bytes(w)


def _read_shapes(data: bytes, m: BRepModel) -> None:
    r = BlockReader(data, "SHAP")
    types = r.ints()
    if len(types) and (types.min() < 0 or types.max() > 7):
        raise SectionError("SHAP: unknown shape type")
    m.shape_type = types.astype(np.uint8)
    n = len(m.shape_type)
    flags = r.ints(n)
    if n and (flags.min() < 0 or flags.max() > 255):
        raise SectionError("SHAP: unknown shape flags")
    m.shape_flags = flags.astype(np.uint8)
    nkids = r.ints(n)
    c = _counts(nkids, r, "SHAP child counts")
    back = r.ints(c)
    orient = r.ints(c)
    m.child_loc = r.ints(c)
    m.root_shape, m.root_orient, m.root_loc = r.ints(3).tolist()
    r.done()
    m.child_start = np.concatenate([[0], np.cumsum(nkids)]).astype(np.int64)
    parent = np.repeat(np.arange(n), nkids)
    if c and ((back < 1).any() or (back > parent).any()):
        raise BadReferenceError(
            "SHAP: a shape refers to itself or to a later shape (a cycle, or out of order)"
        )
    if c and (orient.min() < 0 or orient.max() > 3):
        raise SectionError("SHAP: unknown orientation")
    m.child_shape = parent - back
    m.child_orient = orient.astype(np.uint8)
    if not 0 <= m.root_shape < n or not 0 <= m.root_orient <= 3:
        raise BadReferenceError("SHAP: bad root reference")


def vertex_grid(tol: float) -> float:
    """Step of the grid lossy vertices are snapped to: every coordinate moves by
    at most h/2, so a vertex by at most tol/2 (``h = tol/√3``)."""
    return tol / np.sqrt(3.0)


def _write_vertices(m: BRepModel, tol: float = 0.0) -> bytes:
    """Vertices whose point is a grid point (``vertex_grid``) bit for bit are
    stored as grid integers; the others as floats."""
    w = BlockWriter()
    pts = m.vertex_point
    on_grid = np.zeros(len(pts), bool)
    q = np.zeros_like(pts, dtype=np.int64)
    if tol > 0 and len(pts):
        h = vertex_grid(tol)
        small = (np.abs(pts) < 2.0**50 * h).all(-1)
        q[small] = np.rint(pts[small] / h).astype(np.int64)
        on_grid = small & ((q * h).view(np.int64) == pts.view(np.int64)).all(-1)  # bit for bit
    w.ints(on_grid.astype(np.int64))
    w.floats(pts[~on_grid].reshape(-1))
    for axis in range(3):
        w.deltas(q[on_grid, axis])
    w.floats(m.vertex_tol)
    reps = m.vertex_reps
    w.ints(np.bincount(reps[:, 0], minlength=len(m.vertex_tol)) if len(reps) else [])
    for col in range(1, 5):
        w.ints(reps[:, col])
    w.floats(m.vertex_rep_params.reshape(-1))
    return bytes(w)


def _read_vertices(data: bytes, m: BRepModel, tol: float = 0.0) -> None:
    r = BlockReader(data, "VERT")
    kind = r.ints()
    if len(kind) and (kind.min() < 0 or kind.max() > 1):
        raise SectionError("VERT: unknown vertex kind")
    on_grid = kind.astype(bool)
    nv, ng = len(on_grid), int(on_grid.sum())
    pts = np.zeros((nv, 3))
    pts[~on_grid] = r.floats(3 * (nv - ng)).reshape(-1, 3)
    q = np.stack([r.deltas(ng) for _ in range(3)], axis=1)
    if ng and not tol > 0:
        raise SectionError("VERT: grid vertices need a positive tolerance")
    if ng:
        with np.errstate(over="ignore"):
            pts[on_grid] = q * vertex_grid(tol)
    _finite(pts, "VERT points", MAX_COORD)
    m.vertex_point = pts
    m.vertex_tol = r.floats(nv)
    _tolerances(m.vertex_tol, "VERT tolerances")
    per = r.ints()
    if len(per) not in (0, nv):
        raise SectionError("VERT: bad representation counts")
    nrep = _counts(per, r, "VERT representation counts")
    cols = [r.ints(nrep) for _ in range(4)]
    m.vertex_rep_params = r.floats(2 * nrep).reshape(-1, 2)
    r.done()
    _finite(m.vertex_rep_params, "VERT parameters", MAX_COORD)
    cols.insert(0, np.repeat(np.arange(len(per)), per))
    m.vertex_reps = np.stack(cols, axis=1).astype(np.int64).reshape(-1, 5)


def _write_edges(m: BRepModel) -> bytes:
    w = BlockWriter()
    w.floats(m.edge_tol)
    w.ints(m.edge_flags)
    reps = m.edge_reps
    w.ints(np.bincount(reps[:, 0], minlength=len(m.edge_tol)) if len(reps) else [])
    kind = reps[:, 1]
    w.ints(kind)
    # each column only where the representation kind uses it
    w.deltas(reps[kind == RepKind.CURVE3D, 2])  # 3-D curve
    w.deltas(reps[(kind == RepKind.ON_SURFACE) | (kind == RepKind.ON_CLOSED_SURFACE), 2])  # pcurve
    w.ints(reps[kind == RepKind.ON_CLOSED_SURFACE, 3])  # second pcurve
    w.deltas(reps[kind != RepKind.CURVE3D, 4])  # surface
    w.deltas(reps[kind == RepKind.ON_TWO_SURFACES, 5])  # second surface
    w.ints(reps[:, 6])  # location
    w.ints(reps[kind == RepKind.ON_TWO_SURFACES, 7])  # second location
    cont = (kind == RepKind.ON_CLOSED_SURFACE) | (kind == RepKind.ON_TWO_SURFACES)
    w.ints(m.edge_rep_cont[cont])
    ranged = kind != RepKind.ON_TWO_SURFACES
    how = range_kinds(m)
    w.ints(how[ranged])
    w.floats(m.edge_rep_range[ranged & (how == RANGE_STORED)].reshape(-1))
    on = (kind == RepKind.ON_SURFACE) | (kind == RepKind.ON_CLOSED_SURFACE)
    w.floats(m.edge_rep_uv[on, :4].reshape(-1))
    w.floats(m.edge_rep_uv[kind == RepKind.ON_CLOSED_SURFACE, 4:].reshape(-1))
    return bytes(w)


def _read_edges(data: bytes, m: BRepModel) -> np.ndarray:
    """Fill ``m``'s edge tables; return the range kinds (see :func:`range_kinds`)."""
    r = BlockReader(data, "EDGE")
    m.edge_tol = r.floats()
    _tolerances(m.edge_tol, "EDGE tolerances")
    ne = len(m.edge_tol)
    flags = r.ints(ne)
    if ne and (flags.min() < 0 or flags.max() > 7):
        raise SectionError("EDGE: unknown edge flags")
    m.edge_flags = flags.astype(np.uint8)
    per = r.ints()
    if len(per) not in (0, ne):
        raise SectionError("EDGE: bad representation counts")
    q = _counts(per, r, "EDGE representation counts")
    kind = r.ints(q)
    if q and (kind.min() < 0 or kind.max() > 3):
        raise SectionError("EDGE: unknown representation kind")
    reps = np.full((q, 8), -1, np.int64)
    reps[:, 0] = np.repeat(np.arange(len(per)), per)
    reps[:, 1] = kind
    two = kind == RepKind.ON_TWO_SURFACES
    closed = kind == RepKind.ON_CLOSED_SURFACE
    c3 = kind == RepKind.CURVE3D
    pc = ~two & ~c3
    reps[c3, 2] = r.deltas(int(c3.sum()))
    reps[pc, 2] = r.deltas(int(pc.sum()))
    reps[closed, 3] = r.ints(int(closed.sum()))
    reps[~c3, 4] = r.deltas(int((~c3).sum()))
    reps[two, 5] = r.deltas(int(two.sum()))
    reps[:, 6] = r.ints(q)
    reps[:, 7] = 0
    reps[two, 7] = r.ints(int(two.sum()))
    m.edge_reps = reps
    cont = r.ints(int((closed | two).sum()))
    if len(cont) and (cont.min() < 0 or cont.max() > 6):
        raise SectionError("EDGE: unknown continuity")
    m.edge_rep_cont = np.zeros(q, np.uint8)
    m.edge_rep_cont[closed | two] = cont
    how = np.full(q, RANGE_ZERO, np.int64)  # kind 3 reps have no range
    how[~two] = r.ints(int((~two).sum()))
    if ((how < 0) | (how > RANGE_VERTICES)).any():
        raise SectionError("EDGE: unknown range kind")
    m.edge_rep_range = np.zeros((q, 2))
    stored = how == RANGE_STORED
    m.edge_rep_range[stored] = r.floats(2 * int(stored.sum())).reshape(-1, 2)
    m.edge_rep_uv = np.zeros((q, 8))
    on = (kind == RepKind.ON_SURFACE) | closed
    m.edge_rep_uv[on, :4] = r.floats(4 * int(on.sum())).reshape(-1, 4)
    m.edge_rep_uv[closed, 4:] = r.floats(4 * int(closed.sum())).reshape(-1, 4)
    r.done()
    # an edge without a 3-D curve (degenerated) has OCCT's default range, ±DBL_MAX
    curveless = (kind == RepKind.CURVE3D) & (reps[:, 2] == -1)
    _finite(m.edge_rep_range, "EDGE ranges")
    _finite(m.edge_rep_range[~curveless], "EDGE ranges", MAX_COORD)
    _finite(m.edge_rep_uv, "EDGE uv points", MAX_COORD)
    return how


#: How an edge representation's range is stored (EDGE, format 0.3; VERTICES 0.4).
RANGE_STORED, RANGE_NATURAL, RANGE_OF_3D, RANGE_ZERO, RANGE_VERTICES = 0, 1, 2, 3, 4


def _natural_range(g: Geometry | None) -> tuple[float, float] | None:
    """The parameter range a curve record carries in itself, if any."""
    if isinstance(g, BSplineCurve):
        return (0.0, 1.0) if g.bezier else (float(g.knots[0]), float(g.knots[-1]))
    if isinstance(g, Derived) and g.kind == Kind.TRIMMED_CURVE:
        return float(g.params[0]), float(g.params[1])
    return None


def _curve_of(m: BRepModel, q: int) -> Geometry | None:
    kind, c = int(m.edge_reps[q, 1]), int(m.edge_reps[q, 2])
    table = m.curves3d if kind == RepKind.CURVE3D else m.curves2d
    return table[c] if 0 <= c < len(table) else None


def _range_of_3d(m: BRepModel) -> dict[int, int]:
    """Per edge, its first 3-D curve representation's row."""
    out: dict[int, int] = {}
    for q in np.flatnonzero(m.edge_reps[:, 1] == RepKind.CURVE3D).tolist():
        out.setdefault(int(m.edge_reps[q, 0]), q)
    return out


def range_kinds(m: BRepModel) -> np.ndarray:
    """Per representation, how its range is stored: the curve's own range
    (``RANGE_NATURAL``), the same as the edge's 3-D curve (``RANGE_OF_3D``),
    zeros (a pcurve the decoder computes), the projections of its vertices
    on its line or circle (``RANGE_VERTICES``, :func:`joins.vertex_ranges`), or the two
    floats.  Only a bit for bit equal prediction is used, so the format stays
    lossless."""
    reps, rng = m.edge_reps, m.edge_rep_range
    bits = rng.view(np.int64)
    of3d = _range_of_3d(m)
    by_vertices = joins.vertex_ranges(m)
    out = np.full(len(reps), RANGE_STORED, np.int64)
    for q in range(len(reps)):
        if reps[q, 1] == RepKind.ON_TWO_SURFACES:
            continue
        if not bits[q].any():
            out[q] = RANGE_ZERO
            continue
        nat = _natural_range(_curve_of(m, q))
        if nat is not None and (np.array(nat).view(np.int64) == bits[q]).all():
            out[q] = RANGE_NATURAL
            continue
        r3 = of3d.get(int(reps[q, 0]))
        if reps[q, 1] != RepKind.CURVE3D and r3 is not None and (bits[r3] == bits[q]).all():
            out[q] = RANGE_OF_3D
        elif q in by_vertices and (np.array(by_vertices[q]).view(np.int64) == bits[q]).all():
            out[q] = RANGE_VERTICES
    return out


def _resolve_ranges(m: BRepModel, how: np.ndarray) -> None:
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
    _finite(m.edge_rep_range[how == RANGE_VERTICES], "EDGE: ranges from vertices", MAX_COORD)
    of3d = _range_of_3d(m)
    for q in np.flatnonzero(how == RANGE_OF_3D).tolist():
        r3 = of3d.get(int(m.edge_reps[q, 0]))
        if r3 is None or how[r3] == RANGE_OF_3D:
            raise BadReferenceError(
                f"EDGE: representation {q}'s range refers to a missing 3-D curve"
            )
        m.edge_rep_range[q] = m.edge_rep_range[r3]


def _write_faces(m: BRepModel) -> bytes:
    w = BlockWriter()
    w.deltas(m.face_surface)
    w.ints(m.face_loc)
    w.floats(m.face_tol)
    w.ints(m.face_natural.astype(np.int64))
    return bytes(w)


def _read_faces(data: bytes, m: BRepModel) -> None:
    r = BlockReader(data, "FACE")
    m.face_surface = r.deltas()
    nf = len(m.face_surface)
    m.face_loc = r.ints(nf)
    m.face_tol = r.floats(nf)
    natural = r.ints(nf)
    r.done()
    _tolerances(m.face_tol, "FACE tolerances")
    if nf and (natural.min() < 0 or natural.max() > 1):
        raise SectionError("FACE: a natural-restriction flag is neither 0 nor 1")
    m.face_natural = natural.astype(bool)


# ---------------------------------------------------------------- coded nets


def coded_rows(records: list[Geometry]) -> list[int]:
    """Rows of the first occurrence of each coded B-spline record (NaN poles after reading)."""
    seen: set[int] = set()
    out = []
    for i, g in enumerate(records):
        if isinstance(g, (BSplineSurface, BSplineCurve)) and id(g) not in seen:
            seen.add(id(g))
            if np.isnan(g.poles.flat[0]):
                out.append(i)
    return out


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


def _write_nets(
    records: list[Geometry],
    codes: dict[int, codec.NetCode],
    tol: float,
    anchors: dict[int, np.ndarray] | None = None,
) -> bytes:
    """The codes of a table's coded records, in the order of their first rows.

    Each code is re-based on the origin the decoder will use: the previous
    coded row's decoded first pole (:func:`codec.reorigin`), or the row's
    anchor point where it has one (:func:`joins.anchors`).
    """
    anchors = anchors or {}
    order = []
    seen: set[int] = set()
    origin = None
    for row, g in enumerate(records):
        if id(g) in codes and id(g) not in seen:
            seen.add(id(g))
            code = codes[id(g)]
            if code.method == codec.Method.COPY:  # filled last: not on the origin chain
                order.append(code)
                continue
            if code.method != codec.Method.ISO:  # an ISO code holds references, no point
                code = codec.reorigin(code, anchors.get(row, origin), tol)
            order.append(code)
            poles = cast(BSplineCurve | BSplineSurface, g).poles
            origin = poles.reshape(-1, poles.shape[-1])[0] if code.first is None else code.first
    w = BlockWriter()
    for field in ("method", "quant", "level", "slope"):
        w.ints([int(getattr(c, field)) for c in order])
    w.ints([len(c.ints) for c in order])
    w.ints(np.concatenate([c.ints for c in order]) if order else [])
    w.floats(np.concatenate([c.dcs for c in order]) if order else [])
    return bytes(w)


def _read_nets(
    data: bytes,
    records: list[Geometry],
    tol: float,
    tag: str,
    anchors: dict[int, np.ndarray] | None = None,
    surfaces: list[Geometry] | None = None,
) -> list[tuple[int, int, codec.NetCode]]:
    """Decode a SNET/CNET section into the poles of the coded rows, in row order.

    ``Method.COPY`` rows are left for :func:`_fill_copies` and returned as
    (net number, row, code).

    Each net's first pole is coded against the previous net's decoded first
    pole (the origin chain of :func:`codec.encode_net`).
    """
    rows = coded_rows(records)
    r = BlockReader(data, tag)
    n = len(rows)
    method, quant, level, slope, counts = (r.ints(n) for _ in range(5))
    ints = _Cursor(r.ints(), f"{tag} ints")
    dcs = r.floats()
    r.done()
    _finite(dcs, f"{tag} DC coefficients", MAX_COORD)
    if n and not 0 < tol < MAX_COORD:
        raise SectionError(f"{tag}: coded nets need a positive, finite tolerance")
    if (counts < 0).any() or (quant < 0).any() or (quant > 1).any():
        raise SectionError(f"{tag}: bad net header")
    if (slope < 0).any() or (slope >= len(codec.SLOPES)).any():
        raise SectionError(f"{tag}: bad quantizer slope")
    if n and np.abs(level).max() > MAX_LEVEL:
        raise SectionError(f"{tag}: quantizer level out of range")
    allowed = codec.SURFACE_METHODS if tag == "SNET" else codec.CURVE_COPIES
    if n and not np.isin(method, [int(x) for x in allowed]).all():
        raise SectionError(f"{tag}: a coding method that does not apply to this table")
    origin = None
    dpos = 0
    copies: list[tuple[int, int, codec.NetCode]] = []
    for k, row in enumerate(rows):
        g = records[row]
        try:
            code = codec.NetCode(
                codec.Method(int(method[k])),
                codec.Quant(int(quant[k])),
                int(level[k]),
                int(slope[k]),
                ints.take(int(counts[k])),
                dcs[dpos:],
                0.0,
                0.0,
            )
            s, t = net_abscissae(g)
            if code.method == codec.Method.COPY:
                copies.append((k, row, code))
                continue
            if code.method == codec.Method.ISO:
                net, used = _iso_copy(code, g, surfaces or []), 0
            else:
                at = (anchors or {}).get(row, origin)
                shape = cast(BSplineCurve | BSplineSurface, g).poles.shape
                net, used = codec.decode_net(code, shape, s, t, tol, at, net_basis(g))
        except (ValueError, ArithmeticError) as e:  # LinAlgError is a ValueError
            raise SectionError(f"{tag}: net {k} (table row {row}): {e}") from None
        _finite(net, f"{tag}: net {k} (table row {row})", MAX_COORD)
        dpos += used
        cast(BSplineCurve | BSplineSurface, g).poles[...] = net
        origin = net.reshape(-1, net.shape[-1])[0]
    ints.done()
    if dpos != len(dcs):
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
            net = _twin_copy(code, row, records, leaders)
            t = joins.copy_matrix(where, row, row - int(code.ints[0]))
            if t is not None:
                net = joins.placed(net, t)
        except ValueError as e:
            raise SectionError(f"CNET: net {k} (table row {row}): {e}") from None
        records[row].poles[...] = net  # type: ignore[union-attr]


# ---------------------------------------------------------------- whole model


def model_to_sections(
    m: BRepModel, meta: dict[str, Any], codes: dict[int, codec.NetCode] | None = None
) -> list[tuple[str, bytes]]:
    """The sections of a container holding ``m``.

    ``codes`` maps the ids of B-spline surface records to their net codes
    (tolerance mode); those nets go into SNET, and ``m`` must already hold
    their *decoded* poles, so that what the decoder rebuilds is ``m``.
    """
    meta = {**meta, "unit": m.unit, "source_format": m.source_format}
    codes = codes or {}
    tol = float(meta.get("tolerance_mm") or 0.0)
    return [
        ("META", json.dumps(meta, sort_keys=True, separators=(",", ":")).encode()),
        ("LOCS", _write_locations(m)),
        ("SURF", _write_geometry(m.surfaces, 3, frozenset(codes))),
        ("SNET", _write_nets(m.surfaces, codes, tol)),
        ("CRV3", _write_geometry(m.curves3d, 3, frozenset(codes))),
        ("CNET", _write_nets(m.curves3d, codes, tol, _curve_anchors(m, codes))),
        ("CRV2", _write_geometry(m.curves2d, 2)),
        ("SHAP", _write_shapes(m)),
        ("VERT", _write_vertices(m, tol)),
        ("EDGE", _write_edges(m)),
        ("FACE", _write_faces(m)),
        *([("SIDE", _write_sides(m))] if len(m.side_joins) else []),
    ]


def _write_sides(m: BRepModel) -> bytes:
    """``m.side_joins`` (format 1.1): the count, then per column: the surface
    rows as deltas (they increase), the sides, each leader row as the surface
    row minus it, the leader sides, the reversed flags."""
    w = BlockWriter()
    j = m.side_joins.reshape(-1, 5)
    w.ints([len(j)])
    w.deltas(j[:, 0])
    w.ints(j[:, 1])
    w.ints(j[:, 0] - j[:, 2])
    w.ints(j[:, 3])
    w.ints(j[:, 4])
    return bytes(w)


def _read_sides(data: bytes, m: BRepModel, coded: set[int]) -> None:
    """Read SIDE into ``m.side_joins`` and apply each join, in order, to the
    decoded nets (after SNET and the corner pins, before CNET)."""
    r = BlockReader(data, "SIDE")
    (n,) = r.ints(1)
    if n < 0:
        raise SectionError("SIDE: negative count")
    cols = [r.deltas(int(n)), *(r.ints(int(n)) for _ in range(4))]
    r.done()
    cols[2] = cols[0] - cols[2]
    rows = np.stack(cols, axis=1).astype(np.int64).reshape(-1, 5)
    for k, (b, side, a, lside, rev) in enumerate(rows.tolist()):
        where = f"SIDE row {k}"
        if b not in coded or not 0 <= a < len(m.surfaces):
            raise BadReferenceError(f"{where}: refers to a missing or uncoded surface row")
        if not (0 <= side < joins.SIDES and 0 <= lside < joins.SIDES and rev in (0, 1)):
            raise SectionError(f"{where}: no such side")
        g, lead = m.surfaces[b], m.surfaces[a]
        if not (joins.clamped_surface(g) and joins.clamped_surface(lead)):
            raise SectionError(f"{where}: joins a surface that is not a clamped B-spline")
        try:
            g.poles[...] = joins.joined_sides(g, lead, np.array([b, side, a, lside, rev]))  # type: ignore[arg-type,union-attr]
        except ValueError as e:
            raise SectionError(f"{where}: {e}") from None
    m.side_joins = rows


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


def _twin_copy(
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


def _curve_anchors(m: BRepModel, codes: dict[int, codec.NetCode]) -> dict[int, np.ndarray]:
    rows: dict[int, int] = {}
    for i, g in enumerate(m.curves3d):
        if id(g) in codes:
            rows.setdefault(id(g), i)
    return joins.anchors(m, m.curves3d, set(rows.values()))


#: The sections of format 1.0, in the order they are written and must be read.
SECTIONS = ("META", "LOCS", "SURF", "SNET", "CRV3", "CNET", "CRV2", "SHAP", "VERT", "EDGE", "FACE")
#: What each minor version adds, after the sections of the minors before it.
ADDED = {1: ("SIDE",)}


def layout(minor: int) -> tuple[str, ...]:
    """The sections a file of format 1.``minor`` holds, in order (as far as this reader knows)."""
    return SECTIONS + tuple(t for k, tags in sorted(ADDED.items()) if k <= minor for t in tags)


def check_layout(tags: list[str], minor: int, reader_minor: int) -> None:
    """Check a container's section tags: every section of ``SECTIONS``, in its order.

    A section this reader does not know is refused in a file of a minor version
    it knows (``minor <= reader_minor``), and skipped in a newer minor's file
    (format 1.x adds sections only with a minor bump; docs/format.md, §0).

    Raises
    ------
    CorruptError
        A section is missing, out of order, or unknown.
    """
    order = layout(min(minor, reader_minor))
    known = [t for t in tags if t in order]
    for t in tags:
        if t not in order and minor <= reader_minor:
            raise CorruptError(f"unknown section {t!r} (position {tags.index(t)})")
    for t in SECTIONS:
        if t not in known:
            raise CorruptError(f"missing section {t}")
    expect = [t for t in order if t in known]  # the sections a later minor added are optional
    if known != expect:
        bad = next(i for i, (a, b) in enumerate(zip(known, expect)) if a != b)
        raise CorruptError(f"section {known[bad]} out of order (position {tags.index(known[bad])})")


def _number(x: Any) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool)


#: Largest META section a reader parses, in bytes (a writer's is ~200).
MAX_META_BYTES = 1 << 16
#: Longest string in META, in characters (``source_name`` is a file name).
MAX_META_TEXT = 1024
#: Most digits of an integer in META (``int()`` of a longer one is refused by
#: Python, and ``source_bytes`` fits 2^53 anyway).
MAX_META_DIGITS = 20
#: Largest ``source_bytes`` (exactly representable as a double).
MAX_SOURCE_BYTES = 2**53


def _meta_int(digits: str) -> int:
    if len(digits.lstrip("-")) > MAX_META_DIGITS:
        raise SectionError(f"META: an integer of {len(digits)} digits is too long")
    return int(digits)


def _meta_constant(name: str) -> float:
    raise SectionError(f"META: {name} is not a number")


def _bad_text(s: str) -> bool:
    """A control character (C0, DEL, C1) or a lone surrogate in ``s``."""
    return any(c < " " or "\x7f" <= c <= "\x9f" or "\ud800" <= c <= "\udfff" for c in s)


def meta_text(s: str) -> str:
    """``s`` as META may hold it: control characters and lone surrogates (a
    file name's undecodable bytes) become U+FFFD, and it is cut to ``MAX_META_TEXT``."""
    s = s[:MAX_META_TEXT]
    return "".join("\ufffd" if _bad_text(c) else c for c in s) if _bad_text(s) else s


def read_meta(raw: bytes) -> dict[str, Any]:
    """The META section's JSON object, its fields checked.

    Raises
    ------
    LimitError
        The section is larger than ``MAX_META_BYTES``.
    SectionError
        Not a JSON object, or a field of the wrong type or value: integers of
        more than ``MAX_META_DIGITS`` digits, NaN or infinities, strings longer
        than ``MAX_META_TEXT`` or holding control characters or lone surrogates.
    """
    if len(raw) > MAX_META_BYTES:
        raise LimitError(f"META: {len(raw)} bytes, more than the {MAX_META_BYTES} a reader parses")
    try:
        meta = json.loads(raw.decode("utf-8"), parse_int=_meta_int, parse_constant=_meta_constant)
    except (UnicodeDecodeError, json.JSONDecodeError, RecursionError):
        raise SectionError("META section is not valid JSON") from None
    if not isinstance(meta, dict):
        raise SectionError("META section is not a JSON object")
    for key in ("unit", "source_format", "mode", "source_name", "writer"):
        v = meta.get(key, "")
        if not isinstance(v, str) and not (key == "mode" and v is None):
            raise SectionError(f"META: {key} is not a string")
        if isinstance(v, str) and (len(v) > MAX_META_TEXT or _bad_text(v)):
            raise SectionError(
                f"META: {key} is longer than {MAX_META_TEXT} characters or holds control "
                "characters or lone surrogates"
            )
    unit = meta.get("unit", "MM")
    if unit not in UNITS_MM:
        raise SectionError(f"META: unknown unit {unit[:20]!r}")
    mode, tol = meta.get("mode"), meta.get("tolerance_mm")
    if mode not in ("lossless", "tolerance"):
        raise SectionError(f"META: unknown mode {str(mode)[:20]!r}")
    if mode == "tolerance" and not (_number(tol) and 0 < cast(float, tol) < MAX_COORD):
        raise SectionError("META: tolerance_mm is not a positive number")
    if mode == "lossless" and tol is not None:
        raise SectionError("META: a lossless container has a tolerance")
    size = meta.get("source_bytes", 0)
    if not (_number(size) and 0 <= size <= MAX_SOURCE_BYTES):
        raise SectionError(f"META: source_bytes is not a number from 0 to {MAX_SOURCE_BYTES}")
    return meta


def sections_to_model(
    get: Any,
    minor: int | None = None,
    limits: budget.Limits | None = budget.DEFAULT,
) -> tuple[BRepModel, dict[str, Any]]:
    """Rebuild a model from a section lookup ``get(tag) -> bytes``; check every reference.

    ``minor`` is the file's minor version, capped at this reader's (default:
    the newest this reader knows, ``max(ADDED)``): it says which sections there are.
    ``limits`` is the decoding budget (``budget.check_structure``), checked on
    the tables before any net is decoded or any walk over the shapes is made;
    None skips it (a container just written).

    Raises
    ------
    CorruptError
        A section is missing, or a subclass: ``SectionError`` (a section does
        not decode; its tag and where), ``BadReferenceError`` (an index points
        outside its table).
    LimitError
        Coded nets larger than a reader allocates, or a shape past ``limits``.
    """
    with np.errstate(all="ignore"):  # overflows become non-finite values, refused by name
        return _sections_to_model(get, max(ADDED) if minor is None else minor, limits)


def _optional(get: Any, tag: str) -> bytes | None:
    """A section a later minor added, or None where the file has none
    (``get`` is a container's, raising ``CorruptError``, or a dict's)."""
    try:
        return cast(bytes, get(tag))
    except (CorruptError, KeyError):
        return None


def _sections_to_model(
    get: Any, minor: int, limits: budget.Limits | None
) -> tuple[BRepModel, dict[str, Any]]:
    meta = read_meta(get("META"))
    m = BRepModel()
    m.unit = str(meta.get("unit", "MM"))
    m.source_format = str(meta.get("source_format", "STEP"))
    tol_mm = meta.get("tolerance_mm")
    tol = float(cast(float, tol_mm)) if _number(tol_mm) else 0.0
    # the tables first, coded poles last: nets are coded against vertices
    _read_locations(get("LOCS"), m)
    m.surfaces = _read_geometry(get("SURF"), "SURF", 3)
    m.curves3d = _read_geometry(get("CRV3"), "CRV3", 3)
    m.curves2d = _read_geometry(get("CRV2"), "CRV2", 2)
    _read_shapes(get("SHAP"), m)
    _read_vertices(get("VERT"), m, tol)
    range_how = _read_edges(get("EDGE"), m)
    _read_faces(get("FACE"), m)
    check_references(m)
    if limits is not None:
        budget.check_structure(m, limits)
    _check_location_matrices(m)
    _resolve_ranges(m, range_how)
    coded_surfaces = set(coded_rows(m.surfaces))
    _read_nets(get("SNET"), m.surfaces, tol, "SNET")
    for r, pins in joins.surface_corner_pins(m, m.surfaces, coded_surfaces, tol).items():
        g = m.surfaces[r]
        g.poles[...] = joins.pinned_corners(m, g, pins)  # type: ignore[union-attr,arg-type]
    sides = _optional(get, "SIDE") if "SIDE" in layout(minor) else None
    if sides is not None:
        _read_sides(sides, m, coded_surfaces)
    coded_curves = set(coded_rows(m.curves3d))
    anchors = joins.anchors(m, m.curves3d, coded_curves)
    copies = _read_nets(get("CNET"), m.curves3d, tol, "CNET", anchors, m.surfaces)
    pinned = coded_curves - {row for _, row, _ in copies}
    for c, pins in joins.curve_end_pins(m, m.curves3d, pinned, tol).items():
        g = cast(BSplineCurve, m.curves3d[c])
        g.poles[...] = joins.pinned_poles(m, g, pins)
    _fill_copies(copies, m)
    return m, meta


def check_references(m: BRepModel) -> None:
    """Raise ``BadReferenceError`` unless every index in ``m`` points into its table."""
    ns, n3, n2, nl = len(m.surfaces), len(m.curves3d), len(m.curves2d), len(m.locations)
    counts = m.counts()

    def within(a: np.ndarray, lo: int, hi: int, what: str) -> None:
        if len(a) and (a.min() < lo or a.max() >= hi):
            at = int(np.flatnonzero((a < lo) | (a >= hi))[0])
            raise BadReferenceError(f"{what} (entry {at} of its kind) refers to a missing entry")

    for g in m.surfaces:
        if isinstance(g, Derived):
            if g.kind in SWEPT:
                within(np.array([g.basis]), 0, n3, "a swept surface")
    for table, n in ((m.curves3d, n3), (m.curves2d, n2)):
        for g in table:
            if isinstance(g, Derived):
                within(np.array([g.basis]), 0, n, "a derived curve")
    within(m.child_loc, 0, nl, "a sub-shape location")
    within(np.array([m.root_loc]), 0, nl, "the root location")
    if len(m.vertex_tol) != counts["vertex"] or len(m.edge_tol) != counts["edge"]:
        raise BadReferenceError("vertex or edge table does not match the shapes table")
    if len(m.face_surface) != counts["face"]:
        raise BadReferenceError("face table does not match the shapes table")
    within(m.face_surface, 0, ns, "a face surface")
    within(m.face_loc, 0, nl, "a face location")
    reps = m.edge_reps
    kind = reps[:, 1]
    two = kind == RepKind.ON_TWO_SURFACES
    c3 = kind == RepKind.CURVE3D
    within(reps[c3, 2], -1, n3, "an edge curve")
    within(reps[~two & ~c3, 2], REBUILD, n2, "an edge pcurve")
    within(reps[kind == RepKind.ON_CLOSED_SURFACE, 3], REBUILD, n2, "a seam pcurve")
    if (reps[~two & ~c3, 2] == -1).any() or (
        reps[kind == RepKind.ON_CLOSED_SURFACE, 3] == -1
    ).any():
        raise BadReferenceError("an edge pcurve refers to a missing entry")
    seam = reps[kind == RepKind.ON_CLOSED_SURFACE]
    if ((seam[:, 2] == REBUILD) != (seam[:, 3] == REBUILD)).any():
        raise BadReferenceError("a seam has one pcurve stored and the other one computed")
    within(reps[~c3, 4], 0, ns, "an edge surface")
    within(reps[two, 5], 0, ns, "an edge surface")
    within(reps[:, 6], 0, nl, "an edge location")
    within(reps[two, 7], 0, nl, "an edge location")
    within(m.edge_rep_cont, 0, 7, "a continuity")
    vr = m.vertex_reps
    within(vr[:, 1], 0, 3, "a vertex representation kind")
    within(vr[vr[:, 1] == 0, 2], 0, n3, "a vertex curve")
    within(vr[vr[:, 1] == 1, 2], 0, n2, "a vertex pcurve")
    within(vr[vr[:, 1] > 0, 3], 0, ns, "a vertex surface")
    within(vr[:, 4], 0, nl, "a vertex location")
    types = m.shape_type
    within(types, 0, 8, "a shape type")
