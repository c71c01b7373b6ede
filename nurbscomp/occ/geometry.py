"""Geom / Geom2d objects <-> model geometry records.

``GeometryReader`` turns OCCT curves and surfaces into records of
:mod:`nurbscomp.model` and stores each distinct record once (equal records share
an index).  ``GeometryBuilder`` turns the records back into OCCT handles,
building each index once.
"""

from __future__ import annotations

import itertools
import math
from typing import Any

import numpy as np
from OCP.Geom import (
    Geom_BezierCurve,
    Geom_BezierSurface,
    Geom_BSplineCurve,
    Geom_BSplineSurface,
    Geom_Circle,
    Geom_ConicalSurface,
    Geom_CylindricalSurface,
    Geom_Ellipse,
    Geom_Hyperbola,
    Geom_Line,
    Geom_OffsetCurve,
    Geom_OffsetSurface,
    Geom_Parabola,
    Geom_Plane,
    Geom_RectangularTrimmedSurface,
    Geom_SphericalSurface,
    Geom_SurfaceOfLinearExtrusion,
    Geom_SurfaceOfRevolution,
    Geom_ToroidalSurface,
    Geom_TrimmedCurve,
)
from OCP.Geom2d import (
    Geom2d_BezierCurve,
    Geom2d_BSplineCurve,
    Geom2d_Circle,
    Geom2d_Ellipse,
    Geom2d_Hyperbola,
    Geom2d_Line,
    Geom2d_OffsetCurve,
    Geom2d_Parabola,
    Geom2d_TrimmedCurve,
)
from OCP.gp import (
    gp_Ax1,
    gp_Ax2,
    gp_Ax2d,
    gp_Ax3,
    gp_Ax22d,
    gp_Dir,
    gp_Dir2d,
    gp_Pnt,
    gp_Pnt2d,
)
from OCP.TColgp import (
    TColgp_Array1OfPnt,
    TColgp_Array1OfPnt2d,
    TColgp_Array2OfPnt,
)
from OCP.TColStd import (
    TColStd_Array1OfInteger,
    TColStd_Array1OfReal,
    TColStd_Array2OfReal,
)

from ..errors import UnsupportedError
from ..model import Analytic, BSplineCurve, BSplineSurface, Derived, Geometry, Kind

# ---------------------------------------------------------------- numpy <-> TCol


def _reals(a: Any) -> np.ndarray:
    return np.array([a.Value(i) for i in range(a.Lower(), a.Upper() + 1)], np.float64)


def _ints(a: Any) -> np.ndarray:
    return np.array([a.Value(i) for i in range(a.Lower(), a.Upper() + 1)], np.int64)


def _xyz(p: Any) -> tuple[float, ...]:
    return p.Coord()  # one call for the three (X(), Y(), Z() cost three)


def _xy(p: Any) -> tuple[float, ...]:
    return p.Coord()


def _points1(a: Any, dim: int) -> np.ndarray:
    get = _xyz if dim == 3 else _xy
    return np.array([get(a.Value(i)) for i in range(a.Lower(), a.Upper() + 1)], np.float64)


def _points2(a: Any) -> np.ndarray:
    return np.array(
        [
            [_xyz(a.Value(i, j)) for j in range(a.LowerCol(), a.UpperCol() + 1)]
            for i in range(a.LowerRow(), a.UpperRow() + 1)
        ],
        np.float64,
    ).reshape(a.ColLength(), a.RowLength(), 3)


def _reals2(a: Any) -> np.ndarray:
    return np.array(
        [
            [a.Value(i, j) for j in range(a.LowerCol(), a.UpperCol() + 1)]
            for i in range(a.LowerRow(), a.UpperRow() + 1)
        ],
        np.float64,
    )


def _tcol_reals(x: np.ndarray) -> TColStd_Array1OfReal:
    out = TColStd_Array1OfReal(1, len(x))
    for i, v in enumerate(x.tolist(), 1):
        out.SetValue(i, v)
    return out


def _tcol_ints(x: np.ndarray) -> TColStd_Array1OfInteger:
    out = TColStd_Array1OfInteger(1, len(x))
    for i, v in enumerate(x.tolist(), 1):
        out.SetValue(i, int(v))
    return out


def _tcol_points1(x: np.ndarray) -> Any:
    if x.shape[1] == 3:
        out = TColgp_Array1OfPnt(1, len(x))
        for i, (a, b, c) in enumerate(x.tolist(), 1):
            out.SetValue(i, gp_Pnt(a, b, c))
        return out
    out2 = TColgp_Array1OfPnt2d(1, len(x))
    for i, (a, b) in enumerate(x.tolist(), 1):
        out2.SetValue(i, gp_Pnt2d(a, b))
    return out2


def segment2d(p: tuple[float, float], q: tuple[float, float], first: float, last: float) -> Any:
    """The 2-D segment from ``p`` at ``first`` to ``q`` at ``last``, at a
    constant speed: a degree-1 B-spline (a ``Geom2d_Line`` has unit speed)."""
    return Geom2d_BSplineCurve(
        _tcol_points1(np.array([p, q], float)),
        _tcol_reals(np.array([first, last], float)),
        _tcol_ints(np.array([2, 2])),
        1,
    )


def _tcol_points2(x: np.ndarray) -> TColgp_Array2OfPnt:
    nu, nv, _ = x.shape
    out = TColgp_Array2OfPnt(1, nu, 1, nv)
    for i, row in enumerate(x.tolist(), 1):
        for j, (a, b, c) in enumerate(row, 1):
            out.SetValue(i, j, gp_Pnt(a, b, c))
    return out


def _tcol_reals2(x: np.ndarray) -> TColStd_Array2OfReal:
    nu, nv = x.shape
    out = TColStd_Array2OfReal(1, nu, 1, nv)
    for i, row in enumerate(x.tolist(), 1):
        for j, v in enumerate(row, 1):
            out.SetValue(i, j, v)
    return out


# ---------------------------------------------------------------- frames


def _ax3_rows(a: Any) -> np.ndarray:
    return np.array(
        [
            _xyz(a.Location()),
            _xyz(a.Direction()),
            _xyz(a.XDirection()),
            _xyz(a.YDirection()),
        ]
    )


def _ulps(x: float, radius: int) -> list[float]:
    """``x`` and its neighbouring floats up to ``radius`` ulps away, nearest first."""
    out, lo, hi = [x], x, x
    for _ in range(radius):
        lo, hi = math.nextafter(lo, -math.inf), math.nextafter(hi, math.inf)
        out += [lo, hi]
    return out


def _fixed_point(target: tuple[float, ...], make: Any, read: Any) -> Any:
    """An object built by ``make(c)`` whose ``read()`` is exactly ``target``.

    OCCT's ``gp`` constructors re-normalise directions, so ``make(target)`` may
    come back a few ulps off.  Inputs up to 2 ulps away from ``target`` are
    tried; if none is a pre-image, ``make(target)`` is returned (docs/format.md §3).
    """
    obj = make(target)
    if read(obj) == target:
        return obj
    for cand in itertools.product(*(_ulps(x, 2) for x in target)):
        o = make(cand)
        if read(o) == target:
            return o
    return obj


def _dir(t: np.ndarray) -> gp_Dir:
    return _fixed_point(tuple(t.tolist()), lambda c: gp_Dir(*c), _xyz)


def _dir2d(t: np.ndarray) -> gp_Dir2d:
    return _fixed_point(tuple(t.tolist()), lambda c: gp_Dir2d(*c), _xy)


def _ax3(f: np.ndarray) -> gp_Ax3:
    p, n = gp_Pnt(*f[0]), _dir(f[1])
    a = _fixed_point(
        tuple(f[2].tolist()), lambda c: gp_Ax3(p, n, gp_Dir(*c)), lambda a: _xyz(a.XDirection())
    )
    if np.dot(np.cross(f[1], f[2]), f[3]) < 0:
        a.YReverse()
    return a


def _ax2_rows(a: Any) -> np.ndarray:
    return np.array([_xyz(a.Location()), _xyz(a.Direction()), _xyz(a.XDirection())])


def _ax2(f: np.ndarray) -> gp_Ax2:
    p, n = gp_Pnt(*f[0]), _dir(f[1])
    return _fixed_point(
        tuple(f[2].tolist()), lambda c: gp_Ax2(p, n, gp_Dir(*c)), lambda a: _xyz(a.XDirection())
    )


def _ax22d_rows(a: Any) -> np.ndarray:
    return np.array([_xy(a.Location()), _xy(a.XDirection()), _xy(a.YDirection())])


def _ax22d(f: np.ndarray) -> gp_Ax22d:
    return gp_Ax22d(gp_Pnt2d(*f[0]), _dir2d(f[1]), _dir2d(f[2]))


_EMPTY = np.zeros(0)
_EMPTY_FRAME = np.zeros((0, 3))

# ---------------------------------------------------------------- reading


def record_key(rec: Geometry) -> tuple[Any, ...]:
    """A hashable value for a record: equal keys mean bit-identical geometry."""
    if isinstance(rec, BSplineSurface):
        w = b"" if rec.weights is None else rec.weights.tobytes()
        return (
            rec.kind,
            rec.poles.shape,
            rec.poles.tobytes(),
            w,
            rec.uknots.tobytes(),
            rec.vknots.tobytes(),
            rec.umults.tobytes(),
            rec.vmults.tobytes(),
            rec.udegree,
            rec.vdegree,
            rec.uperiodic,
            rec.vperiodic,
        )
    if isinstance(rec, BSplineCurve):
        w = b"" if rec.weights is None else rec.weights.tobytes()
        return (
            rec.kind,
            rec.poles.shape,
            rec.poles.tobytes(),
            w,
            rec.knots.tobytes(),
            rec.mults.tobytes(),
            rec.degree,
            rec.periodic,
        )
    if isinstance(rec, Derived):
        return (rec.kind, rec.basis, rec.frame.tobytes(), rec.params.tobytes())
    return (rec.kind, rec.frame.shape, rec.frame.tobytes(), rec.params.tobytes())


class GeometryTable:
    """A list of records in which equal records are stored once.

    With ``by_handle`` set, each distinct OCCT handle keeps its own row, as
    surfaces must: OCCT finds an edge's pcurve on a face by the identity of the
    face's surface handle, so two faces must not come to share one.  Rows whose
    records are equal then hold the *same* record object, which the container
    stores once.
    """

    def __init__(self, by_handle: bool = False) -> None:
        self.records: list[Geometry] = []
        self._by_value: dict[tuple[Any, ...], int] = {}
        self._by_handle: dict[int, int] | None = {} if by_handle else None
        self._alive: list[Any] = []  # keeps handle wrappers alive, so id() is stable

    def add(self, rec_of: Any, handle: Any) -> int:
        if self._by_handle is not None:
            i = self._by_handle.get(id(handle))
            if i is not None:
                return i
        rec = rec_of(handle)
        k = record_key(rec)
        i = self._by_value.get(k)
        if self._by_handle is None:
            if i is None:
                i = self._by_value[k] = len(self.records)
                self.records.append(rec)
            return i
        if i is not None:
            rec = self.records[i]
        else:
            self._by_value[k] = len(self.records)
        j = self._by_handle[id(handle)] = len(self.records)
        self._alive.append(handle)
        self.records.append(rec)
        return j


#: Conic curve classes (``Geom2d_`` read as ``Geom_``) and their kinds.
_CONICS = {
    "Geom_Circle": Kind.CIRCLE,
    "Geom_Ellipse": Kind.ELLIPSE,
    "Geom_Hyperbola": Kind.HYPERBOLA,
    "Geom_Parabola": Kind.PARABOLA,
}


def _conic_params(c: Any, kind: Kind) -> list[float]:
    """A conic's radii (circle: one; ellipse, hyperbola: major, minor) or focal length."""
    if kind == Kind.CIRCLE:
        return [c.Radius()]
    if kind == Kind.PARABOLA:
        return [c.Focal()]
    return [c.MajorRadius(), c.MinorRadius()]


class GeometryReader:
    """Reads OCCT geometry into three deduplicated tables."""

    def __init__(self) -> None:
        self.surfaces = GeometryTable(by_handle=True)
        self.curves3d = GeometryTable()
        self.curves2d = GeometryTable()

    def surface(self, s: Any) -> int:
        """Index of a ``Geom_Surface`` in the surface table."""
        return self.surfaces.add(self._surface, s)

    def curve3d(self, c: Any) -> int:
        """Index of a ``Geom_Curve`` in the 3-D curve table (-1 for a null handle)."""
        return -1 if c is None else self.curves3d.add(lambda h: self._curve(h, 3), c)

    def curve2d(self, c: Any) -> int:
        """Index of a ``Geom2d_Curve`` in the 2-D curve table (-1 for a null handle)."""
        return -1 if c is None else self.curves2d.add(lambda h: self._curve(h, 2), c)

    def _surface(self, s: Any) -> Geometry:
        name = type(s).__name__
        if name == "Geom_Plane":
            return Analytic(Kind.PLANE, _ax3_rows(s.Position()), _EMPTY)
        if name == "Geom_CylindricalSurface":
            return Analytic(Kind.CYLINDER, _ax3_rows(s.Position()), np.array([s.Radius()]))
        if name == "Geom_ConicalSurface":
            return Analytic(
                Kind.CONE, _ax3_rows(s.Position()), np.array([s.RefRadius(), s.SemiAngle()])
            )
        if name == "Geom_SphericalSurface":
            return Analytic(Kind.SPHERE, _ax3_rows(s.Position()), np.array([s.Radius()]))
        if name == "Geom_ToroidalSurface":
            return Analytic(
                Kind.TORUS,
                _ax3_rows(s.Position()),
                np.array([s.MajorRadius(), s.MinorRadius()]),
            )
        if name == "Geom_SurfaceOfRevolution":
            ax = s.Axis()
            frame = np.array([_xyz(ax.Location()), _xyz(ax.Direction())])
            return Derived(Kind.REVOLUTION, self.curve3d(s.BasisCurve()), frame, _EMPTY)
        if name == "Geom_SurfaceOfLinearExtrusion":
            frame = np.array([_xyz(s.Direction())])
            return Derived(Kind.EXTRUSION, self.curve3d(s.BasisCurve()), frame, _EMPTY)
        if name == "Geom_OffsetSurface":
            return Derived(
                Kind.OFFSET_SURFACE,
                self.surface(s.BasisSurface()),
                _EMPTY_FRAME,
                np.array([s.Offset()]),
            )
        if name == "Geom_RectangularTrimmedSurface":
            u1, u2, v1, v2 = s.Bounds()
            return Derived(
                Kind.TRIMMED_SURFACE,
                self.surface(s.BasisSurface()),
                _EMPTY_FRAME,
                np.array([u1, u2, v1, v2]),
            )
        if name in ("Geom_BSplineSurface", "Geom_BezierSurface"):
            bezier = name == "Geom_BezierSurface"
            poles = _points2(s.Poles())
            rational = s.IsURational() or s.IsVRational()
            weights = _reals2(s.Weights()) if rational else None
            if bezier:
                nu, nv = poles.shape[:2]
                return BSplineSurface(
                    poles,
                    weights,
                    np.array([0.0, 1.0]),
                    np.array([0.0, 1.0]),
                    np.array([nu, nu]),
                    np.array([nv, nv]),
                    nu - 1,
                    nv - 1,
                    False,
                    False,
                    bezier=True,
                )
            return BSplineSurface(
                poles,
                weights,
                _reals(s.UKnots()),
                _reals(s.VKnots()),
                _ints(s.UMultiplicities()),
                _ints(s.VMultiplicities()),
                s.UDegree(),
                s.VDegree(),
                s.IsUPeriodic(),
                s.IsVPeriodic(),
            )
        raise UnsupportedError(f"surface type {name} is not supported")

    def _curve(self, c: Any, dim: int) -> Geometry:
        name = type(c).__name__.replace("Geom2d_", "Geom_")
        if name == "Geom_Line":
            p = c.Position()
            get = _xyz if dim == 3 else _xy
            return Analytic(Kind.LINE, np.array([get(p.Location()), get(p.Direction())]), _EMPTY)
        if name in _CONICS:
            kind = _CONICS[name]
            frame = _ax2_rows(c.Position()) if dim == 3 else _ax22d_rows(c.Position())
            return Analytic(kind, frame, np.array(_conic_params(c, kind), np.float64))
        if name in ("Geom_BSplineCurve", "Geom_BezierCurve"):
            poles = _points1(c.Poles(), dim)
            weights = _reals(c.Weights()) if c.IsRational() else None
            if name == "Geom_BezierCurve":
                n = len(poles)
                return BSplineCurve(
                    poles, weights, np.array([0.0, 1.0]), np.array([n, n]), n - 1, False, True
                )
            return BSplineCurve(
                poles,
                weights,
                _reals(c.Knots()),
                _ints(c.Multiplicities()),
                c.Degree(),
                c.IsPeriodic(),
            )
        add = self.curve3d if dim == 3 else self.curve2d
        if name == "Geom_TrimmedCurve":
            bounds = np.array([c.FirstParameter(), c.LastParameter()])
            return Derived(Kind.TRIMMED_CURVE, add(c.BasisCurve()), _EMPTY_FRAME, bounds)
        if name == "Geom_OffsetCurve":
            frame = np.array([_xyz(c.Direction())]) if dim == 3 else _EMPTY_FRAME
            return Derived(Kind.OFFSET_CURVE, add(c.BasisCurve()), frame, np.array([c.Offset()]))
        raise UnsupportedError(f"curve type {type(c).__name__} is not supported")


# ---------------------------------------------------------------- building


class GeometryBuilder:
    """Builds OCCT handles from the model's tables, each index once."""

    def __init__(
        self, surfaces: list[Geometry], curves3d: list[Geometry], curves2d: list[Geometry]
    ) -> None:
        self._tables = {"s": surfaces, "3": curves3d, "2": curves2d}
        self._built: dict[tuple[str, int], Any] = {}

    def surface(self, i: int) -> Any:
        return self._get("s", i)

    def curve3d(self, i: int) -> Any:
        return self._get("3", i)

    def curve2d(self, i: int) -> Any:
        return self._get("2", i)

    def _get(self, table: str, i: int) -> Any:
        if i < 0:
            return None
        h = self._built.get((table, i))
        if h is None:
            rec = self._tables[table][i]
            if table == "s":
                h = self._make_surface(rec)
            else:
                h = self._make_curve(rec, 3 if table == "3" else 2)
            self._built[(table, i)] = h
        return h

    def _make_surface(self, r: Geometry) -> Any:
        k = r.kind
        if isinstance(r, Analytic):
            p = r.params.tolist()
            if k == Kind.PLANE:
                return Geom_Plane(_ax3(r.frame))
            if k == Kind.CYLINDER:
                return Geom_CylindricalSurface(_ax3(r.frame), p[0])
            if k == Kind.CONE:
                return Geom_ConicalSurface(_ax3(r.frame), p[1], p[0])
            if k == Kind.SPHERE:
                return Geom_SphericalSurface(_ax3(r.frame), p[0])
            if k == Kind.TORUS:
                return Geom_ToroidalSurface(_ax3(r.frame), p[0], p[1])
        if isinstance(r, Derived):
            p = r.params.tolist()
            if k == Kind.REVOLUTION:
                ax = gp_Ax1(gp_Pnt(*r.frame[0]), _dir(r.frame[1]))
                return Geom_SurfaceOfRevolution(self.curve3d(r.basis), ax)
            if k == Kind.EXTRUSION:
                return Geom_SurfaceOfLinearExtrusion(self.curve3d(r.basis), _dir(r.frame[0]))
            if k == Kind.OFFSET_SURFACE:
                return Geom_OffsetSurface(self.surface(r.basis), p[0], True)
            if k == Kind.TRIMMED_SURFACE:
                return Geom_RectangularTrimmedSurface(
                    self.surface(r.basis), p[0], p[1], p[2], p[3], True, True
                )
        if isinstance(r, BSplineSurface):
            poles = _tcol_points2(r.poles)
            if r.bezier:
                if r.weights is None:
                    return Geom_BezierSurface(poles)
                return Geom_BezierSurface(poles, _tcol_reals2(r.weights))
            uk, vk = _tcol_reals(r.uknots), _tcol_reals(r.vknots)
            um, vm = _tcol_ints(r.umults), _tcol_ints(r.vmults)
            ud, vd, up, vp = r.udegree, r.vdegree, r.uperiodic, r.vperiodic
            if r.weights is None:
                return Geom_BSplineSurface(poles, uk, vk, um, vm, ud, vd, up, vp)
            w = _tcol_reals2(r.weights)
            return Geom_BSplineSurface(poles, w, uk, vk, um, vm, ud, vd, up, vp)
        raise UnsupportedError(f"not a surface record: {k!r}")

    def _make_curve(self, r: Geometry, dim: int) -> Any:
        k = r.kind
        three = dim == 3
        if isinstance(r, Analytic):
            f, p = r.frame, r.params.tolist()
            if k == Kind.LINE:
                if three:
                    return Geom_Line(gp_Ax1(gp_Pnt(*f[0]), _dir(f[1])))
                return Geom2d_Line(gp_Ax2d(gp_Pnt2d(*f[0]), _dir2d(f[1])))
            # gp_Ax2 for the Geom_ classes, gp_Ax22d for the Geom2d_ ones
            ax: Any = _ax2(f) if three else _ax22d(f)
            if k == Kind.CIRCLE:
                return (Geom_Circle if three else Geom2d_Circle)(ax, p[0])
            if k == Kind.ELLIPSE:
                return (Geom_Ellipse if three else Geom2d_Ellipse)(ax, p[0], p[1])
            if k == Kind.HYPERBOLA:
                return (Geom_Hyperbola if three else Geom2d_Hyperbola)(ax, p[0], p[1])
            if k == Kind.PARABOLA:
                return (Geom_Parabola if three else Geom2d_Parabola)(ax, p[0])
        if isinstance(r, BSplineCurve):
            poles = _tcol_points1(r.poles)
            if r.bezier:
                bezier = Geom_BezierCurve if three else Geom2d_BezierCurve
                if r.weights is None:
                    return bezier(poles)
                return bezier(poles, _tcol_reals(r.weights))
            bspline = Geom_BSplineCurve if three else Geom2d_BSplineCurve
            knots, mults = _tcol_reals(r.knots), _tcol_ints(r.mults)
            if r.weights is None:
                return bspline(poles, knots, mults, r.degree, r.periodic)
            return bspline(poles, _tcol_reals(r.weights), knots, mults, r.degree, r.periodic)
        if isinstance(r, Derived):
            basis = self.curve3d(r.basis) if three else self.curve2d(r.basis)
            p = r.params.tolist()
            if k == Kind.TRIMMED_CURVE:
                trimmed = Geom_TrimmedCurve if three else Geom2d_TrimmedCurve
                return trimmed(basis, p[0], p[1], True, False)
            if k == Kind.OFFSET_CURVE:
                if three:
                    return Geom_OffsetCurve(basis, p[0], _dir(r.frame[0]), True)
                return Geom2d_OffsetCurve(basis, p[0], True)
        raise UnsupportedError(f"not a {dim}-D curve record: {k!r}")
