"""The stress corpus: a seeded generator of varied B-rep shapes (issue 10).

:func:`entries` lists over 200 shapes in fifteen categories, each an
:class:`Entry` with a short unique name and a builder that returns a
``TopoDS_Shape``.  The parameters of every shape (radii, degrees, knots,
multiplicities, weights, poles, placements) are drawn from a numpy generator
seeded by ``(seed, category)`` when the list is made, so the same seed gives
the same shapes, and a category's shapes do not change when another category
grows.  Building is lazy: only the shapes asked for are built.

Categories (see ``CATEGORIES``):

``fillet``, ``chamfer``
    boxes and cylinders with fillets / chamfers of varied radii and edge sets;
``shell``
    cadquery ``.shell()`` of boxes, cylinders, filleted boxes, and hollow solids;
``loft``, ``sweep``, ``revolve``
    lofts through closed and open spline sections (two shelled: offset
    surfaces whose edges OCCT approximates by curves of hundreds of poles;
    two filleted at both ends: fillets that OCCT's STEP reader mends), sweeps
    of circles and spline sections along spline paths, revolves of spline
    profiles (partial, and touching the axis);
``periodic``
    one face each on a periodic B-spline surface: periodic in u, v or both;
    degrees 1-5; uniform and non-uniform knots; interior multiplicities > 1;
    made by ``GeomAPI_PointsToBSplineSurface.Interpolate(..., periodic)``, by
    ``SetUPeriodic``/``SetVPeriodic`` on a clamped surface, or directly;
    some rational, some with fewer poles than degree + 1;
``net``
    small and odd nets: 2 x N and N x 2, one-span nets, Bezier surfaces
    (rational too), rational B-splines, closed (non-periodic) surfaces, and
    degenerate ones (a row of poles collapsed to a point);
``trimmed``
    faces on B-spline surfaces with an outer wire and one to three holes;
``compound``
    compounds of several solids;
``instance``
    one TShape under several locations, a mirror among them;
``sewn``
    open shells sewn (``BRepBuilderAPI_Sewing``) from several faces;
``seam``
    faces with seam and degenerated edges: spheres, cones, revolved surfaces;
``analytic``
    single faces on planes, cylinders, cones, spheres, tori, extrusions,
    revolutions and offset surfaces;
``feature``
    what modelling operations leave behind: booleans of lofts with primitives
    and with each other, thick solids (a face removed, the rest offset
    inwards), offset shapes, a box split by a B-spline face, cells of a
    general fuse, and solids converted to NURBS (rational faces, seams and
    degenerated edges at once).  Their faces meet along edges cut at other
    points than their neighbours' once written as faces-mode IGES.

Every shape is meant to be valid (``BRepCheck_Analyzer``); an entry whose
``invalid`` field is set is deliberately not (none is at present).  Run
``python -m tests.stress.shapes`` to build them all and print counts, faces,
validity and the time taken.
"""

from __future__ import annotations

import argparse
import math
import time
import zlib
from collections import Counter
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import partial
from typing import Any

import cadquery as cq
import numpy as np
from OCP.BRep import BRep_Builder
from OCP.BRepBuilderAPI import (
    BRepBuilderAPI_MakeEdge,
    BRepBuilderAPI_MakeFace,
    BRepBuilderAPI_MakeWire,
    BRepBuilderAPI_NurbsConvert,
    BRepBuilderAPI_Sewing,
)
from OCP.BRepCheck import BRepCheck_Analyzer
from OCP.BRepLib import BRepLib
from OCP.BRepOffsetAPI import BRepOffsetAPI_ThruSections
from OCP.BRepPrimAPI import BRepPrimAPI_MakeRevol
from OCP.Geom import (
    Geom_BezierSurface,
    Geom_BSplineCurve,
    Geom_BSplineSurface,
    Geom_ConicalSurface,
    Geom_CylindricalSurface,
    Geom_OffsetSurface,
    Geom_Plane,
    Geom_SphericalSurface,
    Geom_SurfaceOfLinearExtrusion,
    Geom_SurfaceOfRevolution,
    Geom_ToroidalSurface,
)
from OCP.Geom2d import Geom2d_Circle, Geom2d_Ellipse, Geom2d_Line
from OCP.GeomAPI import GeomAPI_PointsToBSplineSurface
from OCP.gp import (
    gp_Ax1,
    gp_Ax2,
    gp_Ax2d,
    gp_Ax3,
    gp_Dir,
    gp_Dir2d,
    gp_Pnt,
    gp_Pnt2d,
    gp_Trsf,
    gp_Vec,
)
from OCP.ShapeFix import ShapeFix_Face
from OCP.TColgp import TColgp_Array1OfPnt, TColgp_Array2OfPnt
from OCP.TColStd import (
    TColStd_Array1OfInteger,
    TColStd_Array1OfReal,
    TColStd_Array2OfReal,
)
from OCP.TopAbs import TopAbs_FACE
from OCP.TopExp import TopExp_Explorer
from OCP.TopLoc import TopLoc_Location
from OCP.TopoDS import TopoDS, TopoDS_Compound, TopoDS_Shape

#: Tolerance for degenerated edges when a face is made on a whole surface.
TOL_DEGEN = 1e-7


@dataclass(frozen=True)
class Entry:
    """One generated shape.

    Attributes
    ----------
    name : str
        Short and unique, ``<category>_<kind>_<nn>``; used as the file stem.
    category : str
    build : callable
        Returns the ``TopoDS_Shape`` (millimetres).
    invalid : str
        Empty for a shape meant to be valid; otherwise why it is deliberately not.
    """

    name: str
    category: str
    build: Callable[[], TopoDS_Shape]
    invalid: str = ""


# ---------------------------------------------------------------- OCP helpers


def _pnt(p: Sequence[float]) -> gp_Pnt:
    return gp_Pnt(float(p[0]), float(p[1]), float(p[2]))


def _reals(values: Sequence[float]) -> TColStd_Array1OfReal:
    a = TColStd_Array1OfReal(1, len(values))
    for i, v in enumerate(values):
        a.SetValue(i + 1, float(v))
    return a


def _ints(values: Sequence[int]) -> TColStd_Array1OfInteger:
    a = TColStd_Array1OfInteger(1, len(values))
    for i, v in enumerate(values):
        a.SetValue(i + 1, int(v))
    return a


def _array2(values: np.ndarray, cls: Any, item: Callable[[np.ndarray], Any]) -> Any:
    """An OCCT 2-D array (1-based) of ``cls`` holding ``item`` of each entry."""
    nu, nv = values.shape[:2]
    a = cls(1, nu, 1, nv)
    for i in range(nu):
        for j in range(nv):
            a.SetValue(i + 1, j + 1, item(values[i, j]))
    return a


def _poles2(poles: np.ndarray) -> TColgp_Array2OfPnt:
    return _array2(poles, TColgp_Array2OfPnt, _pnt)


def _weights2(w: np.ndarray) -> TColStd_Array2OfReal:
    return _array2(w, TColStd_Array2OfReal, float)


def _poles1(poles: np.ndarray) -> TColgp_Array1OfPnt:
    a = TColgp_Array1OfPnt(1, len(poles))
    for i, p in enumerate(poles):
        a.SetValue(i + 1, _pnt(p))
    return a


def bspline_surface(
    poles: np.ndarray,
    uknots: Sequence[float],
    umults: Sequence[int],
    vknots: Sequence[float],
    vmults: Sequence[int],
    udeg: int,
    vdeg: int,
    uper: bool = False,
    vper: bool = False,
    weights: np.ndarray | None = None,
) -> Geom_BSplineSurface:
    """A ``Geom_BSplineSurface`` from numpy poles (nu, nv, 3) and optional weights (nu, nv)."""
    args: list[Any] = [_poles2(poles)]
    if weights is not None:
        args.append(_weights2(weights))
    args += [_reals(uknots), _reals(vknots), _ints(umults), _ints(vmults), udeg, vdeg, uper, vper]
    return Geom_BSplineSurface(*args)


def face_on(surface: Any, bounds: Sequence[float] | None = None) -> TopoDS_Shape:
    """A face on a whole surface (``MakeFace(surface, 1e-7)``) or on a UV box."""
    if bounds is None:
        mk = BRepBuilderAPI_MakeFace(surface, TOL_DEGEN)
    else:
        mk = BRepBuilderAPI_MakeFace(surface, *map(float, bounds), TOL_DEGEN)
    if not mk.IsDone():
        raise RuntimeError(f"MakeFace failed ({mk.Error()})")
    return mk.Face()


def compound(shapes: Sequence[TopoDS_Shape]) -> TopoDS_Compound:
    c = TopoDS_Compound()
    b = BRep_Builder()
    b.MakeCompound(c)
    for s in shapes:
        b.Add(c, s)
    return c


def knot_vector(
    rng: np.random.Generator,
    n: int,
    degree: int,
    periodic: bool,
    uniform: bool,
    max_mult: int = 1,
) -> tuple[list[float], list[int]]:
    """Distinct knots and multiplicities of an OCCT B-spline with ``n`` poles.

    Non-periodic: clamped ends (multiplicity degree + 1), sum(mults) = n +
    degree + 1.  Periodic: mults[0] == mults[-1] and sum(mults) - mults[-1]
    = n.  Interior multiplicities are drawn from 1 .. min(max_mult, degree).
    """
    top = max(1, min(max_mult, degree))
    if periodic:
        first = int(rng.integers(1, min(top, n) + 1))
        left = n - first
    else:
        if n < degree + 1:
            raise ValueError(f"{n} poles cannot carry degree {degree}")
        first = degree + 1
        left = n - degree - 1
    inner: list[int] = []
    while left > 0:
        m = int(rng.integers(1, min(top, left) + 1))
        inner.append(m)
        left -= m
    mults = [first, *inner, first]
    if uniform:
        knots = [float(i) for i in range(len(mults))]
    else:
        knots = np.concatenate([[0.0], np.cumsum(rng.uniform(0.3, 1.7, len(mults) - 1))]).tolist()
    return knots, mults


def _bumpy(rng: np.random.Generator, nu: int, nv: int, size: float, amp: float) -> np.ndarray:
    """A height field net over [0, size]^2 with random bumps, shape (nu, nv, 3)."""
    x = np.linspace(0, size, nu)[:, None] * np.ones((1, nv))
    y = np.linspace(0, size, nv)[None, :] * np.ones((nu, 1))
    z = amp * rng.standard_normal((nu, nv))
    return np.stack([x, y, z], -1)


def _tube(
    rng: np.random.Generator, nu: int, nv: int, radius: float, height: float, wobble: float
) -> np.ndarray:
    """A net around the z axis: u goes round (nu poles, not repeated), v up."""
    a = 2 * np.pi * np.arange(nu) / nu
    r = radius * (1 + wobble * rng.standard_normal((nu, nv)))
    z = np.linspace(0, height, nv)[None, :] + wobble * radius * rng.standard_normal((nu, nv))
    return np.stack([r * np.cos(a)[:, None], r * np.sin(a)[:, None], z], -1)


def _torus_net(rng: np.random.Generator, nu: int, nv: int, big: float, small: float) -> np.ndarray:
    """A net round a torus, periodic both ways (no pole repeated), shape (nu, nv, 3)."""
    a = 2 * np.pi * np.arange(nu)[:, None] / nu
    b = 2 * np.pi * np.arange(nv)[None, :] / nv
    r = small * (1 + 0.15 * rng.standard_normal((nu, nv)))
    rho = big + r * np.cos(b)
    return np.stack([rho * np.cos(a), rho * np.sin(a), r * np.sin(b)], -1)


def _weights(rng: np.random.Generator, shape: tuple[int, ...]) -> np.ndarray:
    return rng.uniform(0.5, 2.0, shape)


def _unit(rng: np.random.Generator) -> np.ndarray:
    v = rng.standard_normal(3)
    return v / np.linalg.norm(v)


def _frame(rng: np.random.Generator, spread: float = 20.0) -> gp_Ax3:
    """A random right-handed frame."""
    z = _unit(rng)
    x = np.cross(z, _unit(rng))
    x /= np.linalg.norm(x)
    o = rng.uniform(-spread, spread, 3)
    return gp_Ax3(_pnt(o), gp_Dir(*map(float, z)), gp_Dir(*map(float, x)))


def _vecs(points: np.ndarray) -> list[cq.Vector]:
    return [cq.Vector(*map(float, p)) for p in points]


# ---------------------------------------------------------------- categories


def _fillets(rng: np.random.Generator) -> list[tuple[str, Callable[[], TopoDS_Shape]]]:
    out: list[tuple[str, Callable[[], TopoDS_Shape]]] = []
    selectors = ["|Z", ">Z", "<X", None, "|X", "#Z"]
    for k in range(10):
        a, b, c = rng.uniform(8, 40, 3)
        sel = selectors[k % len(selectors)]
        r = float(rng.uniform(0.05, 0.45) * min(a, b, c) / 2)
        if sel is None:  # every edge: radius below half the thinnest side
            r = float(rng.uniform(0.05, 0.9) * min(a, b, c) / 2)
        out.append((f"box_{k:02d}", partial(_fillet_box, a, b, c, sel, r)))
    for k in range(6):
        r, h = rng.uniform(3, 15), rng.uniform(5, 30)
        f = float(rng.uniform(0.05, 0.45) * min(r, h / 2))
        sel = ">Z" if k % 2 else None
        out.append((f"cyl_{k:02d}", partial(_fillet_cyl, r, h, f, sel)))
    return out


def _fillet_box(a: float, b: float, c: float, sel: str | None, r: float) -> TopoDS_Shape:
    w = cq.Workplane("XY").box(a, b, c)
    edges = w.edges(sel) if sel else w.edges()
    return edges.fillet(r).val().wrapped


def _fillet_cyl(r: float, h: float, f: float, sel: str | None) -> TopoDS_Shape:
    w = cq.Workplane("XY").circle(r).extrude(h)
    edges = w.edges(sel) if sel else w.edges()
    return edges.fillet(f).val().wrapped


def _chamfers(rng: np.random.Generator) -> list[tuple[str, Callable[[], TopoDS_Shape]]]:
    out: list[tuple[str, Callable[[], TopoDS_Shape]]] = []
    selectors = ["|Z", ">Z", None, "<Y", "|Y", None]
    for k in range(8):
        a, b, c = rng.uniform(8, 40, 3)
        d = float(rng.uniform(0.05, 0.4) * min(a, b, c) / 2)
        d2 = float(rng.uniform(0.05, 0.4) * min(a, b, c) / 2) if k % 3 == 1 else None
        out.append((f"box_{k:02d}", partial(_chamfer_box, a, b, c, selectors[k % 6], d, d2)))
    for k in range(4):
        r, h = rng.uniform(3, 15), rng.uniform(5, 30)
        d = float(rng.uniform(0.05, 0.4) * min(r, h / 2))
        d2 = float(rng.uniform(0.05, 0.4) * min(r, h / 2)) if k % 2 else None
        out.append((f"cyl_{k:02d}", partial(_chamfer_cyl, r, h, d, d2)))
    return out


def _chamfer_box(
    a: float, b: float, c: float, sel: str | None, d: float, d2: float | None
) -> TopoDS_Shape:
    w = cq.Workplane("XY").box(a, b, c)
    edges = w.edges(sel) if sel else w.edges()
    return (edges.chamfer(d, d2) if d2 else edges.chamfer(d)).val().wrapped


def _chamfer_cyl(r: float, h: float, d: float, d2: float | None) -> TopoDS_Shape:
    w = cq.Workplane("XY").circle(r).extrude(h).edges()
    return (w.chamfer(d, d2) if d2 else w.chamfer(d)).val().wrapped


def _shells(rng: np.random.Generator) -> list[tuple[str, Callable[[], TopoDS_Shape]]]:
    out: list[tuple[str, Callable[[], TopoDS_Shape]]] = []
    kinds = ["box", "box_in", "cyl", "filleted", "hollow"]
    for k in range(10):
        kind = kinds[k % len(kinds)]
        a, b, c = rng.uniform(10, 40, 3)
        t = float(rng.uniform(0.5, 0.15 * min(a, b, c)))
        out.append((f"{kind}_{k:02d}", partial(_shell, kind, a, b, c, t)))
    return out


def _shell(kind: str, a: float, b: float, c: float, t: float) -> TopoDS_Shape:
    if kind == "box":
        return cq.Workplane("XY").box(a, b, c).faces(">Z").shell(-t).val().wrapped
    if kind == "box_in":  # outward, two faces removed
        return cq.Workplane("XY").box(a, b, c).faces(">Z or <X").shell(t).val().wrapped
    if kind == "cyl":
        return cq.Workplane("XY").circle(a / 2).extrude(c).faces(">Z").shell(-t).val().wrapped
    if kind == "filleted":
        w = cq.Workplane("XY").box(a, b, c).edges("|Z").fillet(min(a, b) / 5)
        return w.faces(">Z").shell(-t).val().wrapped
    # a hollow solid: an outer and an inner shell
    return cq.Workplane("XY").box(a, b, c).shell(-t).val().wrapped


def _closed_spline(rng: np.random.Generator, n: int, r: float, z: float) -> np.ndarray:
    a = np.sort(rng.uniform(0, 2 * np.pi, n))
    a = 2 * np.pi * np.arange(n) / n + 0.3 * (a - a.mean()) / n
    rr = r * (1 + 0.2 * rng.uniform(-1, 1, n))
    return np.stack([rr * np.cos(a), rr * np.sin(a), np.full(n, z)], -1)


def _lofts(rng: np.random.Generator) -> list[tuple[str, Callable[[], TopoDS_Shape]]]:
    out: list[tuple[str, Callable[[], TopoDS_Shape]]] = []
    for k in range(8):
        ns = int(rng.integers(2, 5))
        sections = [
            _closed_spline(rng, int(rng.integers(4, 9)), rng.uniform(5, 15), z)
            for z in np.cumsum(rng.uniform(5, 15, ns))
        ]
        out.append((f"closed_{k:02d}", partial(_loft_closed, sections, k % 4 == 3)))
    for k in range(4):
        ns = int(rng.integers(2, 5))
        npts = int(rng.integers(3, 8))
        sections = [
            np.stack(
                [np.linspace(0, 30, npts), rng.uniform(-3, 3, npts) + y, rng.uniform(-3, 3, npts)],
                -1,
            )
            for y in np.cumsum(rng.uniform(5, 12, ns))
        ]
        out.append((f"open_{k:02d}", partial(_loft_open, sections, k % 2 == 1)))
    # shelled lofts (offset surfaces, whose edges OCCT approximates by curves
    # of hundreds of poles) and lofts filleted at both ends (fillets that
    # OCCT's STEP reader mends)
    for k in range(2):
        sections = [
            _closed_spline(rng, int(rng.integers(6, 13)), rng.uniform(9, 14), z)
            for z in np.cumsum(rng.uniform(6, 10, 4))
        ]
        out.append((f"shelled_{k:02d}", partial(_loft_shelled, sections, rng.uniform(0.6, 1.2))))
    for k in range(2):
        out.append((f"filleted_{k:02d}", partial(_loft_filleted, rng.uniform(18, 22))))
    return out


def _loft_shelled(sections: list[np.ndarray], thick: float) -> TopoDS_Shape:
    solid = cq.Workplane().add(cq.Shape.cast(_loft_closed(sections, False)))
    return solid.faces(">Z").shell(-float(thick)).val().wrapped


def _loft_filleted(w: float) -> TopoDS_Shape:
    w = float(w)
    loft = cq.Workplane().rect(w, w / 2).workplane(offset=w / 2).circle(0.3 * w)
    loft = loft.workplane(offset=w / 2).rect(0.4 * w, 0.8 * w).loft()
    return loft.edges(">Z or <Z").fillet(0.05 * w).val().wrapped


def _loft_closed(sections: list[np.ndarray], ruled: bool) -> TopoDS_Shape:
    wires = [cq.Wire.assembleEdges([cq.Edge.makeSpline(_vecs(s), periodic=True)]) for s in sections]
    return cq.Solid.makeLoft(wires, ruled).wrapped


def _loft_open(sections: list[np.ndarray], ruled: bool) -> TopoDS_Shape:
    ts = BRepOffsetAPI_ThruSections(False, ruled)
    for s in sections:
        ts.AddWire(cq.Wire.assembleEdges([cq.Edge.makeSpline(_vecs(s))]).wrapped)
    ts.Build()
    return ts.Shape()


def _sweeps(rng: np.random.Generator) -> list[tuple[str, Callable[[], TopoDS_Shape]]]:
    out: list[tuple[str, Callable[[], TopoDS_Shape]]] = []
    profiles = ["circle", "spline", "tube", "spline"]
    for k in range(12):
        n = int(rng.integers(3, 7))
        path = np.cumsum(
            np.stack([rng.uniform(8, 15, n), rng.uniform(-6, 6, n), rng.uniform(-6, 6, n)], -1),
            0,
        )
        path = np.vstack([[0.0, 0.0, 0.0], path])
        r = float(rng.uniform(1, 3))
        sec = _closed_spline(rng, int(rng.integers(4, 8)), r, 0.0)[:, :2]
        out.append(
            (
                f"{profiles[k % 4]}_{k:02d}",
                partial(_sweep, path, profiles[k % 4], r, sec, bool(k % 3 == 2)),
            )
        )
    return out


def _sweep(path: np.ndarray, profile: str, r: float, sec: np.ndarray, frenet: bool) -> TopoDS_Shape:
    spine = cq.Wire.assembleEdges([cq.Edge.makeSpline(_vecs(path))])
    t = spine.tangentAt(0)
    z = np.array(t.toTuple())
    x = np.cross(z, [0.0, 0.0, 1.0] if abs(z[2]) < 0.9 else [1.0, 0.0, 0.0])
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    o = path[0]
    if profile in ("circle", "tube"):
        outer = cq.Wire.makeCircle(r, cq.Vector(*o), t)
        inner = [cq.Wire.makeCircle(r / 2, cq.Vector(*o), t)] if profile == "tube" else []
        return cq.Solid.sweep(outer, inner, spine, True, frenet).wrapped
    pts = o + sec[:, :1] * x + sec[:, 1:2] * y
    outer = cq.Wire.assembleEdges([cq.Edge.makeSpline(_vecs(pts), periodic=True)])
    return cq.Solid.sweep(outer, [], spine, True, frenet).wrapped


def _revolves(rng: np.random.Generator) -> list[tuple[str, Callable[[], TopoDS_Shape]]]:
    out: list[tuple[str, Callable[[], TopoDS_Shape]]] = []
    kinds = ["ring", "axis", "partial", "closed"]
    for k in range(12):
        kind = kinds[k % 4]
        n = int(rng.integers(3, 7))
        h = float(rng.uniform(10, 30))
        xs = rng.uniform(4, 12, n)
        zs = np.linspace(0, h, n)
        angle = float(rng.uniform(60, 300)) if kind == "partial" else 360.0
        prof = np.stack([xs, np.zeros(n), zs], -1)
        sec = _closed_spline(rng, int(rng.integers(4, 8)), rng.uniform(2, 4), 0.0)
        out.append((f"{kind}_{k:02d}", partial(_revolve, kind, prof, angle, sec)))
    return out


def _revolve(kind: str, prof: np.ndarray, angle: float, sec: np.ndarray) -> TopoDS_Shape:
    axis = (cq.Vector(0, 0, 0), cq.Vector(0, 0, 1))
    if kind == "closed":  # a closed spline section away from the axis: a spline torus
        pts = np.stack([sec[:, 0] + 10, sec[:, 2], sec[:, 1]], -1)
        wire = cq.Wire.assembleEdges([cq.Edge.makeSpline(_vecs(pts), periodic=True)])
        return cq.Solid.revolve(wire, [], angle, *axis).wrapped
    spline = cq.Edge.makeSpline(_vecs(prof))
    a, b = prof[0], prof[-1]
    if kind == "ring":  # a band between the spline and a line parallel to the axis
        inner = min(prof[:, 0].min() / 2, 2.0)
        p = [cq.Vector(*b), cq.Vector(inner, 0, b[2]), cq.Vector(inner, 0, a[2]), cq.Vector(*a)]
        edges = [spline] + [cq.Edge.makeLine(p[i], p[i + 1]) for i in range(3)]
    else:  # down to the axis: an apex-free disc at each end
        p = [cq.Vector(*b), cq.Vector(0, 0, b[2]), cq.Vector(0, 0, a[2]), cq.Vector(*a)]
        edges = [spline] + [cq.Edge.makeLine(p[i], p[i + 1]) for i in range(3)]
    return cq.Solid.revolve(cq.Wire.assembleEdges(edges), [], angle, *axis).wrapped


def _periodic(rng: np.random.Generator) -> list[tuple[str, Callable[[], TopoDS_Shape]]]:
    out: list[tuple[str, Callable[[], TopoDS_Shape]]] = []
    # GeomAPI_PointsToBSplineSurface.Interpolate(points, periodic): periodic in u,
    # swapped for v, and made periodic in v too by SetVPeriodic
    for k in range(6):
        nu, nv = int(rng.integers(4, 11)), int(rng.integers(3, 8))
        pts = _tube(rng, nu, nv, rng.uniform(5, 15), rng.uniform(10, 30), 0.05)
        how = ("u", "v", "uv")[k % 3]
        out.append((f"interp_{how}_{k:02d}", partial(_interp_periodic, pts, how)))
    # SetUPeriodic / SetVPeriodic on a clamped surface
    for k in range(10):
        how = ("u", "v", "uv")[k % 3]
        du, dv = int(rng.integers(1, 6)), int(rng.integers(1, 6))
        # SetXPeriodic keeps n - 1 poles: at least 2, and at least the degree
        nu, nv = (
            int(rng.integers(max(du + 1, 3), du + 8)),
            int(rng.integers(max(dv + 1, 3), dv + 8)),
        )
        uk, um = knot_vector(rng, nu, du, False, k % 2 == 0, int(rng.integers(1, 4)))
        vk, vm = knot_vector(rng, nv, dv, False, k % 4 < 2, int(rng.integers(1, 4)))
        pts = _tube(rng, nu, nv, rng.uniform(5, 15), rng.uniform(10, 30), 0.1)
        if how == "v":
            pts = pts.transpose(1, 0, 2)
            uk, um, vk, vm, du, dv = vk, vm, uk, um, dv, du
        w = _weights(rng, pts.shape[:2]) if k % 4 == 3 else None
        g = (pts, uk, um, vk, vm, du, dv, False, False, w)
        out.append((f"setper_{how}_d{du}{dv}_{k:02d}", partial(_set_periodic, g, how)))
    # built periodic: every degree 1-5 in the periodic direction, uniform and
    # not, interior multiplicities up to the degree, rational or not
    for k in range(24):
        how = ("u", "v", "uv")[k % 3]
        dp = k % 5 + 1  # degree in the periodic direction(s)
        do = int(rng.integers(1, 6))
        mm = int(rng.integers(1, dp + 1))
        uniform = (k // 3) % 2 == 0
        np_ = int(rng.integers(max(2, dp) if k % 7 == 6 else dp + 1, dp + 9))
        if how == "uv":
            nu, nv = np_, int(rng.integers(max(2, dp) if k % 5 == 4 else dp + 1, dp + 7))
            uk, um = knot_vector(rng, nu, dp, True, uniform, mm)
            vk, vm = knot_vector(rng, nv, dp, True, not uniform, mm)
            pts = _torus_net(rng, nu, nv, rng.uniform(10, 20), rng.uniform(2, 6))
            du, dv = dp, dp
        else:
            no = int(rng.integers(do + 1, do + 7))
            uk, um = knot_vector(rng, np_, dp, True, uniform, mm)
            vk, vm = knot_vector(rng, no, do, False, not uniform, mm)
            pts = _tube(rng, np_, no, rng.uniform(5, 15), rng.uniform(10, 30), 0.1)
            du, dv = dp, do
            if how == "v":
                pts = pts.transpose(1, 0, 2)
                uk, um, vk, vm, du, dv = vk, vm, uk, um, dv, du
        w = _weights(rng, pts.shape[:2]) if k % 4 == 1 else None
        g = (pts, uk, um, vk, vm, du, dv, how != "v", how != "u", w)
        tag = "r" if w is not None else ""
        out.append((f"built_{how}_d{du}{dv}{tag}_{k:02d}", partial(_surface_face, g)))
    # periodic with as many poles as the degree, the fewest OCCT's STEP and IGES
    # writers take (with fewer, OCCT builds the surface but the STEP writer
    # leaves it out and the IGES writer raises)
    for k, (how, dp, n) in enumerate([("u", 3, 3), ("v", 4, 4), ("uv", 5, 5), ("u", 2, 2)]):
        do = int(rng.integers(1, 4))
        no = int(rng.integers(do + 1, do + 5))
        uk, um = knot_vector(rng, n, dp, True, k % 2 == 0, 1)
        if how == "uv":
            vk, vm = knot_vector(rng, n + 1, dp, True, True, 1)
            pts, du, dv = _torus_net(rng, n, n + 1, 15.0, 4.0), dp, dp
        else:
            vk, vm = knot_vector(rng, no, do, False, True, 1)
            pts, du, dv = _tube(rng, n, no, 10.0, 20.0, 0.1), dp, do
            if how == "v":
                pts = pts.transpose(1, 0, 2)
                uk, um, vk, vm, du, dv = vk, vm, uk, um, dv, du
        w = _weights(rng, pts.shape[:2]) if k == 1 else None
        g = (pts, uk, um, vk, vm, du, dv, how != "v", how != "u", w)
        out.append((f"few_{how}_d{du}{dv}_{k:02d}", partial(_surface_face, g)))
    return out


def _interp_periodic(pts: np.ndarray, how: str) -> TopoDS_Shape:
    api = GeomAPI_PointsToBSplineSurface()
    api.Interpolate(_poles2(pts), True)
    s = api.Surface()
    if how == "v":
        s.ExchangeUV()
    elif how == "uv":
        s.SetVPeriodic()
    return face_on(s)


def _set_periodic(g: tuple[Any, ...], how: str) -> TopoDS_Shape:
    s = bspline_surface(*g)
    if "u" in how:
        s.SetUPeriodic()
    if "v" in how:
        s.SetVPeriodic()
    return face_on(s)


def _surface_face(g: tuple[Any, ...]) -> TopoDS_Shape:
    return face_on(bspline_surface(*g))


def _nets(rng: np.random.Generator) -> list[tuple[str, Callable[[], TopoDS_Shape]]]:
    out: list[tuple[str, Callable[[], TopoDS_Shape]]] = []
    size = 20.0
    # 2 x N and N x 2 (degree 1 across)
    for k in range(5):
        n = int(rng.integers(2, 10))
        d = int(rng.integers(1, min(5, n - 1) + 1)) if n > 2 else 1
        vk, vm = knot_vector(rng, n, d, False, k % 2 == 0, 2)
        pts = _bumpy(rng, 2, n, size, 2.0)
        w = _weights(rng, (2, n)) if k == 3 else None
        g = (pts, [0.0, 1.0], [2, 2], vk, vm, 1, d, False, False, w)
        if k % 2:
            g = (pts.transpose(1, 0, 2), vk, vm, [0.0, 1.0], [2, 2], d, 1, False, False)
            g = (*g, None if w is None else w.T)
        out.append((f"two_by_n_{k:02d}", partial(_surface_face, g)))
    # one span: n = degree + 1 both ways, B-spline records
    for k in range(5):
        du, dv = int(rng.integers(1, 6)), int(rng.integers(1, 6))
        pts = _bumpy(rng, du + 1, dv + 1, size, 3.0)
        w = _weights(rng, pts.shape[:2]) if k % 2 else None
        g = (pts, [0.0, 1.0], [du + 1] * 2, [0.0, 2.0], [dv + 1] * 2, du, dv, False, False, w)
        out.append((f"one_span_{k:02d}", partial(_surface_face, g)))
    # Bezier surfaces, polynomial and rational
    for k in range(5):
        nu, nv = int(rng.integers(2, 8)), int(rng.integers(2, 8))
        pts = _bumpy(rng, nu, nv, size, 3.0)
        w = _weights(rng, (nu, nv)) if k % 2 else None
        out.append((f"bezier_{k:02d}", partial(_bezier, pts, w)))
    # rational B-splines with interior knots
    for k in range(5):
        du, dv = int(rng.integers(1, 5)), int(rng.integers(1, 5))
        nu, nv = int(rng.integers(du + 2, 13)), int(rng.integers(dv + 2, 13))
        uk, um = knot_vector(rng, nu, du, False, k % 2 == 0, 3)
        vk, vm = knot_vector(rng, nv, dv, False, k % 2 == 1, 3)
        pts = _bumpy(rng, nu, nv, size, 2.0)
        g = (pts, uk, um, vk, vm, du, dv, False, False, _weights(rng, (nu, nv)))
        out.append((f"rational_{k:02d}", partial(_surface_face, g)))
    # closed, not periodic: clamped knots, last row of poles = first row
    for k in range(5):
        du, dv = int(rng.integers(1, 4)), int(rng.integers(1, 4))
        nu, nv = int(rng.integers(du + 3, 12)), int(rng.integers(dv + 1, 8))
        uk, um = knot_vector(rng, nu, du, False, k % 2 == 0, 2)
        vk, vm = knot_vector(rng, nv, dv, False, True, 1)
        pts = _tube(rng, nu - 1, nv, rng.uniform(5, 12), rng.uniform(10, 25), 0.05)
        pts = np.concatenate([pts, pts[:1]])
        w = None
        if k % 2:
            w = _weights(rng, (nu, nv))
            w[-1] = w[0]
        g = (pts, uk, um, vk, vm, du, dv, False, False, w)
        out.append((f"closed_{k:02d}", partial(_surface_face, g)))
    # degenerate: a row (or two) of poles collapsed to a point, like a sphere's pole
    for k in range(5):
        du, dv = int(rng.integers(2, 5)), int(rng.integers(1, 4))
        nu, nv = int(rng.integers(du + 1, 10)), int(rng.integers(dv + 2, 9))
        uk, um = knot_vector(rng, nu, du, False, True, 1)
        vk, vm = knot_vector(rng, nv, dv, False, k % 2 == 0, 2)
        # u goes half round (an open fan), v from the pole outwards
        a = np.linspace(0, np.pi * rng.uniform(0.5, 1.5), nu)[:, None]
        rad = np.linspace(0, rng.uniform(8, 15), nv)[None, :] * np.ones((nu, 1))
        z = rng.uniform(-1, 1, (nu, nv)) + 5
        z[:, 0] = 5.0
        pts = np.stack([rad * np.cos(a), rad * np.sin(a), z], -1)
        if k >= 3:  # both ends collapsed: a lens between two poles
            pts[:, -1] = pts[0, -1]
        w = _weights(rng, (nu, nv)) if k == 4 else None
        g = (pts, uk, um, vk, vm, du, dv, False, False, w)
        out.append((f"degen_{k:02d}", partial(_surface_face, g)))
    return out


def _bezier(pts: np.ndarray, w: np.ndarray | None) -> TopoDS_Shape:
    s = (
        Geom_BezierSurface(_poles2(pts))
        if w is None
        else Geom_BezierSurface(_poles2(pts), _weights2(w))
    )
    return face_on(s)


def _trimmed(rng: np.random.Generator) -> list[tuple[str, Callable[[], TopoDS_Shape]]]:
    out: list[tuple[str, Callable[[], TopoDS_Shape]]] = []
    for k in range(10):
        du, dv = int(rng.integers(2, 5)), int(rng.integers(2, 5))
        nu, nv = int(rng.integers(du + 1, 10)), int(rng.integers(dv + 1, 10))
        uk, um = knot_vector(rng, nu, du, False, k % 2 == 0, 2)
        vk, vm = knot_vector(rng, nv, dv, False, True, 1)
        uk = [x / uk[-1] for x in uk]
        vk = [x / vk[-1] for x in vk]
        pts = _bumpy(rng, nu, nv, 30.0, 2.5)
        w = _weights(rng, (nu, nv)) if k % 3 == 2 else None
        g = (pts, uk, um, vk, vm, du, dv, False, False, w)
        outer = ("natural", "ellipse", "polygon")[k % 3]
        nholes = k % 3 + 1
        # holes on a row across the middle, small enough not to touch
        holes = []
        for i in range(nholes):
            cx = (i + 1) / (nholes + 1)
            r = float(rng.uniform(0.04, 0.3 / (nholes + 1)))
            holes.append((cx, 0.5 + rng.uniform(-0.05, 0.05), r, k % 2 == 1))
        out.append((f"{outer}_{nholes}h_{k:02d}", partial(_trimmed_face, g, outer, holes)))
    return out


def _edge_on(curve2d: Any, surf: Any, *rng_: float) -> Any:
    mk = BRepBuilderAPI_MakeEdge(curve2d, surf, *rng_)
    if not mk.IsDone():
        raise RuntimeError("MakeEdge on a surface failed")
    e = mk.Edge()
    BRepLib.BuildCurves3d_s(e)
    return e


def _trimmed_face(g: tuple[Any, ...], outer: str, holes: list[tuple[Any, ...]]) -> TopoDS_Shape:
    s = bspline_surface(*g)
    if outer == "natural":
        mk = BRepBuilderAPI_MakeFace(s, TOL_DEGEN)
    else:
        if outer == "ellipse":
            ax = gp_Ax2d(gp_Pnt2d(0.5, 0.5), gp_Dir2d(1, 0))
            edges = [_edge_on(Geom2d_Ellipse(ax, 0.46, 0.4), s)]
        else:
            corners = [(0.05, 0.1), (0.5, 0.02), (0.95, 0.1), (0.92, 0.9), (0.3, 0.96)]
            edges = []
            for (x0, y0), (x1, y1) in zip(corners, corners[1:] + corners[:1]):
                d = math.hypot(x1 - x0, y1 - y0)
                line = Geom2d_Line(gp_Pnt2d(x0, y0), gp_Dir2d(x1 - x0, y1 - y0))
                edges.append(_edge_on(line, s, 0.0, d))
        wm = BRepBuilderAPI_MakeWire()
        for e in edges:
            wm.Add(e)
        mk = BRepBuilderAPI_MakeFace(s, wm.Wire(), True)
    for cx, cy, r, ellipse in holes:
        ax = gp_Ax2d(gp_Pnt2d(cx, cy), gp_Dir2d(1, 0))
        c = Geom2d_Ellipse(ax, r, r * 0.6) if ellipse else Geom2d_Circle(ax, r)
        wm = BRepBuilderAPI_MakeWire(_edge_on(c, s))
        mk.Add(TopoDS.Wire_s(wm.Wire().Reversed()))
    face = mk.Face()
    fix = ShapeFix_Face(face)
    fix.Perform()
    face = fix.Face()
    BRepLib.BuildCurves3d_s(face)
    return face


def _solid(rng: np.random.Generator) -> tuple[str, tuple[float, ...]]:
    kind = ("box", "cyl", "sphere", "cone", "fbox", "torus")[int(rng.integers(0, 6))]
    return kind, tuple(float(x) for x in (*rng.uniform(3, 12, 3), *rng.uniform(-25, 25, 3)))


def _make_solid(kind: str, p: tuple[float, ...]) -> TopoDS_Shape:
    a, b, c, x, y, z = p
    at = cq.Vector(x, y, z)
    if kind == "box":
        return cq.Solid.makeBox(a, b, c, at).wrapped
    if kind == "cyl":
        return cq.Solid.makeCylinder(a / 2, c, at).wrapped
    if kind == "sphere":
        return cq.Solid.makeSphere(a / 2, at).wrapped
    if kind == "cone":
        return cq.Solid.makeCone(a / 2, b / 4, c, at).wrapped
    if kind == "torus":
        return cq.Solid.makeTorus(a, min(a, b) / 3, at).wrapped
    w = cq.Workplane("XY").box(a, b, c).edges().fillet(min(a, b, c) / 5).translate(at)
    return w.val().wrapped


def _compounds(rng: np.random.Generator) -> list[tuple[str, Callable[[], TopoDS_Shape]]]:
    out: list[tuple[str, Callable[[], TopoDS_Shape]]] = []
    for k in range(8):
        solids = [_solid(rng) for _ in range(int(rng.integers(2, 6)))]
        out.append((f"solids{len(solids)}_{k:02d}", partial(_compound_of, solids, k % 3 == 2)))
    return out


def _compound_of(solids: list[tuple[str, tuple[float, ...]]], nested: bool) -> TopoDS_Shape:
    shapes = [_make_solid(k, p) for k, p in solids]
    if nested:  # a compound inside the compound
        return compound([shapes[0], compound(shapes[1:])])
    return compound(shapes)


def _instances(rng: np.random.Generator) -> list[tuple[str, Callable[[], TopoDS_Shape]]]:
    out: list[tuple[str, Callable[[], TopoDS_Shape]]] = []
    bases = ["fbox", "sphere", "bspline", "loft"]
    for k in range(8):
        base = bases[k % 4]
        n = int(rng.integers(2, 5))
        moves = [
            (rng.uniform(-40, 40, 3), _unit(rng), float(rng.uniform(0, 2 * np.pi)))
            for _ in range(n)
        ]
        mirror = (rng.uniform(-20, 20, 3), _unit(rng))
        params = rng.uniform(5, 15, 4)
        sec = [_closed_spline(rng, 5, rng.uniform(4, 8), z) for z in (0.0, 10.0)]
        net = _bumpy(rng, 5, 4, 20.0, 2.0)
        out.append(
            (f"{base}_{n + 1}x_{k:02d}", partial(_instanced, base, params, sec, net, moves, mirror))
        )
    return out


def _instanced(
    base: str,
    params: np.ndarray,
    sec: list[np.ndarray],
    net: np.ndarray,
    moves: list[tuple[np.ndarray, np.ndarray, float]],
    mirror: tuple[np.ndarray, np.ndarray],
) -> TopoDS_Shape:
    a, b, c, _ = map(float, params)
    if base == "fbox":
        shape = cq.Workplane("XY").box(a, b, c).edges("|Z").fillet(min(a, b) / 4).val().wrapped
    elif base == "sphere":
        shape = cq.Solid.makeSphere(a / 2).wrapped
    elif base == "bspline":
        uk, um = [0.0, 1.0, 2.0], [4, 1, 4]
        vk, vm = [0.0, 1.0], [4, 4]
        shape = face_on(bspline_surface(net, uk, um, vk, vm, 3, 3))
    else:
        shape = _loft_closed(sec, False)
    placed = []
    for t, axis, angle in moves:
        tr = gp_Trsf()
        tr.SetRotation(gp_Ax1(gp_Pnt(0, 0, 0), gp_Dir(*map(float, axis))), angle)
        tt = gp_Trsf()
        tt.SetTranslation(gp_Vec(*map(float, t)))
        placed.append(shape.Moved(TopLoc_Location(tt.Multiplied(tr))))
    m = gp_Trsf()
    o, n = mirror
    m.SetMirror(gp_Ax2(_pnt(o), gp_Dir(*map(float, n))))
    placed.append(shape.Moved(TopLoc_Location(m), False))
    return compound([shape, *placed])


def _sewns(rng: np.random.Generator) -> list[tuple[str, Callable[[], TopoDS_Shape]]]:
    out: list[tuple[str, Callable[[], TopoDS_Shape]]] = []
    for k in range(6):
        nu, nv = int(rng.integers(5, 10)), int(rng.integers(5, 10))
        pts = _bumpy(rng, nu, nv, 40.0, 3.0)
        cuts = (int(rng.integers(1, 4)), int(rng.integers(1, 4)))
        out.append(
            (f"patches{(cuts[0] + 1) * (cuts[1] + 1)}_{k:02d}", partial(_sewn_patches, pts, cuts))
        )
    for k in range(2):
        a, b, c = rng.uniform(10, 30, 3)
        out.append((f"open_box_{k:02d}", partial(_sewn_open_box, a, b, c, k)))
    return out


def _sewn_patches(pts: np.ndarray, cuts: tuple[int, int]) -> TopoDS_Shape:
    nu, nv = pts.shape[:2]
    uk, um = knot_vector(np.random.default_rng(0), nu, 3, False, True, 1)
    vk, vm = knot_vector(np.random.default_rng(0), nv, 3, False, True, 1)
    us = np.linspace(uk[0], uk[-1], cuts[0] + 2)
    vs = np.linspace(vk[0], vk[-1], cuts[1] + 2)
    sew = BRepBuilderAPI_Sewing(1e-6)
    for i in range(len(us) - 1):
        for j in range(len(vs) - 1):
            piece = bspline_surface(pts, uk, um, vk, vm, 3, 3)
            piece.Segment(us[i], us[i + 1], vs[j], vs[j + 1])
            sew.Add(face_on(piece))
    sew.Perform()
    return sew.SewedShape()


def _sewn_open_box(a: float, b: float, c: float, k: int) -> TopoDS_Shape:
    box = cq.Workplane("XY").box(a, b, c)
    if k % 2:
        box = box.edges("|Z").fillet(min(a, b) / 5)
    sew = BRepBuilderAPI_Sewing(1e-6)
    exp = TopExp_Explorer(box.val().wrapped, TopAbs_FACE)
    first = True
    while exp.More():
        if not first:  # leave the first face out: an open shell
            f = BRepBuilderAPI_MakeFace(TopoDS.Face_s(exp.Current())).Face()
            sew.Add(f)
        first = False
        exp.Next()
    sew.Perform()
    return sew.SewedShape()


def _seams(rng: np.random.Generator) -> list[tuple[str, Callable[[], TopoDS_Shape]]]:
    out: list[tuple[str, Callable[[], TopoDS_Shape]]] = []
    for k in range(4):
        r = float(rng.uniform(3, 15))
        a1, a2 = (-90.0, 90.0) if k < 2 else (float(rng.uniform(-90, 0)), 90.0)
        a3 = 360.0 if k % 2 == 0 else float(rng.uniform(90, 330))
        out.append((f"sphere_{k:02d}", partial(_sphere, r, a1, a2, a3)))
    for k in range(4):
        r, h = float(rng.uniform(3, 15)), float(rng.uniform(5, 20))
        r2 = 0.0 if k < 3 else float(rng.uniform(1, r))
        a = 360.0 if k % 2 == 0 else float(rng.uniform(90, 330))
        out.append((f"cone_{k:02d}", partial(_cone, r, r2, h, a)))
    for k in range(4):
        n = int(rng.integers(3, 7))
        zs = np.linspace(0, rng.uniform(10, 30), n)
        xs = rng.uniform(3, 10, n)
        xs[0] = 0.0  # starts on the axis: a degenerated edge at the pole
        if k % 2:
            xs[-1] = 0.0
        prof = np.stack([xs, np.zeros(n), zs], -1)
        out.append((f"revol_{k:02d}", partial(_revolved_faces, prof, 360.0 if k < 2 else 200.0)))
    return out


def _sphere(r: float, a1: float, a2: float, a3: float) -> TopoDS_Shape:
    return cq.Solid.makeSphere(r, angleDegrees1=a1, angleDegrees2=a2, angleDegrees3=a3).wrapped


def _cone(r: float, r2: float, h: float, a: float) -> TopoDS_Shape:
    return cq.Solid.makeCone(r, r2, h, angleDegrees=a).wrapped


def _revolved_faces(prof: np.ndarray, angle: float) -> TopoDS_Shape:
    spline = cq.Edge.makeSpline(_vecs(prof)).wrapped
    axis = gp_Ax1(gp_Pnt(0, 0, 0), gp_Dir(0, 0, 1))
    mk = BRepPrimAPI_MakeRevol(spline, axis, math.radians(angle))
    mk.Build()
    return mk.Shape()


def _analytics(rng: np.random.Generator) -> list[tuple[str, Callable[[], TopoDS_Shape]]]:
    out: list[tuple[str, Callable[[], TopoDS_Shape]]] = []
    kinds = [
        "plane",
        "cylinder",
        "cone",
        "sphere",
        "torus",
        "extrusion",
        "revolution",
        "offset_bspline",
        "offset_cylinder",
    ]
    for k in range(18):
        kind = kinds[k % len(kinds)]
        frame = _frame(rng)
        p = tuple(float(x) for x in rng.uniform(0, 1, 6))
        curve = np.cumsum(rng.uniform(-4, 4, (int(rng.integers(4, 8)), 3)), 0)
        curve[:, 0] = np.linspace(0, 20, len(curve))
        out.append((f"{kind}_{k:02d}", partial(_analytic_face, kind, frame, p, curve, k)))
    return out


def _bspline_curve(pts: np.ndarray, degree: int = 3) -> Geom_BSplineCurve:
    n = len(pts)
    d = min(degree, n - 1)
    knots, mults = knot_vector(np.random.default_rng(n), n, d, False, True, 1)
    return Geom_BSplineCurve(_poles1(pts), _reals(knots), _ints(mults), d, False)


def _analytic_face(
    kind: str, frame: gp_Ax3, p: tuple[float, ...], curve: np.ndarray, k: int
) -> TopoDS_Shape:
    a, b, c, d, e, f = p
    full = k % 2 == 0  # whole periods where the surface has them: seams
    if kind == "plane":
        return face_on(Geom_Plane(frame), (-5 - 10 * a, 5 + 10 * b, -5 - 10 * c, 5 + 10 * d))
    if kind == "cylinder":
        s = Geom_CylindricalSurface(frame, 2 + 10 * a)
        u1 = 2 * math.pi if full else 0.5 + 5 * b
        return face_on(s, (0.0, u1, -10 * c, 1 + 20 * d))
    if kind == "cone":
        s = Geom_ConicalSurface(frame, 0.1 + 1.2 * a, 1 + 10 * b)
        u1 = 2 * math.pi if full else 0.5 + 5 * c
        return face_on(s, (0.0, u1, -5 * d, 1 + 10 * e))
    if kind == "sphere":
        s = Geom_SphericalSurface(frame, 2 + 10 * a)
        if full:
            return face_on(s)
        return face_on(s, (0.0, 0.5 + 5 * b, -1.5 * c, 1.5 * d + 0.05))
    if kind == "torus":
        big = 8 + 10 * a
        s = Geom_ToroidalSurface(frame, big, 1 + (big - 2) * b * 0.5)
        if full:
            return face_on(s)
        return face_on(s, (0.0, 0.5 + 5 * c, 0.0, 0.5 + 5 * d))
    if kind == "extrusion":
        bc = _bspline_curve(curve)
        s = Geom_SurfaceOfLinearExtrusion(bc, gp_Dir(0.1 + a, 0.2 + b, 1.0))
        return face_on(s, (bc.FirstParameter(), bc.LastParameter(), -5 * c, 1 + 20 * d))
    if kind == "revolution":
        pts = curve.copy()
        pts[:, 0] = np.abs(pts[:, 0]) / 2 + 3  # off the axis
        bc = _bspline_curve(pts[:, [0, 1, 2]])
        s = Geom_SurfaceOfRevolution(bc, gp_Ax1(gp_Pnt(0, 0, 0), gp_Dir(0, 1, 0)))
        u1 = 2 * math.pi if full else 0.5 + 5 * a
        return face_on(s, (0.0, u1, bc.FirstParameter(), bc.LastParameter()))
    if kind == "offset_bspline":
        net = _bumpy(np.random.default_rng(int(1000 * a)), 5, 5, 30.0, 1.0)
        base = bspline_surface(net, [0.0, 1.0, 2.0], [4, 1, 4], [0.0, 1.0, 2.0], [4, 1, 4], 3, 3)
        return face_on(Geom_OffsetSurface(base, 0.5 + 3 * b))
    s0 = Geom_CylindricalSurface(frame, 5 + 10 * a)
    s = Geom_OffsetSurface(s0, (1 if full else -1) * (0.5 + 3 * b))
    return face_on(s, (0.0, 2 * math.pi if full else 3.0, 0.0, 5 + 20 * c))


# ---------------------------------------------------------------- the list


#: Category name -> its generator: a seeded rng in, (kind, builder) pairs out.
def _features(rng: np.random.Generator) -> list[tuple[str, Callable[[], TopoDS_Shape]]]:
    out: list[tuple[str, Callable[[], TopoDS_Shape]]] = []

    def sections(n: int) -> list[np.ndarray]:
        return [
            _closed_spline(rng, int(rng.integers(5, 9)), rng.uniform(4, 8), z)
            for z in np.cumsum(rng.uniform(3, 6, n))
        ]

    for k in range(3):
        out.append((f"cut_cyl_{k:02d}", partial(_feature_cut, sections(4), rng.uniform(0.8, 2))))
        out.append((f"fuse_lofts_{k:02d}", partial(_feature_fuse, sections(3), sections(3))))
        out.append((f"thick_{k:02d}", partial(_feature_thick, sections(4), -rng.uniform(0.2, 0.4))))
    for k in range(2):
        out.append((f"offset_{k:02d}", partial(_feature_offset, sections(3), rng.uniform(0.3, 1))))
        out.append((f"split_{k:02d}", partial(_feature_split, rng.uniform(-2, 2, (5, 5)))))
        out.append((f"cells_{k:02d}", partial(_feature_cells, sections(3))))
    for kind in ("sphere", "torus", "cone", "fillet_box"):
        out.append((f"nurbs_{kind}", partial(_feature_nurbs, kind, rng.uniform(3, 8))))
    return out


def _feature_loft(sections: list[np.ndarray]) -> cq.Solid:
    wires = [cq.Wire.assembleEdges([cq.Edge.makeSpline(_vecs(s), periodic=True)]) for s in sections]
    return cq.Solid.makeLoft(wires, False)


def _feature_cut(sections: list[np.ndarray], r: float) -> TopoDS_Shape:
    z = sections[0][0, 2]
    return (
        _feature_loft(sections).cut(cq.Solid.makeCylinder(r, 100, cq.Vector(0, 0, z - 1))).wrapped
    )


def _feature_fuse(a: list[np.ndarray], b: list[np.ndarray]) -> TopoDS_Shape:
    other = _feature_loft(b).translate(cq.Vector(3, 1, 2))
    return _feature_loft(a).fuse(other).clean().wrapped


def _feature_thick(sections: list[np.ndarray], t: float) -> TopoDS_Shape:
    from OCP.BRepOffsetAPI import BRepOffsetAPI_MakeThickSolid
    from OCP.TopTools import TopTools_ListOfShape

    loft = _feature_loft(sections)
    top = TopTools_ListOfShape()
    top.Append(max(loft.Faces(), key=lambda f: f.Center().z).wrapped)
    m = BRepOffsetAPI_MakeThickSolid()
    m.MakeThickSolidByJoin(loft.wrapped, top, t, 1e-3)
    m.Build()
    return m.Shape()


def _feature_offset(sections: list[np.ndarray], d: float) -> TopoDS_Shape:
    from OCP.BRepOffsetAPI import BRepOffsetAPI_MakeOffsetShape

    m = BRepOffsetAPI_MakeOffsetShape()
    m.PerformByJoin(_feature_loft(sections).wrapped, d, 1e-3)
    return m.Shape()


def _feature_split(bumps: np.ndarray) -> TopoDS_Shape:
    from OCP.BRepAlgoAPI import BRepAlgoAPI_Splitter
    from OCP.TopTools import TopTools_ListOfShape

    xs = np.linspace(-1, 11, 5)
    pts = [[cq.Vector(x, y, 5 + bumps[i, j]) for j, y in enumerate(xs)] for i, x in enumerate(xs)]
    args, tools = TopTools_ListOfShape(), TopTools_ListOfShape()
    args.Append(cq.Solid.makeBox(10, 10, 10).wrapped)
    tools.Append(cq.Face.makeSplineApprox(pts).wrapped)
    sp = BRepAlgoAPI_Splitter()
    sp.SetArguments(args)
    sp.SetTools(tools)
    sp.Build()
    return sp.Shape()


def _feature_cells(sections: list[np.ndarray]) -> TopoDS_Shape:
    from OCP.BOPAlgo import BOPAlgo_MakerVolume
    from OCP.TopTools import TopTools_ListOfShape

    args = TopTools_ListOfShape()
    args.Append(cq.Solid.makeBox(10, 10, 10, cq.Vector(-5, -5, 0)).wrapped)
    args.Append(_feature_loft(sections).translate(cq.Vector(3, 3, -2)).wrapped)
    mv = BOPAlgo_MakerVolume()
    mv.SetArguments(args)
    mv.Perform()
    return mv.Shape()


def _feature_nurbs(kind: str, r: float) -> TopoDS_Shape:
    solid = {
        "sphere": lambda: cq.Solid.makeSphere(r),
        "torus": lambda: cq.Solid.makeTorus(r, r / 3),
        "cone": lambda: cq.Solid.makeCone(r, 0, 1.5 * r),
        "fillet_box": lambda: (
            cq.Workplane()
            .box(2 * r, r, r / 2)
            .faces(">Z")
            .workplane()
            .hole(r / 3)
            .edges()
            .fillet(r / 20)
            .val()
        ),
    }[kind]()
    return BRepBuilderAPI_NurbsConvert(solid.wrapped, True).Shape()


def _booleans(rng: np.random.Generator) -> list[tuple[str, Callable[[], TopoDS_Shape]]]:
    """Lofts and sweeps cut by a box or a hole: the cut trims their faces but
    not their surfaces, and the edges along a surface's side keep the whole
    side as their curve over a part of its range (ec_turbine-A.stp's 31
    such edges; docs/method.md item 50)."""
    out: list[tuple[str, Callable[[], TopoDS_Shape]]] = []
    for k in range(4):
        w, h = rng.uniform(14, 24), rng.uniform(10, 16)
        out.append((f"loft_{k:02d}", partial(_cut_loft, w, h, rng.uniform(0.3, 0.7), k % 2 == 1)))
    for k in range(4):
        pts = [(0.0, 0.0), (rng.uniform(3, 8), 10.0), (rng.uniform(-2, 2), rng.uniform(18, 24))]
        dims = (rng.uniform(3, 6), rng.uniform(2, 4))
        out.append((f"sweep_{k:02d}", partial(_cut_sweep, pts, dims, rng.uniform(0.3, 0.7))))
    return out


def _cut_loft(w: float, h: float, at: float, hole: bool) -> TopoDS_Shape:
    w, h, at = float(w), float(h), float(at)
    body = cq.Workplane().rect(w, 0.7 * w).workplane(offset=h / 2).circle(0.3 * w)
    body = body.workplane(offset=h / 2).rect(0.5 * w, 0.4 * w).loft(ruled=False)
    body = body.cut(cq.Workplane().box(0.4 * w, 2 * w, 0.15 * h).translate((0, 0, at * h)))
    if hole:
        body = body.cut(
            cq.Workplane("YZ").circle(0.08 * w).extrude(w, both=True).translate((0, 0, 0.8 * h))
        )
    return body.val().wrapped


def _cut_sweep(
    pts: list[tuple[float, float]], dims: tuple[float, float], at: float
) -> TopoDS_Shape:
    path = cq.Workplane("XZ").spline([(float(x), float(y)) for x, y in pts])
    body = cq.Workplane("XY").rect(float(dims[0]), float(dims[1])).sweep(path)
    top = float(pts[-1][1])
    body = body.cut(cq.Workplane("XY").box(4 * top, 4 * top, 0.2 * top).translate((0, 0, at * top)))
    return body.val().wrapped


CATEGORIES: dict[str, Callable[[np.random.Generator], list[tuple[str, Any]]]] = {
    "fillet": _fillets,
    "chamfer": _chamfers,
    "shell": _shells,
    "loft": _lofts,
    "sweep": _sweeps,
    "revolve": _revolves,
    "periodic": _periodic,
    "net": _nets,
    "trimmed": _trimmed,
    "compound": _compounds,
    "instance": _instances,
    "sewn": _sewns,
    "seam": _seams,
    "analytic": _analytics,
    "feature": _features,
    "boolean": _booleans,
}

#: Entries that are deliberately invalid, name -> why (none at present).
DELIBERATELY_INVALID: dict[str, str] = {}


def _shape_of(build: Callable[[], Any]) -> TopoDS_Shape:
    s = build()
    return s.wrapped if isinstance(s, cq.Shape) else s


def entries(seed: int = 0) -> list[Entry]:
    """Every shape of the corpus, category by category (building is lazy)."""
    out: list[Entry] = []
    for cat, gen in CATEGORIES.items():
        rng = np.random.default_rng([seed, zlib.crc32(cat.encode())])
        for kind, build in gen(rng):
            name = f"{cat}_{kind}"
            out.append(
                Entry(name, cat, partial(_shape_of, build), DELIBERATELY_INVALID.get(name, ""))
            )
    names = [e.name for e in out]
    assert len(set(names)) == len(names), "entry names must be unique"
    return out


def interleaved(items: Sequence[Entry]) -> list[Entry]:
    """The entries round-robin over their categories, so any prefix covers them all."""
    by_cat: dict[str, list[Entry]] = {}
    for e in items:
        by_cat.setdefault(e.category, []).append(e)
    out: list[Entry] = []
    queues = list(by_cat.values())
    i = 0
    while any(i < len(q) for q in queues):
        out.extend(q[i] for q in queues if i < len(q))
        i += 1
    return out


def is_valid(shape: TopoDS_Shape) -> bool:
    return bool(BRepCheck_Analyzer(shape).IsValid())


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--only", default="", help="build only names containing this")
    args = ap.parse_args(argv)
    from nurbscomp import occ

    bad = 0
    per_cat: Counter[str] = Counter()
    t0 = time.perf_counter()
    for e in entries(args.seed):
        if args.only not in e.name:
            continue
        t = time.perf_counter()
        shape = e.build()
        n = occ.counts(shape)
        valid = is_valid(shape)
        per_cat[e.category] += 1
        flag = "" if valid else ("  INVALID (deliberate)" if e.invalid else "  INVALID")
        bad += (not valid) and not e.invalid
        print(
            f"{e.name:40s} {n['solids']:2d} so {n['faces']:3d} fa {n['edges']:4d} ed"
            f" {time.perf_counter() - t:6.3f} s{flag}"
        )
    print(dict(per_cat), f"total {sum(per_cat.values())} in {time.perf_counter() - t0:.1f} s")
    return 1 if bad else 0


if __name__ == "__main__":
    raise SystemExit(main())
