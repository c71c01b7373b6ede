"""Directions of analytic records straightened within tol (``encode.analytic``):
noise in a frame's directions is set to 0, with a bound from the reach of the
faces and edges the record bounds."""

from __future__ import annotations

import math

import numpy as np
import pytest

import nurbscomp
from nurbscomp import container, pipeline
from nurbscomp.encode import analytic
from nurbscomp.model import Analytic, Kind


def _cylinder(noise: float) -> Analytic:
    n = np.array([noise, -noise, 1.0])
    n /= np.linalg.norm(n)
    x = np.array([1.0, 0.0, -noise])
    x -= n * (x @ n)
    x /= np.linalg.norm(x)
    frame = np.array([[1.0, 2.0, 3.0], n, x, np.cross(n, x)])
    return Analytic(Kind.CYLINDER, frame, np.array([4.0]))


def _points(g: Analytic, reach: float) -> np.ndarray:
    """Points of cylinder ``g`` within ``reach`` of its origin, on a grid of (u, v)."""
    o, n, x = g.frame[0], g.frame[1], g.frame[2]
    y = np.cross(n, x)
    r = float(g.params[0])
    u, v = np.meshgrid(np.linspace(0, 2 * math.pi, 64), np.linspace(-1, 1, 33))
    v = v * math.sqrt(reach**2 - r**2)
    return o + r * (np.cos(u)[..., None] * x + np.sin(u)[..., None] * y) + v[..., None] * n


def test_noise_goes_within_the_bound() -> None:
    g = _cylinder(3e-11)
    reach = 50.0
    out = analytic.straighten(g, reach, 0.001)
    assert out is not None
    s, bound = out
    np.testing.assert_array_equal(s.frame[1:], [[0, 0, 1], [1, 0, 0], [0, 1, 0]])
    np.testing.assert_array_equal(s.frame[0], g.frame[0])
    moved = np.linalg.norm(_points(s, reach) - _points(g, reach), axis=-1).max()
    assert 0 < moved <= bound <= analytic.STRAIGHT_SHARE * 0.001
    assert bound < 100 * moved  # not loose by orders of magnitude


def test_what_is_not_noise_stays() -> None:
    g = _cylinder(1e-6)  # a real angle stays: only what is below NOISE goes
    out = analytic.straighten(g, 50.0, 0.001)
    assert out is not None
    big = np.abs(g.frame[1:]) > analytic.NOISE
    np.testing.assert_allclose(out[0].frame[1:][big], g.frame[1:][big], rtol=1e-15, atol=0)
    np.testing.assert_array_equal(out[0].frame[1:][~big], 0.0)
    assert analytic.straighten(_cylinder(0.0), 50.0, 0.001) is None  # nothing to do
    # noise, but too far from the origin for its move to stay within tol's share
    assert analytic.straighten(_cylinder(3e-11), 1e9, 0.001) is None


def _axes(data: bytes, through: bool = True) -> tuple[int, int]:
    """(directions that are axes, directions) of the analytic rows of a
    container; without ``through``, not those of lines through their
    vertices, whose direction the decoder takes from the vertices."""
    m, _ = pipeline.decode(container.unpack(data))  # lines through vertices made
    rows = [g for g in (*m.surfaces, *m.curves3d) if isinstance(g, Analytic)]
    rows = [g for g in rows if through or not (g.kind == Kind.LINE and g.through)]
    d = np.concatenate([g.frame[1:] for g in rows if g.kind in analytic.STRAIGHT_KINDS])
    axis = (np.sort(np.abs(d), axis=-1) == [0.0, 0.0, 1.0]).all(-1)
    return int(axis.sum()), len(d)


@pytest.mark.slow
@pytest.mark.parametrize("angle, straight", [(1e-12, True), (1e-3, False)])
def test_a_part_turned_by_noise_comes_back_on_its_axes(angle: float, straight: bool) -> None:
    """A filleted plate with holes, turned about z by ``angle`` (radians):
    by 1e-12 its frames are the axes up to noise, and they come back on the
    axes, within tol; by 1e-3 they stay as they are."""
    import cadquery as cq

    part = (
        cq.Workplane()
        .box(40, 20, 5)
        .faces(">Z")
        .workplane()
        .rarray(20, 1, 2, 1)
        .hole(4)
        .edges("|Z")
        .fillet(2)
        .val()
        .rotate((0, 0, 0), (0, 0, 1), math.degrees(angle))
    )
    tol = 0.001
    data = nurbscomp.compress(part, tol=tol)
    # (made in memory, its holes' placements are baked: the lines through
    # vertices that stay off the grid, fewer than MIN_LOOSE, keep the noise
    # of those vertices, 1e-12 at most here)
    axes, total = _axes(data, through=False)
    assert (axes == total) is straight
    if straight:
        m, _ = pipeline.decode(container.unpack(data))
        lines = [g for g in m.curves3d if isinstance(g, Analytic) and g.kind == Kind.LINE]
        d = np.sort(np.abs(np.array([g.frame[1] for g in lines])), axis=-1)
        assert np.abs(d - [0.0, 0.0, 1.0]).max() <= 1e-11
    report = nurbscomp.evaluate(part, data)
    assert report.within_tolerance and report.same_topology and report.valid_reconstructed
    assert report.max_deviation_mm <= tol
    if straight:  # the lossless container keeps the noise
        axes, total = _axes(nurbscomp.compress(part, lossless="brep"))
        assert axes < total


def test_a_located_face_is_measured_in_its_own_frame() -> None:
    """A plane placed 100 mm along x by its face's location, the face's
    boundary 200 mm from where the placed plane's origin lands: the reach is at
    least that distance (measuring from the unplaced origin gave 4.2)."""
    from OCP.BRep import BRep_Builder
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeFace
    from OCP.Geom import Geom_Plane
    from OCP.gp import gp_Dir, gp_Pln, gp_Pnt, gp_Trsf, gp_Vec
    from OCP.TopLoc import TopLoc_Location

    from nurbscomp import occ

    face = BRepBuilderAPI_MakeFace(
        gp_Pln(gp_Pnt(0, 0, 0), gp_Dir(0, 0, 1)), -101.0, -99.0, -1.0, 1.0
    ).Face()
    move = gp_Trsf()
    move.SetTranslation(gp_Vec(100, 0, 0))
    plane = Geom_Plane(gp_Pnt(0, 0, 0), gp_Dir(0, 0, 1))
    BRep_Builder().UpdateFace(face, plane, TopLoc_Location(move), 1e-7)
    m, _ = occ.shape_to_model(face)
    (row,) = [i for i in range(len(m.surfaces)) if m.face_surface[0] == i]
    reach, _ = analytic.reaches(m)
    true = math.hypot(201.0, 1.0)  # the boundary's far corner from the origin, placed
    assert true <= reach[row] <= 3 * true
