"""Triangles of a shape's faces, for pictures (``nurbscomp.heatmap``).

OCCT's ``BRepMesh_IncrementalMesh`` triangulates every face (the triangulation
is stored on the shape, as any mesher or exporter of OCCT does); each face's
nodes and triangles are then read into numpy arrays, in model space.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from OCP.BRep import BRep_Tool
from OCP.BRepMesh import BRepMesh_IncrementalMesh
from OCP.TopAbs import TopAbs_REVERSED
from OCP.TopLoc import TopLoc_Location

from .measure import diagonal, faces

#: Linear deflection of the mesh, as a fraction of the shape's bounding-box diagonal.
DEFLECTION = 1e-3
#: Angular deflection of the mesh, radians.
ANGLE = 0.3


def face_meshes(shape: Any) -> list[tuple[np.ndarray, np.ndarray]]:
    """Per face, in ``TopExp.MapShapes`` order (``measure.faces``): its nodes,
    shape (n, 3), and triangles, shape (t, 3), 0-based, wound along the
    face's outward normal.  A face OCCT cannot mesh has empty arrays."""
    diag = diagonal(shape)
    if diag == 0.0:  # nothing to mesh
        return [(np.zeros((0, 3)), np.zeros((0, 3), np.int64)) for _ in faces(shape)]
    BRepMesh_IncrementalMesh(shape, DEFLECTION * diag, False, ANGLE, False)
    out = []
    for f in faces(shape):
        loc = TopLoc_Location()
        tri = BRep_Tool.Triangulation_s(f, loc)
        if tri is None:
            out.append((np.zeros((0, 3)), np.zeros((0, 3), np.int64)))
            continue
        trsf = loc.Transformation()
        pts = np.empty((tri.NbNodes(), 3))
        for i in range(tri.NbNodes()):
            p = tri.Node(i + 1).Transformed(trsf)
            pts[i] = p.X(), p.Y(), p.Z()
        tris = np.empty((tri.NbTriangles(), 3), np.int64)
        for i in range(tri.NbTriangles()):
            t = tri.Triangle(i + 1)
            tris[i] = t.Value(1) - 1, t.Value(2) - 1, t.Value(3) - 1
        if f.Orientation() == TopAbs_REVERSED:
            tris = tris[:, ::-1]
        out.append((pts, np.ascontiguousarray(tris)))
    return out
