"""Sub-shape locations baked into the geometry (tolerance mode; issue 28).

OCCT's modelling places features by locations and keeps them: a cadquery
block's holes are one hole placed several times, its faces and edges
referenced through locations, their surfaces and curves in the frames they
were made in.  The encoder leaves located geometry as it is (lines and
circles through their vertices, vertices on the grid, planes through a
vertex all need unlocated records), so such a part made in memory came out
1.8 times the size of the same part read from a STEP file, whose reader
writes every placement into the geometry.

:func:`bake` does what that reader does, on the model: every placed
occurrence of a shape (the shape and the product of the locations on the
path from the root) becomes a row of its own, with its geometry moved by
that placement (a rotation, a mirror or both, and a translation), and no
location is left.  A part read from a file gets the same where it has
located faces (OCCT's IGES reader places a surface under a transformation
matrix so, the face's wires under the inverse, which kept every pcurve on
such a face in the container).  Occurrences at one placement stay one
row, so what the shape shares stays shared; one at two placements (a hole
placed twice) becomes two rows, as the shape's explorers already
count it (``TopExp::MapShapes``: same counts, faces in the same order).  The
move keeps each point at its parameters (:meth:`_Tables._move`), so pcurves,
parameters and ranges are unchanged, and it changes each point by rounding
only (a few ulps).
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np

from ..model import (
    EC,
    IDENTITY,
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
    rows_by_owner,
)
from ..product import INSTANCE, ProductData
from ..rules.joins import location_matrix, placed

#: Two placements within this (matrix entries, translation in mm) are one.
SAME = 1e-9

#: Derived kinds whose basis is a 3-D curve although they are surfaces.
_SWEPT = (Kind.REVOLUTION, Kind.EXTRUSION)


def _isometry(t: np.ndarray) -> bool:
    """Whether ``t`` (4 x 4) is a rotation, a mirror or both (no scale), and a
    translation."""
    r = t[:3, :3]
    return bool(np.abs(r @ r.T - np.eye(3)).max() < 1e-12)


#: Analytic curves whose frame is a ``gp_Ax2`` (right-handed: its Y is its
#: main direction times its X).
_AX2 = (Kind.CIRCLE, Kind.ELLIPSE, Kind.HYPERBOLA, Kind.PARABOLA)


class _Placed:
    """Rows of a table made for (old row, placement), each made once."""

    def __init__(self) -> None:
        self.rows: dict[int, list[tuple[np.ndarray, int]]] = {}

    def get(self, row: int, t: np.ndarray) -> int | None:
        for u, new in self.rows.get(row, []):
            if np.abs(u - t).max() <= SAME:
                return new
        return None

    def put(self, row: int, t: np.ndarray, new: int) -> None:
        self.rows.setdefault(row, []).append((t, new))


class _Tables:
    """The new surface and 3-D curve tables, rows added as placements need them."""

    def __init__(self, m: BRepModel) -> None:
        self.m = m
        self.surfaces: list[Geometry] = []
        self.curves: list[Geometry] = []
        self._s, self._c = _Placed(), _Placed()
        self._objects: dict[tuple[int, bytes], Geometry] = {}

    def surface(self, row: int, t: np.ndarray) -> int:
        if row < 0:
            return row
        got = self._s.get(row, t)
        if got is None:  # its basis first: a base comes before what it bears
            g = self._moved(self.m.surfaces[row], t, True)
            got = len(self.surfaces)
            self.surfaces.append(g)
            self._s.put(row, t, got)
        return got

    def curve(self, row: int, t: np.ndarray) -> int:
        if row < 0:
            return row
        got = self._c.get(row, t)
        if got is None:
            g = self._moved(self.m.curves3d[row], t, False)
            got = len(self.curves)
            self.curves.append(g)
            self._c.put(row, t, got)
        return got

    def _moved(self, g: Geometry, t: np.ndarray, surface: bool) -> Geometry:
        """``g`` moved by ``t``; one object for one (object, placement), so
        rows that shared a record share its moved one."""
        key = (id(g), np.round(t, 9).tobytes())
        if key not in self._objects:
            self._objects[key] = self._move(g, t, surface)
        return self._objects[key]

    def _move(self, g: Geometry, t: np.ndarray, surface: bool) -> Geometry:
        """``g`` moved by ``t``, each point of it at the same parameters: a
        mirror (``t`` of determinant -1) turns the sense of a rotation about
        an axis and of a cross product, so there a conic's main direction, a
        revolution's axis and an offset's sign are turned back (a plane's or
        quadric's ``gp_Ax3`` becomes indirect, as OCCT's own move makes it)."""
        r, d = t[:3, :3], t[:3, 3]
        mirror = bool(np.linalg.det(r) < 0)
        if isinstance(g, BSplineSurface | BSplineCurve):
            return replace(g, poles=placed(g.poles, t))
        if isinstance(g, Analytic):
            frame = g.frame @ r.T
            frame[0] += d  # the origin; the other rows are directions
            if mirror and not surface and g.kind in _AX2:
                frame[1] = -frame[1]
            return replace(g, frame=frame)
        assert isinstance(g, Derived)
        if g.kind in _SWEPT:
            basis = self.curve(g.basis, t)
        elif surface:
            basis = self.surface(g.basis, t)
        else:
            basis = self.curve(g.basis, t)
        frame = g.frame @ r.T if len(g.frame) else g.frame
        params = g.params
        if g.kind == Kind.REVOLUTION:
            frame[0] += d  # the axis' origin
            if mirror:
                frame[1] = -frame[1]
        elif mirror and g.kind in (Kind.OFFSET_SURFACE, Kind.OFFSET_CURVE):
            params = -params
        return replace(g, basis=basis, frame=frame, params=params)


def bake(m: BRepModel) -> BRepModel | None:
    """``m`` with its sub-shapes' locations written into their geometry
    (see the module's docstring); None where it has none to bake, where a
    location is not an isometry (it scales), or where ``m``'s product data
    places anything or names a shape the bake makes two rows of (:func:`_product_refs`; its
    references are otherwise mapped onto the new rows)."""
    used = (
        m.child_loc,
        m.face_loc,
        m.edge_reps[:, EC.LOC],
        m.edge_reps[:, EC.LOC2],  # -1 where the row has no second surface
        m.vertex_reps[:, VC.LOC],
    )
    if m.root_loc == 0 and not any((a > 0).any() for a in used):
        return None
    mats = [location_matrix(m, k) for k in range(len(m.locations))]
    if not all(_isometry(t) for t in mats):
        return None
    tables = _Tables(m)
    tidx = m.type_index().tolist()
    types = m.shape_type.tolist()
    start, kids = m.child_start.tolist(), m.child_shape.tolist()
    orients, locs = m.child_orient.tolist(), m.child_loc.tolist()
    shapes = _Placed()
    new_type: list[int] = []
    new_flags: list[int] = []
    new_children: list[list[tuple[int, int]]] = []
    faces: list[tuple[int, np.ndarray]] = []
    edges: list[tuple[int, np.ndarray]] = []
    vertices: list[tuple[int, np.ndarray]] = []
    # post-order, iterative: (shape, placement, children made so far)
    root_t = mats[m.root_loc]
    stack: list[tuple[int, np.ndarray, list[tuple[int, int]]]] = [(m.root_shape, root_t, [])]
    while stack:
        s, t, made = stack[-1]
        k = start[s] + len(made)
        if k < start[s + 1]:
            c, ct = kids[k], t @ mats[locs[k]]
            got = shapes.get(c, ct)
            if got is None:
                stack.append((c, ct, []))
            else:
                made.append((got, orients[k]))
            continue
        stack.pop()
        new = len(new_type)
        shapes.put(s, t, new)
        new_type.append(types[s])
        new_flags.append(int(m.shape_flags[s]))
        new_children.append(made)
        if types[s] == ShapeType.FACE:
            faces.append((tidx[s], t))
        elif types[s] == ShapeType.EDGE:
            edges.append((tidx[s], t))
        elif types[s] == ShapeType.VERTEX:
            vertices.append((tidx[s], t))
        if stack:
            stack[-1][2].append((new, orients[start[stack[-1][0]] + len(stack[-1][2])]))
    out = replace(m)
    out.shape_type = np.array(new_type, m.shape_type.dtype)
    out.shape_flags = np.array(new_flags, m.shape_flags.dtype)
    counts = [len(c) for c in new_children]
    out.child_start = np.concatenate([[0], np.cumsum(counts)]).astype(m.child_start.dtype)
    out.child_shape = np.array([c for cs in new_children for c, _ in cs], m.child_shape.dtype)
    out.child_orient = np.array([o for cs in new_children for _, o in cs], m.child_orient.dtype)
    out.child_loc = np.zeros(len(out.child_shape), m.child_loc.dtype)
    out.root_shape, out.root_loc = len(new_type) - 1, 0
    out.locations = [IDENTITY]
    out.datums = np.zeros((0, 3, 4))
    out.datum_forms = np.zeros(0, m.datum_forms.dtype)
    # faces
    rows = [f for f, _ in faces]
    out.face_surface = np.array(
        [tables.surface(int(m.face_surface[f]), t @ mats[int(m.face_loc[f])]) for f, t in faces],
        m.face_surface.dtype,
    )
    out.face_loc = np.zeros(len(faces), m.face_loc.dtype)
    out.face_tol = m.face_tol[rows]
    out.face_natural = m.face_natural[rows]
    # edges, vertices and their representations
    erows = [e for e, _ in edges]
    out.edge_tol, out.edge_flags = m.edge_tol[erows], m.edge_flags[erows]

    def edge_rep(row: np.ndarray, place: np.ndarray, t: np.ndarray) -> None:
        kind = int(row[EC.KIND])
        if kind == RepKind.CURVE3D:
            row[EC.CURVE] = tables.curve(int(row[EC.CURVE]), place)
            return
        row[EC.SURFACE] = tables.surface(int(row[EC.SURFACE]), place)
        if kind == RepKind.ON_TWO_SURFACES:
            place2 = t @ mats[int(row[EC.LOC2])]
            row[EC.SURFACE2] = tables.surface(int(row[EC.SURFACE2]), place2)
            row[EC.LOC2] = 0

    n = len(m.edge_tol)
    out.edge_reps, picked = _reps(m.edge_reps, EC.EDGE, EC.LOC, edges, n, mats, edge_rep)
    out.edge_rep_cont = m.edge_rep_cont[picked]
    out.edge_rep_range = m.edge_rep_range[picked]
    out.edge_rep_uv = m.edge_rep_uv[picked]
    vrows = [v for v, _ in vertices]
    out.vertex_point = np.array([placed(m.vertex_point[v], t) for v, t in vertices]).reshape(-1, 3)
    out.vertex_tol = m.vertex_tol[vrows]

    def vertex_rep(row: np.ndarray, place: np.ndarray, t: np.ndarray) -> None:
        if int(row[VC.KIND]) == PointRepKind.ON_CURVE:
            row[VC.CURVE] = tables.curve(int(row[VC.CURVE]), place)
        else:
            row[VC.SURFACE] = tables.surface(int(row[VC.SURFACE]), place)

    n = len(m.vertex_tol)
    out.vertex_reps, picked = _reps(m.vertex_reps, VC.VERTEX, VC.LOC, vertices, n, mats, vertex_rep)
    out.vertex_rep_params = m.vertex_rep_params[picked]
    out.surfaces, out.curves3d = tables.surfaces, tables.curves
    if m.product is not None:
        refs = _product_refs(m.product, shapes)
        if refs is None:
            return None
        out.product = replace(m.product, ref=refs)
    return out


def _product_refs(p: ProductData, shapes: _Placed) -> np.ndarray | None:
    """``p``'s references to ``SHAP`` rows, as rows of the baked shapes
    table; None where ``p`` places anything (an assembly's instances, a
    sub-shape's placement: the structure a user gets back) or refers to a
    shape that the bake made more than one row of."""
    if len(p.placements) or (p.kind == INSTANCE).any() or (p.place >= 0).any():
        return None
    refs = p.ref.copy()
    for i, r in enumerate(p.ref.tolist()):
        if r < 0:
            continue
        rows = shapes.rows.get(r, [])
        if len(rows) != 1:
            return None
        refs[i] = rows[0][1]
    return refs


def _reps(
    table: np.ndarray,
    owner: int,
    loc: int,
    placed_rows: list[tuple[int, np.ndarray]],
    n: int,
    mats: list[np.ndarray],
    move: Any,
) -> tuple[np.ndarray, list[int]]:
    """The representation rows of the new owners (``placed_rows``: per new
    row, the old row and its placement; ``table``'s column ``owner`` names
    one of ``n`` old rows), each moved by ``move(row, placement of the
    representation, placement of its owner)`` and its ``loc`` column set to
    the identity; and the old rows they came from."""
    groups = rows_by_owner(table[:, owner], n)
    picked: list[int] = []
    out = []
    for new, (old, t) in enumerate(placed_rows):
        for q in groups[old]:
            row = table[q].copy()
            row[owner] = new
            move(row, t @ mats[int(row[loc])], t)
            row[loc] = 0
            out.append(row)
            picked.append(q)
    return np.array(out, table.dtype).reshape(-1, table.shape[1]), picked
