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
