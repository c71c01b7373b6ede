"""The bound of an offset surface's move when its basis is coded
(``encode.offsets``): certified, so no sample of the moved offset may pass it,
and the bound of |S_u × S_v| from below is below every sample of it."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from nurbscomp import occ, pipeline
from nurbscomp.encode import offsets
from nurbscomp.model import BSplineSurface, Derived, Kind


def _surface(seed: int, nu: int = 7, nv: int = 5, bump: float = 3.0) -> BSplineSurface:
    """A clamped bicubic B-spline over [0, 1]², 40 × 30 mm, bent by ``bump``."""
    rng = np.random.default_rng(seed)
    tu = np.r_[0.0, np.sort(rng.uniform(0.1, 0.9, nu - 4)), 1.0]
    tv = np.r_[0.0, np.sort(rng.uniform(0.1, 0.9, nv - 4)), 1.0]
    x, y = np.meshgrid(np.linspace(0, 40, nu), np.linspace(0, 30, nv), indexing="ij")
    z = bump * np.sin(x / 11 + seed) * np.cos(y / 9) + rng.normal(0, bump / 10, x.shape)
    mu = np.r_[4, np.ones(nu - 4, int), 4]
    mv = np.r_[4, np.ones(nv - 4, int), 4]
    return BSplineSurface(np.stack([x, y, z], -1), None, tu, tv, mu, mv, 3, 3, False, False)


def _offset_points(g: BSplineSurface, d: float, us: np.ndarray, vs: np.ndarray) -> np.ndarray:
    from OCP.Geom import Geom_OffsetSurface

    from nurbscomp.occ.geometry import GeometryBuilder

    s = Geom_OffsetSurface(GeometryBuilder([g], [], []).surface(0), d)
    out = np.empty((len(us), len(vs), 3))
    for i, u in enumerate(us.tolist()):
        for j, v in enumerate(vs.tolist()):
            p = s.Value(u, v)
            out[i, j] = p.X(), p.Y(), p.Z()
    return out


def _normals(g: BSplineSurface, us: np.ndarray, vs: np.ndarray) -> np.ndarray:
    from OCP.gp import gp_Pnt, gp_Vec

    from nurbscomp.occ.geometry import GeometryBuilder

    s = GeometryBuilder([g], [], []).surface(0)
    out = np.empty((len(us), len(vs)))
    p, du, dv = gp_Pnt(), gp_Vec(), gp_Vec()
    for i, u in enumerate(us.tolist()):
        for j, v in enumerate(vs.tolist()):
            s.D1(u, v, p, du, dv)
            out[i, j] = du.Crossed(dv).Magnitude()
    return out


WHOLE = (0.0, 1.0, 0.0, 1.0)


def test_n_min_of_a_plane_is_its_jacobian() -> None:
    g = _surface(0, bump=0.0)
    g = BSplineSurface(
        g.poles * np.array([1, 1, 0]), None, g.uknots, g.vknots, g.umults, g.vmults, 3, 3,
        False, False,
    )  # fmt: skip
    t = offsets.terms(g, WHOLE)
    assert t is not None
    n = _normals(g, np.linspace(0, 1, 23), np.linspace(0, 1, 19))
    assert t.n_min <= n.min() + 1e-6
    # the knots are not uniform: the parametrisation stretches, so the bound
    # is below the smallest sample, but not far below it
    assert t.n_min > 0.5 * n.min()


@settings(max_examples=12, deadline=None)
@given(seed=st.integers(0, 10_000), d=st.floats(-3.0, 3.0), b=st.floats(1e-4, 0.05))
def test_offset_move_is_bounded(seed: int, d: float, b: float) -> None:
    """Poles moved by at most b: the offset by d moves by at most gain(b)·b
    at every sample, and n_min is below every sample of |S_u × S_v|."""
    g = _surface(seed)
    t = offsets.terms(g, WHOLE)
    if t is None:
        return
    us, vs = np.linspace(0, 1, 31), np.linspace(0, 1, 27)
    assert t.n_min <= _normals(g, us, vs).min() * (1 + 1e-9)
    rng = np.random.default_rng(seed + 1)
    e = rng.uniform(-1, 1, g.poles.shape)
    e *= b / np.sqrt((e * e).sum(-1)).max()
    h = BSplineSurface(
        g.poles + e, None, g.uknots, g.vknots, g.umults, g.vmults, 3, 3, False, False
    )
    bound = offsets.moved(g, h, d, WHOLE)
    assert math.isclose(bound, t.gain(d, b) * b, rel_tol=1e-9)
    moved = np.sqrt(((_offset_points(h, d, us, vs) - _offset_points(g, d, us, vs)) ** 2).sum(-1))
    # the points differ by rounding too (an ulp of 40 mm): d = 0 makes the bound b itself
    assert moved.max() <= bound + 1e-12 * np.abs(g.poles).max()


def _tube(seed: int, n: int = 9, nv: int = 5) -> BSplineSurface:
    """A cubic B-spline tube, periodic in u (uniform knots, every
    multiplicity 1), open in v, bent and uneven."""
    rng = np.random.default_rng(seed)
    a = np.linspace(0, 2 * np.pi, n, endpoint=False)[:, None]
    z = np.linspace(0, 30, nv)[None, :]
    r = 8 + rng.uniform(-0.8, 0.8, (n, nv))
    poles = np.stack([r * np.cos(a) + 0 * z, r * np.sin(a) + 0.05 * z**1.5, z + 0 * a], -1)
    uk, um = np.linspace(0, 1, n + 1), np.ones(n + 1, int)
    vk, vm = np.r_[0.0, 1.0], np.r_[nv, nv]  # a Bezier direction
    return BSplineSurface(poles, None, uk, vk, um, vm, 3, nv - 1, True, False)


@settings(max_examples=8, deadline=None)
@given(seed=st.integers(0, 10_000), d=st.floats(-2.0, 2.0), b=st.floats(1e-4, 0.05))
def test_periodic_offset_move_is_bounded(seed: int, d: float, b: float) -> None:
    """The same on a basis periodic in u: written out over one period, its
    ends clamped by knot insertion (``offsets._direction``)."""
    g = _tube(seed)
    t = offsets.terms(g, WHOLE)
    assert t is not None
    us, vs = np.linspace(0, 1, 37), np.linspace(0, 1, 11)
    assert t.n_min <= _normals(g, us, vs).min() * (1 + 1e-9)
    e = np.random.default_rng(seed + 1).uniform(-1, 1, g.poles.shape)
    e *= b / np.sqrt((e * e).sum(-1)).max()
    h = BSplineSurface(
        g.poles + e, None, g.uknots, g.vknots, g.umults, g.vmults, 3, g.vdegree, True, False
    )
    moved = np.sqrt(((_offset_points(h, d, us, vs) - _offset_points(g, d, us, vs)) ** 2).sum(-1))
    assert moved.max() <= offsets.moved(g, h, d, WHOLE) + 1e-12 * np.abs(g.poles).max()


def test_periodic_direction_written_out_is_the_same_surface() -> None:
    from nurbscomp import bspline
    from nurbscomp.occ.geometry import GeometryBuilder

    g = _tube(5)
    p, tu = offsets._direction(np.asarray(g.poles), g.uknots, g.umults, 3, True, 0)
    tv = np.repeat(g.vknots, g.vmults).astype(float)
    us, vs = np.linspace(0, 1, 29), np.linspace(0, 1, 7)
    a = bspline.points(tu, p.reshape(len(p), -1), 3, us).reshape(len(us), p.shape[1], 3)
    mine = bspline.points(tv, a.transpose(1, 0, 2).reshape(p.shape[1], -1), g.vdegree, vs)
    mine = mine.reshape(len(vs), len(us), 3).transpose(1, 0, 2)
    s = GeometryBuilder([g], [], []).surface(0)
    ref = np.array([[[*s.Value(u, v).Coord()] for v in vs.tolist()] for u in us.tolist()])
    assert np.abs(mine - ref).max() < 1e-9


def test_moved_refuses_other_knots() -> None:
    g = _surface(3)
    h = BSplineSurface(
        g.poles, None, g.uknots * 0.5 + 0.25 * (g.uknots > 0), g.vknots, g.umults, g.vmults,
        3, 3, False, False,
    )  # fmt: skip
    assert offsets.moved(g, h, 1.0, WHOLE) == math.inf
    assert offsets.moved(g, g, 1.0, WHOLE) == 0.0


@pytest.mark.slow
@pytest.mark.parametrize("tol", [0.1, 0.01])
def test_offset_face_coded_within_tol(thick_step, tmp_path, monkeypatch, tol: float) -> None:
    """The offset face's basis is coded, not stored exact: the container is
    smaller than with it exact; the certified bound and an independent
    sample of every face stay within tol; the shape is valid."""
    out = tmp_path / "new.nzc"
    report = pipeline.compress_file(thick_step, out, tol=tol)
    m, _ = pipeline.decode(pipeline.read_container(out), None)
    on_offset = [
        f
        for f, r in enumerate(m.face_surface.tolist())
        if isinstance(m.surfaces[r], Derived) and m.surfaces[r].kind == Kind.OFFSET_SURFACE
    ]
    assert on_offset, "the case this test is about"
    assert 0 < report["max_bound_mm"] <= tol
    monkeypatch.setattr(offsets, "MAX_GAIN", 0.0)  # every offset basis exact, as before
    old = tmp_path / "old.nzc"
    pipeline.compress_file(thick_step, old, tol=tol)
    assert out.stat().st_size < old.stat().st_size - 1000
    back = pipeline.decode_file(out)[0]
    src = occ.read_cad(thick_step).shape
    assert occ.is_valid(back)
    dev = occ.deviation(src, back, n=15)
    assert dev.max() <= tol
    assert dev[on_offset].max() > 0  # the offset face did move


@pytest.mark.slow
def test_coded_offset_basis_never_costs_more(tmp_path, monkeypatch) -> None:
    """A revolved spline body shelled from its flat bottom, as an IGES faces
    model: its offset face lies on a periodic basis, and coding that basis
    sends the face up the validity ladder for more than the basis cost.  The
    part is then coded again with the basis exact and the smaller kept: no
    larger than with offset bases never coded."""
    import cadquery as cq
    from OCP.BRepOffsetAPI import BRepOffsetAPI_MakeThickSolid
    from OCP.TopTools import TopTools_ListOfShape

    from tests.stress.files import write_iges

    body = (
        cq.Workplane("XZ")
        .spline([(5, 0), (8, 6), (6, 12), (3, 16)])
        .lineTo(0, 16)
        .lineTo(0, 0)
        .close()
        .revolve()
        .val()
    )
    opened = TopTools_ListOfShape()
    opened.Append(min(body.Faces(), key=lambda f: f.Center().z).wrapped)
    thick = BRepOffsetAPI_MakeThickSolid()
    thick.MakeThickSolidByJoin(body.wrapped, opened, -0.6, 1e-3)
    thick.Build()
    src = tmp_path / "shelled.faces.igs"
    write_iges(thick.Shape(), src, 0)
    sizes = []
    for gain in (offsets.MAX_GAIN, 0.0):
        monkeypatch.setattr(offsets, "MAX_GAIN", gain)
        out = tmp_path / f"{gain}.nzc"
        pipeline.compress_file(src, out, tol=0.1)
        sizes.append(out.stat().st_size)
    assert sizes[0] <= sizes[1], sizes
