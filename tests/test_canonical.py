"""Surfaces of revolution of a line written as cylinders and cones
(``encode.canonical``): the same point at the same (u, v)."""

from __future__ import annotations

import math

import pytest

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
