"""Surfaces of revolution of a line or a circle written as the cylinders,
cones, tori and spheres they are (tolerance mode; issue 28).

IGES has no cylinder or cone among the entities most writers use: they write
a surface of revolution of a line (entity 120 about a 110), which OCCT's IGES
reader keeps as one (``Geom_SurfaceOfRevolution`` of a trimmed line), and so
does its own IGES writer for every cylinder and cone of a surface model.
The container then holds the axis, the line and its trim, and the coder's
rules for quadrics (frames on the grid, a cylinder through a vertex, lines
through their vertices on its faces) do not reach them.

:func:`revolved_lines` writes each such surface as a ``CYLINDER`` (the line
parallel to the axis) or a ``CONE`` (the line meeting the axis, or parallel
to it at no distance from a plane through it) with the same point at the
same (u, v): u is the angle of the rotation about the axis, so the quadric's
Y direction is the axis times its X direction (the radial direction of the
line's origin); v is the line's own parameter, so its main direction is the
line's (a ``gp_Ax3`` that is indirect where the line runs against the axis).
A surface of revolution of a circle in a plane through the axis, whose X
direction points away from the axis and whose Y direction is the axis's (or
its opposite), is a ``TORUS`` (its centre off the axis) or a ``SPHERE`` (on
it, the circle's range within [−π/2, π/2]) at the same (u, v): v is the
circle's angle, the quadric's X direction the circle's, its main direction
the circle's Y direction (IGES writers' tori and spheres, entity 120 about
a 100 in the plane of the axis, read so).
Pcurves, ranges and orientations are then unchanged, and each point moves by
rounding only (a few ulps; a surface whose sampled points would move by more
than :data:`SAME` of its size is left as it is).  The lines and trims nothing
else uses leave the table.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import replace
from typing import Any

import numpy as np

from ..model import (
    EC,
    VC,
    Analytic,
    BRepModel,
    Derived,
    Geometry,
    Kind,
    PointRepKind,
    RepKind,
    kept_rows,
)
from ..serialize import SWEPT

#: How far (relative to the surface's size) a sampled point of the quadric
#: may be from the surface of revolution's.
SAME = 1e-12


def revolved_lines(m: BRepModel) -> BRepModel | None:
    """``m`` with each surface of revolution of a line written as its cylinder
    or cone (see the module's docstring); None where it has none."""
    keep = {int(r) for r, n in zip(m.face_surface.tolist(), m.face_natural.tolist()) if n}
    # an offset or trim of one stays as read: OCCT's STEP reader looped for
    # minutes on the offset of such a cylinder (its evaluator throwing at
    # every point of a projection)
    keep |= {g.basis for g in m.surfaces if isinstance(g, Derived) and g.kind not in SWEPT}
    surfaces = list(m.surfaces)
    for i, g in enumerate(m.surfaces):
        if i not in keep:
            q = _quadric(m, g)
            if q is not None:
                surfaces[i] = q
    if all(a is b for a, b in zip(surfaces, m.surfaces)):
        return None
    out: Any = replace(m)
    out.surfaces = surfaces
    return prune_curves3d(out)


def _line_of(curves: list[Geometry], c: int) -> tuple[np.ndarray, np.ndarray, float] | None:
    """The origin and unit direction of the line that 3-D curve ``c`` is (through
    trims), and how far its points in use reach along it; None if it is not one."""
    reach = 1.0
    g = curves[c]
    while isinstance(g, Derived) and g.kind == Kind.TRIMMED_CURVE:
        reach = max(reach, float(np.abs(g.params).max(initial=0.0)))
        g = curves[g.basis]
    if not (isinstance(g, Analytic) and g.kind == Kind.LINE and g.frame.shape == (2, 3)):
        return None
    return g.frame[0], g.frame[1], reach


def _quadric(m: BRepModel, g: Geometry) -> Analytic | None:
    """The cylinder, cone, torus or sphere that surface ``g`` is at the same
    parameters, if it is a surface of revolution of a line or a circle."""
    if not (isinstance(g, Derived) and g.kind == Kind.REVOLUTION):
        return None
    o, a = g.frame[0], g.frame[1] / np.linalg.norm(g.frame[1])
    circle = _circle_of(m.curves3d, g.basis)
    if circle is not None:
        return _revolved_circle(o, a, *circle)
    line = _line_of(m.curves3d, g.basis)
    if line is None:
        return None
    p, d, reach = line
    along = p - o
    radial = along - float(along @ a) * a
    r = float(np.linalg.norm(radial))
    d_radial = d - float(d @ a) * a
    scale = max(1.0, float(np.abs(p).max()), float(np.abs(o).max()), reach)
    if float(np.linalg.norm(d_radial)) <= SAME:  # along the axis: a cylinder
        if r <= SAME * scale:
            return None  # the axis itself
        x = radial / r
        new = Analytic(Kind.CYLINDER, _frame(p - radial, d, x, a), np.array([r]))
    else:
        if abs(float(d @ a)) <= SAME:
            return None  # square to the axis: a plane
        z = a if float(d @ a) > 0 else -a
        x = radial / r if r > SAME * scale else d_radial / float(np.linalg.norm(d_radial))
        sin, cos = float(d @ x), float(d @ z)
        if np.abs(d - (sin * x + cos * z)).max() > SAME:
            return None  # skew to the axis: a hyperboloid
        angle = math.atan2(sin, cos)
        if not 1e-9 < abs(angle) < math.pi / 2 - 1e-9:
            return None
        if r <= SAME * scale:
            r = 0.0
        new = Analytic(Kind.CONE, _frame(p - r * x, z, x, a), np.array([r, angle]))
    vs = np.linspace(-reach, reach, 5)
    if _gap(new, o, a, lambda v: p[None, :] + v * d[None, :], vs) > SAME * scale * 64:
        return None
    return new


def _circle_of(
    curves: list[Geometry], c: int
) -> tuple[Analytic, tuple[float, float] | None] | None:
    """The circle that 3-D curve ``c`` is (through trims) and the range of
    the innermost trim (None: untrimmed); None if it is not a circle."""
    g, span = curves[c], None
    while isinstance(g, Derived) and g.kind == Kind.TRIMMED_CURVE:
        span = (float(g.params[0]), float(g.params[1]))
        g = curves[g.basis]
    if not (isinstance(g, Analytic) and g.kind == Kind.CIRCLE and g.frame.shape == (3, 3)):
        return None
    return g, span


def _revolved_circle(
    o: np.ndarray, a: np.ndarray, circle: Analytic, span: tuple[float, float] | None
) -> Analytic | None:
    """The torus or sphere that the revolution of ``circle`` about (``o``,
    ``a``) is at the same (u, v), or None."""
    c, n, x = circle.frame
    r = float(circle.params[0])
    y = np.cross(n, x)
    if abs(abs(float(y @ a)) - 1.0) > SAME or abs(float(x @ a)) > SAME:
        return None  # not in a plane through the axis, or turned in it
    w = c - o
    radial = w - float(w @ a) * a
    big = float(np.linalg.norm(radial))
    scale = max(1.0, float(np.abs(c).max()), float(np.abs(o).max()), r)
    if abs(float(radial @ np.cross(a, x))) > SAME * scale:
        return None  # the centre is off the circle's plane through the axis
    if big <= SAME * scale:
        if span is None or not -math.pi / 2 <= min(span) <= max(span) <= math.pi / 2:
            return None  # a sphere's v stays within its poles
        new = Analytic(Kind.SPHERE, _frame(c, y, x, a), np.array([r]))
    else:
        if float(radial @ x) < 0 or big <= r * (1 + 1e-9):
            return None  # the circle round the other way, or crossing the axis
        new = Analytic(Kind.TORUS, _frame(o + float(w @ a) * a, y, x, a), np.array([big, r]))
    sphere = new.kind == Kind.SPHERE
    vs = np.linspace(-math.pi / 2, math.pi / 2, 5) if sphere else np.linspace(0.0, 2 * math.pi, 7)

    def arc(v: np.ndarray) -> np.ndarray:
        return c[None, :] + r * (np.cos(v) * x + np.sin(v) * y)

    if _gap(new, o, a, arc, vs) > SAME * scale * 64:
        return None
    return new


def _frame(origin: np.ndarray, z: np.ndarray, x: np.ndarray, axis: np.ndarray) -> np.ndarray:
    """A ``gp_Ax3``'s rows: origin, main, X, and Y the axis times X (the sense
    the revolution turns in)."""
    return np.array([origin, z, x, np.cross(axis, x)])


def _gap(
    q: Analytic,
    o: np.ndarray,
    a: np.ndarray,
    basis: Callable[[np.ndarray], np.ndarray],
    vs: np.ndarray,
) -> float:
    """The largest distance, over sampled (u, v) (``vs`` in v, seven angles
    in u), between the revolution about (``o``, ``a``) of the curve whose
    points ``basis(v)`` gives and the quadric ``q`` (:func:`_quadric_points`)."""
    us = np.linspace(0.0, 2 * math.pi, 7)
    u, v = np.meshgrid(us, vs, indexing="ij")
    u, v = u.ravel()[:, None], v.ravel()[:, None]
    w = basis(v) - o[None, :]  # the curve's point, from the axis
    # Rodrigues: the point turned by u about a
    turned = (
        w * np.cos(u)
        + np.cross(a[None, :], w) * np.sin(u)
        + a[None, :] * (w @ a)[:, None] * (1 - np.cos(u))
    )
    return float(np.abs(o[None, :] + turned - _quadric_points(q, u, v)).max())


def _quadric_points(q: Analytic, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """The points of the cylinder, cone, torus or sphere ``q`` at (u, v)."""
    origin, z, x, y = q.frame
    if q.kind == Kind.CYLINDER:
        rad = q.params[0]
        return origin + rad * (np.cos(u) * x + np.sin(u) * y) + v * z
    if q.kind == Kind.CONE:
        rad, angle = q.params
        quad = origin + (rad + v * math.sin(angle)) * (np.cos(u) * x + np.sin(u) * y)
        return quad + v * math.cos(angle) * z
    big = 0.0 if q.kind == Kind.SPHERE else float(q.params[0])
    rad = float(q.params[-1])
    quad = origin + (big + rad * np.cos(v)) * (np.cos(u) * x + np.sin(u) * y)
    return quad + rad * np.sin(v) * z


def prune_curves3d(m: BRepModel) -> BRepModel:
    """Drop 3-D curves nothing refers to (edges, vertices, swept surfaces,
    other curves), renumbering the references."""
    used = np.zeros(len(m.curves3d), bool)
    reps = m.edge_reps
    c3 = reps[:, EC.KIND] == RepKind.CURVE3D
    idx = reps[c3, EC.CURVE]
    used[idx[idx >= 0]] = True
    vr = m.vertex_reps
    on = vr[:, VC.KIND] == PointRepKind.ON_CURVE
    idx = vr[on, VC.CURVE]
    used[idx[idx >= 0]] = True
    for g in m.surfaces:
        if isinstance(g, Derived) and g.kind in SWEPT:
            used[g.basis] = True
    out: Any = replace(m)
    out.curves3d, new_index = kept_rows(m.curves3d, used)
    if len(out.curves3d) == len(m.curves3d):
        return m
    out.surfaces = [
        replace(g, basis=int(new_index[g.basis]))
        if isinstance(g, Derived) and g.kind in SWEPT
        else g
        for g in m.surfaces
    ]
    reps = reps.copy()
    sel = c3 & (reps[:, EC.CURVE] >= 0)
    reps[sel, EC.CURVE] = new_index[reps[sel, EC.CURVE]]
    out.edge_reps = reps
    vr = vr.copy()
    sel = on & (vr[:, VC.CURVE] >= 0)
    vr[sel, VC.CURVE] = new_index[vr[sel, VC.CURVE]]
    out.vertex_reps = vr
    return out
