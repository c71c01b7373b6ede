"""Sub-shape locations baked into the geometry for shapes made in memory
(``encode.placed.bake``), and the deviation measure on located faces."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from nurbscomp import occ
from nurbscomp.encode import placed
from nurbscomp.model import EC, VC
from nurbscomp.occ import topology


def _bolted():
    """A cadquery block with a pocket, a bolt pattern of counterbored holes
    (one hole placed four times: edges shared between placements) and a
    boss on its side, turned off-axis."""
    import cadquery as cq

    p = (
        cq.Workplane()
        .box(60, 30, 12)
        .faces(">Z")
        .workplane()
        .rect(20, 10)
        .cutBlind(-4)
        .faces("<Z")
        .workplane()
        .rarray(40, 20, 2, 2)
        .cboreHole(4, 7, 2)
        .faces(">X")
        .workplane()
        .circle(4)
        .extrude(6)
    )
    return p.val().rotate((0, 0, 0), (1, 1, 0), 30)


def test_bake_keeps_the_shape_and_leaves_no_location() -> None:
    shape = _bolted()
    m, _ = occ.shape_to_model(shape.wrapped)
    assert m.child_loc.any()  # the case: OCCT's modelling placed sub-shapes
    b = placed.bake(m)
    assert b is not None
    assert not b.child_loc.any() and not b.face_loc.any() and b.root_loc == 0
    assert not b.edge_reps[:, EC.LOC].any() and not b.vertex_reps[:, VC.LOC].any()
    assert len(b.locations) == 1 and len(b.datums) == 0
    built = topology.model_to_shape(b)
    assert occ.is_valid(built)
    # the same placed shapes in the same order, and the same points
    assert occ.counts(built) == occ.counts(shape.wrapped)
    assert occ.deviation(shape.wrapped, built, 5).max() < 1e-9
    # one row per placed shape, as TopExp::MapShapes counts them
    for kind, t in (("faces", 4), ("edges", 6), ("vertices", 7)):
        assert (b.shape_type == t).sum() == occ.counts(shape.wrapped)[kind]
    # an unlocated model has nothing to bake
    assert placed.bake(b) is None


def test_a_shape_placed_twice_becomes_two() -> None:
    """One solid placed at two places (its TShapes shared): two sets of rows,
    each where its placement puts it; what one placement shares stays
    shared (a box's edge between two faces is one edge)."""
    import cadquery as cq

    box = cq.Workplane().box(2, 3, 4).edges("|Z").fillet(0.5).val()
    pair = cq.Compound.makeCompound(
        [box.moved(cq.Location((10, 0, 0))), box.moved(cq.Location((0, 0, 0), (1, 0, 0), 30))]
    )
    m, _ = occ.shape_to_model(pair.wrapped)
    b = placed.bake(m)
    assert b is not None
    assert (b.shape_type == 4).sum() == 2 * (m.shape_type == 4).sum()
    assert (b.shape_type == 6).sum() == 2 * (m.shape_type == 6).sum()
    built = topology.model_to_shape(b)
    assert occ.counts(built) == occ.counts(pair.wrapped)
    assert occ.is_valid(built)
    assert occ.deviation(pair.wrapped, built, 5).max() < 1e-9


def test_deviation_of_located_faces() -> None:
    """``occ.deviation`` samples a located face where it is: the one-argument
    ``BRep_Tool::Surface`` already holds the face's placement (it applied it
    twice, so a located face against its unlocated copy measured 40 mm)."""
    shape = _bolted()
    m, _ = occ.shape_to_model(shape.wrapped)
    b = placed.bake(m)
    assert b is not None
    built = topology.model_to_shape(b)
    d = occ.deviation(shape.wrapped, built, 5)
    assert d.max() < 1e-9
    # and it still sees a real move
    moved = built.Moved(_shift(0.5))
    assert np.isclose(occ.deviation(shape.wrapped, moved, 5, 1e9).min(), 0.5, atol=1e-9)


def _shift(dz: float):
    from OCP.gp import gp_Trsf, gp_Vec
    from OCP.TopLoc import TopLoc_Location

    t = gp_Trsf()
    t.SetTranslation(gp_Vec(0, 0, dz))
    return TopLoc_Location(t)


@pytest.mark.slow
def test_a_part_made_in_memory_is_coded_as_its_step_file_is(tmp_path) -> None:
    """Compressed in memory at 0.01 mm, the part is no larger than 1.6 times
    its STEP file's container (1.48 here; 2.0 before the bake: its lines,
    circles, vertices and planes were left where its placements put them),
    and comes back within tol, valid, with the same counts."""
    import cadquery as cq

    import nurbscomp

    shape = _bolted()
    data = nurbscomp.compress(shape, tol=0.01)
    src = tmp_path / "part.step"
    cq.exporters.export(cq.Workplane().add(shape), str(src))
    via_step = nurbscomp.compress(src, tol=0.01)
    assert len(data) <= 1.6 * len(via_step), (len(data), len(via_step))
    r = nurbscomp.evaluate(shape, data)
    assert r.same_topology and r.within_tolerance
    assert nurbscomp.decompress(data).isValid()


def _crossed_cylinders_faces_iges(tmp_path):
    """Two crossed cylinders written by OCCT as an IGES surface model: its
    reader puts each cylinder's face under a location (the IGES surface of
    revolution under a transformation matrix), the face's wires under its
    inverse."""
    import cadquery as cq

    from tests.golden.make_golden import faces_iges

    a = cq.Workplane("XY").cylinder(40, 8)
    b = cq.Workplane("YZ").cylinder(40, 6)
    step = tmp_path / "crossed.step"
    cq.exporters.export(a.union(b), str(step))
    return faces_iges(step, tmp_path / "crossed.igs")


def test_located_faces_of_a_file_are_baked(tmp_path) -> None:
    """A part read from a file with located faces and no assembly is baked
    like a shape made in memory, its product data's references mapped onto
    the new rows; the pcurves on those faces can then be left out (their
    location is the face's): 7,301 bytes at 0.01 mm before, every pcurve
    stored."""
    from nurbscomp import container, pipeline, serialize

    src = _crossed_cylinders_faces_iges(tmp_path)
    cad = occ.read_cad(src, product=True)
    m, _ = occ.shape_to_model(cad.shape)
    m.product = cad.product
    assert m.child_loc.any() and cad.product is not None
    b = placed.bake(m)
    assert b is not None and b.product is not None
    assert b.product.ref.tolist() == [b.root_shape]  # the part's shape, renumbered
    nzc = tmp_path / "crossed.nzc"
    report = pipeline.compress_file(src, nzc, tol=0.01)
    assert report["verified"] and report["pcurves_rebuilt"] > 0
    c = container.unpack(nzc.read_bytes())
    dm, _ = serialize.read_sections(c.get, c.revision, None)[:2]
    assert len(dm.curves2d) == 0  # no pcurve kept
    assert nzc.stat().st_size < 3000, nzc.stat().st_size
    got = pipeline.evaluate(src, nzc)
    assert got["within_tolerance"] and got["topology_same"] and got["valid_kept"], got


def test_an_assembly_is_not_baked() -> None:
    """Product data that places anything (an assembly's instances) keeps the
    model's locations: the structure a user gets back."""
    import cadquery as cq

    from nurbscomp.product import INSTANCE, ProductData

    box = cq.Workplane().box(2, 3, 4).val()
    pair = cq.Compound.makeCompound([box.moved(cq.Location((10, 0, 0))), box])
    m, _ = occ.shape_to_model(pair.wrapped)
    plain = ProductData(
        kind=np.array([0]), parent=np.array([-1]), ref=np.array([m.root_shape]),
        orient=np.zeros(1, np.int64), place=np.array([-1]), flags=np.zeros(1, np.int64),
        colour=-np.ones((1, 3), np.int64), names=[""],
    )  # fmt: skip
    m.product = plain
    assert placed.bake(m) is not None
    m.product = replace(plain, kind=np.array([INSTANCE]))
    assert placed.bake(m) is None
    # a shape the bake makes two rows of cannot keep its reference
    m.product = replace(plain, ref=np.array([int(m.child_shape[0])]))
    assert placed.bake(m) is None


def _offset_face():
    """A face on an offset of a B-spline surface (``Geom_OffsetSurface``)."""
    import cadquery as cq
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeFace
    from OCP.Geom import Geom_OffsetSurface

    net = [
        [cq.Vector(i, j, ((i - 2) ** 2 - (j - 2) ** 2) * 0.3) for j in range(5)] for i in range(5)
    ]
    base = cq.Face.makeSplineApprox(net)
    from OCP.BRep import BRep_Tool

    surf = Geom_OffsetSurface(BRep_Tool.Surface_s(base.wrapped), 0.5)
    return BRepBuilderAPI_MakeFace(surf, 1e-7).Face()


@pytest.mark.parametrize("kind", ["plane", "axis", "point"])
def test_a_mirror_is_baked_at_the_same_parameters(kind: str) -> None:
    """Located under a mirror (OCCT's IGES reader places some surfaces so),
    every point keeps its parameters: a conic's frame (a right-handed
    ``gp_Ax2``), a revolution's axis and an offset's sign are turned back,
    as the mirror turns the sense of rotations and cross products.  Without
    that, circles and revolutions ran the other way (BRepCheck faults, 5 to
    26 mm at the same parameters)."""
    import cadquery as cq
    from OCP.gp import gp_Ax1, gp_Ax2, gp_Dir, gp_Pnt, gp_Trsf
    from OCP.TopLoc import TopLoc_Location

    spline = cq.Workplane("XZ").spline([(1, 0), (3, 2), (2, 5), (1, 7)])
    parts = [
        spline.lineTo(0, 7).lineTo(0, 0).close().revolve().val().wrapped,  # a revolution
        cq.Workplane().circle(4).extrude(12).edges(">Z").fillet(1).faces("<Z").workplane()
        .hole(2).val().wrapped,  # planes, cylinders, a torus, circles
        cq.Workplane("XZ").center(10, 0).ellipse(4, 2).revolve(180, (-10, 0, 0), (-10, 1, 0))
        .val().wrapped,  # ellipses
        _offset_face(),
    ]  # fmt: skip
    t = gp_Trsf()
    if kind == "plane":
        t.SetMirror(gp_Ax2(gp_Pnt(0, 0, 5), gp_Dir(1, 1, 0)))
    elif kind == "point":
        t.SetMirror(gp_Pnt(1, 2, 3))
    else:  # a half turn: no mirror, the case that always worked
        t.SetMirror(gp_Ax1(gp_Pnt(0, 0, 0), gp_Dir(0, 0, 1)))
    for part in parts:
        shape = part.Moved(TopLoc_Location(t))
        m, _ = occ.shape_to_model(shape)
        b = placed.bake(m)
        assert b is not None and not b.child_loc.any()
        built = topology.model_to_shape(b)
        assert occ.is_valid(built) == occ.is_valid(shape)
        assert occ.counts(built) == occ.counts(shape)
        # each point where the same (u, v) puts it (a large tol: no projection)
        assert occ.deviation(shape, built, 5, 1e9).max() < 1e-9
