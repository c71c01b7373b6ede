"""Surfaces whose parameters nothing else holds are reparametrized where
that is cheaper (``encode.pcurves.unit_surfaces``, no format change): a
B-spline's knots onto [0, 1], an axis plane's origin onto its axis.  The
same surfaces point for point; the decoder projects every pcurve on them."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import cadquery as cq
import numpy as np
import pytest
from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeFace
from OCP.Geom import Geom_BSplineSurface
from OCP.gp import gp_Pnt
from OCP.TColgp import TColgp_Array2OfPnt
from OCP.TColStd import TColStd_Array1OfInteger, TColStd_Array1OfReal

from nurbscomp import codec, container, occ, pipeline, serialize
from nurbscomp.encode import pcurves
from nurbscomp.model import (
    EC,
    REBUILD,
    Analytic,
    BSplineSurface,
    Kind,
    RepKind,
    Table,
    records,
)

from .conftest import assert_comes_back, assert_step_keeps_floor


def _bspline_face(rough: float = 0.0, k: int = 0) -> cq.Face:
    """A bicubic face of 5 × 4 poles, its u domain [0.37, 41.3] + k·1.13
    with a knot in the middle and its v domain [−2.9, 17.1] − k·0.71: ends
    that cost 52 bits each as floats.  Smooth, it is coded best by boundary
    curves and a map; with poles ``rough`` = 0.3 mm off smooth, by a grid
    predictor.  The k-th such face lies 50·k mm along y."""
    poles = TColgp_Array2OfPnt(1, 5, 1, 4)
    for i in range(5):
        for j in range(4):
            z = 2.0 * np.sin(0.7 * i + j + k) + 0.1 * i * i + rough * ((i * 7 + j * 3) % 5)
            poles.SetValue(i + 1, j + 1, gp_Pnt(10.0 * i, 8.0 * j + 50.0 * k, z))

    def reals(xs: list[float]) -> TColStd_Array1OfReal:
        a = TColStd_Array1OfReal(1, len(xs))
        for n, x in enumerate(xs):
            a.SetValue(n + 1, x)
        return a

    def ints(xs: list[int]) -> TColStd_Array1OfInteger:
        a = TColStd_Array1OfInteger(1, len(xs))
        for n, x in enumerate(xs):
            a.SetValue(n + 1, x)
        return a

    u0, u1, v0, v1 = 0.37 + 1.13 * k, 41.3 + 1.13 * k, -2.9 - 0.71 * k, 17.1 - 0.71 * k
    s = Geom_BSplineSurface(
        poles, reals([u0, (u0 + u1) / 2, u1]), reals([v0, v1]), ints([4, 1, 4]), ints([4, 4]), 3, 3
    )
    return cq.Face(BRepBuilderAPI_MakeFace(s, 1e-6).Face())


def _faces(rough: float = 0.0, n: int = 6) -> list[cq.Shape]:
    """``n`` such faces, each trimmed by a box turned 20° about z: their
    edges are intersection curves, not copies of the surfaces' sides (a
    trimmed face, as most B-spline faces of CAD files are)."""
    out = []
    for k in range(n):
        box = cq.Solid.makeBox(22, 14, 40, pnt=cq.Vector(9, 50 * k + 5, -20))
        mid = cq.Vector(20, 50 * k + 12, 0)
        out.append(_bspline_face(rough, k).intersect(box.rotate(mid, mid + cq.Vector(0, 0, 1), 20)))
    return out


def _model(shape: cq.Shape):
    m, _ = occ.shape_to_model(shape.wrapped)
    return m


@pytest.mark.parametrize("what", ["planes", "splines"])
def test_free_surfaces_are_reparametrized_and_stay_where_they_are(what: str) -> None:
    if what == "planes":  # a turned pentagonal prism: two axis planes, five others
        prism = cq.Workplane().polygon(5, 20).extrude(10).rotate((0, 0, 0), (0, 0, 1), 7)
        shape = prism.translate((3.25, 4.5, 5.75)).val()
    else:
        shape = cq.Compound.makeCompound(_faces())
    m = _model(shape)
    free = pcurves.drop_pcurves(m, set(), set())  # every pcurve left to the decoder
    out = pcurves.unit_surfaces(free, {})
    if what == "splines":
        splines = [s for s in out.surfaces if isinstance(s, BSplineSurface)]
        assert len(splines) == 6
        for g in splines:
            assert (g.uknots[0], g.uknots[-1], g.vknots[0], g.vknots[-1]) == (0.0, 1.0, 0.0, 1.0)
            assert g.uknots[1] == pytest.approx(0.5, abs=1e-15)
    else:
        at_vertex = set(m.vertex_point.reshape(-1).tolist())
        moved = 0
        for p, src in zip(out.surfaces, m.surfaces):
            assert isinstance(p, Analytic) and isinstance(src, Analytic) and p.kind == Kind.PLANE
            n, o = p.frame[1], p.frame[0]
            assert np.array_equal(p.frame[1:], src.frame[1:])
            if np.count_nonzero(n) > 1:  # a turned plane stays
                assert p is src
                continue
            a = int(np.flatnonzero(n)[0])
            assert o[a] == src.frame[0, a]  # the same plane, bit for bit
            # in the plane: 0, or a vertex's coordinate kept as it was
            kept = [o[j] == 0 or o[j] == src.frame[0, j] in at_vertex for j in range(3) if j != a]
            assert all(kept)
            moved += p is not src
        assert moved == 2
    # the decoder's shape: the same surfaces point for point, valid
    back = occ.model_to_shape(out)
    assert occ.is_valid(back) and occ.counts(back) == occ.counts(shape.wrapped)
    assert occ.deviation(shape.wrapped, back, n=5).max() < 1e-9


def test_held_surfaces_and_knot_dependent_codes_stay() -> None:
    """A surface with a stored pcurve keeps its parameters, and so does a
    B-spline coded by a method that samples it at its knots."""
    m = _model(cq.Compound.makeCompound(_faces()))
    assert pcurves.unit_surfaces(m, {}) is m  # the source's pcurves are all stored
    free = pcurves.drop_pcurves(m, set(), set())
    assert (free.edge_reps[:, EC.CURVE] == REBUILD).any()
    recs = records(free.surfaces, Table.SURFACE)

    class Code:
        method = codec.Method.DDMAP

    def coded_as(method: codec.Method) -> dict:
        Code.method = method
        return {r: Code() for r in recs}

    assert pcurves.unit_surfaces(free, coded_as(codec.Method.DDMAP)) is free
    assert pcurves.unit_surfaces(free, coded_as(codec.Method.SPATIAL2)) is not free
    # one stored pcurve on a surface holds that one's parameters (the others
    # map or not by the size test, which the held one's unmapped knots sway)
    reps = free.edge_reps.copy()
    q = int(np.flatnonzero(reps[:, EC.KIND] == RepKind.ON_SURFACE)[0])
    reps[q, EC.CURVE] = m.edge_reps[q, EC.CURVE]
    held = pcurves.unit_surfaces(replace(free, edge_reps=reps), {})
    row = int(reps[q, EC.SURFACE])
    assert held.surfaces[row] is free.surfaces[row]


def test_a_moved_part_comes_back_with_its_planes_on_their_axes(tmp_path: Path) -> None:
    part = (
        cq.Workplane()
        .polygon(5, 30)
        .extrude(12)
        .edges("|Z")
        .fillet(3)
        .faces(">Z")
        .workplane()
        .hole(5)
        .rotate((0, 0, 0), (0, 0, 1), 7)
        .translate((17.125, -8.375, 4.0625))
    )
    src = tmp_path / "part.step"
    cq.exporters.export(part, str(src))
    nzc = tmp_path / "part.nzc"
    rep = pipeline.compress_file(src, nzc, tol=0.01)
    assert rep["verified"]
    m, _, _ = serialize.read_sections(container.unpack(nzc.read_bytes()).get, None)
    planes = [g for g in m.surfaces if isinstance(g, Analytic) and g.kind == Kind.PLANE]
    axis = [g for g in planes if np.count_nonzero(g.frame[1]) == 1]
    # on their axes, or (2.7) through a vertex of their face: no origin stored
    assert len(axis) == 2
    assert all(g.through or np.count_nonzero(g.frame[0]) == 1 for g in axis)
    assert_comes_back(src, nzc, 0.01, n=7)
    assert_step_keeps_floor(occ.read_cad(src), nzc, tmp_path)


def test_bspline_faces_come_back_on_unit_domains_where_their_codes_allow(tmp_path: Path) -> None:
    """Mapped where the code is a grid predictor's, kept where the code
    samples the surface at its knots (boundary curves and a map)."""
    src = tmp_path / "faces.step"
    cq.exporters.export(cq.Workplane().add(cq.Compound.makeCompound(_faces(0.3))), str(src))
    nzc = tmp_path / "faces.nzc"
    assert pipeline.compress_file(src, nzc, tol=0.01)["verified"]
    m, _, t = serialize.read_sections(container.unpack(nzc.read_bytes()).get, None)
    splines = [s for s in m.surfaces if isinstance(s, BSplineSurface)]
    assert len(splines) == len(t.snet.method) == 6
    mapped = 0
    for k, (g, method) in enumerate(zip(splines, t.snet.method.tolist())):
        ends = (g.uknots[0], g.uknots[-1], g.vknots[0], g.vknots[-1])
        if method in pcurves.KNOTLESS_CODES:
            mapped += ends == (0.0, 1.0, 0.0, 1.0)
        else:  # as read (through the STEP text's digits)
            want = (0.37 + 1.13 * k, 41.3 + 1.13 * k, -2.9 - 0.71 * k, 17.1 - 0.71 * k)
            assert ends == pytest.approx(want, rel=1e-12)
    assert mapped >= 2
    assert_comes_back(src, nzc, 0.01, n=7)
