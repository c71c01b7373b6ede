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
