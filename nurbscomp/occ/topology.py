"""TopoDS shapes <-> the model's topology tables.

Reading walks the shape graph once, in post-order, and stores every TShape once,
keyed by the shape at the identity location with FORWARD orientation.  Each
reference to a sub-shape keeps its own orientation and location.

Building goes front to back through the shapes table with ``BRep_Builder``
(never sewing), and restores every curve and point representation of edges and
vertices as it was, so that the rebuilt shape is the same B-rep: same sub-shape
order, same sharing, same flags, same numbers.  :func:`model_to_shape` does
that in one call into OCCT where it can, by way of a ``BinTools`` stream
(:mod:`.bintools`, issue 30), and with one call per entity
(:func:`slow_model_to_shape`) where the stream cannot carry the model; both
give the same shape.
"""

from __future__ import annotations

import collections
import dataclasses
import math
import struct
from collections.abc import Callable
from typing import Any, cast

import numpy as np
from OCP.BRep import (
    BRep_Builder,
    BRep_Curve3D,
    BRep_CurveOn2Surfaces,
    BRep_CurveOnClosedSurface,
    BRep_CurveOnSurface,
    BRep_PointOnCurve,
    BRep_PointOnCurveOnSurface,
    BRep_PointOnSurface,
    BRep_TEdge,
    BRep_TFace,
    BRep_Tool,
    BRep_TVertex,
)
from OCP.BRepCheck import BRepCheck_NoError, BRepCheck_Wire
from OCP.Geom import Geom_Plane, Geom_RectangularTrimmedSurface
from OCP.GeomAbs import GeomAbs_Shape
from OCP.gp import gp_Pln, gp_Pnt, gp_Pnt2d, gp_Trsf, gp_TrsfForm, gp_Vec, gp_Vec2d
from OCP.ShapeAnalysis import ShapeAnalysis_Edge, ShapeAnalysis_Surface
from OCP.ShapeExtend import ShapeExtend_DONE3, ShapeExtend_FAIL, ShapeExtend_WireData
from OCP.ShapeFix import ShapeFix_Edge, ShapeFix_Wire
from OCP.Standard import Standard_Failure
from OCP.Storage import Storage_StreamFormatError, Storage_StreamReadError
from OCP.TopAbs import (
    TopAbs_FACE,
    TopAbs_FORWARD,
    TopAbs_Orientation,
    TopAbs_REVERSED,
    TopAbs_WIRE,
)
from OCP.TopExp import TopExp, TopExp_Explorer
from OCP.TopLoc import TopLoc_Datum3D, TopLoc_Location
from OCP.TopoDS import (
    TopoDS,
    TopoDS_Compound,
    TopoDS_CompSolid,
    TopoDS_Edge,
    TopoDS_Face,
    TopoDS_Iterator,
    TopoDS_Shape,
    TopoDS_Shell,
    TopoDS_Solid,
    TopoDS_Vertex,
    TopoDS_Wire,
)
from OCP.TopTools import TopTools_IndexedMapOfShape, TopTools_MapOfShape

from ..errors import UnsupportedError
from ..model import (
    EC,
    REBUILD,
    VC,
    BRepModel,
    Derived,
    Kind,
    Location,
    PointRepKind,
    RepKind,
    ShapeType,
    Table,
    rows_by_owner,
)
from . import bintools
from .geometry import GeometryBuilder, GeometryReader, record_key, segment2d
from .isolated import ReaderCrash, RoundTrip, can_fork, spare_core
from .lists import items

_ORIENT = [TopAbs_Orientation(i) for i in range(4)]
_CONT = [GeomAbs_Shape(i) for i in range(7)]
# plain ints for the builder's loops (an enum member looked up on its class
# costs a Python call in 3.11, thousands of times a build)
_VERTEX, _EDGE, _FACE = int(ShapeType.VERTEX), int(ShapeType.EDGE), int(ShapeType.FACE)
_CURVE3D, _ON_SURFACE = int(RepKind.CURVE3D), int(RepKind.ON_SURFACE)
_ON_CLOSED_SURFACE, _ON_TWO_SURFACES = int(RepKind.ON_CLOSED_SURFACE), int(RepKind.ON_TWO_SURFACES)
_ON_CURVE, _ON_CURVE_ON_SURFACE = int(PointRepKind.ON_CURVE), int(PointRepKind.ON_CURVE_ON_SURFACE)
_ON_SURFACE_POINT = int(PointRepKind.ON_SURFACE)


def _flags(ts: Any) -> int:
    """The TShape's eight flags as bits 0-7: Free, Modified, Checked,
    Orientable, Closed, Infinite, Convex, Locked (docs/format.md, the shape flags)."""
    return (
        ts.Free()
        | ts.Modified() << 1
        | ts.Checked() << 2
        | ts.Orientable() << 3
        | ts.Closed() << 4
        | ts.Infinite() << 5
        | ts.Convex() << 6
        | ts.Locked() << 7
    )


def _set_flags(ts: Any, flags: int) -> None:
    """Set the flags :func:`_flags` reads."""
    ts.Free(bool(flags & 1))
    ts.Modified(bool(flags & 2))
    ts.Checked(bool(flags & 4))
    ts.Orientable(bool(flags & 8))
    ts.Closed(bool(flags & 16))
    ts.Infinite(bool(flags & 32))
    ts.Convex(bool(flags & 64))
    ts.Locked(bool(flags & 128))


def _trsf_rows(t: gp_Trsf) -> list[float]:
    return [t.Value(i, j) for i in (1, 2, 3) for j in (1, 2, 3, 4)]


def _trsf(rows: np.ndarray, form: int) -> gp_Trsf:
    t = gp_Trsf()
    v = rows.reshape(12).tolist()
    if form == gp_TrsfForm.gp_Identity.value:
        return t
    if form == gp_TrsfForm.gp_Translation.value:
        t.SetTranslation(gp_Vec(v[3], v[7], v[11]))
        return t
    t.SetValues(*v)
    return t


class _Reader:
    def __init__(self) -> None:
        self.geo = GeometryReader()
        self.keys = TopTools_IndexedMapOfShape()
        self.datum_objs: list[Any] = []
        self.datum_rows: list[list[float]] = []
        self.datum_forms: list[int] = []
        self.loc_index: dict[tuple[tuple[int, int], ...], int] = {(): 0}
        self.locations: list[Location] = [Location((), ())]
        self.types: list[int] = []
        self.flags: list[int] = []
        self.child_start = [0]
        self.children: list[tuple[int, int, int]] = []
        self.vpoint: list[tuple[float, float, float]] = []
        self.vtol: list[float] = []
        self.vreps: list[tuple[int, ...]] = []
        self.vrep_params: list[tuple[float, float]] = []
        self.etol: list[float] = []
        self.eflags: list[int] = []
        self.ereps: list[tuple[int, ...]] = []
        self.erep_cont: list[int] = []
        self.erep_range: list[tuple[float, float]] = []
        self.erep_uv: list[tuple[float, ...]] = []
        self.fsurf: list[int] = []
        self.floc: list[int] = []
        self.ftol: list[float] = []
        self.fnat: list[bool] = []
        self.warnings: list[str] = []
        # shape index -> table index (keys map is 1-based and filled in pre-order)
        self.index_of: dict[int, int] = {}

    def location(self, loc: TopLoc_Location) -> int:
        items = []
        while not loc.IsIdentity():
            d = loc.FirstDatum()
            k = next((i for i, o in enumerate(self.datum_objs) if o is d), -1)
            if k < 0:
                k = len(self.datum_objs)
                self.datum_objs.append(d)
                t = d.Transformation()
                self.datum_rows.append(_trsf_rows(t))
                self.datum_forms.append(t.Form().value)
            items.append((k, loc.FirstPower()))
            loc = loc.NextLocation()
        key = tuple(items)
        i = self.loc_index.get(key)
        if i is None:
            i = self.loc_index[key] = len(self.locations)
            self.locations.append(Location(tuple(k for k, _ in items), tuple(p for _, p in items)))
        return i

    def shape(self, s: Any) -> int:
        """Table index of the TShape under ``s`` (adding it and its sub-shapes).

        A depth-first walk in post-order with a stack of its own (no
        recursion, so no nesting depth exhausts Python's stack); a TShape seen
        before is looked up, never walked again."""
        key = s.Located(TopLoc_Location()).Oriented(TopAbs_FORWARD)
        k = self.keys.FindIndex(key)
        if k:
            return self.index_of[k]
        # frames: [key, its map index, iterator over its children, children so far]
        stack: list[list[Any]] = [[key, self.keys.Add(key), TopoDS_Iterator(key, False, False), []]]
        done = -1
        while stack:
            key, k, it, kids = stack[-1]
            if it.More():
                c = it.Value()
                ckey = c.Located(TopLoc_Location()).Oriented(TopAbs_FORWARD)
                ck = self.keys.FindIndex(ckey)
                if not ck:  # first visit: walk it, then come back to this child
                    stack.append(
                        [ckey, self.keys.Add(ckey), TopoDS_Iterator(ckey, False, False), []]
                    )
                    continue
                kids.append((self.index_of[ck], c.Orientation().value, self.location(c.Location())))
                it.Next()
                continue
            stack.pop()
            done = self._add(key, k, kids)
        return done

    def _face_surfaces_first(self, root: Any) -> None:
        """Give the faces' surfaces the first rows of the surface table, in
        ``FACE`` order (the explorer's order of first visits is the walk's),
        so that ``FACE``'s surface column steps by one: otherwise a face's
        surface is numbered where a pcurve of an edge of an earlier face
        first names it, and the column is a permutation (about 5 bits a
        face once compressed)."""
        ex = TopExp_Explorer(root, TopAbs_FACE)
        loc = TopLoc_Location()
        while ex.More():
            s = BRep_Tool.Surface_s(TopoDS.Face(ex.Current()), loc)  # the TFace's own
            if s is not None:
                self.geo.surface(s)
            ex.Next()

    def _add(self, key: Any, k: int, kids: list[tuple[int, int, int]]) -> int:
        """Append one TShape whose sub-shapes are in the table; its index."""
        ts = key.TShape()
        t = key.ShapeType().value
        if t == _VERTEX:
            self._vertex(ts)
        elif t == _EDGE:
            self._edge(ts)
        elif t == _FACE:
            self._face(ts)
        i = len(self.types)
        self.index_of[k] = i
        self.types.append(t)
        self.flags.append(_flags(ts))
        self.children.extend(kids)
        self.child_start.append(len(self.children))
        return i

    def _vertex(self, tv: Any) -> None:
        v = len(self.vtol)
        self.vpoint.append((tv.Pnt().X(), tv.Pnt().Y(), tv.Pnt().Z()))
        self.vtol.append(tv.Tolerance())
        for pr in items(tv.Points()):
            name = type(pr).__name__
            loc = self.location(pr.Location())
            if name == "BRep_PointOnCurve":
                row = (v, _ON_CURVE, self.geo.curve3d(pr.Curve()), -1, loc)
                par = (pr.Parameter(), 0.0)
            elif name == "BRep_PointOnCurveOnSurface":
                row = (
                    v,
                    _ON_CURVE_ON_SURFACE,
                    self.geo.curve2d(pr.PCurve()),
                    self.geo.surface(pr.Surface()),
                    loc,
                )
                par = (pr.Parameter(), 0.0)
            elif name == "BRep_PointOnSurface":
                row = (v, _ON_SURFACE_POINT, -1, self.geo.surface(pr.Surface()), loc)
                par = (pr.Parameter(), pr.Parameter2())
            else:
                raise UnsupportedError(f"vertex representation {name} is not supported")
            self.vreps.append(row)
            self.vrep_params.append(par)

    def _edge(self, te: Any) -> None:
        e = len(self.etol)
        self.etol.append(te.Tolerance())
        self.eflags.append(
            int(te.Degenerated()) | int(te.SameParameter()) << 1 | int(te.SameRange()) << 2
        )
        geo = self.geo
        skipped = 0
        for cr in items(te.Curves()):
            name = type(cr).__name__
            loc = self.location(cr.Location())
            uv = (0.0,) * 8
            rng = (0.0, 0.0)
            cont = 0
            if name == "BRep_Curve3D":
                row = (e, _CURVE3D, geo.curve3d(cr.Curve3D()), -1, -1, -1, loc, 0)
                rng = (cr.First(), cr.Last())
            elif name in ("BRep_CurveOnSurface", "BRep_CurveOnClosedSurface"):
                closed = name == "BRep_CurveOnClosedSurface"
                p1, p2 = gp_Pnt2d(), gp_Pnt2d()
                cr.UVPoints(p1, p2)
                uv2 = (0.0,) * 4
                if closed:
                    q1, q2 = gp_Pnt2d(), gp_Pnt2d()
                    cr.UVPoints2(q1, q2)
                    uv2 = (q1.X(), q1.Y(), q2.X(), q2.Y())
                    cont = cr.Continuity().value
                uv = (p1.X(), p1.Y(), p2.X(), p2.Y(), *uv2)
                row = (
                    e,
                    _ON_CLOSED_SURFACE if closed else _ON_SURFACE,
                    geo.curve2d(cr.PCurve()),
                    geo.curve2d(cr.PCurve2()) if closed else -1,
                    geo.surface(cr.Surface()),
                    -1,
                    loc,
                    0,
                )
                rng = (cr.First(), cr.Last())
            elif name == "BRep_CurveOn2Surfaces":
                row = (
                    e,
                    _ON_TWO_SURFACES,
                    -1,
                    -1,
                    geo.surface(cr.Surface()),
                    geo.surface(cr.Surface2()),
                    loc,
                    self.location(cr.Location2()),
                )
                cont = cr.Continuity().value
            else:
                skipped += 1
                continue
            self.ereps.append(row)
            self.erep_cont.append(cont)
            self.erep_range.append(rng)
            self.erep_uv.append(uv)
        if skipped:
            self.warnings.append("edge polygons (mesh data) are not stored")

    def _face(self, tf: Any) -> None:
        s = tf.Surface()
        if s is None:
            raise UnsupportedError("a face has no surface (mesh-only face)")
        self.fsurf.append(self.geo.surface(s))
        self.floc.append(self.location(tf.Location()))
        self.ftol.append(tf.Tolerance())
        self.fnat.append(bool(tf.NaturalRestriction()))
        if tf.NbTriangulations():
            self.warnings.append("face triangulations (mesh data) are not stored")

    def model(self, root: Any) -> BRepModel:
        self._face_surfaces_first(root)
        r = self.shape(root)
        root_loc = self.location(root.Location())

        def arr(x: list[Any], dtype: Any, shape: tuple[int, ...]) -> np.ndarray:
            return np.array(x, dtype).reshape(shape)

        ch = np.array(self.children, np.int64).reshape(-1, 3)
        return BRepModel(
            datums=arr(self.datum_rows, np.float64, (-1, 3, 4)),
            datum_forms=arr(self.datum_forms, np.uint8, (-1,)),
            locations=self.locations,
            surfaces=self.geo.surfaces.records,
            curves3d=self.geo.curves3d.records,
            curves2d=self.geo.curves2d.records,
            shape_type=arr(self.types, np.uint8, (-1,)),
            shape_flags=arr(self.flags, np.uint8, (-1,)),
            child_start=arr(self.child_start, np.int64, (-1,)),
            child_shape=ch[:, 0].copy(),
            child_orient=ch[:, 1].astype(np.uint8),
            child_loc=ch[:, 2].copy(),
            vertex_point=arr(self.vpoint, np.float64, (-1, 3)),
            vertex_tol=arr(self.vtol, np.float64, (-1,)),
            vertex_reps=arr(self.vreps, np.int64, (-1, 5)),
            vertex_rep_params=arr(self.vrep_params, np.float64, (-1, 2)),
            edge_tol=arr(self.etol, np.float64, (-1,)),
            edge_flags=arr(self.eflags, np.uint8, (-1,)),
            edge_reps=arr(self.ereps, np.int64, (-1, 8)),
            edge_rep_cont=arr(self.erep_cont, np.uint8, (-1,)),
            edge_rep_range=arr(self.erep_range, np.float64, (-1, 2)),
            edge_rep_uv=arr(self.erep_uv, np.float64, (-1, 8)),
            face_surface=arr(self.fsurf, np.int64, (-1,)),
            face_loc=arr(self.floc, np.int64, (-1,)),
            face_tol=arr(self.ftol, np.float64, (-1,)),
            face_natural=arr(self.fnat, bool, (-1,)),
            root_shape=r,
            root_orient=root.Orientation().value,
            root_loc=root_loc,
        )


def shape_to_model(shape: Any) -> tuple[BRepModel, list[str]]:
    """Convert a ``TopoDS_Shape`` to a model; also return warnings (unique, sorted).

    Raises
    ------
    UnsupportedError
        For geometry or representations the model cannot hold.
    """
    r = _Reader()
    m = r.model(shape)
    return m, sorted(set(r.warnings))


_MAKERS = {
    ShapeType.COMPOUND: (TopoDS_Compound, "MakeCompound"),
    ShapeType.COMPSOLID: (TopoDS_CompSolid, "MakeCompSolid"),
    ShapeType.SOLID: (TopoDS_Solid, "MakeSolid"),
    ShapeType.SHELL: (TopoDS_Shell, "MakeShell"),
    ShapeType.WIRE: (TopoDS_Wire, "MakeWire"),
}


def model_to_shape(m: BRepModel, cache: PcurveCache | None = None, pcurves: bool = True) -> Any:
    """Rebuild the ``TopoDS_Shape`` a model describes, with ``BRep_Builder``.

    ``cache`` (kept across builds of models that differ in a few records, as
    the validity stage's candidates do) reuses the pcurves computed for a model
    left out by an earlier build where what they were computed from is the
    same (:class:`PcurveCache`); the shape is the same as without it.

    Without ``pcurves``, the pcurves the model leaves to compute (``REBUILD``)
    are not computed: a shape only to be written to STEP without pcurves
    (``files.write_shape``), which writes the same file from it as from the
    whole shape, at a fraction of the cost of the build.
    """
    if not pcurves:
        keep = m.edge_reps[:, EC.CURVE] != REBUILD
        m = dataclasses.replace(
            m,
            edge_reps=m.edge_reps[keep],
            edge_rep_cont=m.edge_rep_cont[keep],
            edge_rep_range=m.edge_rep_range[keep],
            edge_rep_uv=m.edge_rep_uv[keep],
        )
    if FAST_BUILD:
        got = _fast_build(m, cache)
        if got is not None:
            return got
    return slow_model_to_shape(m, cache)


#: Whether :func:`model_to_shape` builds through a BinTools stream
#: (:mod:`.bintools`) where the stream can carry the model.
FAST_BUILD = True
#: Builds by way of :func:`_fast_build`, and models it handed back (why, counted).
FAST_STATS: collections.Counter[str] = collections.Counter(fast=0)


def _fast_build(m: BRepModel, cache: PcurveCache | None) -> Any:
    """The shape of ``m`` read by ``BinTools_ShapeSet::Read`` from the stream
    :func:`.bintools.stream` writes, with the pcurves the model left out then
    projected as :func:`slow_model_to_shape` projects them and the flags of
    what that touched set again; None where the stream cannot carry ``m``
    (counted in :data:`FAST_STATS` by reason)."""
    try:
        data, loc_index = bintools.stream(m)
    except bintools.Unexpressed as why:
        FAST_STATS[str(why)] += 1
        return None
    except (struct.error, OverflowError):
        # a number the stream's fixed-width fields cannot hold (a damaged
        # container): the per-entity builder says what is wrong with it
        FAST_STATS["out of the stream's range"] += 1
        return None
    try:
        ss = bintools.read(data)
    except (Standard_Failure, Storage_StreamReadError, Storage_StreamFormatError):
        FAST_STATS["reader failed"] += 1
        return None
    FAST_STATS["fast"] += 1
    types = m.shape_type.tolist()
    _restore(ss, m)
    owner = m.edge_reps[:, EC.EDGE]
    pend = sorted(
        np.flatnonzero(m.edge_reps[:, EC.CURVE] == REBUILD).tolist(), key=lambda q: owner[q]
    )
    if pend:
        edge_shape = np.flatnonzero(m.shape_type == _EDGE)
        face_shape = np.flatnonzero(m.shape_type == _FACE).tolist()
        pending: list[tuple[Any, int, int, bool, int]] = []
        edges: dict[int, Any] = {}
        for q in pend:
            _, kind, _, _, srow, _, loc, _ = m.edge_reps[q].tolist()
            k = int(m.edge_reps[q, EC.EDGE])
            sh = edges.get(k)
            if sh is None:
                sh = edges[k] = bintools.edge(ss, int(edge_shape[k]))
            pending.append((sh, srow, loc, kind == _ON_CLOSED_SURFACE, k))
        keys = None
        if cache is not None:
            keys = _PcurveKeys(m, rows_by_owner(m.edge_reps[:, EC.EDGE], len(m.edge_tol)))
        wanted = {(srow, loc) for _, srow, loc, _, _ in pending}
        rows = list(zip(m.face_surface.tolist(), m.face_loc.tolist()))
        _model_pcurves(m, pending, [bintools.face(ss, s) for s in face_shape], cache, keys)
        # the flags of every shape a projection or FixShifted may have marked
        touched = {face_shape[k] for k, r in enumerate(rows) if r in wanted}
        touched |= {int(edge_shape[k]) for k in edges}
        start, child = m.child_start.tolist(), m.child_shape.tolist()
        todo, seen = list(touched), set(touched)
        while todo:
            s = todo.pop()
            for c in child[start[s] : start[s + 1]]:
                if c not in seen:
                    seen.add(c)
                    todo.append(c)
        flags = m.shape_flags.tolist()
        for s in sorted(seen):
            _set_flags(ss.Shape(s + 1).TShape(), flags[s])
    # what the stream cannot say: Free on a sub-shape (TopoDS_Builder::Add
    # clears it), Locked (not written)
    sub = np.zeros(len(types), bool)
    sub[m.child_shape] = True
    for s in np.flatnonzero(((m.shape_flags & 1) != 0) & sub).tolist():
        ss.Shape(s + 1).TShape().Free(True)
    for s in np.flatnonzero((m.shape_flags & 128) != 0).tolist():
        ss.Shape(s + 1).TShape().Locked(True)
    return bintools.root(ss, m, loc_index)


def _restore(ss: Any, m: BRepModel) -> None:
    """Set what a stream cannot say as :func:`slow_model_to_shape` sets it:
    the range of a degenerated edge's null 3-D curve, and the stored UV end
    points of every pcurve the stream carried (``BRep_Builder::Range``
    re-evaluates them from the pcurve while reading; a source may hold
    others).  Each edge's representations are in the stream's order: a
    degenerated edge's null 3-D curve first, then the model's, without the
    pcurves left to compute."""
    reps = m.edge_reps
    kind, c1 = reps[:, EC.KIND], reps[:, EC.CURVE]
    edge_shape = np.flatnonzero(m.shape_type == _EDGE).tolist()
    # a degenerated edge's null 3-D curve (the first representation: checked
    # by bintools) with a range other than the one BRep_Curve3D gives it
    null = (kind == _CURVE3D) & (c1 < 0)
    other = null & (m.edge_rep_range != bintools.NULL_RANGE).any(axis=1)
    for q in np.flatnonzero(other).tolist():
        sh = bintools.edge(ss, edge_shape[int(reps[q, EC.EDGE])])
        first, last = m.edge_rep_range[q].tolist()
        items(cast(BRep_TEdge, sh.TShape()).Curves())[0].SetRange(first, last)
    on = ((kind == _ON_SURFACE) | (kind == _ON_CLOSED_SURFACE)) & (c1 != REBUILD)
    if not on.any():
        return
    uv = m.edge_rep_uv.tolist()
    rows = reps[:, :3].tolist()
    by_edge = rows_by_owner(reps[:, EC.EDGE], len(m.edge_tol))
    for e in sorted(set(reps[on, EC.EDGE].tolist())):
        written = [q for q in by_edge[e] if rows[q][2] != REBUILD]
        got = items(cast(BRep_TEdge, bintools.edge(ss, edge_shape[e]).TShape()).Curves())
        if rows[written[0]][1] == _CURVE3D and rows[written[0]][2] < 0:
            written = written[1:]
            got = got[1:]  # Degenerated() put its own null curve first
            # (the model's null curve is checked to be that one: bintools._check)
        for q, cr in zip(written, got):
            k = rows[q][1]
            if k == _ON_SURFACE or k == _ON_CLOSED_SURFACE:
                u = uv[q]
                cr.SetUVPoints(gp_Pnt2d(u[0], u[1]), gp_Pnt2d(u[2], u[3]))
                if k == _ON_CLOSED_SURFACE:
                    cr.SetUVPoints2(gp_Pnt2d(u[4], u[5]), gp_Pnt2d(u[6], u[7]))


def slow_model_to_shape(m: BRepModel, cache: PcurveCache | None = None) -> Any:
    """:func:`model_to_shape` with one ``BRep_Builder`` call per entity."""
    b = BRep_Builder()
    geo = GeometryBuilder(m.surfaces, m.curves3d, m.curves2d)
    datums = [TopLoc_Datum3D(_trsf(r, int(f))) for r, f in zip(m.datums, m.datum_forms)]
    locs = []
    for loc in m.locations:
        acc = TopLoc_Location()
        # Multiplied() puts its argument's items at the head of the chain.
        for d, p in zip(reversed(loc.datums), reversed(loc.powers)):
            acc = acc.Multiplied(TopLoc_Location(datums[d]).Powered(p))
        locs.append(acc)

    tidx = m.type_index().tolist()
    vreps = rows_by_owner(m.vertex_reps[:, VC.VERTEX], len(m.vertex_tol))
    pending: list[tuple[Any, int, int, bool, int]] = []
    ereps = rows_by_owner(m.edge_reps[:, EC.EDGE], len(m.edge_tol))
    built: list[Any] = []
    start, child_shape = m.child_start.tolist(), m.child_shape.tolist()
    child_orient, child_loc = m.child_orient.tolist(), m.child_loc.tolist()
    for s, t in enumerate(m.shape_type.tolist()):
        k = tidx[s]
        sh: TopoDS_Shape
        if t == _VERTEX:
            sh = TopoDS_Vertex()
            b.MakeVertex(sh, gp_Pnt(*m.vertex_point[k]), float(m.vertex_tol[k]))
            tv = cast(BRep_TVertex, sh.TShape())  # TShape() returns the subclass at run time
            tv.Tolerance(float(m.vertex_tol[k]))
            pts = tv.ChangePoints()
            for q in vreps[k]:
                _, kind, g, surf, loc = m.vertex_reps[q].tolist()
                u, v = m.vertex_rep_params[q].tolist()
                if kind == _ON_CURVE:
                    pts.Append(BRep_PointOnCurve(u, geo.curve3d(g), locs[loc]))
                elif kind == _ON_CURVE_ON_SURFACE:
                    pts.Append(
                        BRep_PointOnCurveOnSurface(u, geo.curve2d(g), geo.surface(surf), locs[loc])
                    )
                else:
                    pts.Append(BRep_PointOnSurface(u, v, geo.surface(surf), locs[loc]))
        elif t == _EDGE:
            sh = TopoDS_Edge()
            b.MakeEdge(sh)
            te = cast(BRep_TEdge, sh.TShape())
            f = int(m.edge_flags[k])
            te.Tolerance(float(m.edge_tol[k]))
            te.Degenerated(bool(f & 1))
            te.SameParameter(bool(f & 2))
            te.SameRange(bool(f & 4))
            curves = te.ChangeCurves()
            for q in ereps[k]:
                row = m.edge_reps[q].tolist()
                if row[EC.CURVE] == REBUILD:
                    closed = row[EC.KIND] == _ON_CLOSED_SURFACE
                    pending.append((sh, row[EC.SURFACE], row[EC.LOC], closed, k))
                else:
                    curves.Append(_edge_rep(m, q, geo, locs, row))
        elif t == _FACE:
            sh = TopoDS_Face()
            b.MakeFace(
                sh, geo.surface(int(m.face_surface[k])), locs[m.face_loc[k]], float(m.face_tol[k])
            )
            tf = cast(BRep_TFace, sh.TShape())
            tf.Tolerance(float(m.face_tol[k]))
            tf.NaturalRestriction(bool(m.face_natural[k]))
        else:
            cls, maker = _MAKERS[ShapeType(t)]
            sh = cls()
            getattr(b, maker)(sh)
        for c in range(start[s], start[s + 1]):
            child = built[child_shape[c]]
            b.Add(sh, child.Oriented(_ORIENT[child_orient[c]]).Located(locs[child_loc[c]]))
        built.append(sh)
    if pending:
        faces = [sh for sh, t in zip(built, m.shape_type.tolist()) if t == _FACE]
        keys = _PcurveKeys(m, ereps) if cache is not None else None
        _model_pcurves(m, pending, faces, cache, keys)
    for sh, fl in zip(built, m.shape_flags.tolist()):
        _set_flags(sh.TShape(), fl)
    root = built[m.root_shape]
    return root.Oriented(_ORIENT[m.root_orient]).Located(locs[m.root_loc])


def _model_pcurves(
    m: BRepModel,
    pending: list[tuple[Any, int, int, bool, int]],
    faces: list[Any],
    cache: PcurveCache | None,
    keys: _PcurveKeys | None,
) -> None:
    """:func:`rebuild_pcurves` of ``m``'s faces (built, in its order) with
    the rules of the format ``m`` was decoded from."""
    rebuild_pcurves(
        pending,
        faces,
        list(zip(m.face_surface.tolist(), m.face_loc.tolist())),
        cache,
        keys,
        m.poles_follow,
        m.periods_in_range,
        face_edge_order(m) if m.pcurves_by_face else None,
        m.seams_set,
        face_uses(m) if m.seams_set else None,
    )


def face_uses(m: BRepModel) -> list[bool]:
    """Per face row, whether the walk of the shapes table from the root (in
    child order, orientations composed: REVERSED flips) first meets it
    reversed: the face as its shell uses it, as BRepCheck checks it."""
    tidx = m.type_index().tolist()
    types = m.shape_type.tolist()
    start, kids, ors = m.child_start.tolist(), m.child_shape.tolist(), m.child_orient.tolist()
    out = [False] * int((m.shape_type == _FACE).sum())
    seen: set[int] = set()
    stack = [(m.root_shape, m.root_orient == 1)]
    while stack:
        s, rev = stack.pop()
        if s in seen:
            continue
        seen.add(s)
        if types[s] == _FACE:
            out[tidx[s]] = rev
            continue
        if types[s] > _FACE:
            continue
        for k in range(start[s + 1] - 1, start[s] - 1, -1):
            stack.append((kids[k], rev != (ors[k] == 1)))
    return out


def face_edge_order(m: BRepModel) -> list[list[int]]:
    """Per face, in the shapes table's order, its edges (rows of the edge
    tables) in the order of its wires and of their children, each once: the
    order in which format 2.15 projects the pcurves a model left out
    (:func:`rebuild_pcurves`)."""
    tidx = m.type_index().tolist()
    start, child = m.child_start.tolist(), m.child_shape.tolist()
    types = m.shape_type.tolist()
    out = []
    for s, t in enumerate(types):
        if t != _FACE:
            continue
        order: list[int] = []
        seen: set[int] = set()
        for w in child[start[s] : start[s + 1]]:
            for e in child[start[w] : start[w + 1]]:
                if types[e] == _EDGE and e not in seen:
                    seen.add(e)
                    order.append(tidx[e])
        out.append(order)
    return out


#: Surface analyses :class:`EdgeProjector` keeps (the most recently used).
ANALYSES_KEPT = 16


class EdgeProjector:
    """``ShapeFix_Edge.FixAddPCurve(edge, face, seam, tolerance of edge)``:
    the same pcurves, bit for bit, for less work.

    Given a face, OCCT 7.9 makes a new ``ShapeAnalysis_Surface`` of the
    face's located surface at every call.  Its point projection
    (``Extrema_GenExtPS``) evaluates the surface on a grid of samples at its
    first ``ValueOfUV``, most of what projecting onto a B-spline surface
    costs (docs/decode-speed.md, "Issue 30, fourteenth session").  Here the
    analysis is kept and handed to the overload that takes one.  Two states
    of it would otherwise carry from one call to the next:

    - the grid spans the surface's bounds widened by the resolution of the
      *first* call's precision (``ShapeAnalysis_Surface::ValueOfUV``:
      ``du = Min(myUDelt, UResolution(preci))``), so an analysis serves the
      calls on one face with one precision (the edge's tolerance: a power of
      two in a decoded model, so few values);
    - the projector's cache of end points, which OCCT empties when given
      another surface (``ShapeConstruct_ProjectCurveOnSurface::SetSurface``),
      is emptied before each call by giving it a spare surface.

    What else the analysis keeps (closure distances, singularities,
    boundary isolines) it computes from the surface alone.  So each call
    reads nothing of an earlier one, as before: the cache of
    :class:`PcurveCache` and the split of :func:`_split` hold.
    """

    def __init__(self) -> None:
        self.fix = ShapeFix_Edge()
        self._spare = ShapeAnalysis_Surface(Geom_Plane(gp_Pln()))
        #: (hash of the face, precision) -> (the face, its analysis)
        self._analyses: collections.OrderedDict[tuple[int, float], Any] = collections.OrderedDict()

    def add(self, edge: Any, face: Any, seam: bool, sas: Any = None) -> bool:
        """``FixAddPCurve`` of ``edge`` on ``face`` with the edge's tolerance.

        With ``sas`` (from :meth:`start_face`), with that analysis and the
        projector's end points left by the call before (format 2.15's rule,
        :func:`_by_face`); without, as if alone."""
        prec = BRep_Tool.Tolerance_s(edge)
        if sas is not None:
            return bool(self.fix.FixAddPCurve(edge, face, seam, sas, prec))
        # OCP hashes a shape by its TShape and location; its == is the
        # wrapper's identity, so the face found is compared with IsSame
        key = (hash(face), prec)
        got = self._analyses.get(key)
        if got is not None and got[0].IsSame(face):
            sas = got[1]
            self._analyses.move_to_end(key)
        else:
            sas = _analysis(face)
            self._analyses[key] = (face, sas)
            self._analyses.move_to_end(key)
            if len(self._analyses) > ANALYSES_KEPT:
                self._analyses.popitem(last=False)
        self.fix.Projector().SetSurface(self._spare)
        return bool(self.fix.FixAddPCurve(edge, face, seam, sas, prec))

    def start_face(self, face: Any) -> Any:
        """A new analysis of ``face``'s located surface, for :meth:`add`'s
        ``sas``, with the projector's cache of end points emptied."""
        self.fix.Projector().SetSurface(self._spare)
        return _analysis(face)

    def plain(self) -> bool:
        """Whether the last call neither failed nor replaced the 3-D curve."""
        fix = self.fix
        return not (fix.Status(ShapeExtend_FAIL) or fix.Projector().Status(ShapeExtend_DONE3))


def _analysis(face: Any) -> Any:
    """A new ``ShapeAnalysis_Surface`` of ``face``'s surface, located."""
    loc = TopLoc_Location()
    surf: Any = BRep_Tool.Surface_s(face, loc)
    if not loc.IsIdentity():
        surf = surf.Transformed(loc.Transformation())
    return ShapeAnalysis_Surface(surf)


#: Whether a build with no :class:`PcurveCache` or an empty one (a decode, or
#: a compress's first candidate) may hand a share of its projections to a
#: forked child (:func:`rebuild_pcurves`); batch workers turn it off, as the
#: other core is busy with another file there.
SPLIT_PROJECTIONS = True
#: Fewest projections worth a fork (a fork of a process holding OCP costs
#: some 20 ms; a projection some 0.3 ms).
SPLIT_MIN = 400
#: The child's share of the projections: the parent also builds the child's
#: curves and replays them.
CHILD_SHARE = 0.45


def rebuild_pcurves(
    pending: list[tuple[Any, int, int, bool, int]],
    faces: list[Any],
    rows: list[tuple[int, int]],
    cache: PcurveCache | None = None,
    keys: _PcurveKeys | None = None,
    poles_follow: bool = True,
    in_range: bool = True,
    face_edges: list[list[int]] | None = None,
    seams: bool = True,
    uses: list[bool] | None = None,
) -> int:
    """Compute the pcurves a model left out, on the faces whose surface they name.

    Each pending item is (edge, surface row, location, seam, edge index).  The 3-D curve
    is projected onto the face's surface (``ShapeFix_Edge.FixAddPCurve``, two
    pcurves for a seam), then each touched face's wires are shifted by whole
    periods where they ended up on another sheet (``ShapeFix_Wire.FixShifted``),
    as OCCT's own STEP reader does; (``in_range``, format 2.9) on a trimmed
    surface of a periodic basis, which ``FixShifted`` takes for not periodic,
    the projected pcurves are moved into its bounds (:func:`into_range`);
    (``seams``, format 2.16) a wire with a seam that ``FixShifted`` leaves
    open in 2-D, as the face is used (``uses``: per face, whether reversed,
    :func:`face_uses`), gets the first trial that closes it
    (:func:`shift_wire`);
    and (``poles_follow``, format 2.8) the pcurves of their degenerated
    edges are made to meet them (:func:`align_degenerated`).
    The calls are made in format 2.14's order (:func:`_one_by_one`), or
    with ``face_edges`` (per face, its edges in wire order:
    :func:`face_edge_order`) in 2.15's (:func:`_by_face`).
    Deterministic: the same model gives the same pcurves.  With a ``cache``
    (and the ``keys`` of the model) a projection made before from the same
    data is replayed
    (:meth:`PcurveCache.add`) instead of made again.  Without one, or with
    an empty one, and with :data:`SPLIT_PROJECTIONS`, at least
    :data:`SPLIT_MIN` projections and a core to spare (:func:`spare_core`),
    a forked child makes a share of them while this process makes the rest
    (:func:`_split`); the edges get the same pcurves either way.

    Returns how many projections the child made.
    """
    by_row: dict[tuple[int, int], list[Any]] = {}
    for f, key in zip(faces, rows):
        by_row.setdefault(key, []).append(f)
    jobs = []
    where: dict[int, int] = {}
    touched: dict[int, Any] = {}
    projected: dict[int, Any] = {}  # per touched face, the edges projected onto it
    for edge, srow, loc, seam, k in pending:
        for face in by_row.get((srow, loc), []):
            # TopoDS.Face/Wire are TopoDS.Face_s/Wire_s in OCP 7.9; the stubs lack the _s names.
            jobs.append((edge, TopoDS.Face(face), seam, k, srow, loc))
            where[id(jobs[-1][1])] = id(face)
            touched[id(face)] = face
            if in_range:
                projected.setdefault(id(face), TopTools_MapOfShape()).Add(edge)
    fix = EdgeProjector()
    handed = 0
    dirty: set[int] = set()  # edges whose 3-D curve a projection replaced
    if face_edges is not None:
        _by_face(fix, faces, face_edges, jobs, where, cache, keys, dirty)
    else:
        handed = _one_by_one(fix, jobs, cache, keys, dirty)
    turned = {id(f) for f, r in zip(faces, uses or []) if r}
    for at, face in touched.items():
        f = TopoDS.Face(face)
        periods = trimmed_periods(f) if in_range else None
        it = TopoDS_Iterator(face, False, False)
        while it.More():
            w = it.Value()
            if w.ShapeType() == TopAbs_WIRE:
                shift_wire(f, TopoDS.Wire(w), seams, at in turned)
                if periods is not None:
                    into_range(f, TopoDS.Wire(w), periods, projected[at])
                if poles_follow:
                    align_degenerated(f, TopoDS.Wire(w))
            it.Next()
    return handed


def _one_by_one(
    fix: EdgeProjector,
    jobs: list[Any],
    cache: PcurveCache | None,
    keys: _PcurveKeys | None,
    dirty: set[int],
) -> int:
    """Format 2.14's order of :func:`rebuild_pcurves`'s projections: the
    jobs in edge order, each call alone, through the ``cache`` by edge, and
    split with a child where that pays (:func:`_split`).  How many
    projections the child made."""
    do: _Do | None = None
    if cache is not None and keys is not None:
        kc, kk = cache, keys

        def do(job: Any, got: _Kept | None = None) -> bool:
            edge, face, seam, k, srow, loc = job
            return kc.add(fix, edge, face, seam, k, srow, loc, kk, dirty, got)

    # a cache holding nothing yet (a first build) has every projection to make
    split = cache is None or not cache
    if split and SPLIT_PROJECTIONS and len(jobs) >= SPLIT_MIN and can_fork() and spare_core():
        return _split(fix, jobs, dirty, do)
    if do is not None:
        for job in jobs:
            do(job)
    else:
        for edge, face, seam, _, _, _ in jobs:
            fix.add(edge, face, seam)
    return 0


#: Per parameter direction, (period, first, last) of a face's trimmed
#: surface where its basis is periodic in that direction, else None.
_Periods = tuple[tuple[float, float, float] | None, tuple[float, float, float] | None]


def trimmed_periods(face: Any) -> _Periods | None:
    """(u, v) periods and bounds of ``face``'s surface where it is a trimmed
    surface whose basis is periodic (:data:`_Periods`); None for any other."""
    surf = BRep_Tool.Surface_s(face)
    if not isinstance(surf, Geom_RectangularTrimmedSurface):
        return None
    basis = surf.BasisSurface()
    u0, u1, v0, v1 = surf.Bounds()
    out = (
        (basis.UPeriod(), u0, u1) if basis.IsUPeriodic() else None,
        (basis.VPeriod(), v0, v1) if basis.IsVPeriodic() else None,
    )
    return out if any(out) else None


def into_range(face: Any, wire: Any, periods: _Periods, projected: Any) -> int:
    """Move each pcurve of ``wire`` that was projected onto ``face``
    (``projected``, a ``TopTools_MapOfShape``) by the whole periods of the
    trimmed surface's basis (``periods``: :func:`trimmed_periods`) that
    bring the point at the middle of its range within the surface's bounds,
    in each periodic direction where its middle lies outside them by more
    than ``RANGE_SLACK`` of the period (docs/format.md §2.8, *(2.9)*).
    Degenerated edges and pairs of pcurves (two faces on one surface) are
    left as they are.  Returns how many pcurves it moved.

    The trimmed surface is not periodic itself, so ``FixShifted`` does not
    move a pcurve that the projection put a period beyond its bounds: a
    surface of revolution trimmed to a full turn, an arc of its edge
    projected onto u in [2π, 3π] rather than [0, π] (bug32596, an ABC
    part): BRepCheck called the face unorientable."""
    wd = ShapeExtend_WireData(wire)
    moved = 0
    for i in range(1, wd.NbEdges() + 1):
        edge = wd.Edge(i)
        if BRep_Tool.Degenerated_s(edge) or not projected.Contains(edge):
            continue
        got = _oriented_pcurve(edge, face)
        if got is None or got[0].IsCurveOnClosedSurface():
            continue
        cr = got[0]
        mid = cr.PCurve().Value(0.5 * (cr.First() + cr.Last()))
        shift = [0.0, 0.0]
        for k, (x, p) in enumerate(((mid.X(), periods[0]), (mid.Y(), periods[1]))):
            if p is None:
                continue
            period, lo, hi = p
            slack = RANGE_SLACK * period
            if lo - slack <= x <= hi + slack:
                continue
            d = -period * math.floor((x - lo) / period)
            if lo <= x + d <= hi:
                shift[k] = d
        if any(shift):
            _translate(cr, shift)
            moved += 1
    return moved


def shift_wire(face: Any, wire: Any, guarded: bool = True, turned: bool = False) -> int:
    """``ShapeFix_Wire.FixShifted`` on ``wire`` of ``face`` (docs/format.md
    §2.8); with ``guarded`` (format 2.16), where the wire holds a seam and
    the shift leaves it open in 2-D (``BRepCheck_Wire.Closed2d`` on the face
    as its shell uses it: reversed where ``turned``), the first
    of eight trials that closes it, each from the pcurves as they were
    before the shift (:func:`_to_base`, :func:`_swap_seams`, the shift in
    the wire's order or in the order its edges connect,
    :func:`chain_order`), or the plain shift where none does.  Returns the
    number of the trial kept (0: the plain shift).

    ``FixShifted`` shifts each pcurve by whole periods to meet the one
    before it in the wire.  On a hole's cylinder or a countersink's cone as
    OCCT's modelling makes them (circle, seam, circle, seam, each circle a
    whole period long), with the seam's second pcurve projected a period
    the wrong way, it put one use of the seam onto the other, or swapped
    the two, and BRepCheck called the face unorientable: a cadquery block
    with one hole kept that face's pcurves in its container."""
    fix = ShapeFix_Wire(wire, face, 1e-7)
    if not guarded or not _wire_pcurves(face, wire, True):
        fix.FixShifted()
        return 0
    kept = _wire_pcurves(face, wire)
    fix.FixShifted()
    used = TopoDS.Face(face.Reversed()) if turned else face
    it = TopoDS_Iterator(used)  # the wire as the used face holds it
    while not it.Value().IsSame(wire):
        it.Next()
    check = BRepCheck_Wire(TopoDS.Wire(it.Value()))

    def closed() -> bool:
        return check.Closed2d(used) == BRepCheck_NoError

    if closed():
        return 0
    wd = ShapeExtend_WireData(wire)
    order = chain_order(wd)
    # (to base: 0 none, 1 the seams, 2 every edge; swap the seams; shift on)
    trials: list[tuple[int, bool, Any]] = [
        (0, False, None),
        (0, True, wd),
        (1, False, None),
        (1, True, None),
        (2, False, None),
        (2, True, None),
    ]
    if order != list(range(1, wd.NbEdges() + 1)):
        chained = ShapeExtend_WireData()
        for i in order:
            chained.Add(wd.Edge(i))
        trials += [(0, False, chained), (0, True, chained)]
    for k, (base, swap, edges) in enumerate(trials, 1):
        _put_back(face, kept)
        if base:
            _to_base(face, wire, base == 2)
        if swap:
            _swap_seams(face, wire)
        if edges is not None:
            shift = ShapeFix_Wire()
            shift.Load(edges)
            shift.SetFace(face)
            shift.SetPrecision(1e-7)
            shift.FixShifted()
        if closed():
            return k
    _put_back(face, kept)
    ShapeFix_Wire(wire, face, 1e-7).FixShifted()
    return 0


def _to_base(face: Any, wire: Any, every: bool) -> None:
    """Move the pcurves of each seam of ``wire`` (``every``: of each edge of
    it; a seam's two together) by the whole periods of ``face``'s surface
    that bring the least of their coordinates at the ends of the edge's
    range into [first, first + period) of the surface's bounds, in each
    periodic direction."""
    surf = BRep_Tool.Surface_s(face)
    u0, _, v0, _ = surf.Bounds()
    periods = (
        surf.UPeriod() if surf.IsUPeriodic() else 0.0,
        surf.VPeriod() if surf.IsVPeriodic() else 0.0,
    )
    for edge, c1, c2 in _wire_pcurves(face, wire):
        if c2 is None and not every:
            continue
        first, last = BRep_Tool.Range_s(edge, face)
        pts = [c.Value(t) for c in (c1, c2) if c is not None for t in (first, last)]
        low = (min(p.X() for p in pts), min(p.Y() for p in pts))
        shift = [
            -p * math.floor((lo - start) / p + 1e-9) if p > 0 else 0.0
            for lo, start, p in zip(low, (u0, v0), periods)
        ]
        if any(shift):
            vec = gp_Vec2d(*shift)
            _set_pcurves(face, edge, c1.Translated(vec), None if c2 is None else c2.Translated(vec))


def _swap_seams(face: Any, wire: Any) -> None:
    """Swap the two pcurves of each seam of ``wire`` on ``face``."""
    for edge, c1, c2 in _wire_pcurves(face, wire, True):
        _set_pcurves(face, edge, c2, c1)


def _put_back(face: Any, kept: list[tuple[Any, Any, Any]]) -> None:
    """The pcurves of :func:`_wire_pcurves` back on ``face``."""
    for edge, c1, c2 in kept:
        _set_pcurves(face, edge, c1, c2)


def _wire_pcurves(face: Any, wire: Any, seams: bool = False) -> list[tuple[Any, Any, Any]]:
    """The pcurves on ``face`` of the edges of ``wire``, each edge once:
    (edge, pcurve, the second pcurve of a seam or None); with ``seams``,
    of its seams only (found with ``BRep_Tool::IsClosed`` before any pcurve
    is read)."""
    out = []
    seen = TopTools_MapOfShape()
    wd = ShapeExtend_WireData(wire)
    for i in range(1, wd.NbEdges() + 1):
        edge = wd.Edge(i)
        if (seams and not BRep_Tool.IsClosed_s(edge, face)) or not seen.Add(edge):
            continue
        got = _oriented_pcurve(edge, face)
        if got is None:
            continue
        cr = got[0]
        closed = cr.IsCurveOnClosedSurface()
        if closed or not seams:
            out.append((edge, cr.PCurve(), cr.PCurve2() if closed else None))
    return out


def _set_pcurves(face: Any, edge: Any, c1: Any, c2: Any = None) -> None:
    """``edge``'s pcurve on ``face`` set to ``c1`` (and a seam's second to
    ``c2``), its stored (u, v) ends following."""
    got = _oriented_pcurve(edge, face)
    if got is None:
        return
    cr = got[0]
    cr.PCurve(c1)
    if c2 is not None and cr.IsCurveOnClosedSurface():
        cr.PCurve2(c2)
    cr.SetRange(cr.First(), cr.Last())


def chain_order(wd: Any) -> list[int]:
    """The edges of ``wd`` (a ``ShapeExtend_WireData``, numbered from 1) in
    the order in which they connect: from edge 1, each next one the first
    edge not yet taken, in ``wd``'s order, whose first vertex is the last
    vertex of the one taken before (``TopExp.FirstVertex``/``LastVertex``
    with the edges' orientations; ``IsSame``), or the first not yet taken
    where none is."""
    n = wd.NbEdges()
    first = [TopExp.FirstVertex_s(wd.Edge(i), True) for i in range(1, n + 1)]
    last = [TopExp.LastVertex_s(wd.Edge(i), True) for i in range(1, n + 1)]
    order = [0] if n else []
    free = list(range(1, n))
    while free:
        end = last[order[-1]]
        nxt = next((i for i in free if not end.IsNull() and first[i].IsSame(end)), free[0])
        free.remove(nxt)
        order.append(nxt)
    return [i + 1 for i in order]


def _translate(cr: Any, shift: list[float]) -> None:
    """Translate the pcurve of representation ``cr`` by ``shift`` in (u, v);
    its stored (u, v) ends follow."""
    cr.PCurve(cr.PCurve().Translated(gp_Vec2d(*shift)))
    cr.SetRange(cr.First(), cr.Last())


#: :func:`into_range` leaves a pcurve whose middle is this fraction of the
#: period or less outside the bounds where it is (a line along a bound).
RANGE_SLACK = 1e-6


def _curve_on(edge: Any, surf: Any, loc: Any) -> Any:
    """``edge``'s first representation on surface ``surf`` at ``loc`` (a
    pcurve, or a seam's pair), or None."""
    for cr in items(cast(BRep_TEdge, edge.TShape()).Curves()):
        if cr.IsCurveOnSurface(surf, loc):
            return cr
    return None


def _oriented_pcurve(edge: Any, face: Any) -> tuple[Any, gp_Pnt2d, gp_Pnt2d] | None:
    """The representation of ``edge``'s pcurve on ``face`` and its (u, v)
    ends in the order the edge is walked in its wire (a seam: the pcurve of
    its orientation); None if it has none."""
    loc = TopLoc_Location()
    surf = BRep_Tool.Surface_s(face, loc)
    cr = _curve_on(edge, surf, loc.Predivided(edge.Location()))
    if cr is None:
        return None
    forward = edge.Orientation() != TopAbs_REVERSED
    c = cr.PCurve2() if cr.IsCurveOnClosedSurface() and not forward else cr.PCurve()
    a, b = c.Value(cr.First()), c.Value(cr.Last())
    return (cr, a, b) if forward else (cr, b, a)


def align_degenerated(face: Any, wire: Any) -> int:
    """Make the pcurve of each degenerated edge of ``wire`` (on ``face``) meet
    its neighbours' in the wire, which were projected; returns how many edges
    it changed (docs/format.md §2.8, format 2.8).

    A degenerated edge's pcurve is stored, and ``FixShifted`` leaves it where
    it is.  Two ways it can miss its projected neighbours:

    * on another sheet of a periodic surface: a sphere's corner patch u in
      [3π/2, 2π] (a filleted box's) whose meridians project onto [−π/2, 0].
      It is moved by the whole periods that bring both its ends nearer
      theirs, to within a fifth of the period (``FixShifted``'s own bound);
    * at a pole, where a projection's parameter along the pole is anyone's
      guess: a revolved B-spline's meridians ended at v = 3.1324 and 2.1043
      on a pole stored from 3.1416 to 2.1066.  Then (and after a move) where
      an end is still more than ``SNAP_MIN`` from its neighbour's, and no
      end further than ``SNAP`` times its own length, the pcurve becomes the
      segment from the previous edge's end to the next edge's start
      (:func:`geometry.segment2d`, on the edge's range).

    BRepCheck rejected both kinds of face (an unorientable wire).
    Neighbours that are degenerated too, or have no pcurve, leave the edge
    as it is.
    """
    wd = ShapeExtend_WireData(wire)
    edges = [wd.Edge(i) for i in range(1, wd.NbEdges() + 1)]
    n, changed = len(edges), 0
    deg = [BRep_Tool.Degenerated_s(e) for e in edges]
    if n < 3 or not any(deg):
        return 0
    surf = BRep_Tool.Surface_s(face)
    period = (
        surf.UPeriod() if surf.IsUPeriodic() else 0.0,
        surf.VPeriod() if surf.IsVPeriodic() else 0.0,
    )
    for i, edge in enumerate(edges):
        if not deg[i] or deg[i - 1] or deg[(i + 1) % n]:
            continue
        prev, nxt = edges[i - 1], edges[(i + 1) % n]
        me, before, after = (_oriented_pcurve(e, face) for e in (edge, prev, nxt))
        if me is None or before is None or after is None or me[0].IsCurveOnClosedSurface():
            continue
        cr, start, end = me
        moved = False
        p, q = before[2].XY(), after[1].XY()
        gap = (p - start.XY(), q - end.XY())
        shift = [t * round(gap[0].Coord(k) / t) if t else 0.0 for k, t in enumerate(period, 1)]
        if any(shift):
            s = gp_Vec2d(*shift).XY()
            old = max(g.Modulus() for g in gap)
            new = max((g - s).Modulus() for g in gap)
            if new < old and new <= 0.2 * min(t for t in period if t):
                _translate(cr, shift)
                gap = (gap[0] - s, gap[1] - s)
                moved = True
        worst = max(g.Modulus() for g in gap)
        length = (end.XY() - start.XY()).Modulus()
        if SNAP_MIN < worst <= SNAP * length:
            forward = edge.Orientation() != TopAbs_REVERSED
            a, b = ((p.X(), p.Y()), (q.X(), q.Y()))
            first, last = cr.First(), cr.Last()
            cr.PCurve(segment2d(a, b, first, last) if forward else segment2d(b, a, first, last))
            cr.SetRange(first, last)
            moved = True
        changed += moved
    return changed


#: :func:`align_degenerated` leaves a pole whose ends are within this of its
#: neighbours' (in parameter space) as it is ...
SNAP_MIN = 1e-9
#: ... and snaps one no further than this times its own length from them.
SNAP = 0.25


#: What a projection left on its edge, to be replayed: the pcurve, the second
#: pcurve of a seam (or None), and the range on the surface.
_Kept = tuple[Any, Any, float, float]


def _copied(kept: _Kept) -> _Kept:
    """``kept`` with copies of its curves, so that neither the edge it is
    replayed on nor the one it came from shares a curve with the other."""
    c1, c2, first, last = kept
    return (c1.Copy(), None if c2 is None else c2.Copy(), first, last)


def _settled(edge: Any, face: Any, k: int, dirty: set[int], sae: Any) -> Any:
    """The face's located surface, or None where ``FixAddPCurve`` would not
    project the edge's own 3-D curve afresh (it does nothing, or works from
    the edge's pcurve there, or from a 3-D curve an earlier projection
    replaced): such a call is made, never replayed."""
    surf_loc = TopLoc_Location()
    surf = BRep_Tool.Surface_s(face, surf_loc)
    if k in dirty or sae.HasPCurve(edge, surf, surf_loc):
        return None
    return surf, surf_loc


def _project(
    fix: EdgeProjector,
    edge: Any,
    face: Any,
    seam: bool,
    k: int,
    at: Any,
    dirty: set[int],
    sas: Any = None,
) -> _Kept | None:
    """``FixAddPCurve`` of a settled edge (``at``: :func:`_settled`'s answer;
    ``sas`` as :meth:`EdgeProjector.add`'s), and what it left to replay, or
    None (and ``k`` made dirty) where it did not simply add the projected
    pcurves."""
    surf, surf_loc = at
    done = fix.add(edge, face, seam, sas)
    if not done or not fix.plain():
        dirty.add(k)
        return None
    cr = _curve_on(edge, surf, surf_loc)
    if cr is None or cr.IsCurveOnClosedSurface() != bool(seam):
        dirty.add(k)
        return None
    closed = cr.IsCurveOnClosedSurface()
    return cr.PCurve(), cr.PCurve2() if closed else None, cr.First(), cr.Last()


def _replay(b: Any, edge: Any, at: Any, kept: _Kept) -> None:
    """The two builder calls with which ``FixAddPCurve`` stores its pcurves
    (``kept``'s curves are the edge's own from here on)."""
    surf, surf_loc = at
    c1, c2, first, last = kept
    if c2 is None:
        b.UpdateEdge(edge, c1, surf, surf_loc, 0.0)
    else:
        b.UpdateEdge(edge, c1, c2, surf, surf_loc, 0.0)
        b.Range(edge, surf, surf_loc, first, last)


def _by_face(
    fix: EdgeProjector,
    faces: list[Any],
    face_edges: list[list[int]],
    jobs: list[Any],
    where: dict[int, int],
    cache: PcurveCache | None,
    keys: _PcurveKeys | None,
    dirty: set[int],
) -> None:
    """Format 2.15's order of :func:`rebuild_pcurves`'s projections.

    Face by face in the shapes table's order, each face's edges in the order
    of its wires (``face_edges``), as OCCT's STEP reader projects them
    (``ShapeFix_Wire::FixEdgeCurves``): one ``ShapeAnalysis_Surface`` per
    face, and the projector's end points carried from one edge to the next
    (an edge starts where the one before ended, so its first point needs no
    search of the surface's grid).  A job is (edge, face, seam, edge row,
    surface row, location); ``where`` maps a job's face to the face's
    ``id`` in ``faces``.  A call that would do nothing (the edge has its
    pcurve on that surface already, from a face before) is not made.  Jobs
    of an edge that is in no wire of a face of its surface are projected
    last, each alone.
    """
    sae = ShapeAnalysis_Edge()
    by_key = {(job[3], where[id(job[1])]): job for job in jobs}
    done: set[tuple[int, int]] = set()
    for f, order in zip(faces, face_edges):
        mine, ats, whole = [], [], True
        on: tuple[Any, Any] | None = None  # the face's located surface, once
        for k in order:
            job = by_key.get((k, id(f)))
            if job is None or (k, id(f)) in done:
                continue
            done.add((k, id(f)))
            edge, face, seam = job[:3]
            if on is None:
                surf_loc = TopLoc_Location()
                on = BRep_Tool.Surface_s(face, surf_loc), surf_loc
            if sae.IsSeam(edge, *on) if seam else sae.HasPCurve(edge, *on):
                continue  # FixAddPCurve returns at once
            # as _settled: a seam with one pcurve there, or a dirty edge, is not
            at = None if k in dirty or (seam and sae.HasPCurve(edge, *on)) else on
            whole = whole and at is not None
            mine.append(job)
            ats.append(at)
        if not mine:
            continue
        if whole and cache is not None and keys is not None:
            cache.face(fix, mine, ats, keys, dirty)
        else:
            _face_projections(fix, mine, ats, dirty)
    for job in jobs:
        if (job[3], where[id(job[1])]) not in done:
            fix.add(job[0], job[1], job[2])


def _face_projections(
    fix: EdgeProjector, jobs: list[Any], ats: list[Any], dirty: set[int]
) -> list[_Kept | None]:
    """One face's jobs projected in order with one analysis and the
    projector's end points carried (:func:`_by_face`); what each settled
    job (``ats``) left to replay, or None."""
    sas = fix.start_face(jobs[0][1])
    made: list[_Kept | None] = []
    for job, at in zip(jobs, ats):
        edge, face, seam, k = job[:4]
        if at is None:
            fix.add(edge, face, seam, sas)
            made.append(None)
        else:
            made.append(_project(fix, edge, face, seam, k, at, dirty, sas))
    return made


#: A job of :func:`rebuild_pcurves` done through its cache
#: (:meth:`PcurveCache.add`), with the pcurves a child projected for it, if
#: any; whether those were used.
_Do = Callable[..., bool]


def _split(fix: EdgeProjector, jobs: list[Any], dirty: set[int], do: _Do | None = None) -> int:
    """Project ``jobs`` (edge, face, seam, edge index, ...) here and in a child.

    The child takes the edges of the first :data:`CHILD_SHARE` of the jobs,
    this process the rest (every job of an edge to the same one; in blocks,
    so that the faces of consecutive edges repeat and each process's
    :class:`EdgeProjector` finds their analyses kept): projections of
    different edges touch different edges only, so they commute, and each
    edge sees its own jobs in their serial order.  The
    child, forked with the edges as they are, projects its jobs and sends
    back what each left (:func:`_child_projections`) while this process
    projects its own.  Then this process takes the child's jobs in order,
    replaying each that the child kept (its edge was settled: no pcurve on
    that surface yet, its 3-D curve its own; the edge is in the same state
    here) and projecting the others itself, so every edge ends with the
    pcurves of a serial build, in the same order.  If the child dies, this
    process projects its jobs.  With ``do`` (a build with a cache) every job
    goes through the cache, the child's with what the child projected, so
    the cache keeps those too.
    """
    side: dict[int, bool] = {}  # edge index -> the child's?
    mine: list[Any] = []
    theirs: list[Any] = []
    for job in jobs:
        k = job[3]
        if k not in side:
            side[k] = len(theirs) < CHILD_SHARE * len(jobs)
        (theirs if side[k] else mine).append(job)
    with RoundTrip(lambda: _child_projections(theirs)) as child:
        for job in mine:
            if do is not None:
                do(job)
            else:
                edge, face, seam = job[:3]
                fix.add(edge, face, seam)
        try:
            records, answers = child.ask(_itself)
        except ReaderCrash:
            records, answers = [], [None] * len(theirs)
    geo = GeometryBuilder([], [], records)
    b, sae, handed = BRep_Builder(), ShapeAnalysis_Edge(), 0
    for job, got in zip(theirs, answers):
        kept = None
        if got is not None:  # copies: a serial build shares no curve between edges
            i1, i2, first, last = got
            kept = _copied((geo.curve2d(i1), None if i2 < 0 else geo.curve2d(i2), first, last))
        if do is not None:
            handed += do(job, kept)
            continue
        edge, face, seam, k = job[:4]
        at = _settled(edge, face, k, dirty, sae)
        if at is None:
            fix.add(edge, face, seam)
        elif kept is None:
            _project(fix, edge, face, seam, k, at, dirty)
        else:
            _replay(b, edge, at, kept)
            handed += 1
    return handed


def _child_projections(jobs: list[Any]) -> tuple[list[Any], list[Any]]:
    """In the child: each job projected in order as the serial build would,
    and what it left as rows of a 2-D curve table (None where the parent
    must project it itself)."""
    reader, fix, sae = GeometryReader(), EdgeProjector(), ShapeAnalysis_Edge()
    dirty: set[int] = set()
    answers: list[Any] = []
    for edge, face, seam, k, _, _ in jobs:
        at = _settled(edge, face, k, dirty, sae)
        if at is None:
            fix.add(edge, face, seam)
            answers.append(None)
            continue
        kept = _project(fix, edge, face, seam, k, at, dirty)
        if kept is None:
            answers.append(None)
        else:
            c1, c2, first, last = kept
            answers.append((reader.curve2d(c1), reader.curve2d(c2), first, last))
    return reader.curves2d.records, answers


def _itself(x: Any) -> Any:
    return x


class PcurveCache:
    """Pcurves ``ShapeFix_Edge.FixAddPCurve`` projected, by what it read.

    OCCT 7.9's ``FixAddPCurve`` (an edge without a pcurve on the face's
    surface and location, a surface that is not a plane) projects the edge's
    first 3-D curve (``BRep_Tool::Curve``: the curve, its location and range)
    onto a ``ShapeAnalysis_Surface`` of the face's located surface (a fresh one; in
    :class:`EdgeProjector` one kept per face and precision, to the same end), with
    the precision passed (the edge's tolerance) and the tolerances of the
    edge's FORWARD and REVERSED vertices (``TopExp::Vertices``); its
    projector's point cache is reset with each new surface, so nothing of an
    earlier call is used.  It then stores the pcurve with
    ``BRep_Builder::UpdateEdge(edge, c2d[, c2d2], surf, loc, 0.)`` (a zero
    tolerance changes no tolerance) and, for a seam, the 3-D range on it
    (``BRep_Builder::Range``).  Where the projector replaced the 3-D curve
    (``DONE3``) or failed, nothing is kept and the edge is projected afresh
    for the rest of the build.

    The key is the exact content of all of that (records bit for bit, their
    bases', the locations' datums); a hit replays the two builder calls with
    copies of the kept curves, so the edge gets the same representations in
    the same order as a fresh projection gives it.
    """

    def __init__(self) -> None:
        self._kept: dict[tuple[Any, ...], _Kept] = {}
        #: format 2.15: a face's projections, by all that they read
        self._faces: dict[tuple[Any, ...], list[_Kept]] = {}
        self.hits = 0
        self.misses = 0
        self._sae = ShapeAnalysis_Edge()
        self._b = BRep_Builder()

    def add(
        self,
        fix: EdgeProjector,
        edge: Any,
        face: Any,
        seam: bool,
        k: int,
        srow: int,
        loc: int,
        keys: _PcurveKeys,
        dirty: set[int],
        projected: _Kept | None = None,
    ) -> bool:
        """What ``fix.add(edge, face, seam)`` (``FixAddPCurve``) does,
        from the cache when it can be, else from ``projected`` (what a child
        that forked with this edge as it is now kept of that call:
        :func:`_split`) if given.  Whether ``projected`` was used."""
        at = _settled(edge, face, k, dirty, self._sae)
        if at is None:
            fix.add(edge, face, seam)
            return False
        key = (keys.surface(srow), keys.location(loc), self.key(edge, seam, k, keys))
        kept = self._kept.get(key)
        if kept is not None:
            self.hits += 1
            _replay(self._b, edge, at, _copied(kept))
            return False
        self.misses += 1
        if projected is not None:
            _replay(self._b, edge, at, projected)
            got: _Kept | None = projected
        else:
            got = _project(fix, edge, face, seam, k, at, dirty)
        if got is not None:
            self._kept[key] = _copied(got)
        return projected is not None

    @staticmethod
    def key(edge: Any, seam: bool, k: int, keys: _PcurveKeys) -> tuple[Any, ...]:
        """What a projection of ``edge`` (row ``k``) reads of the edge itself."""
        v1, v2 = TopoDS_Vertex(), TopoDS_Vertex()
        TopExp.Vertices_s(edge, v1, v2)
        return (
            keys.edge(k),
            bool(seam),
            BRep_Tool.Tolerance_s(edge),
            -1.0 if v1.IsNull() else BRep_Tool.Tolerance_s(v1),
            -1.0 if v2.IsNull() else BRep_Tool.Tolerance_s(v2),
        )

    def face(
        self,
        fix: EdgeProjector,
        jobs: list[Any],
        ats: list[Any],
        keys: _PcurveKeys,
        dirty: set[int],
    ) -> None:
        """Format 2.15's projections of one face (:func:`_by_face`), every
        job settled (``ats``), from the cache where the face's jobs were
        seen before, in the same order, with the same data."""
        _, _, _, _, srow, loc = jobs[0]
        key = (
            keys.surface(srow),
            keys.location(loc),
            tuple(self.key(j[0], j[2], j[3], keys) for j in jobs),
        )
        kept = self._faces.get(key)
        if kept is not None:
            self.hits += len(jobs)
            for job, at, got in zip(jobs, ats, kept):
                _replay(self._b, job[0], at, _copied(got))
            return
        self.misses += len(jobs)
        made = _face_projections(fix, jobs, ats, dirty)
        if all(got is not None for got in made):
            self._faces[key] = [_copied(cast(_Kept, got)) for got in made]

    def __len__(self) -> int:
        """Projections kept."""
        return len(self._kept) + sum(len(v) for v in self._faces.values())


def _array_key(a: np.ndarray) -> tuple[Any, ...]:
    return (a.dtype.str, a.shape, a.tobytes())


class _PcurveKeys:
    """Exact content keys of one model's edges' 3-D curves, surfaces and
    locations, for :class:`PcurveCache`."""

    def __init__(self, m: BRepModel, ereps: list[list[int]]) -> None:
        self.m, self.ereps = m, ereps
        self._reps = m.edge_reps[:, :7].tolist()  # plain ints: numpy scalars are slow
        self._ranges = m.edge_rep_range.astype(np.float64).tobytes()  # bit for bit
        self._geo: dict[tuple[Table, int], tuple[Any, ...]] = {}
        self._loc: dict[int, tuple[Any, ...]] = {}
        self._edge: dict[int, tuple[Any, ...]] = {}

    def _record(self, table: Table, i: int) -> tuple[Any, ...]:
        """Row ``i``'s geometry (``geometry.record_key``), with its basis's for a
        derived row: the key holds the content a projection reads."""
        if i < 0:
            return ("none",)
        got = self._geo.get((table, i))
        if got is not None:
            return got
        r = (self.m.surfaces if table == Table.SURFACE else self.m.curves3d)[i]
        key = record_key(r)
        if isinstance(r, Derived):
            swept = r.kind in (Kind.REVOLUTION, Kind.EXTRUSION)
            key += (self._record(Table.CURVE3D if swept else table, r.basis),)
        self._geo[(table, i)] = key
        return key

    def surface(self, i: int) -> tuple[Any, ...]:
        return self._record(Table.SURFACE, i)

    def location(self, i: int) -> tuple[Any, ...]:
        got = self._loc.get(i)
        if got is None:
            loc, m = self.m.locations[i], self.m
            got = tuple(
                (_array_key(m.datums[d]), int(m.datum_forms[d]), p)
                for d, p in zip(loc.datums, loc.powers)
            )
            self._loc[i] = got
        return got

    def edge(self, k: int) -> tuple[Any, ...]:
        """The edge's 3-D curves (every one, in order: ``BRep_Tool::Curve``
        reads the first) with their locations and ranges."""
        got = self._edge.get(k)
        if got is None:
            out = []
            for q in self.ereps[k]:
                _, kind, c, _, _, _, loc = self._reps[q]
                if kind == _CURVE3D and c != REBUILD:
                    rng = self._ranges[16 * q : 16 * q + 16]
                    out.append((self._record(Table.CURVE3D, c), self.location(loc), rng))
            got = self._edge[k] = tuple(out)
        return got


def _edge_rep(m: BRepModel, q: int, geo: GeometryBuilder, locs: list[Any], row: list[int]) -> Any:
    """Representation ``q`` of ``m``'s edges (``row``: its ``edge_reps`` row, as a list)."""
    _, kind, c1, c2, s1, s2, l1, l2 = row
    first, last = m.edge_rep_range[q].tolist()
    if kind == _CURVE3D:
        c3d = BRep_Curve3D(geo.curve3d(c1), locs[l1])
        c3d.SetRange(first, last)
        return c3d
    if kind == _ON_TWO_SURFACES:
        return BRep_CurveOn2Surfaces(
            geo.surface(s1), geo.surface(s2), locs[l1], locs[l2], _CONT[m.edge_rep_cont[q]]
        )
    uv = m.edge_rep_uv[q].tolist()
    rep: BRep_CurveOnSurface
    if kind == _ON_SURFACE:
        rep = BRep_CurveOnSurface(geo.curve2d(c1), geo.surface(s1), locs[l1])
    else:
        rep = BRep_CurveOnClosedSurface(
            geo.curve2d(c1),
            geo.curve2d(c2),
            geo.surface(s1),
            locs[l1],
            _CONT[m.edge_rep_cont[q]],
        )
        rep.SetUVPoints2(gp_Pnt2d(uv[4], uv[5]), gp_Pnt2d(uv[6], uv[7]))
    rep.SetRange(first, last)
    rep.SetUVPoints(gp_Pnt2d(uv[0], uv[1]), gp_Pnt2d(uv[2], uv[3]))
    return rep
