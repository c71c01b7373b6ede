"""The independent reader: a container's bytes to its tables and floats, from
docs/format.md alone.  ``read(data)`` returns a :class:`Model`;
``Model.floats()`` gives the arrays that ``tests/golden/*.npz`` hold."""

from __future__ import annotations

import hashlib
import math
import struct
from dataclasses import dataclass, field

import numpy as np

from . import nets
from .container import Container, ReadError
from .tables import (
    Analytic,
    Derived,
    Edges,
    Faces,
    Record,
    Shapes,
    Spline,
    Vertices,
    read_edges,
    read_faces,
    read_geometry,
    read_locs,
    read_sides,
    read_vertices,
)
from .topo import read_shap

ORDER = ["META", "LOCS", "SURF", "SNET", "CRV3", "CNET", "CRV2", "SHAP", "VERT", "EDGE", "FACE"]


@dataclass(eq=False)
class Model:
    revision: int
    meta: dict
    tol: float | None
    datum_forms: np.ndarray
    datums: np.ndarray
    locations: list[tuple[list[int], list[int]]]
    surfaces: list[Record]
    curves3d: list[Record]
    curves2d: list[Record]
    shapes: Shapes
    vertices: Vertices
    edges: Edges
    faces: Faces
    sides: list[tuple[int, int, int, int, int]]
    snet: bytes
    cnet: bytes
    surf_copies: list[bool]
    crv3_copies: list[bool]
    #: CNET copies (method 9) as decoded: (row, leader row), filled by nets.decode
    copies: list[tuple[int, int]] = field(default_factory=list)

    def int_arrays(self) -> dict[str, np.ndarray]:
        """Every integer, as make_golden.int_arrays lays them out."""
        geo: list[int] = []
        for g in [*self.surfaces, *self.curves3d, *self.curves2d]:
            geo.append(g.kind)
            if isinstance(g, Spline) and g.is_surface:
                assert g.poles is not None
                geo += [*g.degrees, *g.poles.shape, *(int(p) for p in g.periodic)]
                geo += [*g.mults[0].tolist(), -1, *g.mults[1].tolist(), int(g.weights is not None)]
            elif isinstance(g, Spline):
                assert g.poles is not None
                geo += [g.degrees[0], *g.poles.shape, int(g.periodic[0]), *g.mults[0].tolist()]
                geo.append(int(g.weights is not None))
            elif isinstance(g, Derived):
                geo.append(g.basis)
        sh = self.shapes
        nchild = [len(c) for c in sh.children]
        flat = [c for cs in sh.children for c in cs]
        out = {
            "geometry": geo,
            "datum_forms": self.datum_forms,
            "locations": [x for d, p in self.locations[1:] for x in (*d, *p)],
            "shape_type": sh.type,
            "shape_flags": sh.flags,
            "child_start": np.concatenate([[0], np.cumsum(nchild)]),
            "child_shape": [c[0] for c in flat],
            "child_orient": [c[1] for c in flat],
            "child_loc": [c[2] for c in flat],
            "root": list(sh.root),
            "vertex_reps": self.vertices.reps,
            "edge_flags": self.edges.flags,
            "edge_reps": self.edges.reps,
            "edge_rep_cont": self.edges.cont,
            "face_surface": self.faces.surface,
            "face_loc": self.faces.loc,
            "face_natural": self.faces.natural,
        }
        return {k: np.asarray(v).astype(np.int64) for k, v in out.items()}

    def int_digest(self) -> str:
        """SHA-256 of :meth:`int_arrays`, as make_golden.int_digest."""
        h = hashlib.sha256()
        for k, a in sorted(self.int_arrays().items()):
            h.update(k.encode() + struct.pack("<Q", a.size) + a.astype("<i8").tobytes())
        return h.hexdigest()

    def floats(self) -> dict[str, np.ndarray]:
        """Every float, one array per kind of value, as make_golden.model_floats."""

        def cat(parts: list) -> np.ndarray:
            return np.concatenate(
                [np.asarray(p, float).reshape(-1) for p in parts] or [np.zeros(0)]
            )

        recs = [*self.surfaces, *self.curves3d, *self.curves2d]
        spl = [g for g in recs if isinstance(g, Spline)]
        return {
            "poles": cat([g.poles for g in spl]),
            "weights": cat([g.weights for g in spl if g.weights is not None]),
            "knots": cat([k for g in spl for k in g.knots]),
            "frames": cat([g.frame for g in recs if isinstance(g, (Analytic, Derived))]),
            "params": cat([g.params for g in recs if isinstance(g, (Analytic, Derived))]),
            "datums": self.datums.reshape(-1),
            "vertex_point": self.vertices.point.reshape(-1),
            "vertex_tol": self.vertices.tol,
            "vertex_rep_params": self.vertices.params.reshape(-1),
            "edge_tol": self.edges.tol,
            "edge_rep_range": self.edges.range.reshape(-1),
            "edge_rep_uv": self.edges.uv.reshape(-1),
            "face_tol": self.faces.tol,
        }


def check_layout(c: Container) -> None:
    want = list(ORDER)
    if c.revision >= 1:
        want.append("SIDE")
    if c.revision >= 2:
        want.append("PROD")
    tags = [t for t in c.order if t in want or c.revision < 3]
    pos = -1
    for t in tags:
        if t not in want:
            if c.major == 1 and c.minor > 2:
                continue
            raise ReadError(f"unknown section {t}")
        i = want.index(t)
        if i <= pos:
            raise ReadError(f"section {t} out of order")
        pos = i
    for t in ORDER:
        if t not in c.sections:
            raise ReadError(f"missing section {t}")


def below(shapes: Shapes) -> list[set[int]]:
    """For each shape, every shape reached from it through references (itself included)."""
    out: list[set[int]] = []
    for s in range(len(shapes.type)):
        acc = {s}
        for c, _, _ in shapes.children[s]:
            acc |= out[c]
        out.append(acc)
    return out


def face_uses(shapes: Shapes, faces: Faces) -> list[list[tuple[int, int]]]:
    """§2.7 (2.11): per edge row, (face row, references) of each face whose
    walk reaches it: the references to it in the child lists of the shapes
    of types 0-5 reached from the face, the face included."""
    reach = below(shapes)
    edge_shapes = shapes.of(6)
    out: list[list[tuple[int, int]]] = [[] for _ in edge_shapes]
    for f, fs in enumerate(shapes.of(4)):
        count: dict[int, int] = {}
        for x in reach[fs]:
            if shapes.type[x] <= 5:
                for ch, _, _ in shapes.children[x]:
                    if shapes.type[ch] == 6:
                        count[ch] = count.get(ch, 0) + 1
        for ch in sorted(count, key=lambda e: shapes.row_of[e]):
            out[shapes.row_of[ch]].append((f, count[ch]))
    return out


def pcurve_faces(
    uses: list[list[tuple[int, int]]], faces: Faces, surfaces: list[Record], bare: int
) -> list[list[tuple[int, int]]]:
    """§2.7 (2.11): the faces predicted to hold a pcurve of each edge: two
    references or more, or a surface whose kind (a Bezier or B-spline: 10)
    is not in the mask ``bare``."""

    def held(f: int) -> bool:
        g = surfaces[int(faces.surface[f])]
        kind = g.kind if isinstance(g, (Analytic, Derived)) else 10
        return not bare >> kind & 1

    return [[(f, n) for f, n in u if n >= 2 or held(f)] for u in uses]


def resolve_picks(
    shapes: Shapes,
    faces: Faces,
    edges: Edges,
    with_pcurve: list[list[tuple[int, int]]] | None = None,
) -> None:
    """§2.7, surfaces by prediction (2.0); from 2.11 (``with_pcurve`` given)
    each pick stored less its prediction, modulo the edge's candidates."""
    if edges.picks is None:
        return
    p1, p2, esc = edges.picks
    reach = below(shapes)
    face_shapes = shapes.of(4)
    edge_shapes = shapes.of(6)
    cache: dict[int, list[int]] = {}

    def cand(e: int) -> list[int]:
        if e not in cache:
            es = edge_shapes[e]
            lst: list[int] = []
            for f, fs in enumerate(face_shapes):
                if es in reach[fs] and int(faces.surface[f]) not in lst:
                    lst.append(int(faces.surface[f]))
            cache[e] = lst
        return cache[e]

    nth: dict[int, int] = {}

    def guess(r: int, col: int) -> int:
        e, k = int(edges.reps[r, 0]), int(edges.reps[r, 1])
        if with_pcurve is None:
            return 0
        if k == 3:
            return 0 if col == 4 else int(len(cand(e)) > 1)
        j = nth.get(e, 0)
        nth[e] = j + 1
        pf = with_pcurve[e]
        return cand(e).index(int(faces.surface[pf[j][0]])) if j < len(pf) else 0

    it1, it2, ie = iter(p1), iter(p2), iter(esc)
    for col, it, kinds in ((4, it1, (1, 2, 3)), (5, it2, (3,))):
        for r in range(len(edges.reps)):
            if edges.reps[r, 1] not in kinds:
                continue
            k = next(it)
            g = guess(r, col)
            if k >= 0:
                lst = cand(int(edges.reps[r, 0]))
                if k >= len(lst):
                    raise ReadError("EDGE: pick past the candidates")
                edges.reps[r, col] = lst[(k + g) % len(lst)]
            elif k == -1:
                edges.reps[r, col] = next(ie)
            else:
                raise ReadError("EDGE: pick below -1")
    for it in (it1, it2, ie):
        if next(it, None) is not None:
            raise ReadError("EDGE: picks left over")


def curve_range(g: Record) -> tuple[float, float]:
    if isinstance(g, Spline):
        if g.bezier:
            return 0.0, 1.0
        return float(g.knots[0][0]), float(g.knots[0][-1])
    if isinstance(g, Derived) and g.kind == 23:
        return float(g.params[0]), float(g.params[1])
    raise ReadError("EDGE: range kind 1 on a curve without its own range")


def _angle(p: np.ndarray, g: Analytic) -> float:
    o, n, x = g.frame[0], g.frame[1], g.frame[2]
    y = np.array([n[1] * x[2] - n[2] * x[1], n[2] * x[0] - n[0] * x[2], n[0] * x[1] - n[1] * x[0]])
    y = y / math.sqrt((y[0] * y[0] + y[1] * y[1]) + y[2] * y[2])
    q = p - o
    a = math.atan2(
        (q[0] * y[0] + q[1] * y[1]) + q[2] * y[2], (q[0] * x[0] + q[1] * x[1]) + q[2] * x[2]
    )
    if a < 0:
        a = 0.0 if a > -1e-9 else a + 2 * math.pi
    return a


def _ends(m: Model, r: int) -> tuple[int, int] | None:
    """The first FORWARD and REVERSED unlocated vertex children of representation r's edge."""
    sh = m.shapes
    es = sh.of(6)[int(m.edges.reps[r, 0])]
    fwd = rev = None
    for c, o, loc in sh.children[es]:
        if sh.type[c] != 7 or loc != 0:
            continue
        if o == 0 and fwd is None:
            fwd = c
        elif o == 1 and rev is None:
            rev = c
    return None if fwd is None or rev is None else (fwd, rev)


def _axis_face(m: Model, edge_shape: int) -> int | None:
    """§2.3 (2.4): the first face of location 0 on a cylinder, cone, sphere or
    torus that holds the edge in one of its wires, both links of location 0."""
    sh = m.shapes
    for f, fs in enumerate(sh.of(4)):
        g = m.surfaces[int(m.faces.surface[f])]
        if int(m.faces.loc[f]) != 0 or not (isinstance(g, Analytic) and g.kind in (1, 2, 3, 4)):
            continue
        for w, _, wl in sh.children[fs]:
            if sh.type[w] == 5 and wl == 0:
                if any(e == edge_shape and el == 0 for e, _, el in sh.children[w]):
                    return f
    return None


def circle_through(m: Model, i: int, g: Analytic) -> None:
    """§2.3 (2.4): the frame and radius of a circle through its edge's vertex."""
    reps = m.edges.reps
    uses = [r for r in range(len(reps)) if int(reps[r, 1]) == 0 and int(reps[r, 2]) == i]
    if not uses or any(int(reps[r, 6]) != 0 for r in uses):
        raise ReadError("CRV3: a circle through a vertex not on unlocated edges")
    es = m.shapes.of(6)[int(reps[uses[0], 0])]
    fwd = next((c for c, o, loc in m.shapes.children[es]
                if m.shapes.type[c] == 7 and o == 0 and loc == 0), None)  # fmt: skip
    f = _axis_face(m, es)
    if fwd is None or f is None:
        raise ReadError("CRV3: a circle through a vertex without its vertex or axis face")
    axis = m.surfaces[int(m.faces.surface[f])]
    p = [float(x) for x in m.vertices.point[m.shapes.row_of[fwd]]]
    o, d, x = ([float(v) for v in axis.frame[k]] for k in range(3))
    w = [p[j] - o[j] for j in range(3)]
    h = (w[0] * d[0] + w[1] * d[1]) + w[2] * d[2]
    c = [o[j] + h * d[j] for j in range(3)]
    v = [p[j] - c[j] for j in range(3)]
    r = math.sqrt((v[0] * v[0] + v[1] * v[1]) + v[2] * v[2])
    if not (r > 0 and math.isfinite(r)):
        raise ReadError("CRV3: a circle through a vertex on its axis")
    g.frame = np.array([c, [g.through * dj for dj in d], x])
    g.params = np.array([r])
    _made(g.frame, g.params)


def _made(*values) -> None:
    """§2.3, made values: each below 1e15 in magnitude."""
    for v in values:
        if not all(abs(float(x)) < 1e15 for x in np.ravel(v)):
            raise ReadError("a record made through a vertex at or past 1e15 mm")


def surface_through(m: Model, i: int, g: Analytic) -> None:
    """§2.3 (2.7): the origin of a plane at a vertex of its first face (on its
    row or a copy of it), or of a cylinder at its radius from that vertex."""
    sh = m.shapes
    faces = [f for f in range(len(m.faces.surface)) if m.surfaces[int(m.faces.surface[f])] is g]
    if not faces or int(m.faces.loc[faces[0]]) != 0:
        raise ReadError("SURF: a surface through a vertex without an unlocated first face")
    fs = sh.of(4)[faces[0]]
    wire = next((w for w, _, wl in sh.children[fs] if sh.type[w] == 5 and wl == 0), None)
    for e, _, el in sh.children[wire] if wire is not None else []:
        if sh.type[e] != 6 or el != 0:
            continue
        fwd = next((c for c, o, loc in sh.children[e]
                    if sh.type[c] == 7 and o == 0 and loc == 0), None)  # fmt: skip
        if fwd is not None:
            p = [float(x) for x in m.vertices.point[sh.row_of[fwd]]]
            if g.kind == 0:
                g.frame[0] = p
                _made(g.frame[0])
                return
            q = g.through - 1  # against X, Y, -X, -Y
            u = [(1.0 if q < 2 else -1.0) * float(x) for x in g.frame[2 + q % 2]]
            r = float(g.params[0])
            g.frame[0] = [p[j] - r * u[j] for j in range(3)]
            _made(g.frame[0])
            return
    raise ReadError("SURF: a plane or cylinder through a vertex without its vertex")


def lines_through(m: Model) -> None:
    """§2.3: the origin of each plane or cylinder through a vertex of its face (2.7), the
    frame of each line through its edge's vertices (2.2) and of each circle
    through its edge's vertex about its face's axis (2.4)."""
    done: list[Analytic] = []
    for i, g in enumerate(m.surfaces):
        if isinstance(g, Analytic) and g.through and not any(h is g for h in done):
            done.append(g)  # a copy row holds the same record: made once
            surface_through(m, i, g)
    for i, g in enumerate(m.curves3d):
        if not (isinstance(g, Analytic) and g.through):
            continue
        if g.kind == 17:
            if sum(h is g for h in m.curves3d) != 1:
                raise ReadError("CRV3: a circle through a vertex is copied")
            circle_through(m, i, g)
            continue
        uses = [r for r in range(len(m.edges.reps))
                if int(m.edges.reps[r, 1]) == 0 and int(m.edges.reps[r, 2]) == i]  # fmt: skip
        if len(uses) != 1 or int(m.edges.reps[uses[0], 6]) != 0:
            raise ReadError("CRV3: a line through vertices not on one unlocated edge")
        if sum(h is g for h in m.curves3d) != 1:
            raise ReadError("CRV3: a line through vertices is copied")
        ends = _ends(m, uses[0])
        if ends is None:
            raise ReadError("CRV3: a line through vertices without its vertices")
        a, b = (m.vertices.point[m.shapes.row_of[v]] for v in ends)
        d = [float(b[j]) - float(a[j]) for j in range(3)]
        n = math.sqrt((d[0] * d[0] + d[1] * d[1]) + d[2] * d[2])
        if not (n > 0 and math.isfinite(n)):
            raise ReadError("CRV3: a line through two vertices at one point")
        g.frame = np.array([[float(x) for x in a], [x / n for x in d]])
        _made(g.frame)


def vertex_range(m: Model, r: int) -> tuple[float, float]:
    """§2.7, range kind 4."""
    sh = m.shapes
    g = m.curves3d[int(m.edges.reps[r, 2])]
    ends = _ends(m, r)
    if ends is None or not isinstance(g, Analytic) or m.edges.reps[r, 6] != 0:
        raise ReadError("EDGE: range kind 4 without its vertices")
    fwd, rev = ends
    pa = m.vertices.point[sh.row_of[fwd]]
    pb = m.vertices.point[sh.row_of[rev]]
    if g.kind == 16:
        o, d = g.frame[0], g.frame[1]

        def par(p: np.ndarray) -> float:
            return ((p[0] - o[0]) * d[0] + (p[1] - o[1]) * d[1]) + (p[2] - o[2]) * d[2]

        return par(pa), par(pb)
    if g.kind == 17:
        a = _angle(pa, g)
        if fwd == rev:
            return a, a + 2 * math.pi
        b = _angle(pb, g)
        if b <= a:
            b += 2 * math.pi
        return a, b
    raise ReadError("EDGE: range kind 4 on a curve other than a line or circle")


def fill_ranges(m: Model) -> None:
    e = m.edges
    first0: dict[int, int] = {}
    for r in range(len(e.reps)):
        k, rk = int(e.reps[r, 1]), int(e.range_kind[r])
        if k == 0 and int(e.reps[r, 0]) not in first0:
            first0[int(e.reps[r, 0])] = r
        if rk == 1:
            table = m.curves3d if k == 0 else m.curves2d
            e.range[r] = curve_range(table[int(e.reps[r, 2])])
        elif rk == 3:
            e.range[r] = 0.0
        elif rk == 4:
            e.range[r] = vertex_range(m, r)
        elif rk not in (0, 2, -1):
            raise ReadError(f"EDGE: range kind {rk}")
    for r in range(len(e.reps)):
        if int(e.range_kind[r]) == 2:
            e.range[r] = e.range[first0[int(e.reps[r, 0])]]


def read(data: bytes) -> Model:
    c = Container(data)
    if not c.has_model:
        raise ReadError("no model: a passthrough or byte-exact container")
    check_layout(c)
    meta = c.meta()
    tol = None if meta["mode"] == "lossless" else float(meta["tolerance_mm"])
    if c.lossless != (tol is None):
        raise ReadError("lossless flag")
    rev = c.revision
    forms, datums, locs = read_locs(c.sections["LOCS"])
    surfaces, surf_copies = read_geometry(c.sections["SURF"], "SURF", 3, rev)
    curves3d, crv3_copies = read_geometry(c.sections["CRV3"], "CRV3", 3, rev)
    curves2d, _ = read_geometry(c.sections["CRV2"], "CRV2", 2, rev)
    shapes = read_shap(c.sections["SHAP"], rev)
    vertices = read_vertices(c.sections["VERT"], rev, shapes, tol)
    faces = read_faces(c.sections["FACE"])
    uses = face_uses(shapes, faces) if rev >= 14 else []

    def predict(bare: int, regular: int, last: int) -> list[list[int]]:
        out = []
        for u, pf in zip(uses, pcurve_faces(uses, faces, surfaces, bare)):
            pcs = [2 if n >= 2 else 1 for _, n in pf]
            kinds = pcs + [0] if last else [0] + pcs
            out.append(kinds + ([3] if regular and len(u) == 2 else []))
        return out

    edges = read_edges(c.sections["EDGE"], rev, predict, curves3d)
    with_pcurve = pcurve_faces(uses, faces, surfaces, edges.settings[0]) if rev >= 14 else None
    resolve_picks(shapes, faces, edges, with_pcurve)
    sides = read_sides(c.sections["SIDE"]) if "SIDE" in c.sections else []
    m = Model(rev, meta, tol, forms, datums, locs, surfaces, curves3d, curves2d, shapes,
              vertices, edges, faces, sides, c.sections["SNET"], c.sections["CNET"],
              surf_copies, crv3_copies)  # fmt: skip
    lines_through(m)
    fill_ranges(m)
    nets.decode(m)
    return m
