"""Model tables -> an OCCT ``BinTools`` stream, read back in one call.

:func:`model_to_shape` of :mod:`.topology` makes one Python call into OCCT per
entity.  This module writes the same B-rep as the binary stream OCCT's own
``BinTools::Write`` makes (format "Open CASCADE Topology V3", the layout of
``BinTools_ShapeSet``, ``BinTools_LocationSet``, ``BinTools_Curve2dSet``,
``BinTools_CurveSet`` and ``BinTools_SurfaceSet``), with numpy and ``struct``,
and lets ``BinTools_ShapeSet::Read`` build it, so the cost of a build is in C++.

The stream is written so that the shape read is the one
:func:`.topology.model_to_shape` builds: the same sub-shapes in the same
order, the same representations in the same order with the same numbers, the
same flags.  Where ``BinTools_ShapeSet::Read`` would build something else
(:func:`unsupported` says why), the caller builds with the per-entity builder
instead.  What the reader does that the stream cannot say, and how it is met:

- ``BRep_Builder::Range`` re-evaluates a pcurve's end points (``UVPoints``)
  from the pcurve; the per-entity builder sets the stored ones.  They are the
  same wherever the stored points are the pcurve's ends (a shape OCCT built).
- ``BRep_Builder::Degenerated`` gives a degenerated edge a null 3-D curve
  with the range ``RealFirst()``, ``RealLast()``; another stored range is set
  afterwards.
- ``TopoDS_Builder::Add`` clears a sub-shape's Free flag, and the stream has
  no Locked flag: both are set afterwards on the shapes that have them.
- Pcurves the container left out (``REBUILD``) are projected afterwards by the
  same code as the per-entity builder (:func:`.topology.rebuild_pcurves`), and
  the flags of what that touched are set again, as that builder does last.
"""

from __future__ import annotations

import io
import math
import struct
from typing import Any

import numpy as np
from OCP.BinTools import BinTools_ShapeSet
from OCP.gp import gp_Ax2, gp_Ax3, gp_Dir, gp_Dir2d, gp_Pnt, gp_TrsfForm
from OCP.TopAbs import TopAbs_Orientation
from OCP.TopoDS import TopoDS

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
)
from .geometry import _ulps

_ORIENT = [TopAbs_Orientation(i) for i in range(4)]
_VERSION = b"\nOpen CASCADE Topology V3 (c)\n"
#: ``RealEpsilon()``: the tolerance a new ``BRep_TVertex``/``BRep_TEdge`` has;
#: ``UpdateTolerance`` only raises it.
_REAL_EPSILON = 2.220446049250313e-16
#: gp_TrsfForm values that ``gp_Trsf::SetValues`` (the stream's reader) does
#: not give back: the per-entity builder keeps them.
_IDENTITY, _TRANSLATION = gp_TrsfForm.gp_Identity.value, gp_TrsfForm.gp_Translation.value
#: The range of ``BRep_Curve3D`` of a null curve: ``RealFirst()``, ``RealLast()``
#: (a degenerated edge's null curve with another range has it set after the read).
NULL_RANGE = np.array([-np.finfo(np.float64).max, np.finfo(np.float64).max])

# BinTools_SurfaceSet / BinTools_CurveSet / BinTools_Curve2dSet type bytes
_SURFACE_CODE = {
    Kind.PLANE: 1,
    Kind.CYLINDER: 2,
    Kind.CONE: 3,
    Kind.SPHERE: 4,
    Kind.TORUS: 5,
    Kind.EXTRUSION: 6,
    Kind.REVOLUTION: 7,
    Kind.BEZIER_SURFACE: 8,
    Kind.BSPLINE_SURFACE: 9,
    Kind.TRIMMED_SURFACE: 10,
    Kind.OFFSET_SURFACE: 11,
}
_CURVE_CODE = {
    Kind.LINE: 1,
    Kind.CIRCLE: 2,
    Kind.ELLIPSE: 3,
    Kind.PARABOLA: 4,
    Kind.HYPERBOLA: 5,
    Kind.BEZIER_CURVE: 6,
    Kind.BSPLINE_CURVE: 7,
    Kind.TRIMMED_CURVE: 8,
    Kind.OFFSET_CURVE: 9,
}

_VERTEX, _EDGE, _FACE = int(ShapeType.VERTEX), int(ShapeType.EDGE), int(ShapeType.FACE)
_CURVE3D, _ON_SURFACE = int(RepKind.CURVE3D), int(RepKind.ON_SURFACE)
_ON_CLOSED, _ON_TWO = int(RepKind.ON_CLOSED_SURFACE), int(RepKind.ON_TWO_SURFACES)
_P_CURVE, _P_CURVE_SURF = int(PointRepKind.ON_CURVE), int(PointRepKind.ON_CURVE_ON_SURFACE)

_d = struct.Struct("<d").pack
_i = struct.Struct("<i").pack
_ii = struct.Struct("<ii").pack
_3d = struct.Struct("<3d").pack
_2d = struct.Struct("<2d").pack
_KNOT = np.dtype([("k", "<f8"), ("m", "<i4")])


class Unexpressed(Exception):
    """A model the stream cannot carry so that it reads back as the
    per-entity builder's shape (the message says what)."""


# ---------------------------------------------------------------- directions


def _preimage(target: tuple[float, ...], make: Any, read: Any) -> tuple[float, ...]:
    """The input ``c`` that ``geometry._fixed_point`` hands to ``make``: the
    target itself if ``read(make(target))`` is the target, else the first of
    its neighbours up to 2 ulps away that is a pre-image, else the target."""
    if read(make(target)) == target:
        return target
    import itertools

    for cand in itertools.product(*(_ulps(x, 2) for x in target)):
        if read(make(cand)) == target:
            return tuple(cand)
    return target


def _xyz(p: Any) -> tuple[float, ...]:
    return p.Coord()


class _Frames:
    """The numbers to write for directions and frames so that OCCT's
    constructors (which normalise) give what ``geometry.GeometryBuilder``
    gives: its ``_dir``, ``_dir2d``, ``_ax2`` and ``_ax3`` search the inputs
    a few ulps around the stored values; so does this, once per value."""

    def __init__(self) -> None:
        # keyed by the bits (0.0 == -0.0 as floats, not as bits)
        self._dirs: dict[bytes, tuple[float, ...]] = {}
        self._xdirs: dict[tuple[Any, ...], tuple[float, ...]] = {}

    def dir(self, t: np.ndarray) -> tuple[float, ...]:
        bits = t.astype(np.float64).tobytes()
        got = self._dirs.get(bits)
        if got is None:
            key = tuple(t.tolist())
            if len(key) == 3:
                got = _preimage(key, lambda c: gp_Dir(*c), _xyz)
            else:
                got = _preimage(key, lambda c: gp_Dir2d(*c), _xyz)
            self._dirs[bits] = got
        return got

    def xdir(self, f: np.ndarray, ax: Any = gp_Ax3) -> tuple[tuple[float, ...], tuple[float, ...]]:
        """Main and X direction inputs of ``gp_Ax3(P, N, Vx)`` (or ``ax``:
        ``gp_Ax2``) as ``GeometryBuilder``'s ``_ax3`` (``_ax2``) finds them
        (the X direction is derived from ``N`` and ``Vx`` alone)."""
        n = self.dir(f[1])
        key = (ax.__name__, struct.pack("<3d", *n), f[2].astype(np.float64).tobytes())
        got = self._xdirs.get(key)
        if got is None:
            p, dn = gp_Pnt(*f[0].tolist()), gp_Dir(*n)
            got = _preimage(
                tuple(f[2].tolist()),
                lambda c: ax(p, dn, gp_Dir(*c)),
                lambda a: _xyz(a.XDirection()),
            )
            self._xdirs[key] = got
        return n, got


# ---------------------------------------------------------------- geometry


class _Geometry:
    """Writes the three geometry sets; every row of each table is one entry
    (index row + 1), so rows keep their own handles as in ``GeometryBuilder``."""

    def __init__(self, m: BRepModel) -> None:
        self.m = m
        self.frames = _Frames()

    def check(self) -> None:
        """Raise :class:`Unexpressed` where a record would read back otherwise
        than ``GeometryBuilder`` builds it."""
        m = self.m
        face_rows = set(m.face_surface.tolist())
        used = (
            face_rows
            | set(m.edge_reps[:, EC.SURFACE].tolist())
            | set(m.edge_reps[:, EC.SURFACE2].tolist())
        )
        used |= set(m.vertex_reps[:, VC.SURFACE].tolist())
        for table in (m.curves3d, m.curves2d):
            for r in table:
                if isinstance(r, Derived):
                    if r.kind == Kind.OFFSET_CURVE:
                        raise Unexpressed("offset curve (the reader checks C0 bases)")
                    if r.kind == Kind.TRIMMED_CURVE and not _trim_kept(table, r):
                        raise Unexpressed("trimmed periodic curve (the reader adjusts its period)")
        for r in m.surfaces:
            if isinstance(r, Derived):
                if r.kind == Kind.OFFSET_SURFACE:
                    raise Unexpressed("offset surface (the reader checks C0 bases)")
                if r.kind == Kind.TRIMMED_SURFACE and r.basis in used:
                    raise Unexpressed("trimmed surface on a surface a shape uses (shared handle)")

    def surface(self, r: Geometry, out: list[bytes]) -> None:
        code = _SURFACE_CODE[r.kind]
        out.append(bytes((code,)))
        if isinstance(r, Analytic):
            out.append(self._ax3(r.frame))
            p = r.params.tolist()
            if r.kind == Kind.CONE:  # radius, then semi-angle
                out.append(_2d(p[0], p[1]))
            elif r.kind == Kind.TORUS:
                out.append(_2d(p[0], p[1]))
            elif r.kind != Kind.PLANE:
                out.append(_d(p[0]))
        elif isinstance(r, Derived):
            if r.kind == Kind.REVOLUTION:
                out.append(_3d(*r.frame[0].tolist()))
                out.append(_3d(*self.frames.dir(r.frame[1])))
                self.curve(self.m.curves3d, self.m.curves3d[r.basis], 3, out)
            elif r.kind == Kind.EXTRUSION:
                out.append(_3d(*self.frames.dir(r.frame[0])))
                self.curve(self.m.curves3d, self.m.curves3d[r.basis], 3, out)
            elif r.kind == Kind.TRIMMED_SURFACE:
                out.append(r.params.astype("<f8").tobytes())
                self.surface(self.m.surfaces[r.basis], out)
            else:  # pragma: no cover - refused by check()
                raise Unexpressed(f"surface kind {r.kind!r}")
        else:
            assert isinstance(r, BSplineSurface)
            rational = r.weights is not None
            nu, nv = r.poles.shape[:2]
            if r.bezier:
                out.append(struct.pack("<??HH", rational, rational, nu - 1, nv - 1))
            else:
                out.append(
                    struct.pack(
                        "<????HHiiii",
                        rational,
                        rational,
                        bool(r.uperiodic),
                        bool(r.vperiodic),
                        r.udegree,
                        r.vdegree,
                        nu,
                        nv,
                        len(r.uknots),
                        len(r.vknots),
                    )
                )
            poles = r.poles.astype("<f8", copy=False)
            if rational:
                assert r.weights is not None
                poles = np.concatenate([poles, r.weights[..., None].astype("<f8")], axis=-1)
            out.append(np.ascontiguousarray(poles).tobytes())
            if not r.bezier:
                out.append(_knots(r.uknots, r.umults))
                out.append(_knots(r.vknots, r.vmults))

    def curve(self, table: list[Geometry], r: Geometry, dim: int, out: list[bytes]) -> None:
        out.append(bytes((_CURVE_CODE[r.kind],)))
        if isinstance(r, Analytic):
            f = r.frame
            if r.kind == Kind.LINE:
                out.append(f[0].astype("<f8").tobytes())
                out.append(struct.pack(f"<{dim}d", *self.frames.dir(f[1])))
                return
            if dim == 3:
                a, x = self.frames.xdir(f, gp_Ax2)
                out.append(f[0].astype("<f8").tobytes())  # gp_Ax2(P, A, AX); AY unread
                out.append(_3d(*a) + _3d(*x) + _3d(*a))
            else:
                # gp_Ax22d(P, Vx, Vy): the two directions as GeometryBuilder's _ax22d
                out.append(f[0].astype("<f8").tobytes())
                out.append(_2d(*self.frames.dir(f[1])) + _2d(*self.frames.dir(f[2])))
            out.append(r.params.astype("<f8").tobytes())
        elif isinstance(r, BSplineCurve):
            rational = r.weights is not None
            n = len(r.poles)
            if r.bezier:
                out.append(struct.pack("<?H", rational, n - 1))
            else:
                head = (rational, bool(r.periodic), r.degree, n, len(r.knots))
                out.append(struct.pack("<??Hii", *head))
            poles = r.poles.astype("<f8", copy=False)
            if rational:
                assert r.weights is not None
                poles = np.concatenate([poles, r.weights[:, None].astype("<f8")], axis=1)
            out.append(np.ascontiguousarray(poles).tobytes())
            if not r.bezier:
                out.append(_knots(r.knots, r.mults))
        else:
            assert isinstance(r, Derived)
            if r.kind != Kind.TRIMMED_CURVE:  # pragma: no cover - refused by check()
                raise Unexpressed(f"curve kind {r.kind!r}")
            out.append(r.params.astype("<f8").tobytes())
            self.curve(table, table[r.basis], dim, out)

    def _ax3(self, f: np.ndarray) -> bytes:
        n, x = self.frames.xdir(f)
        # the reader reverses Y where AY . (A ^ AX) < 0; GeometryBuilder where
        # the stored frame's (main ^ X) . Y < 0: write +-(A ^ AX) to agree
        a, b = np.array(n), np.array(x)
        y = np.cross(a, b)
        if np.dot(np.cross(f[1], f[2]), f[3]) < 0:
            y = -y
        return f[0].astype("<f8").tobytes() + _3d(*n) + _3d(*x) + y.astype("<f8").tobytes()


def _bits(*x: float) -> bytes:
    return struct.pack(f"<{len(x)}d", *x)


def _trim_kept(table: list[Geometry], r: Derived) -> bool:
    """Whether ``Geom_TrimmedCurve(basis, u1, u2)`` (the reader's, which
    adjusts a periodic basis's bounds: ``ElCLib::AdjustPeriodic``) keeps
    ``u1``, ``u2`` bit for bit, as ``GeometryBuilder``'s (no adjusting) does."""
    b = table[r.basis]
    u1, u2 = r.params.tolist()
    if isinstance(b, Analytic):
        if b.kind not in (Kind.CIRCLE, Kind.ELLIPSE):
            return True  # a line or an open conic is not periodic
        first, last = 0.0, 2.0 * math.pi
    elif isinstance(b, BSplineCurve):
        return not b.periodic  # a periodic one: not worth the analysis
    else:
        return False  # a derived basis
    # ElCLib::AdjustPeriodic(first, last, min(|u2 - u1| / 2, PConfusion), u1, u2)
    preci = min(abs(u2 - u1) / 2, 1e-9)
    period = last - first
    a1 = u1 - math.floor((u1 - first) / period) * period
    if last - a1 < preci:
        a1 -= period
    a2 = u2 - math.floor((u2 - a1) / period) * period
    if a2 - a1 < preci:
        a2 += period
    return _bits(a1, a2) == _bits(u1, u2)


def _knots(k: np.ndarray, mlt: np.ndarray) -> bytes:
    a = np.empty(len(k), _KNOT)
    a["k"], a["m"] = k, mlt
    return a.tobytes()


# ---------------------------------------------------------------- the stream


def _locations(m: BRepModel) -> tuple[bytes, list[int]]:
    """The location set, and each model location's index in it.

    Every datum is an elementary entry (index datum + 1); a location that is
    one datum to the power 1 is that entry, every other one a composite entry
    after them (``BinTools_LocationSet::Read`` chains its items in order)."""
    forms = m.datum_forms.tolist()
    if any(f in (_IDENTITY, _TRANSLATION) for f in forms):
        raise Unexpressed("identity or translation datum (the reader makes a compound gp_Trsf)")
    out = []
    for rows in m.datums:
        out.append(b"\x01" + np.asarray(rows, "<f8").reshape(12).tobytes())
    index = [0]
    n = len(forms)
    for loc in m.locations[1:]:
        if len(loc.datums) == 1 and loc.powers[0] == 1:
            index.append(int(loc.datums[0]) + 1)
            continue
        parts = [b"\x02"]
        for d, p in zip(loc.datums, loc.powers):
            parts.append(_ii(int(d) + 1, int(p)))
        parts.append(_i(0))
        out.append(b"".join(parts))
        n += 1
        index.append(n)
    return b"Locations %d\n" % len(out) + b"".join(out), index


def unsupported(m: BRepModel) -> str:
    """Why the stream cannot carry ``m`` (""  if it can); see :func:`stream`."""
    try:
        _check(m)
        _locations(m)
        _Geometry(m).check()
    except Unexpressed as e:
        return str(e)
    return ""


def _check(m: BRepModel) -> None:
    if len(m.vertex_tol) and float(m.vertex_tol.min()) < _REAL_EPSILON:
        raise Unexpressed("vertex tolerance below RealEpsilon")
    reps = m.edge_reps
    ne = len(m.edge_tol)
    kind, c1 = reps[:, EC.KIND], reps[:, EC.CURVE]
    written = (kind == _CURVE3D) & (c1 >= 0) | ((kind == _ON_SURFACE) | (kind == _ON_CLOSED)) & (
        c1 != REBUILD
    )
    has = np.zeros(ne, bool)
    has[reps[written, EC.EDGE]] = True
    if ne and not has.all():
        raise Unexpressed("edge without a curve to carry its tolerance")
    if ne and float(m.edge_tol.min()) < _REAL_EPSILON:
        raise Unexpressed("edge tolerance below RealEpsilon")
    degenerated = (m.edge_flags & 1).astype(bool)
    # per edge: its representations in order, as BRep_Builder's UpdateCurves would merge them
    by_edge: dict[int, list[list[int]]] = {}
    for row in reps.tolist():
        by_edge.setdefault(row[0], []).append(row)
    for e, rows in by_edge.items():
        c3 = [r for r in rows if r[1] == _CURVE3D]
        if degenerated[e]:
            # the reader's Degenerated(E, true) puts a null 3-D curve first
            if not rows or rows[0][1] != _CURVE3D or rows[0][2] >= 0 or rows[0][6] != 0:
                raise Unexpressed("degenerated edge without its null 3-D curve first")
            if len(c3) != 1:
                raise Unexpressed("degenerated edge with a 3-D curve")
        elif any(r[2] < 0 for r in c3):
            raise Unexpressed("null 3-D curve on an edge that is not degenerated")
        if len(c3) > 1:
            raise Unexpressed("edge with two 3-D curves")
        seen: set[tuple[int, int]] = set()
        regular: set[tuple[int, int, int, int]] = set()
        for r in rows:
            if r[1] in (_ON_SURFACE, _ON_CLOSED):
                if (r[4], r[6]) in seen:
                    raise Unexpressed("edge with two pcurves on one surface")
                seen.add((r[4], r[6]))
                if r[1] == _ON_CLOSED:
                    regular.add((r[4], r[4], r[6], r[6]))
            elif r[1] == _ON_TWO:
                k = (r[4], r[5], r[6], r[7])
                if k in regular or (k[1], k[0], k[3], k[2]) in regular:
                    raise Unexpressed("edge with two regularities on one pair of surfaces")
                regular.add(k)


def stream(m: BRepModel) -> tuple[bytes, list[int]]:
    """The BinTools stream of ``m``'s shapes, and each model location's index
    in its location set.  Raises :class:`Unexpressed`."""
    _check(m)
    locs, loc_index = _locations(m)
    geo = _Geometry(m)
    geo.check()
    out: list[bytes] = [_VERSION, locs]
    out.append(b"\nCurve2ds %d\n" % len(m.curves2d))
    for r in m.curves2d:
        geo.curve(m.curves2d, r, 2, out)
    out.append(b"\nCurves %d\n" % len(m.curves3d))
    for r in m.curves3d:
        geo.curve(m.curves3d, r, 3, out)
    out.append(b"\nPolygon3D 0\n")
    out.append(b"PolygonOnTriangulations 0\n")
    out.append(b"\nSurfaces %d\n" % len(m.surfaces))
    for r in m.surfaces:
        geo.surface(r, out)
    out.append(b"\nTriangulations 0\n")
    out.append(_shapes(m, loc_index))
    return b"".join(out), loc_index


def _shapes(m: BRepModel, li: list[int]) -> bytes:
    n = len(m.shape_type)
    out = [b"\nTShapes %d\n" % n]
    tidx = m.type_index().tolist()
    start, child, corient, cloc = (
        m.child_start.tolist(),
        m.child_shape.tolist(),
        m.child_orient.tolist(),
        m.child_loc.tolist(),
    )
    vreps: list[list[int]] = [[] for _ in range(len(m.vertex_tol))]
    for q, v in enumerate(m.vertex_reps[:, VC.VERTEX].tolist()):
        vreps[v].append(q)
    ereps: list[list[int]] = [[] for _ in range(len(m.edge_tol))]
    for q, e in enumerate(m.edge_reps[:, EC.EDGE].tolist()):
        ereps[e].append(q)
    vrows, vpar = m.vertex_reps.tolist(), m.vertex_rep_params.astype("<f8")
    vpt, vtol = m.vertex_point.astype("<f8"), m.vertex_tol.tolist()
    erows, erng, euv = m.edge_reps.tolist(), m.edge_rep_range.astype("<f8"), m.edge_rep_uv
    econt, etol, eflags = m.edge_rep_cont.tolist(), m.edge_tol.tolist(), m.edge_flags.tolist()
    fsurf, floc, ftol = m.face_surface.tolist(), m.face_loc.tolist(), m.face_tol.tolist()
    fnat, flags = m.face_natural.tolist(), m.shape_flags.tolist()
    flag_bytes = [bytes((f >> b) & 1 for b in range(7)) for f in range(256)]
    for s, t in enumerate(m.shape_type.tolist()):
        out.append(bytes((t,)))
        k = tidx[s]
        if t == _VERTEX:
            out.append(_d(vtol[k]) + vpt[k].tobytes())
            for q in vreps[k]:
                _, kind, g, surf, loc = vrows[q]
                if kind == _P_CURVE:
                    out.append(b"\x01" + vpar[q, :1].tobytes() + _i(g + 1))
                elif kind == _P_CURVE_SURF:
                    out.append(b"\x02" + vpar[q, :1].tobytes() + _ii(g + 1, surf + 1))
                else:  # the reader takes u, then v
                    out.append(b"\x03" + vpar[q].tobytes() + _i(surf + 1))
                out.append(_i(li[loc]))
            out.append(b"\x00")
        elif t == _EDGE:
            f = eflags[k]
            out.append(_d(etol[k]) + bytes((f >> 1 & 1, f >> 2 & 1, f & 1)))
            for q in ereps[k]:
                _, kind, c1, c2, s1, s2, l1, l2 = erows[q]
                if kind == _CURVE3D:
                    if c1 < 0:
                        continue  # the null curve of a degenerated edge: Degenerated() makes it
                    out.append(b"\x01" + _ii(c1 + 1, li[l1]) + erng[q].tobytes())
                elif kind == _ON_SURFACE:
                    if c1 == REBUILD:
                        continue
                    out.append(b"\x02" + _i(c1 + 1) + _ii(s1 + 1, li[l1]) + erng[q].tobytes())
                    out.append(euv[q, :4].astype("<f8").tobytes())
                elif kind == _ON_CLOSED:
                    if c1 == REBUILD:
                        continue
                    out.append(
                        b"\x03"
                        + _ii(c1 + 1, c2 + 1)
                        + bytes((econt[q],))
                        + _ii(s1 + 1, li[l1])
                        + erng[q].tobytes()
                        + euv[q, 4:].astype("<f8").tobytes()
                    )
                else:
                    regular = _ii(s1 + 1, li[l1]) + _ii(s2 + 1, li[l2])
                    out.append(b"\x04" + bytes((econt[q],)) + regular)
            out.append(b"\x00")
        elif t == _FACE:
            surf = _ii(fsurf[k] + 1, li[floc[k]])
            out.append(bytes((bool(fnat[k]),)) + _d(ftol[k]) + surf + b"\x00")
        out.append(flag_bytes[flags[s]])
        for c in range(start[s], start[s + 1]):
            out.append(bytes((corient[c],)) + _ii(n - child[c], li[cloc[c]]))
        out.append(b"*")
    return b"".join(out)


def read(data: bytes) -> BinTools_ShapeSet:
    """``BinTools_ShapeSet::Read`` of a stream: the set, whose ``Shape(i + 1)``
    is the model's shape ``i``."""
    ss = BinTools_ShapeSet()
    ss.Read(io.BytesIO(data))
    return ss


def edge(ss: BinTools_ShapeSet, i: int) -> Any:
    return TopoDS.Edge(ss.Shape(i + 1))


def face(ss: BinTools_ShapeSet, i: int) -> Any:
    return TopoDS.Face(ss.Shape(i + 1))


def root(ss: BinTools_ShapeSet, m: BRepModel, loc_index: list[int]) -> Any:
    s = ss.Shape(m.root_shape + 1)
    loc = ss.Locations().Location(loc_index[m.root_loc])
    return s.Oriented(_ORIENT[m.root_orient]).Located(loc)
