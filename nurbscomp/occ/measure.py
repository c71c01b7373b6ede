"""Measures on shapes: topology counts, validity, free edges, face deviation.

The deviation measure is independent of the codec: it samples points inside
each original face (a UV grid, kept where the face's own 2-D classifier says
"inside") and takes their distance to the decoded face of the same index.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from OCP.BRep import BRep_Tool
from OCP.BRepCheck import BRepCheck_Analyzer
from OCP.BRepTools import BRepTools
from OCP.BRepTopAdaptor import BRepTopAdaptor_FClass2d
from OCP.GeomAPI import GeomAPI_ProjectPointOnSurf
from OCP.gp import gp_Pnt2d
from OCP.ShapeAnalysis import ShapeAnalysis_FreeBounds
from OCP.TopAbs import (
    TopAbs_COMPOUND,
    TopAbs_EDGE,
    TopAbs_FACE,
    TopAbs_IN,
    TopAbs_ON,
    TopAbs_SHELL,
    TopAbs_SOLID,
    TopAbs_VERTEX,
)
from OCP.TopExp import TopExp, TopExp_Explorer
from OCP.TopoDS import TopoDS
from OCP.TopTools import TopTools_IndexedMapOfShape


def _map(shape: Any, kind: Any) -> TopTools_IndexedMapOfShape:
    m = TopTools_IndexedMapOfShape()
    TopExp.MapShapes_s(shape, kind, m)
    return m


def faces(shape: Any) -> list[Any]:
    """The faces of a shape in ``TopExp.MapShapes(shape, FACE)`` order."""
    m = _map(shape, TopAbs_FACE)
    return [TopoDS.Face_s(m.FindKey(i)) for i in range(1, m.Extent() + 1)]


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


def free_edges(shape: Any) -> int:
    """Number of free (unshared) edges, by ShapeAnalysis_FreeBounds, per shell or face set."""
    n = 0
    exp = TopExp_Explorer(shape, TopAbs_SHELL)
    shells = []
    while exp.More():
        shells.append(exp.Current())
        exp.Next()
    if not shells:
        shells = [shape]
    for sh in shells:
        fb = ShapeAnalysis_FreeBounds(sh, False, False)
        for comp in (fb.GetClosedWires(), fb.GetOpenWires()):
            n += _map(comp, TopAbs_EDGE).Extent()
    return n


def sample_face(face: Any, n: int = 7) -> tuple[np.ndarray, np.ndarray]:
    """Points inside a face: an ``n`` x ``n`` UV grid, kept where inside.

    Returns
    -------
    uv : ndarray, shape (k, 2)
    xyz : ndarray, shape (k, 3)
        Points of the located face surface, in model space.
    """
    u0, u1, v0, v1 = BRepTools.UVBounds_s(face)
    surf = BRep_Tool.Surface_s(face)
    cls = BRepTopAdaptor_FClass2d(face, 1e-9)
    t = (np.arange(n) + 0.5) / n
    uv, xyz = [], []
    trsf = face.Location().Transformation()
    for a in t:
        for b in t:
            u, v = u0 + a * (u1 - u0), v0 + b * (v1 - v0)
            if cls.Perform(gp_Pnt2d(u, v)) in (TopAbs_IN, TopAbs_ON):
                p = surf.Value(u, v).Transformed(trsf)
                uv.append((u, v))
                xyz.append((p.X(), p.Y(), p.Z()))
    if not uv:  # a sliver: fall back to the middle of its UV box
        u, v = (u0 + u1) / 2, (v0 + v1) / 2
        p = surf.Value(u, v).Transformed(trsf)
        uv.append((u, v))
        xyz.append((p.X(), p.Y(), p.Z()))
    return np.array(uv), np.array(xyz)


def face_deviation(original: Any, decoded: Any, n: int = 7, tol: float = 0.0) -> float:
    """Largest distance from points inside ``original`` to the surface of ``decoded``.

    Each sample is first compared with the decoded surface at the same (u, v),
    which bounds the distance from above; only where that exceeds ``tol`` is the
    point projected onto the decoded surface.
    """
    uv, xyz = sample_face(original, n)
    surf = BRep_Tool.Surface_s(decoded)
    trsf = decoded.Location().Transformation()
    inv = trsf.Inverted()
    worst = 0.0
    for (u, v), p in zip(uv, xyz):
        q = surf.Value(u, v).Transformed(trsf)
        d = float(np.sqrt((q.X() - p[0]) ** 2 + (q.Y() - p[1]) ** 2 + (q.Z() - p[2]) ** 2))
        if d > tol:
            from OCP.gp import gp_Pnt

            proj = GeomAPI_ProjectPointOnSurf(gp_Pnt(*p).Transformed(inv), surf)
            if proj.NbPoints():
                d = min(d, proj.LowerDistance())
        worst = max(worst, d)
    return worst


def deviation(original: Any, decoded: Any, n: int = 7, tol: float = 0.0) -> np.ndarray:
    """Per-face deviation between two shapes with faces in the same order, shape (F,)."""
    fa, fb = faces(original), faces(decoded)
    if len(fa) != len(fb):
        raise ValueError(f"face counts differ: {len(fa)} != {len(fb)}")
    return np.array([face_deviation(a, b, n, tol) for a, b in zip(fa, fb)])


def is_compound(shape: Any) -> bool:
    return shape.ShapeType() == TopAbs_COMPOUND
