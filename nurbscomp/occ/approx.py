"""Dense stored pcurves re-approximated with fewer poles (the encoder's).

Where the validity stage must store a pcurve (OCCT's projection of the coded
edge fails its checks), the pcurve it stores is the one the source was read
with.  Some are far denser than their edge: an offset face's trimming curves
that OCCT's offset algorithm or IGES reader made come with hundreds or
thousands of poles of degree 8 to 11 (a shelled loft's: 1,992 poles, against
26 for the edge's 3-D curve).  :func:`compact_pcurve` gives a cubic curve
with the same parameter that stays within a chosen distance *on the surface*,
so that the edge's tolerance need only grow by that distance
(``encode.pcurves.compact_kept``).  No decoder rule: the container stores
the new curve as it stores any pcurve.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from OCP.Geom2d import Geom2d_TrimmedCurve
from OCP.Geom2dConvert import Geom2dConvert_ApproxCurve
from OCP.GeomAbs import GeomAbs_C1
from OCP.gp import gp_Pnt, gp_Vec

from ..model import BSplineCurve, Geometry
from .geometry import GeometryBuilder, GeometryReader

#: The approximation's degree and most segments: a C1 cubic (a shelled
#: loft's degree-11 pcurve of 1,992 poles comes out at 66 poles within
#: 0.025 mm; C2 took 107, degree 5 C1 78).
DEGREE = 3
MAX_SEGMENTS = 1000
#: The rounding grids of :func:`_rounded`, as fractions of the (u, v) bound
#: and of the shortest knot span.
ROUND = 8
#: Samples per pole (of both curves) where the distance on the surface is
#: measured, and at least this many.
PER_POLE = 8
MIN_SAMPLES = 256


def _points(surface: Any, curve: Any, t: np.ndarray) -> np.ndarray:
    """The surface's points at the curve's (u, v) for each parameter of ``t``."""
    out = np.empty((len(t), 3))
    for i, x in enumerate(t.tolist()):
        uv = curve.Value(x)
        p = surface.Value(uv.X(), uv.Y())
        out[i] = p.X(), p.Y(), p.Z()
    return out


def _speed(surface: Any, curve: Any, t: np.ndarray) -> float:
    """The largest of sqrt(|S_u|² + |S_v|²) at the curve's points (sampled)."""
    p, du, dv = gp_Pnt(), gp_Vec(), gp_Vec()
    out = 0.0
    for x in t.tolist():
        uv = curve.Value(x)
        surface.D1(uv.X(), uv.Y(), p, du, dv)
        out = max(out, math.hypot(du.Magnitude(), dv.Magnitude()))
    return out


def compact_pcurve(
    surfaces: list[Geometry],
    curves3d: list[Geometry],
    curves2d: list[Geometry],
    curve: int,
    surface: int,
    first: float,
    last: float,
    within: float,
) -> tuple[BSplineCurve, np.ndarray, float] | None:
    """A cubic B-spline standing for pcurve ``curve`` (a row of ``curves2d``)
    on ``surface`` (a row of ``surfaces``; a swept one's curve is a row of
    ``curves3d``) over [first, last], or None where none has at most half
    its poles (or where the curve is periodic, or [first, last] is not
    within its parameters).

    The approximation (``Geom2dConvert_ApproxCurve``, C1) is held to
    ``within`` / L in (u, v), L the largest sqrt(|S_u|² + |S_v|²) along the
    pcurve; then the distance between the two curves' points *on the
    surface* at the same parameter is measured at ``PER_POLE`` samples per
    pole of the old curve and must be at most ``within`` (else once more
    with half the (u, v) bound).  Its poles and knots are first rounded to
    binary grids (:func:`_rounded`), where that stays within.  Returned: the new
    record, its (u, v) at ``first`` and ``last`` (4 numbers, as
    ``BRepModel.edge_rep_uv`` holds them) and the measured distance.

    The distance is sampled, not certified: it widens the edge's tolerance,
    which BRepCheck and the STEP check of the validity stage then hold the
    candidate to, as OCCT's own tolerances are found (``BRepLib``).
    """
    old = curves2d[curve]
    if not isinstance(old, BSplineCurve) or old.periodic or not first < last:
        return None
    build = GeometryBuilder(surfaces, curves3d, curves2d)
    c, s = build.curve2d(curve), build.surface(surface)
    if not c.FirstParameter() <= first < last <= c.LastParameter():
        return None  # a range past the curve's own (its end extrapolated): as it is
    n_old = len(old.poles)
    t = np.linspace(first, last, max(MIN_SAMPLES, PER_POLE * n_old))
    speed = _speed(s, c, t[:: max(1, len(t) // MIN_SAMPLES)])
    if not speed > 0 or not math.isfinite(speed):
        return None
    trimmed, at = Geom2d_TrimmedCurve(c, first, last), _points(s, c, t)
    for share in (1, 2):
        uv = within / (share * speed)
        a = Geom2dConvert_ApproxCurve(trimmed, uv, GeomAbs_C1, MAX_SEGMENTS, DEGREE)
        if not a.HasResult() or 2 * a.Curve().NbPoles() > n_old:
            return None
        reader = GeometryReader()
        exact = reader.curves2d.records[reader.curve2d(a.Curve())]
        assert isinstance(exact, BSplineCurve)
        for rec in (_rounded(exact, uv), exact):
            new = GeometryBuilder([], [], [rec]).curve2d(0)
            moved = float(np.linalg.norm(_points(s, new, t) - at, axis=1).max())
            if moved <= within:
                p, q = new.Value(first), new.Value(last)
                return rec, np.array([p.X(), p.Y(), q.X(), q.Y()]), moved
    return None


def _rounded(g: BSplineCurve, uv: float) -> BSplineCurve:
    """``g`` with its inner poles on the binary grid of step ≤ ``uv`` /
    ``ROUND`` (the end poles, which its neighbours in a wire meet, stay) and
    its inner knots on one of step ≤ its shortest span / ``ROUND`` (the
    ends kept): doubles that end in zero bits, which the entropy stage codes
    for little (as ``encode.pcurves.rounded_ranges`` rounds ranges).  The
    caller measures the rounded curve again."""
    step = 2.0 ** math.floor(math.log2(uv / ROUND))
    knots = g.knots.copy()
    if len(knots) > 2:
        q = 2.0 ** math.floor(math.log2(float(np.diff(knots).min()) / ROUND))
        knots[1:-1] = np.round(knots[1:-1] / q) * q
        if not (np.diff(knots) > 0).all():
            knots = g.knots
    poles = g.poles.copy()  # the end poles, the curve's ends, stay: a wire's
    poles[1:-1] = np.round(poles[1:-1] / step) * step  # pcurves meet there
    return BSplineCurve(poles, None, knots, g.mults, g.degree, False)
