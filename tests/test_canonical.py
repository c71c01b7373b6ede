"""Surfaces of revolution of a line or a circle written as cylinders,
cones, tori and spheres (``encode.canonical``): the same point at the same
(u, v)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from OCP.BRep import BRep_Tool

from nurbscomp import occ
from nurbscomp.encode import canonical
from nurbscomp.model import Analytic, Derived, Kind
from nurbscomp.occ import topology


def _revolved(p, d, o, a, v=(-3.0, 4.0)):
    """A face on the revolution of the line (p, d) trimmed to ``v``, about
    the axis (o, a), over u in [0.3, 5] (not its natural bounds)."""
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeFace
    from OCP.Geom import Geom_Line, Geom_SurfaceOfRevolution, Geom_TrimmedCurve
    from OCP.gp import gp_Ax1, gp_Dir, gp_Pnt

    line = Geom_TrimmedCurve(Geom_Line(gp_Pnt(*p), gp_Dir(*d)), *v)
    surf = Geom_SurfaceOfRevolution(line, gp_Ax1(gp_Pnt(*o), gp_Dir(*a)))
    return BRepBuilderAPI_MakeFace(surf, 0.3, 5.0, v[0] + 0.5, v[1] - 0.5, 1e-7).Face()


CASES = {
    # name: (line origin, line direction, axis origin, axis direction, kind)
    "cylinder": ((4, 1, 2), (0, 0, 1), (1, 1, 0), (0, 0, 1), Kind.CYLINDER),
    "cylinder, against the axis": ((2, 3, 1), (0, .6, -.8), (0, 0, 0), (0, -.6, .8), Kind.CYLINDER),
    "cone": ((3, 0, 1), (0.6, 0, 0.8), (0, 0, 0), (0, 0, 1), Kind.CONE),
    "cone, against the axis": ((5, 0, 1), (0.6, 0, -0.8), (0, 0, 0), (0, 0, 1), Kind.CONE),
    "cone from the axis": ((0, 0, 2), (0.8, 0, 0.6), (0, 0, -1), (0, 0, 1), Kind.CONE),
}  # fmt: skip


@pytest.mark.parametrize("name", list(CASES))
def test_a_revolved_line_is_its_quadric_at_the_same_parameters(name: str) -> None:
    p, d, o, a, kind = CASES[name]
    face = _revolved(p, d, o, a)
    m, _ = occ.shape_to_model(face)
    assert any(isinstance(g, Derived) and g.kind == Kind.REVOLUTION for g in m.surfaces)
    q = canonical.revolved_lines(m)
    assert q is not None
    assert [g.kind for g in q.surfaces] == [kind]
    # the line and its trim, used by nothing else, leave the table
    assert len(q.curves3d) == len(m.curves3d) - 2
    built = topology.model_to_shape(q)
    assert occ.is_valid(built) and occ.counts(built) == occ.counts(face)
    # each point where the same (u, v) puts it (a large tol: no projection)
    assert occ.deviation(face, built, 7, 1e9).max() < 1e-12 * 10


def test_a_skew_line_is_left_as_it_is() -> None:
    """A line skew to the axis sweeps a hyperboloid: no quadric of the
    format, so the surface of revolution stays."""
    face = _revolved((3, 0, 0), (0, math.sqrt(0.5), math.sqrt(0.5)), (0, 0, 0), (0, 0, 1))
    m, _ = occ.shape_to_model(face)
    assert canonical.revolved_lines(m) is None


def _revolved_circle(c, n, x, r, o, a, v=(0.2, 2.5)):
    """A face on the revolution of the circle (centre ``c``, normal ``n``,
    X ``x``, radius ``r``) trimmed to ``v``, about the axis (o, a), over u in
    [0.3, 5]."""
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeFace
    from OCP.Geom import Geom_Circle, Geom_SurfaceOfRevolution, Geom_TrimmedCurve
    from OCP.gp import gp_Ax1, gp_Ax2, gp_Dir, gp_Pnt

    circle = Geom_Circle(gp_Ax2(gp_Pnt(*c), gp_Dir(*n), gp_Dir(*x)), r)
    arc = Geom_TrimmedCurve(circle, *v)
    surf = Geom_SurfaceOfRevolution(arc, gp_Ax1(gp_Pnt(*o), gp_Dir(*a)))
    return BRepBuilderAPI_MakeFace(surf, 0.3, 5.0, v[0] + 0.1, v[1] - 0.1, 1e-7).Face()


CIRCLES = {
    # name: (centre, normal, X, radius, axis origin, axis direction, range, kind)
    "torus": (
        (7, 0, 2), (0, -1, 0), (1, 0, 0), 2.5, (0, 0, 1), (0, 0, 1), (0.2, 2.5), Kind.TORUS
    ),
    "torus, Y against the axis": (
        (7, 0, 2), (0, 1, 0), (1, 0, 0), 2.5, (0, 0, 1), (0, 0, 1), (0.2, 2.5), Kind.TORUS
    ),
    "torus about a tilted axis": (
        (0, 9.68, -1.24), (-1, 0, 0), (0, 0.6, -0.8), 1.5, (0, 1, 1), (0, 0.8, 0.6), (-3, 3),
        Kind.TORUS,
    ),
    "sphere": (
        (0, 0, 3), (0, -1, 0), (1, 0, 0), 4.0, (0, 0, 0), (0, 0, 1), (0.1, 1.5), Kind.SPHERE
    ),
}  # fmt: skip


@pytest.mark.parametrize("name", list(CIRCLES))
def test_a_revolved_circle_is_its_torus_or_sphere_at_the_same_parameters(name: str) -> None:
    c, n, x, r, o, a, v, kind = CIRCLES[name]
    face = _revolved_circle(c, n, x, r, o, a, v)
    m, _ = occ.shape_to_model(face)
    q = canonical.revolved_lines(m)
    assert q is not None
    assert [g.kind for g in q.surfaces] == [kind]
    assert len(q.curves3d) == len(m.curves3d) - 2  # the circle and its trim
    built = topology.model_to_shape(q)
    assert occ.is_valid(built) and occ.counts(built) == occ.counts(face)
    assert occ.deviation(face, built, 7).max() < 1e-9
    # each point where the same (u, v) puts it (the two surfaces' bounds
    # differ, so occ.deviation would map one domain onto the other)
    sa, sb = (BRep_Tool.Surface_s(f) for f in occ.faces(face) + occ.faces(built))
    for u in (0.3, 1.7, 5.0):
        for w in np.linspace(*v, 5):
            pa, pb = sa.Value(u, w), sb.Value(u, w)
            assert pa.Distance(pb) < 1e-12 * 10


@pytest.mark.parametrize(
    "c, x, v, why",
    [
        ((7, 0, 2), (0, 0, 1), (0.2, 2.5), "X along the axis: v turned by a quarter"),
        ((7, 0, 2), (-1, 0, 0), (0.2, 2.5), "X towards the axis"),
        ((0, 0, 3), (1, 0, 0), (0.2, 2.5), "a sphere's range past its pole"),
        ((0, 0, 3), (1, 0, 0), (-1.5, 1.5), "a sphere's range, which OCCT's trim puts past 2π"),
        ((1, 0, 2), (1, 0, 0), (0.2, 2.5), "a circle across the axis"),
    ],
)
def test_other_revolved_circles_are_left_as_they_are(c, x, v, why) -> None:
    n = (0, -1, 0)
    r = 4.0 if c[0] == 0 else 2.5
    face = _revolved_circle(c, n, x, r, (0, 0, 0), (0, 0, 1), v)
    m, _ = occ.shape_to_model(face)
    assert canonical.revolved_lines(m) is None, why


def test_iges_cylinders_come_back_as_cylinders(tmp_path) -> None:
    """OCCT writes every cylinder of an IGES surface model as a surface of
    revolution of a line; compressed, they are cylinders, within tol, and
    the file is smaller (1,727 → 1,691 bytes here at 0.01 mm)."""
    import cadquery as cq

    from nurbscomp import container, pipeline, serialize
    from tests.golden.make_golden import faces_iges

    step = tmp_path / "crossed.step"
    a, b = cq.Workplane("XY").cylinder(40, 8), cq.Workplane("YZ").cylinder(40, 6)
    cq.exporters.export(a.union(b), str(step))
    src = faces_iges(step, tmp_path / "crossed.igs")
    m, _ = occ.shape_to_model(occ.read_cad(src).shape)
    assert sum(isinstance(g, Derived) and g.kind == Kind.REVOLUTION for g in m.surfaces) == 3
    nzc = tmp_path / "crossed.nzc"
    pipeline.compress_file(src, nzc, tol=0.01)
    c = container.unpack(nzc.read_bytes())
    dm, _, _ = serialize.read_sections(c.get, c.revision, None)
    assert sum(isinstance(g, Analytic) and g.kind == Kind.CYLINDER for g in dm.surfaces) == 3
    assert not any(isinstance(g, Derived) and g.kind == Kind.REVOLUTION for g in dm.surfaces)
    got = pipeline.evaluate(src, nzc)
    assert got["within_tolerance"] and got["topology_same"] and got["valid_kept"], got


def test_the_basis_of_an_offset_stays() -> None:
    """An offset of a surface of revolution keeps its basis as read: the
    STEP check's time limit for OCCT's reader (``step_reader_hangs``) is
    given to offsets of surfaces of revolution, and the reader looped on the
    offset of the cylinder this would make."""
    from OCP.BRep import BRep_Tool
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeFace
    from OCP.Geom import Geom_OffsetSurface

    from nurbscomp.encode import validity

    p, d, o, a, _ = CASES["cylinder"]
    base = BRep_Tool.Surface_s(_revolved(p, d, o, a))
    face = BRepBuilderAPI_MakeFace(Geom_OffsetSurface(base, 0.5), 0.3, 5.0, -2.5, 3.5, 1e-7).Face()
    m, _ = occ.shape_to_model(face)
    assert canonical.revolved_lines(m) is None
    assert validity.step_reader_hangs(m)


def test_iges_tori_and_spheres_come_back_as_tori_and_spheres(tmp_path, monkeypatch) -> None:
    """OCCT writes every torus and sphere of an IGES surface model as a
    surface of revolution of a circle arc; compressed, they are tori and
    spheres, within tol, and the file is smaller than with them kept."""
    import cadquery as cq

    from nurbscomp import container, pipeline, serialize
    from tests.golden.make_golden import faces_iges

    step = tmp_path / "knob.step"
    # a dome on top (a sphere's v within [0, pi/2]; a lower half's arc, which
    # OCCT trims to [3pi/2, 2pi], stays a surface of revolution)
    knob = cq.Workplane("XY").cylinder(10, 6).edges("<Z").fillet(2)
    cq.exporters.export(knob.union(cq.Workplane("XY").sphere(3).translate((0, 0, 5))), str(step))
    src = faces_iges(step, tmp_path / "knob.igs")
    m, _ = occ.shape_to_model(occ.read_cad(src).shape)
    revolved = sum(isinstance(g, Derived) and g.kind == Kind.REVOLUTION for g in m.surfaces)
    nzc = tmp_path / "knob.nzc"
    pipeline.compress_file(src, nzc, tol=0.01)
    c = container.unpack(nzc.read_bytes())
    dm, _, _ = serialize.read_sections(c.get, c.revision, None)
    kinds = [g.kind for g in dm.surfaces if isinstance(g, Analytic)]
    assert kinds.count(Kind.TORUS) >= 1 and kinds.count(Kind.SPHERE) >= 1
    assert not any(isinstance(g, Derived) and g.kind == Kind.REVOLUTION for g in dm.surfaces)
    assert revolved >= 3  # the cylinder, the fillet's torus and the sphere
    got = pipeline.evaluate(src, nzc)
    assert got["verdict"] == "pass", got["failed"]
    monkeypatch.setattr(canonical, "_revolved_circle", lambda *a: None)
    kept = pipeline.compress_file(src, tmp_path / "kept.nzc", tol=0.01)
    assert nzc.stat().st_size < kept["output_bytes"]
