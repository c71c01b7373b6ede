"""``topology.EdgeProjector``: the pcurves of ``ShapeFix_Edge.FixAddPCurve``
with a fresh surface analysis per call, bit for bit, with analyses kept.

OCCT's analysis carries two states from a call to the next (the precision of
its first point projection, the projector's cache of end points), so the
shapes below give edges of one face several tolerances, and the builds are
compared with every analysis kept, with none, and with the plain call.
"""

from __future__ import annotations

from typing import Any

import cadquery as cq
import numpy as np
import pytest
from OCP.BRep import BRep_Tool
from OCP.BRepBuilderAPI import BRepBuilderAPI_NurbsConvert

from nurbscomp.encode.pcurves import drop_pcurves
from nurbscomp.model import EC, REBUILD
from nurbscomp.occ import shape_to_model, topology

from .conftest import brep_bytes


def _shapes() -> dict[str, Any]:
    loft = cq.Workplane().circle(5).workplane(offset=8).rect(4, 6).loft()
    sweep = (
        cq.Workplane("XY")
        .ellipse(2, 1)
        .sweep(cq.Workplane("XZ").spline([(0, 0), (2, 5), (-1, 10)], includeCurrent=False))
    )
    blend = cq.Workplane().box(10, 8, 6).edges().fillet(1.2)
    return {
        "loft": loft.val().wrapped,
        "sweep": sweep.val().wrapped,
        "nurbs_fillets": BRepBuilderAPI_NurbsConvert(blend.val().wrapped, True).Shape(),
    }


SHAPES = _shapes()


def _model(name: str, mixed: bool = True, by_face: bool = False) -> Any:
    """The shape's model with every pcurve to compute, and edge tolerances
    powers of two, as a decoder's are: with ``mixed``, differing along each
    wire (analyses kept side by side), else one (an analysis serves calls
    one after the other, whose end points the projector would remember).
    Projected in format 2.14's order unless ``by_face`` (2.15's)."""
    m, _ = shape_to_model(SHAPES[name])
    m = drop_pcurves(m, set(), set())
    m.edge_tol = np.array([2.0 ** -(7 + mixed * (i % 3)) for i in range(len(m.edge_tol))])
    m.pcurves_by_face = by_face
    return m


class _Plain(topology.EdgeProjector):
    """OCCT's own call: a fresh analysis every time."""

    def add(self, edge: Any, face: Any, seam: bool) -> bool:
        return bool(self.fix.FixAddPCurve(edge, face, seam, BRep_Tool.Tolerance_s(edge)))


@pytest.mark.parametrize("mixed", [True, False])
@pytest.mark.parametrize("name", sorted(SHAPES))
def test_kept_analyses_give_the_plain_calls_pcurves(
    name: str, mixed: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    m = _model(name, mixed)
    assert (m.edge_reps[:, EC.CURVE] == REBUILD).sum() >= 3  # projections are made
    monkeypatch.setattr(topology, "SPLIT_PROJECTIONS", False)
    kept = brep_bytes(topology.model_to_shape(m))
    monkeypatch.setattr(topology, "ANALYSES_KEPT", 0)
    none_kept = brep_bytes(topology.model_to_shape(m))
    monkeypatch.setattr(topology, "EdgeProjector", _Plain)
    plain = brep_bytes(topology.model_to_shape(m))
    assert kept == plain
    assert none_kept == plain


def _count_analyses(monkeypatch: pytest.MonkeyPatch) -> list[int]:
    """A list that gets an item for each ``ShapeAnalysis_Surface`` made."""
    made: list[int] = []
    real = topology.ShapeAnalysis_Surface

    def counted(surface: Any) -> Any:
        made.append(1)
        return real(surface)

    monkeypatch.setattr(topology, "ShapeAnalysis_Surface", counted)
    return made


def test_analyses_are_reused(monkeypatch: pytest.MonkeyPatch) -> None:
    """Some calls find their face's analysis kept (else nothing is saved)."""
    made = _count_analyses(monkeypatch)
    monkeypatch.setattr(topology, "SPLIT_PROJECTIONS", False)
    calls = []
    add = topology.EdgeProjector.add

    def add_counted(self: Any, edge: Any, face: Any, seam: bool) -> bool:
        calls.append(1)
        return add(self, edge, face, seam)

    monkeypatch.setattr(topology.EdgeProjector, "add", add_counted)
    m, _ = shape_to_model(SHAPES["nurbs_fillets"])
    m = drop_pcurves(m, set(), set())
    m.pcurves_by_face = False
    topology.model_to_shape(m)
    assert len(calls) > 0
    assert len(made) - 1 < len(calls)  # one analysis is the spare surface


def test_a_shared_precision_would_differ(monkeypatch: pytest.MonkeyPatch) -> None:
    """Kept per face alone (not per precision), an analysis gives other
    pcurves on these models: the key's precision is what keeps them equal,
    and the comparison above can fail."""

    class _PerFace(topology.EdgeProjector):
        def add(self, edge: Any, face: Any, seam: bool) -> bool:
            sas = self._analyses.get((face, 0.0))
            if sas is None:
                sas = self._analyses[(face, 0.0)] = topology.ShapeAnalysis_Surface(
                    BRep_Tool.Surface_s(face)
                )
            self.fix.Projector().SetSurface(self._spare)
            return bool(self.fix.FixAddPCurve(edge, face, seam, sas, BRep_Tool.Tolerance_s(edge)))

    monkeypatch.setattr(topology, "SPLIT_PROJECTIONS", False)
    differ = 0
    for name in SHAPES:
        m = _model(name)
        ours = brep_bytes(topology.model_to_shape(m))
        with monkeypatch.context() as mp:
            mp.setattr(topology, "EdgeProjector", _PerFace)
            differ += brep_bytes(topology.model_to_shape(m)) != ours
    assert differ > 0


def test_an_analysis_is_found_for_another_wrapper_of_its_face(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """OCP's ``==`` on shapes is the wrapper's identity: the projector finds a
    face's analysis by hash and ``IsSame``, so another wrapper of the face,
    or the face reversed, finds it too; another face does not."""
    from OCP.TopAbs import TopAbs_EDGE, TopAbs_FACE
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopoDS import TopoDS

    made = _count_analyses(monkeypatch)
    shape = SHAPES["loft"]
    faces = TopExp_Explorer(shape, TopAbs_FACE)
    face = TopoDS.Face_s(faces.Current())
    faces.Next()
    other = TopoDS.Face_s(faces.Current())
    edges = TopExp_Explorer(face, TopAbs_EDGE)
    edge = TopoDS.Edge_s(edges.Current())
    proj = topology.EdgeProjector()
    assert len(made) == 1  # the spare surface
    proj.add(edge, face, False)
    proj.add(edge, TopoDS.Face_s(face.Oriented(face.Orientation())), False)
    proj.add(edge, TopoDS.Face_s(face.Reversed()), False)
    assert len(made) == 2
    proj.add(edge, other, False)
    assert len(made) == 3
