"""Measures on shapes: topology counts, validity, free edges, face deviation.

The deviation measure is independent of the codec: it samples points inside
each original face (a UV grid, kept where the face's own 2-D classifier says
"inside") and takes their distance to the decoded face of the same index.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from OCP.Bnd import Bnd_Box
from OCP.BRep import BRep_Builder, BRep_Tool
from OCP.BRepBndLib import BRepBndLib
from OCP.BRepBuilderAPI import BRepBuilderAPI_Sewing
from OCP.BRepCheck import BRepCheck_Analyzer, BRepCheck_NoError
from OCP.BRepTools import BRepTools
from OCP.BRepTopAdaptor import BRepTopAdaptor_FClass2d
from OCP.GeomAPI import GeomAPI_ProjectPointOnSurf
from OCP.gp import gp_Pnt, gp_Pnt2d
from OCP.ShapeAnalysis import ShapeAnalysis_FreeBounds
from OCP.TopAbs import (
    TopAbs_EDGE,
    TopAbs_FACE,
    TopAbs_IN,
    TopAbs_ON,
    TopAbs_SHELL,
    TopAbs_SOLID,
    TopAbs_VERTEX,
    TopAbs_WIRE,
)
from OCP.TopExp import TopExp, TopExp_Explorer
from OCP.TopoDS import TopoDS, TopoDS_Iterator
from OCP.TopTools import TopTools_IndexedMapOfShape

from .lists import items


def _map(shape: Any, kind: Any) -> TopTools_IndexedMapOfShape:
    m = TopTools_IndexedMapOfShape()
    TopExp.MapShapes_s(shape, kind, m)
    return m


def faces(shape: Any) -> list[Any]:
    """The faces of a shape in ``TopExp.MapShapes(shape, FACE)`` order."""
    m = _map(shape, TopAbs_FACE)
    # TopoDS.Face is TopoDS.Face_s in OCP 7.9; the stubs lack the _s name.
    return [TopoDS.Face(m.FindKey(i)) for i in range(1, m.Extent() + 1)]


def counts(shape: Any) -> dict[str, int]:
    """Distinct solids, shells, faces, edges and vertices of a shape."""
    kinds = {
        "solids": TopAbs_SOLID,
        "shells": TopAbs_SHELL,
        "faces": TopAbs_FACE,
        "edges": TopAbs_EDGE,
        "vertices": TopAbs_VERTEX,
    }
    return {name: _map(shape, k).Extent() for name, k in kinds.items()}


def is_valid(shape: Any) -> bool:
    """BRepCheck's verdict on the whole shape."""
    return bool(BRepCheck_Analyzer(shape).IsValid())


def _extent(shape: Any) -> np.ndarray | None:
    """The sides of the shape's bounding box (dx, dy, dz) in mm; None if empty."""
    box = Bnd_Box()
    BRepBndLib.Add_s(shape, box)
    if box.IsVoid():
        return None
    x0, y0, z0, x1, y1, z1 = box.Get()
    return np.array([x1 - x0, y1 - y0, z1 - z0])


def diagonal(shape: Any) -> float:
    """The length of the shape's bounding-box diagonal in mm (0 for an empty
    shape): its size, to weigh a tolerance or a mesh deflection against."""
    sides = _extent(shape)
    return 0.0 if sides is None else float(np.sqrt((sides**2).sum()))


def thin_solids(shape: Any, tol: float, fraction: float = 0.2) -> list[tuple[int, float]]:
    """Solids a tolerance is not small against: (index in ``MapShapes`` order,
    the bound) where moving every face by ``tol`` could change the volume by
    more than ``fraction`` of it (area x tol / volume: a plate of thickness
    t gives about 2 tol / t).  A wall thinner than tol may then cross itself,
    and neither the counts nor BRepCheck would see it.

    Only solids whose bounding box is under 1,000 tol across in some
    direction are measured (their volume and area cost a fraction of a
    second on a large part): a thin solid is thin across its box.  A part
    placed many times is measured once (:func:`once_each`; the index is then
    among the distinct solids).
    """
    from OCP.BRepGProp import BRepGProp
    from OCP.GProp import GProp_GProps

    out = []
    distinct = once_each(shape)
    solids = _map(shape if distinct is None else distinct, TopAbs_SOLID)
    for i in range(1, solids.Extent() + 1):
        s = solids.FindKey(i)
        sides = _extent(s)
        if sides is None or sides.min() > 1000 * tol:
            continue
        v, a = GProp_GProps(), GProp_GProps()
        BRepGProp.VolumeProperties_s(s, v)
        BRepGProp.SurfaceProperties_s(s, a)
        volume = abs(v.Mass())
        bound = a.Mass() * tol / volume if volume > 0 else float("inf")
        if bound > fraction:
            out.append((i - 1, bound))
    return out


def free_edges(shape: Any) -> int:
    """Number of free (unshared) edges, by ShapeAnalysis_FreeBounds, per shell,
    and over the faces that are in no shell, taken as one face set (the loose
    faces of an IGES surface model, or beside a solid)."""
    from OCP.TopoDS import TopoDS_Compound
    from OCP.TopTools import TopTools_IndexedDataMapOfShapeListOfShape

    sets = []
    exp = TopExp_Explorer(shape, TopAbs_SHELL)
    while exp.More():
        sets.append(exp.Current())
        exp.Next()
    f2s = TopTools_IndexedDataMapOfShapeListOfShape()
    TopExp.MapShapesAndAncestors_s(shape, TopAbs_FACE, TopAbs_SHELL, f2s)
    loose = [f2s.FindKey(i) for i in range(1, f2s.Extent() + 1) if f2s.FindFromIndex(i).Size() == 0]
    if loose:
        b, comp = BRep_Builder(), TopoDS_Compound()
        b.MakeCompound(comp)
        for f in loose:
            b.Add(comp, f)
        sets.append(comp)
    n = 0
    for sh in sets:
        fb = ShapeAnalysis_FreeBounds(sh, False, False)
        for wires in (fb.GetClosedWires(), fb.GetOpenWires()):
            n += _map(wires, TopAbs_EDGE).Extent()
    return n


def edge_points(shape: Any, edges: list[int], n: int = 9) -> np.ndarray:
    """Points along edges (0-based, model order) of ``shape``, in the shape's
    frame, evenly spread over each edge's range; shape (len(edges), n, 3)."""
    from OCP.BRepAdaptor import BRepAdaptor_Curve

    em = _map(shape, TopAbs_EDGE)
    out = np.full((len(edges), n, 3), np.nan)
    for k, e in enumerate(edges):
        edge = TopoDS.Edge(em.FindKey(e + 1))
        if BRep_Tool.Degenerated_s(edge):
            continue
        c = BRepAdaptor_Curve(edge)
        a, b = c.FirstParameter(), c.LastParameter()
        for i, t in enumerate(np.linspace(a, b, n).tolist()):
            p = c.Value(t)
            out[k, i] = p.X(), p.Y(), p.Z()
    return out


def sewn_edge_pairs(shape: Any, tolerance: float = 1e-7) -> list[tuple[int, int]]:
    """Pairs (a, b), a < b, of model edges (:func:`model_order`) that the
    sewing of :func:`free_edges_sewn` finds meeting: the original edges of
    each of its contiguous edges, whole or in part.

    Coincident edges of faces that share no edge are found here even where
    their ends differ (one face's boundary cut in two where its neighbour's
    runs on) or where they are apart by more than ``tolerance`` but within
    the edges' own tolerances, which the sewing also accepts (a faces-mode
    IGES file written at 1e-5).  Sewing is only analysed, never applied.
    """
    sew = _sewing(shape, tolerance)
    edges = _map(shape, TopAbs_EDGE)
    order = model_order(shape, "edge")
    out: set[tuple[int, int]] = set()
    for i in range(1, sew.NbContigousEdges() + 1):
        found = set()
        for s in items(sew.ContigousEdgeCouple(i)):
            e = TopoDS.Edge(s)
            k = edges.FindIndex(sew.SectionToBoundary(e) if sew.IsSectionBound(e) else e)
            if k:
                found.add(int(order[k - 1]))
        ks = sorted(found)
        out.update((a, b) for j, a in enumerate(ks) for b in ks[j + 1 :])
    return sorted(out)


def _sewing(shape: Any, tolerance: float) -> Any:
    """``BRepBuilderAPI_Sewing`` at ``tolerance`` performed (analysis only: no
    face cut, no non-manifold mode) on the top-level sub-shapes of ``shape``."""
    sew = BRepBuilderAPI_Sewing(tolerance, False, False)
    it = TopoDS_Iterator(shape)
    while it.More():
        sew.Add(it.Value())
        it.Next()
    sew.Perform()
    return sew


def free_edges_sewn(shape: Any, tolerance: float = 1e-7) -> int:
    """Free edges left after sewing at ``tolerance``: edges that no other face
    meets within it, shared or not (``ShapeAnalysis_FreeBounds(shape, tolerance)``).

    This is the measure of "no new gaps" (issue 10): faces of an IGES surface
    model meet along separate, coincident edges, and count as closed here.
    """
    fb = ShapeAnalysis_FreeBounds(shape, tolerance, False, False)
    n = 0
    for comp in (fb.GetClosedWires(), fb.GetOpenWires()):
        if not comp.IsNull():
            n += _map(comp, TopAbs_EDGE).Extent()
    return n


def free_edges_per_face(shape: Any, tolerance: float = 1e-7) -> np.ndarray:
    """Per face (:func:`faces` order), its edges that :func:`free_edges_sewn`'s
    sewing leaves free (an edge of two faces counts for both), shape (F,).

    The sewing hands back free edges of its own making (vertices merged):
    each is traced to the edge it replaced through the sewing's history,
    else (some edges a few 1e-7 long) to the edge whose ends and middle are
    nearest its own.  What a STEP check blames when a re-read has more free
    edges than it should (``encode.validity``).
    """
    from OCP.BRepAdaptor import BRepAdaptor_Curve
    from OCP.TopTools import TopTools_IndexedDataMapOfShapeListOfShape

    sew = _sewing(shape, tolerance)
    e2f = TopTools_IndexedDataMapOfShapeListOfShape()
    TopExp.MapShapesAndAncestors_s(shape, TopAbs_EDGE, TopAbs_FACE, e2f)
    fm = _map(shape, TopAbs_FACE)
    out = np.zeros(fm.Extent(), np.int64)
    free = [sew.FreeEdge(i) for i in range(1, sew.NbFreeEdges() + 1)]
    free = [e for e in free if not BRep_Tool.Degenerated_s(e)]
    if not free:
        return out

    def ends(e: Any) -> list[float]:
        c = BRepAdaptor_Curve(e)
        a, b = c.FirstParameter(), c.LastParameter()
        return [x for t in (a, (a + b) / 2, b) for x in c.Value(t).Coord()]

    replaced = TopTools_IndexedMapOfShape()  # what the sewing made of each edge
    owner: list[int] = []
    context = sew.GetContext()
    for k in range(1, e2f.Extent() + 1):
        if replaced.Add(context.Apply(e2f.FindKey(k))) > len(owner):
            owner.append(k)
    tree: Any = None
    for e in free:
        j = replaced.FindIndex(e)
        if j:
            k = owner[j - 1]
        else:  # not in the history: the nearest by ends and middle, either way round
            if tree is None:
                # imported only here (0.1 to 1 s): most sewings trace every
                # free edge through their history.  (Of equal distances, the
                # one cKDTree finds is kept: a numpy search that took the first
                # changed which of two coincident edges of an IGES surface
                # model is blamed, and bearing.iges's container at 0.01 mm.)
                from scipy.spatial import cKDTree

                keys, rows = [], []
                for i in range(1, e2f.Extent() + 1):
                    edge = TopoDS.Edge(e2f.FindKey(i))
                    if not BRep_Tool.Degenerated_s(edge):
                        p = np.array(ends(edge)).reshape(3, 3)
                        keys += [p.ravel(), p[::-1].ravel()]
                        rows += [i, i]
                tree = (cKDTree(np.array(keys)), rows)
            k = tree[1][int(tree[0].query(ends(e))[1])]
        for f in items(e2f.FindFromIndex(k)):
            out[fm.FindIndex(f) - 1] += 1
    return out


def sample_face(face: Any, n: int = 7) -> tuple[np.ndarray, np.ndarray]:
    """Points inside a face: an ``n`` x ``n`` UV grid, kept where inside.

    Returns
    -------
    uv : ndarray, shape (k, 2)
    xyz : ndarray, shape (k, 3)
        Points of the located face surface, in model space.
    """
    u0, u1, v0, v1 = BRepTools.UVBounds_s(face)
    surf = BRep_Tool.Surface_s(face)  # located: the face's placement applied
    cls = BRepTopAdaptor_FClass2d(face, 1e-9)
    t = (np.arange(n) + 0.5) / n
    uv, xyz = [], []
    for a in t:
        for b in t:
            u, v = u0 + a * (u1 - u0), v0 + b * (v1 - v0)
            if cls.Perform(gp_Pnt2d(u, v)) in (TopAbs_IN, TopAbs_ON):
                p = surf.Value(u, v)
                uv.append((u, v))
                xyz.append((p.X(), p.Y(), p.Z()))
    if not uv:  # a sliver: fall back to the middle of its UV box
        u, v = (u0 + u1) / 2, (v0 + v1) / 2
        p = surf.Value(u, v)
        uv.append((u, v))
        xyz.append((p.X(), p.Y(), p.Z()))
    return np.array(uv), np.array(xyz)


def face_distances(original: Any, decoded: Any, n: int = 7, tol: float = 0.0) -> np.ndarray:
    """Distances from points inside ``original`` to the surface of ``decoded``.

    Each sample is first compared with the decoded surface at the same (u, v),
    which bounds the distance from above; only where that exceeds ``tol`` is the
    point projected onto the decoded surface.  Where the two surfaces' bounded
    domains differ (an encoder maps a B-spline's knots onto [0, 1] where
    nothing holds its parameters), "the same (u, v)" is mapped affinely from
    one domain onto the other.
    """
    uv, xyz = sample_face(original, n)
    surf = BRep_Tool.Surface_s(decoded)  # located: the face's placement applied
    uv = _onto(uv, BRep_Tool.Surface_s(original).Bounds(), surf.Bounds())
    out = []
    for (u, v), p in zip(uv, xyz):
        q = surf.Value(u, v)
        d = float(np.sqrt((q.X() - p[0]) ** 2 + (q.Y() - p[1]) ** 2 + (q.Z() - p[2]) ** 2))
        if d > tol:
            proj = GeomAPI_ProjectPointOnSurf(gp_Pnt(*p), surf)
            if proj.NbPoints():
                d = min(d, proj.LowerDistance())
        out.append(d)
    return np.array(out)


def _onto(uv: np.ndarray, a: tuple[float, ...], b: tuple[float, ...]) -> np.ndarray:
    """Parameters ``uv`` of the domain ``a`` (u1, u2, v1, v2) mapped affinely
    onto ``b``, per direction where both are bounded and differ."""
    out = np.array(uv, dtype=float)
    for k in (0, 1):
        a0, a1, b0, b1 = a[2 * k], a[2 * k + 1], b[2 * k], b[2 * k + 1]
        if (a0, a1) != (b0, b1) and all(abs(x) < 1e100 for x in (a0, a1, b0, b1)) and a1 > a0:
            out[:, k] = b0 + (out[:, k] - a0) * ((b1 - b0) / (a1 - a0))
    return out


def deviation(original: Any, decoded: Any, n: int = 7, tol: float = 0.0) -> np.ndarray:
    """Per-face deviation between two shapes with faces in the same order, shape (F,)."""
    fa, fb = faces(original), faces(decoded)
    if len(fa) != len(fb):
        raise ValueError(f"face counts differ: {len(fa)} != {len(fb)}")
    return np.array([face_distances(a, b, n, tol).max() for a, b in zip(fa, fb)])


def deviation_stats(original: Any, decoded: Any, n: int = 7) -> tuple[np.ndarray, np.ndarray]:
    """Per-face maximum and mean sampled distance, shapes (F,), (F,)."""
    fa, fb = faces(original), faces(decoded)
    if len(fa) != len(fb):
        raise ValueError(f"face counts differ: {len(fa)} != {len(fb)}")
    d = [face_distances(a, b, n) for a, b in zip(fa, fb)]
    return np.array([x.max() for x in d]), np.array([x.mean() for x in d])


_KINDS = {"face": TopAbs_FACE, "edge": TopAbs_EDGE, "vertex": TopAbs_VERTEX}


def model_order(shape: Any, kind: str) -> np.ndarray:
    """Per ``kind`` (``"face"``, ``"edge"``, ``"vertex"``) in
    ``TopExp.MapShapes`` order, 0-based, the index of its
    TShape among the shape's distinct TShapes of that kind in the order first
    met: the model's index (:func:`nurbscomp.occ.shape_to_model` keeps one row
    per TShape, so the faces of a located instance are the model's faces)."""
    return _distinct(shape, kind)[1]


def _distinct(shape: Any, kind: str) -> tuple[TopTools_IndexedMapOfShape, np.ndarray]:
    """The distinct TShapes of ``kind`` (:func:`_tshape` keys, in the order
    first met: a key's index - 1 is its model row), and :func:`model_order`."""
    m, distinct = _map(shape, _KINDS[kind]), TopTools_IndexedMapOfShape()
    out = np.empty(m.Extent(), np.int64)
    for i in range(1, m.Extent() + 1):
        out[i - 1] = distinct.Add(_tshape(m.FindKey(i))) - 1
    return distinct, out


def _tshape(s: Any) -> Any:
    """``s`` unlocated and forward: the key of its TShape (a model row)."""
    from OCP.TopAbs import TopAbs_FORWARD
    from OCP.TopLoc import TopLoc_Location

    return s.Located(TopLoc_Location()).Oriented(TopAbs_FORWARD)


def _failures(shape: Any) -> tuple[set[int], set[int]]:
    """Where BRepCheck finds fault: (edge indices, face indices), 0-based in
    ``TopExp.MapShapes`` order.

    A fault on a vertex counts against its edges; one on a wire, or on an edge
    in the context of a face, counts against that face too.

    A valid shape is answered by one ``IsValid`` call.  Otherwise only the
    faces and edges that ``IsValid`` rejects (with their edges and vertices)
    have their statuses walked: ``IsValid`` of a face covers the statuses of
    its wires, edges and vertices in its context, and of an edge those of its
    vertices, so nothing outside them can carry a fault.
    """
    from OCP.TopTools import TopTools_IndexedDataMapOfShapeListOfShape

    a = BRepCheck_Analyzer(shape)
    if a.IsValid():
        return set(), set()
    em, fm, vm = _map(shape, TopAbs_EDGE), _map(shape, TopAbs_FACE), _map(shape, TopAbs_VERTEX)
    bad_e: set[int] = set()
    bad_f: set[int] = set()

    def faulty(r: Any) -> tuple[bool, list[Any]]:
        own = any(x != BRepCheck_NoError for x in items(r.Status()))
        ctx = []
        r.InitContextIterator()
        while r.MoreShapeInContext():
            if any(x != BRepCheck_NoError for x in items(r.StatusOnShape())):
                ctx.append(r.ContextualShape())
            r.NextShapeInContext()
        return own, ctx

    def mark_context(ctx: list[Any]) -> None:
        for c in ctx:
            if c.ShapeType() == TopAbs_FACE:
                bad_f.add(fm.FindIndex(c) - 1)
            elif c.ShapeType() == TopAbs_EDGE:
                bad_e.add(em.FindIndex(c) - 1)

    suspect_f = [i for i in range(1, fm.Extent() + 1) if not a.IsValid(fm.FindKey(i))]
    suspect_e = {i for i in range(1, em.Extent() + 1) if not a.IsValid(em.FindKey(i))}
    for i in suspect_f:
        sub = _map(fm.FindKey(i), TopAbs_EDGE)
        suspect_e.update(em.FindIndex(sub.FindKey(k)) for k in range(1, sub.Extent() + 1))
    suspect_v: set[int] = set()
    for m, rows in ((em, suspect_e), (fm, suspect_f)):
        for i in rows:
            sub = _map(m.FindKey(i), TopAbs_VERTEX)
            suspect_v.update(vm.FindIndex(sub.FindKey(k)) for k in range(1, sub.Extent() + 1))
    for i in sorted(suspect_e):
        r = a.Result(em.FindKey(i))
        if r is not None:
            own, ctx = faulty(r)
            if own or ctx:
                bad_e.add(i - 1)
            mark_context(ctx)
    for i in suspect_f:
        f = fm.FindKey(i)
        r = a.Result(f)
        if r is not None and any(faulty(r)):
            bad_f.add(i - 1)
        exp = TopExp_Explorer(f, TopAbs_WIRE)
        while exp.More():
            r = a.Result(exp.Current())
            if r is not None and any(faulty(r)):
                bad_f.add(i - 1)
            exp.Next()
    v2e = TopTools_IndexedDataMapOfShapeListOfShape()
    TopExp.MapShapesAndAncestors_s(shape, TopAbs_VERTEX, TopAbs_EDGE, v2e)
    for i in sorted(suspect_v):
        v = vm.FindKey(i)
        r = a.Result(v)
        if r is not None and any(faulty(r)):
            for e in items(v2e.FindFromKey(v)):
                bad_e.add(em.FindIndex(e) - 1)
    return bad_e, bad_f


def once_each(shape: Any) -> Any | None:
    """A compound holding each distinct part of ``shape`` once, where it is
    met first, with the location it has there; None if no part is met twice.

    A part is a sub-shape below the compounds (a solid, shell, face …); a
    compound met again (an instanced sub-assembly) is skipped whole.  Two
    placements of one part differ by a rigid motion, which BRepCheck's
    verdicts do not see: checking each part once answers for every instance
    (an assembly of 5,000 placed parts costs one part's check, not 5,000).
    """
    from OCP.TopAbs import TopAbs_COMPOUND
    from OCP.TopLoc import TopLoc_Location
    from OCP.TopoDS import TopoDS_Compound

    plain = TopLoc_Location()
    seen = TopTools_IndexedMapOfShape()
    b, out = BRep_Builder(), TopoDS_Compound()
    b.MakeCompound(out)
    again = False
    stack = [shape]
    while stack:
        s = stack.pop()
        if seen.Contains(s.Located(plain)):
            again = True
            continue
        seen.Add(s.Located(plain))
        if s.ShapeType() != TopAbs_COMPOUND:
            b.Add(out, s)
            continue
        it = TopoDS_Iterator(s)  # a child carries its parents' locations
        kids = []
        while it.More():
            kids.append(it.Value())
            it.Next()
        stack.extend(reversed(kids))
    return out if again else None


def failures(shape: Any) -> tuple[set[int], set[int]]:
    """Where BRepCheck finds fault: (edge indices, face indices) of the model,
    0-based (:func:`model_order`: a fault on any instance of a located face
    counts against the model's one face).

    Each distinct part is checked once (:func:`once_each`).  See
    :func:`_failures` for what is walked.
    """
    part = once_each(shape)
    checked = shape if part is None else part
    bad_e, bad_f = _failures(checked)
    if not bad_e and not bad_f:
        return bad_e, bad_f
    return _rows_in(shape, checked, "edge", bad_e), _rows_in(shape, checked, "face", bad_f)


def _rows_in(whole: Any, checked: Any, kind: str, found: set[int]) -> set[int]:
    """Model rows (:func:`model_order` of ``whole``) of the sub-shapes of
    ``checked`` (``whole``, or a part of it) at ``found`` (0-based,
    ``MapShapes`` order of ``checked``)."""
    if not found:
        return set()
    distinct = _distinct(whole, kind)[0]
    sub = _map(checked, _KINDS[kind])
    return {distinct.FindIndex(_tshape(sub.FindKey(i + 1))) - 1 for i in found}


def edges_per_face(shape: Any) -> list[int]:
    """Number of distinct edges of each face, in face order."""
    return [_map(f, TopAbs_EDGE).Extent() for f in faces(shape)]


def face_signatures(shape: Any) -> np.ndarray:
    """Per face, in face order: area, centroid x, y, z, number of edges,
    number of those edges shared with another face, number of vertices;
    shape (F, 7).

    Faces of two versions of a model can be paired by these when their order
    differs (OCCT's STEP reader may reorder a shell's faces as it repairs it).
    """
    from OCP.BRepGProp import BRepGProp
    from OCP.GProp import GProp_GProps
    from OCP.TopTools import TopTools_IndexedDataMapOfShapeListOfShape

    e2f = TopTools_IndexedDataMapOfShapeListOfShape()
    TopExp.MapShapesAndAncestors_s(shape, TopAbs_EDGE, TopAbs_FACE, e2f)
    rows = []
    for f in faces(shape):
        g = GProp_GProps()
        BRepGProp.SurfaceProperties_s(f, g)
        c = g.CentreOfMass()
        em = _map(f, TopAbs_EDGE)
        shared = 0
        for i in range(1, em.Extent() + 1):
            around = items(e2f.FindFromKey(em.FindKey(i)))
            shared += any(not x.IsSame(f) for x in around)
        nv = _map(f, TopAbs_VERTEX).Extent()
        rows.append((g.Mass(), c.X(), c.Y(), c.Z(), em.Extent(), shared, nv))
    return np.array(rows, float).reshape(-1, 7)


def faulty_faces(shape: Any) -> set[int]:
    """Faces (0-based, face order) with a BRepCheck fault of their own or on
    one of their edges; if the shape is invalid with no such face (a fault
    of a shell or a solid only: a face the wrong way round in its shell),
    the faces of the shells BRepCheck rejects (:func:`_shell_faults`)."""
    from OCP.TopTools import TopTools_IndexedDataMapOfShapeListOfShape

    bad_e, bad_f = _failures(shape)
    if bad_e:
        em, fm = _map(shape, TopAbs_EDGE), _map(shape, TopAbs_FACE)
        e2f = TopTools_IndexedDataMapOfShapeListOfShape()
        TopExp.MapShapesAndAncestors_s(shape, TopAbs_EDGE, TopAbs_FACE, e2f)
        for e in bad_e:
            for f in items(e2f.FindFromKey(em.FindKey(e + 1))):
                bad_f.add(fm.FindIndex(f) - 1)
    if not bad_f and not is_valid(shape):
        bad_f = _shell_faults(shape)
    return bad_f


def _shell_faults(shape: Any) -> set[int]:
    """Faces (face order) to blame for faults BRepCheck finds on shells or
    solids and on none of their faces and edges: in each shell it rejects or
    that lies in a solid it rejects, the faces along an edge that two of the
    shell's faces use the same way round (a face reversed: BRepCheck rejects
    only the solid); else the faces of the shells, then of the solids, it
    rejects; else every face."""
    a = BRepCheck_Analyzer(shape)
    fm = _map(shape, TopAbs_FACE)
    shells, solids = _map(shape, TopAbs_SHELL), _map(shape, TopAbs_SOLID)
    in_bad_solid = TopTools_IndexedMapOfShape()
    bad_solids = [solids.FindKey(k) for k in range(1, solids.Extent() + 1)]
    bad_solids = [x for x in bad_solids if not a.IsValid(x)]
    for x in bad_solids:
        TopExp.MapShapes_s(x, TopAbs_SHELL, in_bad_solid)
    out: set[int] = set()
    rejected: set[int] = set()
    for k in range(1, shells.Extent() + 1):
        shell = shells.FindKey(k)
        bad = not a.IsValid(shell)
        if not bad and not in_bad_solid.Contains(shell):
            continue
        em = _map(shell, TopAbs_EDGE)
        uses: dict[int, list[tuple[int, Any]]] = {}
        for f in faces(shell):
            ex = TopExp_Explorer(f, TopAbs_EDGE)
            while ex.More():
                e = ex.Current()
                uses.setdefault(em.FindIndex(e), []).append((fm.FindIndex(f) - 1, e.Orientation()))
                ex.Next()
        out |= {
            i
            for u in uses.values()
            if len(u) == 2 and u[0][0] != u[1][0] and u[0][1] == u[1][1]
            for i, _ in u
        }
        if bad:
            rejected |= {fm.FindIndex(f) - 1 for f in faces(shell)}
    if not out:
        out = rejected or {fm.FindIndex(f) - 1 for x in bad_solids for f in faces(x)}
    return out or set(range(fm.Extent()))
