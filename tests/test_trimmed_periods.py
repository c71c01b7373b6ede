"""Format 2.9 (docs/format.md §2.8, *(2.9)*): on a trimmed surface of a
periodic basis, which ``FixShifted`` takes for not periodic, a projected
pcurve whose middle lies a period beyond the surface's bounds is moved back
within them (``occ.topology.into_range``)."""

from __future__ import annotations

from dataclasses import replace

import pytest

from nurbscomp import occ
from nurbscomp.encode import pcurves, validity

from .conftest import CORPUS


@pytest.mark.corpus
def test_a_pcurve_a_period_beyond_a_trimmed_surface_comes_back() -> None:
    """bug32596 (an ABC part): a surface of revolution trimmed to a full turn,
    one arc of its edge projected onto [2π, 3π].  The first candidate at
    0.01 mm is valid with the rule; without it, BRepCheck calls that face
    unorientable, as a 2.8 reader would build it."""
    cad = occ.read_cad(CORPUS / "occt__bug32596_abc_0_13.step")
    m, _ = occ.shape_to_model(cad.shape)
    plan = validity._Plan(pcurves.natural_ends(m, 0.01), 0.01, cad.shape)
    cand, _, _ = plan.candidate()
    source_faults = occ.failures(cad.shape)
    assert cand.periods_in_range
    e, f = occ.failures(validity.build(cand))
    assert (e - source_faults[0], f - source_faults[1]) == (set(), set())
    # (and without 2.16's guard of FixShifted, which closes that wire too)
    e, f = occ.failures(validity.build(replace(cand, periods_in_range=False, seams_set=False)))
    assert not e - source_faults[0] and len(f - source_faults[1]) == 1
