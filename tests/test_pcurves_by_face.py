"""Format 2.15's order of projections (docs/format.md §2.8, *The order of
the projections*; ``occ.topology._by_face``): face by face in the shapes
table's order, edges in wire order, one surface analysis per face and the
projector's end points carried from edge to edge.

Checked on generated shapes (fillets converted to NURBS, a loft, a sweep, a
revolved spline with its seam and poles, a located assembly): the calls come
in that order, a build through a warm :class:`PcurveCache` gives the same
``.brep`` as a cold one (also where a few faces changed), the rule gives
other pcurves than 2.14's (so the version must choose it), and each
container is built with the rule of its version.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import cadquery as cq
import numpy as np
import pytest
from OCP.BRepBuilderAPI import BRepBuilderAPI_NurbsConvert
from OCP.gp import gp_Trsf, gp_Vec
from OCP.TopLoc import TopLoc_Location
from OCP.TopoDS import TopoDS_Iterator

from nurbscomp import container, pipeline
from nurbscomp.encode.pcurves import drop_pcurves
from nurbscomp.model import EC, REBUILD
from nurbscomp.occ import is_valid, shape_to_model, topology

from .conftest import brep_bytes

GOLDEN = Path(__file__).resolve().parent / "golden"


def _shapes() -> dict[str, Any]:
    blend = cq.Workplane().box(10, 8, 6).edges().fillet(1.2)
    loft = cq.Workplane().circle(5).workplane(offset=8).rect(4, 6).loft()
    sweep = (
        cq.Workplane("XY")
        .ellipse(2, 1)
        .sweep(cq.Workplane("XZ").spline([(0, 0), (2, 5), (-1, 10)], includeCurrent=False))
    )
    revolve = (cq.Workplane("XZ").moveTo(0, 0).spline([(4, 3), (3, 6), (0, 9)]).close()).revolve(
        360, (0, 0, 0), (0, 1, 0)
    )
    part = BRepBuilderAPI_NurbsConvert(blend.val().wrapped, True).Shape()
    t = gp_Trsf()
    t.SetTranslation(gp_Vec(30, 0, 0))
    pair = cq.Compound.makeCompound(
        [cq.Shape.cast(part), cq.Shape.cast(part.Moved(TopLoc_Location(t)))]
    )
    return {
        "nurbs_fillets": part,
        "loft": loft.val().wrapped,
        "sweep": sweep.val().wrapped,
        "revolve": BRepBuilderAPI_NurbsConvert(revolve.val().wrapped, True).Shape(),
        "located_pair": pair.wrapped,
    }


SHAPES = _shapes()


def _model(name: str, by_face: bool = True) -> Any:
    """The shape's model with its pcurves left out, edge tolerances powers
    of two that differ along each wire (as a decoder's may)."""
    m, _ = shape_to_model(SHAPES[name])
    m = drop_pcurves(m, set(), set())
    m.edge_tol = np.array([2.0 ** -(7 + i % 3) for i in range(len(m.edge_tol))])
    m.pcurves_by_face = by_face
    assert (m.edge_reps[:, EC.CURVE] == REBUILD).sum() >= 3  # projections are made
    return m


@pytest.mark.parametrize("name", sorted(SHAPES))
def test_calls_run_face_by_face_in_wire_order(name: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """Every projection is made with its face's one analysis, the faces in
    the shapes table's order, each face's edges in its wires' order."""
    monkeypatch.setattr(topology, "SPLIT_PROJECTIONS", False)
    m = _model(name)
    table: list[Any] = []  # the faces in the shapes table's order
    by_face = topology._by_face

    def kept_faces(fix: Any, faces: list[Any], *rest: Any) -> None:
        table.extend(faces)
        by_face(fix, faces, *rest)

    calls: list[tuple[int, int, int]] = []  # (face in the table, edge, analysis)
    add = topology.EdgeProjector.add
    known: list[Any] = []

    def edge_no(e: Any) -> int:
        """The index of ``e`` among the edges met (``IsSame``: OCP's ``==``
        and ``hash`` are the wrapper's)."""
        for i, g in enumerate(known):
            if g.IsSame(e):
                return i
        known.append(e)
        return len(known) - 1

    def recorded(self: Any, edge: Any, face: Any, seam: bool, sas: Any = None) -> bool:
        assert sas is not None  # a face's calls share its analysis
        f = next(i for i, g in enumerate(table) if g.IsSame(face))
        calls.append((f, edge_no(edge), id(sas)))
        return add(self, edge, face, seam, sas)

    monkeypatch.setattr(topology, "_by_face", kept_faces)
    monkeypatch.setattr(topology.EdgeProjector, "add", recorded)
    topology.model_to_shape(m)
    assert len(calls) >= 3
    faces = [f for f, _, _ in calls]
    assert faces == sorted(faces)  # face by face, in the table's order
    for f in set(faces):
        assert len({sas for g, _, sas in calls if g == f}) == 1  # one analysis a face
        wired: list[int] = []  # the face's edges as its wires list them
        wires = TopoDS_Iterator(table[f])
        while wires.More():
            edges = TopoDS_Iterator(wires.Value())
            while edges.More():
                h = edge_no(edges.Value())
                if h not in wired:
                    wired.append(h)
                edges.Next()
            wires.Next()
        made = [e for g, e, _ in calls if g == f]
        assert made == [h for h in wired if h in made]


@pytest.mark.parametrize("name", sorted(SHAPES))
def test_a_warm_cache_builds_what_a_cold_build_does(name: str) -> None:
    """:meth:`PcurveCache.face` replays a face's projections only where all
    they read is the same: a second build replays them, a model whose edge
    tolerances changed on a few edges projects those faces again, and every
    build is the cold build's ``.brep``."""
    m = _model(name)
    cold = brep_bytes(topology.model_to_shape(m))
    cache = topology.PcurveCache()
    assert brep_bytes(topology.model_to_shape(m, cache)) == cold
    misses = cache.misses
    assert brep_bytes(topology.model_to_shape(m, cache)) == cold
    assert cache.misses == misses and cache.hits >= misses  # all replayed
    m2 = _model(name)
    m2.edge_tol = m2.edge_tol.copy()
    m2.edge_tol[::5] *= 2.0
    cold2 = brep_bytes(topology.model_to_shape(m2))
    assert brep_bytes(topology.model_to_shape(m2, cache)) == cold2
    assert cache.misses > misses  # the changed faces were projected again


def test_the_order_changes_the_pcurves() -> None:
    """2.14's calls (each alone) and 2.15's (carried along a face) give
    other pcurves on some of these shapes, as valid: which one a container
    gets must follow its version."""
    differ = 0
    for name in SHAPES:
        a = topology.model_to_shape(_model(name, by_face=False))
        b = topology.model_to_shape(_model(name, by_face=True))
        assert is_valid(a) == is_valid(b)  # (the tolerances set here fail two of them)
        differ += brep_bytes(a) != brep_bytes(b)
    assert differ > 0


@pytest.mark.parametrize(
    "name, by_face, seams",
    [
        ("blob.v2_14.tol0.01.nzc", False, False),
        ("blob.v2_15.tol0.01.nzc", True, False),
        ("bracket.v2_16.tol0.01.nzc", True, True),  # and 2.16's guard (test_seam_shift)
    ],
)
def test_the_rule_follows_the_format_minor(name: str, by_face: bool, seams: bool) -> None:
    c = container.unpack((GOLDEN / name).read_bytes())
    m, _ = pipeline.decode(c)
    assert (m.pcurves_by_face, m.seams_set) == (by_face, seams)


def test_a_new_container_is_built_face_by_face(tmp_path: Path) -> None:
    src = Path(__file__).resolve().parent.parent / "samples" / "blob.step"
    out = tmp_path / "b.nzc"
    pipeline.compress_file(src, out, tol=0.01)
    c = pipeline.read_container(out)
    assert (c.major, c.minor) == (container.MAJOR, container.MINOR) and c.minor >= 15
    m, _ = pipeline.decode(c)
    assert m.pcurves_by_face
