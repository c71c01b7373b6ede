"""Format 2.16: a wire with a seam that ``FixShifted`` leaves open in 2-D is
set by the first trial that closes it (docs/format.md §2.8, *(2.16)*;
``occ.topology.shift_wire``)."""

from __future__ import annotations

from pathlib import Path

import pytest

from nurbscomp import occ, pipeline
from nurbscomp.occ import topology


def _holes():
    """cadquery blocks as its modelling makes them, in memory: OCCT lists a
    hole's cylinder (a countersink's cone) circle, seam, circle, seam."""
    import cadquery as cq

    top = cq.Workplane().box(20, 20, 10).faces(">Z").workplane()
    return {
        "hole": top.hole(6).val(),
        "cbore": top.cboreHole(4, 8, 3).val(),
        "csk": top.cskHole(4, 8, 82).val(),
    }


@pytest.mark.parametrize("name", ["hole", "cbore", "csk"])
def test_holes_pass_the_first_round(name: str, tmp_path: Path) -> None:
    """The validity stage's first candidate is valid: no round more, no
    pcurve kept (before 2.16: 3 or 4 rounds, and the hole's face's pcurves
    stored)."""
    import nurbscomp

    shape = _holes()[name]
    data, rep = nurbscomp.compress(shape, tol=0.01, report=True)
    assert rep.validity["rounds"] == 1 and rep.validity["pcurves_kept"] == 0
    back = nurbscomp.decompress(data)
    assert back.isValid() and nurbscomp.evaluate(shape, data).within_tolerance


def test_the_guard_is_what_makes_the_hole_valid(tmp_path: Path) -> None:
    """The same decoded model built without the guard (a 2.15 reader's rule)
    has a face that BRepCheck rejects: the rule is needed, not decoration."""
    import nurbscomp

    nzc = tmp_path / "hole.nzc"
    nzc.write_bytes(nurbscomp.compress(_holes()["hole"], tol=0.01))
    m, _ = pipeline.decode(pipeline.read_container(nzc))
    assert m.seams_set
    assert occ.is_valid(topology.model_to_shape(m))
    m.seams_set = False
    assert not occ.is_valid(topology.model_to_shape(m))


def test_chain_order() -> None:
    """Edges listed out of the order in which they connect come back in it;
    a wire in order keeps it."""
    import cadquery as cq
    from OCP.ShapeExtend import ShapeExtend_WireData

    sq = cq.Workplane().rect(4, 4).wires().val()
    edges = sq.Edges()
    wd = ShapeExtend_WireData()
    for e in (edges[0], edges[2], edges[1], edges[3]):
        wd.Add(e.wrapped)
    assert topology.chain_order(wd) == [1, 3, 2, 4]
    inorder = ShapeExtend_WireData(sq.wrapped)
    assert topology.chain_order(inorder) == [1, 2, 3, 4]
