"""The writer's option to store iso-parameter pcurves (issue 30 item 2)."""

from __future__ import annotations

import cadquery as cq
import numpy as np
import pytest

from nurbscomp.encode import pcurves
from nurbscomp.model import REBUILD, Analytic, Kind, RepKind
from nurbscomp.occ import shape_to_model


def _model() -> object:
    shape = cq.Workplane().cylinder(6, 3).faces(">Z").workplane().hole(2).val().wrapped
    return shape_to_model(shape)[0]


def test_iso_lines_are_the_axis_aligned_2d_lines() -> None:
    m = _model()
    iso = pcurves.iso_lines(m)
    reps = m.edge_reps
    assert iso.any() and not iso.all()
    for q in np.flatnonzero(iso).tolist():
        assert reps[q, 1] in (RepKind.ON_SURFACE, RepKind.ON_CLOSED_SURFACE)
        g = m.curves2d[int(reps[q, 2])]
        assert isinstance(g, Analytic) and g.kind == Kind.LINE and (g.frame[1] == 0).any()
    # a pcurve that is no line, or a slanted line, is not one
    for q in np.flatnonzero(~iso & (reps[:, 1] == RepKind.ON_SURFACE)).tolist():
        g = m.curves2d[int(reps[q, 2])]
        assert not (isinstance(g, Analytic) and g.kind == Kind.LINE and (g.frame[1] == 0).any())


@pytest.mark.parametrize("store", [False, True])
def test_drop_pcurves_stores_iso_lines_when_asked(store: bool, monkeypatch) -> None:
    m = _model()
    monkeypatch.setattr(pcurves, "STORE_ISO_LINES", store)
    out = pcurves.drop_pcurves(m, set(), set())
    iso = pcurves.iso_lines(m)
    dropped = out.edge_reps[:, 2] == REBUILD
    assert dropped.any()
    assert (dropped & iso).any() != store  # iso lines left out only when not stored


@pytest.mark.corpus
def test_pcurve_pairs_on_a_trimmed_surface_are_stored(monkeypatch) -> None:
    """bug32596 (an ABC part) has surfaces of revolution cut into two faces
    that share one trimmed surface: the edges between them carry two pcurves
    a period apart, which a projection onto the trimmed surface puts on one
    side.  They are stored (a cylinder's seam is still left to the decoder).
    The first candidate at 0.01 mm is then valid; without them it is not
    (one face, two since format 2.10's curves coded between their vertices;
    another one the 2.9 rule mends: tests/test_trimmed_periods.py)."""
    from nurbscomp import occ
    from nurbscomp.encode import validity
    from nurbscomp.model import EC, Derived

    from .conftest import CORPUS

    cad = occ.read_cad(CORPUS / "occt__bug32596_abc_0_13.step")
    m, _ = shape_to_model(cad.shape)
    reps = m.edge_reps
    closed = np.flatnonzero(reps[:, EC.KIND] == RepKind.ON_CLOSED_SURFACE)
    on_trimmed = np.array(
        [
            isinstance(g, Derived) and g.kind == Kind.TRIMMED_SURFACE
            for g in (m.surfaces[int(reps[q, EC.SURFACE])] for q in closed.tolist())
        ]
    )
    assert len(closed) and on_trimmed.all()
    kept = pcurves.drop_pcurves(m, set(), set()).edge_reps[closed, EC.CURVE] != REBUILD
    assert kept.all()
    cyl, _ = shape_to_model(cq.Workplane().cylinder(10, 3).val().wrapped)
    seams = cyl.edge_reps[:, EC.KIND] == RepKind.ON_CLOSED_SURFACE
    assert seams.any()
    dropped = pcurves.drop_pcurves(cyl, set(), set()).edge_reps[seams, EC.CURVE] == REBUILD
    assert dropped.all()

    def faulty_faces() -> int:
        plan = validity._Plan(pcurves.natural_ends(m, 0.01), 0.01, cad.shape)
        cand, _, _ = plan.candidate()
        _, bad = occ.failures(validity.build(cand))
        return len(bad - occ.failures(cad.shape)[1])

    assert faulty_faces() == 0
    monkeypatch.setattr(pcurves, "KEEP_TRIMMED_PAIRS", False)
    assert faulty_faces() >= 1
