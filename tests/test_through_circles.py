"""Circles through their edge's vertex about a face's axis (format 2.4,
docs/format.md §2.3; encode.assembly._thread, rules.joins.through_vertices):
a circle on an edge of a cylinder, cone, sphere or torus face is stored as a
kind code alone and made again from the decoded vertex and surface, within
its bound of the source's circle, its edges' ranges a rule."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import cadquery as cq
import numpy as np
import pytest

from nurbscomp import container, occ, pipeline, serialize
from nurbscomp.encode import assembly
from nurbscomp.errors import BadReferenceError
from nurbscomp.model import EC, REBUILD, Analytic, Kind, RepKind, first_row
from nurbscomp.occ import topology
from nurbscomp.rules import joins
from nurbscomp.rules.ranges import RANGE_VERTICES

from .conftest import (
    assert_comes_back,
    assert_step_keeps_floor,
    compressed_part,
    through_curves,
    through_rows,
)


def _part(path: Path) -> Path:
    """A turned part, tilted: a cylinder with a cone, a sphere cap, a torus
    groove, a bore and filleted holes, so its circles lie on every kind of
    surface of revolution, along and against their axes, and on no axis of
    the frame."""
    body = (
        cq.Workplane("XZ")
        .polyline([(0, 0), (12, 0), (12, 10), (8, 16), (8, 24), (0, 24)])
        .close()
        .revolve(360, (0, 0, 0), (0, 1, 0))
    )
    body = body.union(cq.Workplane().sphere(6).translate((0, 0, 24)))
    groove = cq.Solid.makeTorus(12, 1.5).translate(cq.Vector(0, 0, 5))
    body = body.cut(cq.Workplane().add(groove))
    body = body.faces("<Z").workplane().hole(5, 8)
    body = body.faces(">Z[-2]").workplane().pushPoints([(6, 0), (-6, 0)]).hole(2, 4)
    shape = body.rotate((0, 0, 0), (1, 0.4, 0.2), 23)
    cq.exporters.export(shape, str(path))
    return path


def _uses(m, i: int) -> np.ndarray:
    reps = m.edge_reps
    return np.flatnonzero((reps[:, EC.KIND] == RepKind.CURVE3D) & (reps[:, EC.CURVE] == i))


@pytest.fixture(scope="module")
def turned(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path, dict]:
    return compressed_part(tmp_path_factory, _part, "turned")


def test_circles_go_through_their_vertex(turned) -> None:
    src, nzc, rep = turned
    assert rep["verified"] and rep["max_bound_mm"] <= 0.01
    tables, m, rows, circles = through_rows(nzc, 7, Kind.CIRCLE)  # format 2.4 and later
    assert len(rows) >= len(circles) // 2 > 0
    assert {m.curves3d[i].through for i in rows} == {1, -1}  # along and against
    back, _ = pipeline.decode(container.unpack(nzc.read_bytes()))
    axes = joins.axis_faces(back)
    kinds = set()
    for i in rows:
        g = back.curves3d[i]
        qs = _uses(back, i)
        assert all(tables.range_how[q] == RANGE_VERTICES for q in qs)  # rules, no floats
        s = back.surfaces[int(back.face_surface[axes[int(back.edge_reps[qs[0], EC.EDGE])]])]
        kinds.add(s.kind)
        # on the surface's axis, its normal the axis's direction or its opposite
        w = g.frame[0] - s.frame[0]
        assert np.linalg.norm(np.cross(w, s.frame[1])) < 1e-9
        assert np.array_equal(np.abs(g.frame[1]), np.abs(s.frame[1]))
    assert len(kinds) >= 2
    assert_comes_back(src, nzc, 0.01)


def test_the_step_output_keeps_the_floor(turned, tmp_path: Path) -> None:
    src, nzc, _ = turned
    assert_step_keeps_floor(occ.read_cad(src), nzc, tmp_path)


def test_the_circle_moves_within_its_bound(turned) -> None:
    """Points along each new arc are within tol (and the edge's tolerance)
    of the source arc, which runs the same way."""
    src, nzc, _ = turned
    source, _ = topology.shape_to_model(occ.read_cad(src).shape)
    back, _ = pipeline.decode(container.unpack(nzc.read_bytes()))

    def at(g: Analytic, t: np.ndarray) -> np.ndarray:
        o, n, x = g.frame
        y = np.cross(n, x)
        return o + g.params[0] * (np.cos(t)[:, None] * x + np.sin(t)[:, None] * y)

    for i in through_curves(back, Kind.CIRCLE):
        was, now = source.curves3d[i], back.curves3d[i]
        for q in _uses(back, i):
            t = np.linspace(*source.edge_rep_range[q], 41)
            u = np.linspace(*back.edge_rep_range[q], 41)
            d = np.linalg.norm(at(was, t) - at(now, u), axis=1).max()
            assert d <= min(0.01, back.edge_tol[back.edge_reps[q, EC.EDGE]])


def test_a_circle_whose_edge_keeps_its_pcurve_stays(turned) -> None:
    """assembly.unthread: a kept (stored) pcurve is parameterized on the
    source circle, so that circle comes back, with every edge's range on it."""
    src, nzc, _ = turned
    source, _ = topology.shape_to_model(occ.read_cad(src).shape)
    back, _ = pipeline.decode(container.unpack(nzc.read_bytes()))
    (i, *_) = through_curves(back, Kind.CIRCLE)
    reps = back.edge_reps
    qs = _uses(back, i)
    pcurve = [reps[qs[-1], EC.EDGE], RepKind.ON_SURFACE, REBUILD, -1, 0, -1, 0, 0]
    back.edge_reps = np.vstack([reps, pcurve])
    assert assembly.unthread(back, source) is back  # computed by the decoder: no change
    back.edge_reps[-1, EC.CURVE] = 0
    out = assembly.unthread(back, source)
    assert out.curves3d[i] is source.curves3d[i]
    for q in qs:
        assert np.array_equal(out.edge_rep_range[q], source.edge_rep_range[q])


def test_the_reader_refuses_what_the_rule_cannot_make(turned) -> None:
    _, nzc, _ = turned
    c = container.unpack(nzc.read_bytes())
    m, _, _ = serialize.read_sections(c.get, c.revision)
    (i, j, *_) = through_curves(m, Kind.CIRCLE)
    reps = m.edge_reps.copy()
    m.curves3d = list(m.curves3d)
    m.curves3d[j] = m.curves3d[i]  # a copy of it
    with pytest.raises(BadReferenceError, match="copied"):
        joins.through_vertices(m)
    m, _, _ = serialize.read_sections(c.get, c.revision)
    m.edge_reps = reps.copy()
    m.edge_reps[_uses(m, i), EC.LOC] = 1  # on a located edge
    with pytest.raises(BadReferenceError, match="unlocated"):
        joins.through_vertices(m)
    m, _, _ = serialize.read_sections(c.get, c.revision)
    at, first = joins.face_points(m), first_row(m.surfaces)
    made = {  # planes and cylinders through a vertex (2.7) made first, as the decoder does
        r: replace(g, frame=g.frame.copy(), through=0)
        for r, g in enumerate(m.surfaces)
        if getattr(g, "through", 0) and first[r] == r
    }
    for r, g in made.items():
        g.frame[0] = joins.surface_origin(m.surfaces[r], m.vertex_point[at[r]])
    m.surfaces = [made.get(first[r], g) for r, g in enumerate(m.surfaces)]
    m.face_loc = np.ones_like(m.face_loc)  # no face to take an axis from
    with pytest.raises(BadReferenceError, match="axis"):
        joins.through_vertices(m)


def test_the_rule_is_written_out() -> None:
    """joins.circle_through computes what docs/format.md §2.3 says, in that
    order of operations, and refuses a point on the axis."""
    frame = np.array([[1.0, 2.0, 3.0], [0.0, 0.6, 0.8], [1.0, 0.0, 0.0], [0.0, 0.8, -0.6]])
    axis = Analytic(Kind.CYLINDER, frame, np.array([5.0]))
    p = np.array([4.0, 5.5, 1.25])
    g = joins.circle_through(axis, p, -1)
    assert g is not None and g.kind == Kind.CIRCLE and g.through == -1
    w = p - frame[0]
    h = (w[0] * 0.0 + w[1] * 0.6) + w[2] * 0.8
    c = frame[0] + h * frame[1]
    assert np.array_equal(g.frame[0], c)
    assert np.array_equal(g.frame[1], -frame[1]) and np.array_equal(g.frame[2], frame[2])
    assert g.params[0] == np.sqrt(((p - c) ** 2).sum())
    assert joins.circle_through(axis, frame[0] + 2 * frame[1], 1) is None


def test_lossless_has_none(turned, tmp_path: Path) -> None:
    src, _, _ = turned
    out = tmp_path / "x.nzc"
    pipeline.compress_file(src, out, lossless=True)
    c = container.unpack(out.read_bytes())
    assert not through_curves(serialize.read_sections(c.get, c.revision)[0], Kind.CIRCLE)
