"""A degenerated edge's stored pcurve follows the projected pcurves of its wire
(``occ.topology.align_degenerated``): a filleted box's sphere corners."""

from __future__ import annotations

from pathlib import Path

import cadquery as cq
import pytest

from nurbscomp import occ, pipeline
from nurbscomp.encode import pcurves, validity
from nurbscomp.model import EC, REBUILD
from nurbscomp.occ import topology


def _filleted_box():  # type: ignore[no-untyped-def]
    return cq.Workplane().box(10, 10, 10).edges().fillet(1).val().wrapped


def _read_back(path: Path):  # type: ignore[no-untyped-def]
    """The filleted box written to STEP by cadquery and read by OCCT."""
    cq.exporters.export(cq.Workplane().add(cq.Shape.cast(_filleted_box())), str(path))
    return occ.read_cad(path).shape


@pytest.mark.parametrize("aligned", [True, False])
def test_sphere_corners_with_projected_pcurves_are_valid(
    aligned: bool, monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    """The first candidate of the validity stage at 0.01 mm leaves out every
    pcurve it can: the corners' meridians and latitude arcs come back
    projected onto [−π/2, 0] where the source had them on [3π/2, 2π], and
    the pole's stored pcurve must follow them.  Without the alignment the
    case is still there (four corners unorientable)."""
    box = _read_back(tmp_path / "box.step")
    m, _ = occ.shape_to_model(box)
    plan = validity._Plan(pcurves.natural_ends(m, 0.01), 0.01, box)
    cand = plan.candidate()[0]
    assert (cand.edge_reps[:, EC.CURVE] == REBUILD).sum() > 40
    if not aligned:
        monkeypatch.setattr(topology, "align_degenerated", lambda face, wire: 0)
    shape = validity.build(cand)
    assert occ.counts(shape) == occ.counts(box)
    bad_faces = occ.failures(shape)[1]
    if aligned:
        assert occ.is_valid(shape)
    else:
        assert len(bad_faces) == 4


def test_filleted_box_compresses_in_one_round(tmp_path: Path) -> None:
    """No stored pcurve and no remedy round for the corners (there were
    three rounds and four faces' pcurves stored)."""
    src, nzc = tmp_path / "box.step", tmp_path / "box.nzc"
    _read_back(src)
    report = pipeline.compress_file(src, nzc, tol=0.01)
    assert report["validity"]["rounds"] == 1
    assert report["validity"]["pcurves_kept"] == 0
    assert occ.is_valid(pipeline.decode_file(nzc)[0])


def test_a_pole_off_its_neighbours_is_snapped_to_them(tmp_path: Path) -> None:
    """A pole whose stored pcurve misses its projected neighbours along the
    pole (as a revolved B-spline's did in NIST_MBE_PMI_2: 0.009 in v) becomes
    the segment between their ends; one that meets them is left alone."""
    from OCP.BRep import BRep_Tool
    from OCP.gp import gp_Vec2d
    from OCP.TopAbs import TopAbs_EDGE, TopAbs_FACE, TopAbs_WIRE
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopoDS import TopoDS

    box = _read_back(tmp_path / "box.step")
    m, _ = occ.shape_to_model(box)
    plan = validity._Plan(pcurves.natural_ends(m, 0.01), 0.01, box)
    shape = validity.build(plan.candidate()[0])
    corners = []
    ex = TopExp_Explorer(shape, TopAbs_FACE)
    while ex.More():
        face = TopoDS.Face_s(ex.Current())
        ee = TopExp_Explorer(face, TopAbs_EDGE)
        while ee.More():
            if BRep_Tool.Degenerated_s(TopoDS.Edge_s(ee.Current())):
                corners.append((face, TopoDS.Edge_s(ee.Current())))
            ee.Next()
        ex.Next()
    assert len(corners) == 8
    face, pole = corners[0]
    wire = TopoDS.Wire_s(TopExp_Explorer(face, TopAbs_WIRE).Current())
    assert topology.align_degenerated(face, wire) == 0  # it meets them already
    cr, start, end = topology._oriented_pcurve(pole, face)  # type: ignore[misc]
    cr.PCurve(cr.PCurve().Translated(gp_Vec2d(0.01, 0.0)))  # along the pole line
    cr.SetRange(cr.First(), cr.Last())
    assert topology.align_degenerated(face, wire) == 1
    _, start2, end2 = topology._oriented_pcurve(pole, face)  # type: ignore[misc]
    assert start2.Distance(start) < 1e-12 and end2.Distance(end) < 1e-12
    assert occ.is_valid(face)


@pytest.mark.parametrize(
    "name, poles, periods",
    [
        ("bracket.v2_7.tol0.01.nzc", False, False),
        ("bracket.v2_8.tol0.01.nzc", True, False),
        ("bracket.v2_9.tol0.01.nzc", True, True),
    ],
)
def test_the_rules_follow_the_format_minor(name: str, poles: bool, periods: bool) -> None:
    """A container is built as it was written to be: the poles' rule from 2.8
    (``decode.POLES_FOLLOW``), the trimmed surfaces' periods from 2.9
    (``decode.PERIODS_IN_RANGE``, tests/test_trimmed_periods.py)."""
    from nurbscomp import container
    from nurbscomp.stages import decompress

    golden = Path(__file__).resolve().parent / "golden"
    c = container.unpack((golden / name).read_bytes())
    m, _ = decompress.decode(c, None, None)
    assert (m.poles_follow, m.periods_in_range) == (poles, periods)
