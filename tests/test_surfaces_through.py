"""Planes whose origin is a vertex of their face and cylinders whose axis is
their radius from it (format 2.7, docs/format.md §2.3;
``encode.assembly._surfaces_through``, ``rules.joins.face_points``), seam
lines through their vertices, and
directions that are one within the source's precision made equal
(``encode.analytic.same_directions``)."""

from __future__ import annotations

from pathlib import Path

import cadquery as cq
import numpy as np
import pytest

from nurbscomp import container, occ, pipeline, serialize
from nurbscomp.encode import analytic, assembly
from nurbscomp.errors import BadReferenceError, SectionError
from nurbscomp.model import EC, REBUILD, Analytic, Kind, RepKind, ShapeType, below, first_row
from nurbscomp.occ import topology
from nurbscomp.rules import joins
from nurbscomp.serialize.geometry import (
    CYLINDER_THROUGH,
    PLANE_THROUGH,
    _read_geometry,
    _write_geometry,
)

from .conftest import assert_comes_back, assert_step_keeps_floor, compressed_part


def _part(path: Path) -> Path:
    """A plate with a pocket, holes, bosses and filleted corners, rotated off
    the world's axes: its planes' directions come in variants some 1e-12
    apart, and no origin is on an axis."""
    p = cq.Workplane("XY").box(80, 50, 10)
    p = p.faces(">Z").workplane().rect(64, 34, forConstruction=True).vertices().hole(4)
    p = p.faces(">Z").workplane().rect(30, 16).cutBlind(-4)
    p = p.edges("|Z").fillet(3)
    p = p.faces(">Z").workplane().pushPoints([(25, 0), (-25, 0)]).rect(8, 8).extrude(6)
    shape = p.val().rotate(cq.Vector(0, 0, 0), cq.Vector(1, 2, 3), 21)
    cq.exporters.export(cq.Workplane().add(shape), str(path))
    return path


@pytest.fixture(scope="module")
def plate(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path, dict]:
    return compressed_part(tmp_path_factory, _part, "plate")


def _planes(m) -> list[int]:
    return [i for i, g in enumerate(m.surfaces) if isinstance(g, Analytic) and g.kind == Kind.PLANE]


def test_planes_go_through_a_vertex_of_their_face(plate) -> None:
    src, nzc, rep = plate
    assert rep["verified"] and rep["max_bound_mm"] <= 0.01
    c = container.unpack(nzc.read_bytes())
    assert c.revision >= 10
    m, _, _ = serialize.read_sections(c.get, c.revision)
    planes = _planes(m)
    through = [i for i in planes if m.surfaces[i].through]
    assert len(through) >= len(planes) // 2 > 0
    for i in through:
        assert np.isnan(m.surfaces[i].frame[0]).all()  # no origin in the container
    back, _ = pipeline.decode(c)
    at = joins.face_points(back)
    first = first_row(back.surfaces)
    for i in through:
        assert np.array_equal(back.surfaces[i].frame[0], back.vertex_point[at[first[i]]])
    assert_comes_back(src, nzc, 0.01)


def test_each_plane_moves_within_its_bound(plate) -> None:
    """Every vertex of a face on a plane through a vertex is within tol (and
    its own tolerance) of the decoded plane, and the decoded plane is within
    tol of the source's over the face."""
    src, nzc, _ = plate
    source, _ = topology.shape_to_model(occ.read_cad(src).shape)
    back, _ = pipeline.decode(container.unpack(nzc.read_bytes()))
    faces = np.flatnonzero(back.shape_type == 4)
    for f, row in enumerate(back.face_surface.tolist()):
        g, was = back.surfaces[row], source.surfaces[row]
        if not (isinstance(g, Analytic) and g.kind == Kind.PLANE and g.through):
            continue
        verts = _face_vertices(back, int(faces[f]))
        p = back.vertex_point[verts]
        assert (np.abs((p - g.frame[0]) @ g.frame[1]) <= back.vertex_tol[verts] + 1e-12).all()
        q = source.vertex_point[verts]  # the source face's corners, on the source plane
        assert np.abs((q - g.frame[0]) @ g.frame[1]).max() <= 0.01
        assert np.abs((q - was.frame[0]) @ was.frame[1]).max() <= 1e-6


def _face_vertices(m, s: int) -> list[int]:
    """The vertex rows below face shape ``s``."""
    tidx = m.type_index()
    return sorted(int(tidx[v]) for v in below(m, s, ShapeType.VERTEX))


def test_the_step_output_keeps_the_floor(plate, tmp_path: Path) -> None:
    src, nzc, _ = plate
    assert_step_keeps_floor(occ.read_cad(src), nzc, tmp_path)


def test_directions_within_precision_are_one(plate) -> None:
    """The rotated plate's surfaces hold their directions in variants some
    1e-12 apart; decoded, directions are either one, bit for bit (up to
    sign), or more than 1e-9 apart.  (Lines through their vertices take
    their directions from the decoded vertices: not counted.)"""
    src, nzc, _ = plate
    source, _ = topology.shape_to_model(occ.read_cad(src).shape)
    back, _ = pipeline.decode(container.unpack(nzc.read_bytes()))

    def rows(m) -> np.ndarray:
        out = [
            r
            for g in m.surfaces
            if isinstance(g, Analytic) and not np.isnan(g.frame).any()
            for r in g.frame[1:]
        ]
        a = np.array(out)
        a = np.where((a[np.arange(len(a)), np.argmax(np.abs(a), 1)] < 0)[:, None], -a, a) + 0.0
        return np.unique(a, axis=0)

    def close_pairs(a: np.ndarray) -> int:
        gap = np.abs(a[:, None] - a[None]).max(-1)
        return int(((gap > 0) & (gap <= 1e-9)).sum())

    assert close_pairs(rows(source)) > 0
    assert close_pairs(rows(back)) == 0
    assert len(rows(back)) < len(rows(source))


def test_same_directions_maps_variants_and_negations() -> None:
    d = np.array([0.6, 0.8, 0.0])
    off = np.array([0.6 + 3e-13, np.sqrt(1 - (0.6 + 3e-13) ** 2), 0.0])
    far = np.array([0.6 + 1e-6, np.sqrt(1 - (0.6 + 1e-6) ** 2), 0.0])
    z = np.array([0.0, 0.0, 1.0])
    table = [
        Analytic(Kind.PLANE, np.array([np.zeros(3), z, x, np.cross(z, x)]), np.zeros(0))
        for x in (d, off, -off, far)
    ]
    same = analytic.same_directions([table])
    moved = [analytic.straighten(g, 10.0, 0.01, same) for g in table]
    assert moved[0] is None  # the first of its kind stays
    (g1, b1), (g2, _) = moved[1], moved[2]
    assert np.array_equal(g1.frame[2], d) and np.array_equal(g2.frame[2], -d)
    assert 0 < b1 <= 2 * 10.0 * 1e-12 * 4
    assert moved[3] is None or np.abs(moved[3][0].frame[2] - far).max() < 1e-15  # its own


def test_a_plane_under_a_stored_pcurve_comes_back(plate) -> None:
    """assembly.unthread: a stored pcurve is parameterized on the source
    plane, so that plane comes back."""
    src, nzc, _ = plate
    source, _ = topology.shape_to_model(occ.read_cad(src).shape)
    back, _ = pipeline.decode(container.unpack(nzc.read_bytes()))
    i = next(i for i in _planes(back) if back.surfaces[i].through)
    f = int(np.flatnonzero(back.face_surface == i)[0])
    edge = _face_edges(back, f)[0]
    pcurve = _stored_pcurve(back, edge, i)
    pcurve[EC.CURVE] = REBUILD
    back.edge_reps = np.vstack([back.edge_reps, pcurve])
    assert assembly.unthread(back, source) is back  # computed by the decoder: no change
    back.edge_reps[-1, EC.CURVE] = 0
    out = assembly.unthread(back, source)
    assert out.surfaces[i] is source.surfaces[i]
    assert back.surfaces[i].through  # the candidate itself is left as it was


def _stored_pcurve(m, edge: int, surface: int) -> np.ndarray:
    """An edge representation: a pcurve (2-D curve row 0) of ``edge`` on ``surface``."""
    row = np.zeros(m.edge_reps.shape[1], m.edge_reps.dtype)
    row[EC.EDGE], row[EC.KIND], row[EC.CURVE], row[EC.SURFACE] = (
        edge,
        RepKind.ON_SURFACE,
        0,
        surface,
    )
    return row


def _face_edges(m, f: int) -> list[int]:
    tidx = m.type_index()
    s = int(np.flatnonzero(m.shape_type == 4)[f])
    w = int(m.child_shape[m.child_start[s]])
    return [int(tidx[m.child_shape[k]]) for k in range(m.child_start[w], m.child_start[w + 1])]


def test_the_reader_refuses_what_the_rule_cannot_make(plate) -> None:
    _, nzc, _ = plate
    c = container.unpack(nzc.read_bytes())
    m, _, _ = serialize.read_sections(c.get, c.revision)
    i = [k for k in _planes(m) if m.surfaces[k].through][0]
    m.face_loc = np.where(m.face_surface == i, 1, m.face_loc)  # its first face located
    with pytest.raises(BadReferenceError, match="plane through a vertex has no vertex"):
        joins.through_vertices(m)


def test_a_copied_record_is_made_once_from_its_first_face(plate) -> None:
    """A record on two rows (a COPY row: coplanar faces, or a cylinder's two
    halves, on one surface entity) takes the vertex of the first face on
    either row."""
    _, nzc, _ = plate
    c = container.unpack(nzc.read_bytes())
    m, _, _ = serialize.read_sections(c.get, c.revision)
    i, j = [k for k in _planes(m) if m.surfaces[k].through][:2]
    faces_i = np.flatnonzero(m.face_surface == i)
    faces_j = np.flatnonzero(m.face_surface == j)
    assert faces_i[0] < faces_j[0]
    m.surfaces = list(m.surfaces)
    m.surfaces[j] = m.surfaces[i]  # row j now a copy of row i
    at = joins.face_points(m)
    assert j not in at and i in at
    joins.through_vertices(m)
    assert m.surfaces[j] is m.surfaces[i]
    assert np.array_equal(m.surfaces[i].frame[0], m.vertex_point[at[i]])


def test_the_kind_code_belongs_to_2_7_surfaces() -> None:
    frame = np.array([[1.0, 2, 3], [0, 0, 1], [1, 0, 0], [0, 1, 0]])
    plane = Analytic(Kind.PLANE, frame, np.zeros(0), through=1)
    raw = _write_geometry([plane], 3)
    back = _read_geometry(raw, "SURF", 3)[0]
    assert back.through == 1 and np.isnan(back.frame[0]).all()
    assert np.array_equal(back.frame[1:], plane.frame[1:])
    with pytest.raises(ValueError, match="2.7"):
        _write_geometry([plane], 3, revision=9)
    with pytest.raises(SectionError, match=f"unknown geometry kind {PLANE_THROUGH}"):
        _read_geometry(raw, "SURF", 3, revision=9)
    with pytest.raises(SectionError):
        _read_geometry(raw, "CRV3", 3)


def test_lossless_has_none(plate, tmp_path: Path) -> None:
    src, _, _ = plate
    out = tmp_path / "x.nzc"
    pipeline.compress_file(src, out, lossless=True)
    c = container.unpack(out.read_bytes())
    m = serialize.read_sections(c.get, c.revision)[0]
    assert not [i for i in _planes(m) if m.surfaces[i].through]


def test_seam_lines_go_through_their_vertices(plate) -> None:
    """A hole's seam (a line on a cylinder, its two pcurves computed by the
    decoder) goes through its vertices like any other line, and the decoded
    seam stays within its edge's tolerance of the cylinder."""
    src, nzc, _ = plate
    c = container.unpack(nzc.read_bytes())
    m, _, _ = serialize.read_sections(c.get, c.revision)
    reps = m.edge_reps
    seams = set(reps[reps[:, EC.KIND] == RepKind.ON_CLOSED_SURFACE, EC.EDGE].tolist())
    on_seam = (reps[:, EC.KIND] == RepKind.CURVE3D) & np.isin(reps[:, EC.EDGE], list(seams))
    lines = [int(i) for i in reps[on_seam, EC.CURVE] if m.curves3d[i].kind == Kind.LINE]
    assert len(seams) >= 4 and lines
    assert all(m.curves3d[i].through for i in lines)
    back, _ = pipeline.decode(c)
    for q in np.flatnonzero(on_seam):
        e = int(reps[q, EC.EDGE])
        line = back.curves3d[int(reps[q, EC.CURVE])]
        cyl = back.surfaces[
            int(
                reps[
                    (reps[:, EC.EDGE] == e) & (reps[:, EC.KIND] == RepKind.ON_CLOSED_SURFACE),
                    EC.SURFACE,
                ][0]
            )
        ]
        assert cyl.kind == Kind.CYLINDER
        t = np.array(back.edge_rep_range[q])
        p = line.frame[0] + t[:, None] * line.frame[1]  # the seam's ends
        w = p - cyl.frame[0]
        r = np.linalg.norm(w - (w @ cyl.frame[1])[:, None] * cyl.frame[1], axis=1)
        assert np.abs(r - cyl.params[0]).max() <= back.edge_tol[e]


def _cylinders(m) -> list[int]:
    return [
        i for i, g in enumerate(m.surfaces) if isinstance(g, Analytic) and g.kind == Kind.CYLINDER
    ]


def test_cylinders_go_through_a_vertex_of_their_face(plate) -> None:
    """Holes, bosses and fillets: each cylinder's axis is its radius from the
    vertex of its first face, against the direction the spec names; its
    face's vertices stay within their tolerances of the decoded cylinder,
    and its circles take the decoded axis."""
    src, nzc, _ = plate
    c = container.unpack(nzc.read_bytes())
    m, _, _ = serialize.read_sections(c.get, c.revision)
    cyl = _cylinders(m)
    through = [i for i in cyl if m.surfaces[i].through]
    assert len(through) >= len(cyl) // 2 > 0
    assert all(np.isnan(m.surfaces[i].frame[0]).all() for i in through)
    back, _ = pipeline.decode(c)
    at = joins.face_points(back)
    faces = np.flatnonzero(back.shape_type == 4)
    first = first_row(back.surfaces)
    for i in through:
        g = back.surfaces[i]
        q = g.through - 1
        u = g.frame[2 + q % 2] * (1 if q < 2 else -1)
        p = back.vertex_point[at[first[i]]]
        assert np.array_equal(g.frame[0], np.array([p[j] - g.params[0] * u[j] for j in range(3)]))
        for f in np.flatnonzero(back.face_surface == i):
            verts = _face_vertices(back, int(faces[f]))
            w = back.vertex_point[verts] - g.frame[0]
            r = np.linalg.norm(w - (w @ g.frame[1])[:, None] * g.frame[1], axis=1)
            assert (np.abs(r - g.params[0]) <= back.vertex_tol[verts] + 1e-12).all()
    assert_comes_back(src, nzc, 0.01)


def test_the_cylinder_codes_belong_to_2_7_surfaces() -> None:
    frame = np.array([[1.0, 2, 3], [0, 0, 1], [1, 0, 0], [0, 1, 0]])
    rows = [Analytic(Kind.CYLINDER, frame, np.array([2.5]), through=t) for t in (1, 2, 3, 4)]
    back = _read_geometry(_write_geometry(rows, 3), "SURF", 3)
    assert [g.through for g in back] == [1, 2, 3, 4]
    assert all(g.params[0] == 2.5 and np.isnan(g.frame[0]).all() for g in back)
    for g, t in zip(back, (1, 2, 3, 4)):
        g.frame[0] = 0.0
        made = joins.surface_origin(g, np.array([1.0, 1.0, 1.0]))
        u = [frame[2], frame[3], -frame[2], -frame[3]][t - 1]
        assert np.array_equal(made, 1.0 - 2.5 * u)
    with pytest.raises(ValueError, match="2.7"):
        _write_geometry(rows, 3, revision=9)
    with pytest.raises(ValueError):
        _write_geometry([Analytic(Kind.CYLINDER, frame, np.array([2.5]), through=5)], 3)
    raw = _write_geometry(rows[:1], 3)
    with pytest.raises(SectionError, match=f"unknown geometry kind {CYLINDER_THROUGH}"):
        _read_geometry(raw, "SURF", 3, revision=9)
    bad = [Analytic(Kind.CYLINDER, frame, np.array([-1.0]), through=1)]
    with pytest.raises(SectionError, match="radius"):
        _read_geometry(_write_geometry(bad, 3), "SURF", 3)


def test_a_cylinder_put_back_takes_its_circles_back(plate) -> None:
    """assembly.unthread: a cylinder under a stored pcurve comes back as the
    source's, and so do the circles through a vertex that take its axis
    (the decoder would make them about the source's axis)."""
    src, nzc, _ = plate
    source, _ = topology.shape_to_model(occ.read_cad(src).shape)
    back, _ = pipeline.decode(container.unpack(nzc.read_bytes()))
    axes = joins.axis_faces(back)
    uses = joins.curve_uses(back)
    reps = back.edge_reps
    pairs = [
        (int(back.face_surface[axes[int(reps[qs[0], EC.EDGE])]]), c)
        for c, qs in uses.items()
        if c >= 0
        and getattr(back.curves3d[c], "through", 0)
        and back.curves3d[c].kind == Kind.CIRCLE
        if int(reps[qs[0], EC.EDGE]) in axes
    ]
    i, circle = next((s, c) for s, c in pairs if back.surfaces[s].through)
    f = int(np.flatnonzero(back.face_surface == i)[0])
    back.edge_reps = np.vstack([reps, _stored_pcurve(back, _face_edges(back, f)[0], i)])
    out = assembly.unthread(back, source)
    assert out.surfaces[i] is source.surfaces[i]
    assert out.curves3d[circle] is source.curves3d[circle]


def test_a_record_made_from_a_vertex_far_away_is_refused(plate) -> None:
    """A hostile container's vertex at 1e100 would make a line (or circle,
    plane, cylinder) there, on which OCCT's pcurve projection crashed the
    process: the reader refuses what it would make past 1e15 mm."""
    _, nzc, _ = plate
    c = container.unpack(nzc.read_bytes())
    assert joins.within_reach(
        Analytic(Kind.PLANE, np.full((4, 3), 1e14), np.zeros(0), through=1)
    ) and not joins.within_reach(Analytic(Kind.PLANE, np.full((4, 3), 1e15), np.zeros(0)))
    m, _, _ = serialize.read_sections(c.get, c.revision)
    m.vertex_point[0] = 1e100  # a vertex some plane, line or circle goes through
    with pytest.raises(BadReferenceError, match="through a vertex at or past 1e"):
        joins.through_vertices(m)
