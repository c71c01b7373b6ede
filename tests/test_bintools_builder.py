"""The BinTools-stream builder (occ.bintools, issue 30) against the per-entity one.

Both builders must make the same shape: the same ``.brep`` text (BRepTools)
and the same model read back (every table, bit for bit), on generated shapes
with fillets, lofts, revolutions, seams, degenerated edges, periodic and
rational surfaces, located instances, assemblies and open shells, with their
pcurves stored and left for the decoder to compute.  Where the stream cannot
carry a model the build falls back, and says why.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import cadquery as cq
import numpy as np
import pytest
from OCP.BRep import BRep_Builder
from OCP.BRepBuilderAPI import BRepBuilderAPI_NurbsConvert
from OCP.BRepPrimAPI import BRepPrimAPI_MakeBox
from OCP.gp import gp_Ax1, gp_Dir, gp_Pnt, gp_Trsf, gp_TrsfForm, gp_Vec
from OCP.TopLoc import TopLoc_Location
from OCP.TopoDS import TopoDS_Compound

from nurbscomp import passthrough, pipeline
from nurbscomp.encode.pcurves import drop_pcurves
from nurbscomp.model import differences
from nurbscomp.occ import bintools, shape_to_model, topology

from .conftest import brep_bytes


def _rotated(shape: Any, angle: float, dx: float) -> Any:
    t = gp_Trsf()
    t.SetRotation(gp_Ax1(gp_Pnt(0, 0, 0), gp_Dir(0, 0, 1)), angle)
    t2 = gp_Trsf()
    t2.SetTranslation(gp_Vec(dx, 0, 0))
    return shape.Moved(TopLoc_Location(t2.Multiplied(t)))


def _nurbs(shape: Any) -> Any:
    return BRepBuilderAPI_NurbsConvert(shape, True).Shape()


def _shapes() -> dict[str, Any]:
    box = cq.Workplane().box(10, 8, 6).edges("|Z").fillet(1.5).faces(">Z").shell(-1)
    loft = cq.Workplane().circle(5).workplane(offset=8).rect(4, 6).loft()
    revolve = (
        cq.Workplane("XZ").moveTo(2, 0).spline([(4, 3), (3, 6), (5, 9)]).lineTo(2, 9).close()
    ).revolve(360, (0, 0, 0), (0, 1, 0))
    sphere = cq.Workplane().sphere(4)
    torus = cq.Solid.makeTorus(6, 2)
    cone = cq.Solid.makeCone(3, 0, 5)
    holes = cq.Workplane().box(20, 20, 4).faces(">Z").workplane().rarray(8, 8, 2, 2).hole(3)
    part = cq.Workplane().box(4, 4, 4).edges().chamfer(0.5).val().wrapped
    assembly = cq.Compound.makeCompound(
        [cq.Shape.cast(_rotated(part, a, 10 * i)) for i, a in enumerate((0.3, 1.1, 2.0))]
    ).wrapped
    return {
        "fillet_shell": box.val().wrapped,
        "loft": loft.val().wrapped,
        "revolve_spline": revolve.val().wrapped,
        "sphere": sphere.val().wrapped,
        "torus": torus.wrapped,
        "cone_apex": cone.wrapped,
        "holes": holes.val().wrapped,
        "rational_nurbs": _nurbs(cq.Workplane().cylinder(6, 3).val().wrapped),
        "nurbs_sphere": _nurbs(sphere.val().wrapped),
        "open_shell": box.faces(">Z or <X").shells().val().wrapped
        if box.faces(">Z or <X").shells().size()
        else cq.Shell.makeShell(box.faces(">X or >Y").vals()).wrapped,
        "located_rotations": assembly,
        "face_only": cq.Workplane().box(3, 3, 3).faces(">Z").val().wrapped,
    }


SHAPES = _shapes()


def _compare(m: Any) -> dict[str, int]:
    topology.FAST_STATS.clear()
    topology.FAST_STATS["fast"] = 0
    slow = topology.slow_model_to_shape(m)
    fast = topology.model_to_shape(m)
    assert brep_bytes(fast) == brep_bytes(slow)
    assert differences(shape_to_model(fast)[0], shape_to_model(slow)[0]) == []
    return dict(topology.FAST_STATS)


@pytest.mark.parametrize("name", sorted(SHAPES))
def test_same_shape_as_the_per_entity_builder(name: str) -> None:
    m, _ = shape_to_model(SHAPES[name])
    stats = _compare(m)
    assert stats["fast"] == 1, stats  # the stream carried it: no fallback


@pytest.mark.parametrize("name", sorted(SHAPES))
def test_same_shape_with_pcurves_to_compute(name: str) -> None:
    m, _ = shape_to_model(SHAPES[name])
    dropped = drop_pcurves(m, set(), set())
    stats = _compare(dropped)
    assert stats["fast"] == 1, stats
    if name in ("rational_nurbs", "nurbs_sphere", "loft", "revolve_spline"):
        assert (dropped.edge_reps[:, 2] == -2).any()  # the projection path is exercised


def test_the_comparison_sees_a_difference() -> None:
    """A stream that writes another tolerance gives another shape: the
    comparison above is able to fail."""
    m, _ = shape_to_model(SHAPES["holes"])
    data, index = bintools.stream(m)
    changed = m.face_tol.copy()
    m.face_tol = changed * 2
    other, _ = bintools.stream(m)
    m.face_tol = changed
    a = bintools.root(bintools.read(data), m, index)
    b = bintools.root(bintools.read(other), m, index)
    assert brep_bytes(a) != brep_bytes(b)


def test_translations_fall_back_and_are_counted() -> None:
    """A translation datum reads back as a compound gp_Trsf from the stream
    (gp_Trsf::SetValues): such a model is built by the per-entity builder."""
    part = BRepPrimAPI_MakeBox(2.0, 2.0, 2.0).Shape()
    t = gp_Trsf()
    t.SetTranslation(gp_Vec(5, 0, 0))
    shape = TopoDS_Compound()
    b = BRep_Builder()
    b.MakeCompound(shape)
    b.Add(shape, part)
    b.Add(shape, part.Moved(TopLoc_Location(t)))
    m, _ = shape_to_model(shape)
    assert gp_TrsfForm.gp_Translation.value in m.datum_forms.tolist()
    assert bintools.unsupported(m).startswith("identity or translation datum")
    stats = _compare(m)
    assert stats["fast"] == 0 and sum(stats.values()) == 1


def test_uv_points_other_than_the_pcurve_ends_are_kept() -> None:
    """A stored pcurve end point that is not the pcurve's value (a source may
    hold such) is what the shape gets, as from the per-entity builder."""
    m, _ = shape_to_model(SHAPES["holes"])
    on = np.flatnonzero(m.edge_reps[:, 1] == 1)
    m.edge_rep_uv[on[0], 0] += 1e-9
    assert _compare(m)["fast"] == 1


GOLDEN = [
    p
    for p in sorted((Path(__file__).parent / "golden").glob("*.nzc"))
    if not passthrough.is_verbatim(p)  # those hold a file, not tables
]


@pytest.mark.parametrize("path", GOLDEN, ids=[p.name for p in GOLDEN])
def test_golden_containers_build_the_same(path: Path) -> None:
    """Every golden container (all format versions) builds the same shape
    either way; those the stream carries are counted."""
    m, _ = pipeline.decode(pipeline.read_container(path))
    stats = _compare(m)
    assert sum(stats.values()) == 1
    print(path.name, stats)


def test_a_stream_the_reader_refuses_falls_back(monkeypatch: pytest.MonkeyPatch) -> None:
    """A stream OCCT's reader throws on (here cut short) is counted and the
    model built by the per-entity builder: same shape."""
    m, _ = shape_to_model(SHAPES["holes"])
    real = bintools.stream

    def cut(model: Any) -> tuple[bytes, list[int]]:
        data, index = real(model)
        return data[: len(data) // 2], index

    monkeypatch.setattr(bintools, "stream", cut)
    stats = _compare(m)
    assert stats == {"fast": 0, "reader failed": 1}
