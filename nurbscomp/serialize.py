"""The B-rep model <-> the payloads of a container's sections.

Sections, in the order they are written and read (docs/format.md gives the
array-by-array layout of each):

====  ==========================================================
META  JSON: unit, source format, mode, tolerance, source name/size
LOCS  datums (3x4 matrices) and locations (datum, power chains)
SURF  surface table
SNET  coded B-spline surface nets (tolerance mode; empty when lossless)
CRV3  3-D curve table
CNET  coded B-spline 3-D curve poles (tolerance mode; empty when lossless)
CRV2  2-D curve table (pcurves)
SHAP  shape types, flags, and sub-shape references
VERT  vertex points, tolerances, point representations
EDGE  edge tolerances, flags, curve representations
FACE  face surface, location, tolerance, natural-restriction flag
SIDE  (1.1, optional) net sides set to another net's side
PROD  (1.2, optional) product data: tree, names, colours, layers, header
====  ==========================================================
"""

from __future__ import annotations

import json
import lzma
from collections.abc import Callable, Collection
from dataclasses import dataclass
from typing import Any, cast

import numpy as np

from . import budget, codec, container, product, topocode
from .errors import BadReferenceError, CorruptError, LimitError, SectionError
from .model import (
    EC,
    REBUILD,
    VC,
    Analytic,
    BRepModel,
    BSplineCurve,
    BSplineSurface,
    Derived,
    Geometry,
    Kind,
    Location,
    PointRepKind,
    Rec,
    RepKind,
    ShapeType,
    Table,
    first_row,
)
from .streams import BlockReader, BlockWriter
from .units import UNITS_MM

#: Kind code of a table row that repeats an earlier row's record.
COPY = 255

# rows of `frame` and length of `params`, by kind, for (3-D, 2-D)
_ANALYTIC_SHAPE: dict[Kind, tuple[tuple[int, int], tuple[int, int]]] = {
    Kind.PLANE: ((4, 0), (0, 0)),
    Kind.CYLINDER: ((4, 1), (0, 0)),
    Kind.CONE: ((4, 2), (0, 0)),
    Kind.SPHERE: ((4, 1), (0, 0)),
    Kind.TORUS: ((4, 2), (0, 0)),
    Kind.LINE: ((2, 0), (2, 0)),
    Kind.CIRCLE: ((3, 1), (3, 1)),
    Kind.ELLIPSE: ((3, 2), (3, 2)),
    Kind.HYPERBOLA: ((3, 2), (3, 2)),
    Kind.PARABOLA: ((3, 1), (3, 1)),
}
_DERIVED_SHAPE: dict[Kind, tuple[tuple[int, int], tuple[int, int]]] = {
    Kind.REVOLUTION: ((2, 0), (0, 0)),
    Kind.EXTRUSION: ((1, 0), (0, 0)),
    Kind.OFFSET_SURFACE: ((0, 1), (0, 0)),
    Kind.TRIMMED_SURFACE: ((0, 4), (0, 0)),
    Kind.TRIMMED_CURVE: ((0, 2), (0, 2)),
    Kind.OFFSET_CURVE: ((1, 1), (0, 1)),
}
#: Surfaces swept from a 3-D curve (their basis is in the 3-D curve table).
SWEPT = (Kind.REVOLUTION, Kind.EXTRUSION)
#: Format 2.0, SURF and CRV3: the analytic kinds whose origin and lengths may
#: be on a grid (``Analytic.grid``), and which of their params are lengths.
GRID_LENGTHS: dict[Kind, tuple[int, ...]] = {
    Kind.PLANE: (),
    Kind.CYLINDER: (0,),
    Kind.CONE: (0,),
    Kind.SPHERE: (0,),
    Kind.TORUS: (0, 1),
    Kind.LINE: (),
    Kind.CIRCLE: (0,),
    Kind.ELLIPSE: (0, 1),
    Kind.HYPERBOLA: (0, 1),
    Kind.PARABOLA: (0,),
}
#: Grids 1 ... 127: steps 2^-63 ... 2^63.
GRID_MIN, GRID_MAX = 1, 127
#: Integers on a grid are below 2^53 in magnitude (exact as floats).
MAX_GRID_INT = 1 << 53

# ---------------------------------------------------------------- reader limits
#
# The reader trusts nothing: every count is checked against the bytes that
# remain before anything is allocated from it, every index against its table,
# and every B-spline against OCCT's own rules, so that what reaches OCCT is
# something OCCT's constructors accept.

#: OCCT's largest B-spline degree (``Geom_BSplineSurface::MaxDegree``).
MAX_DEGREE = 25
#: Most poles one coded net may have.  A coded net's poles are not backed by
#: bytes (a boundary-coded n x m net holds O(n + m) integers), so its size is bounded here.
MAX_NET_POLES = 1 << 20
#: Most poles all coded nets of one table may have together.
MAX_CODED_POLES = 1 << 23
#: Largest magnitude of a decoded coordinate (OCCT's ``Precision::Infinite()``).
MAX_COORD = 2e100
#: Largest |level| of a net code's quantizer (steps tol·2^(level/4)).
MAX_LEVEL = 96


def finite(a: np.ndarray, where: str, bound: float = np.inf) -> None:
    """Raise ``SectionError`` unless every value of ``a`` is finite (and below ``bound``)."""
    with np.errstate(invalid="ignore"):
        if a.size and not (np.abs(a) < bound).all():
            raise SectionError(f"{where}: a value is not finite or out of range")


def _tolerances(a: np.ndarray, where: str) -> None:
    """Raise ``SectionError`` unless every tolerance is finite and not negative."""
    finite(a, where, MAX_COORD)
    if a.size and a.min() < 0:
        raise SectionError(f"{where}: a tolerance is negative")


def _counts(per: np.ndarray, r: BlockReader, where: str) -> int:
    """The exact total of per-row counts, each checked against the bytes that remain.

    Every counted value is read from an array of at least one byte per value, so
    a total above ``r.remaining`` cannot be right; it is refused before any
    array of that size is made.
    """
    if len(per) and (per.min() < 0 or per.max() > r.remaining):
        raise SectionError(f"{where}: a count is negative or larger than the section")
    total = sum(per.tolist())  # Python ints: no wrap-around
    if total > r.remaining:
        raise SectionError(f"{where}: counts add up to more than the section holds")
    return int(total)


def _check_bspline(
    where: str, n: int, degree: int, knots: np.ndarray, mults: np.ndarray, periodic: bool
) -> None:
    """OCCT's rules for a B-spline's knots (``BSplCLib::NbPoles``, ``CheckCurveData``).

    Raises
    ------
    SectionError
        The degree, multiplicities or knots do not make a B-spline of ``n`` poles.
    """
    if not 1 <= degree <= MAX_DEGREE:
        raise SectionError(f"{where}: degree {degree} is out of range")
    if len(knots) < 2 or len(mults) != len(knots):
        raise SectionError(f"{where}: too few knots")
    finite(knots, where, MAX_COORD)
    # Python lists: a record has a few knots, where numpy's cost per call dominates
    k, m = knots.tolist(), [int(x) for x in mults.tolist()]
    if not all(b > a for a, b in zip(k, k[1:])):
        raise SectionError(f"{where}: knots do not increase")
    if min(m) < 1 or any(x > degree for x in m[1:-1]):
        raise SectionError(f"{where}: bad knot multiplicity")
    first, last = m[0], m[-1]
    if periodic:
        if first > degree or last > degree or first != last:
            raise SectionError(f"{where}: bad end multiplicities of a periodic B-spline")
        poles = sum(m) - last
    else:
        if first > degree + 1 or last > degree + 1:
            raise SectionError(f"{where}: bad end multiplicities")
        poles = sum(m) - degree - 1
    if poles != n:
        raise SectionError(f"{where}: knots make {poles} poles, the header says {n}")


# ---------------------------------------------------------------- geometry tables


#: Knot vector forms (format 2.0, docs/format.md §2.3): explicit, a repeat
#: of an earlier vector, evenly spaced (ends and ulp residuals); plus
#: ``SIMPLE``: multiplicities e, 1, ..., 1, e coded as e.
K_EXPLICIT, K_REPEAT, K_EVEN, K_SIMPLE = 0, 1, 2, 4
#: Largest |residual| (ulps) the writer codes an evenly spaced vector with.
EVEN_WRITE = 1 << 15
#: Largest |residual| (ulps) a reader accepts.
EVEN_READ = 1 << 31
_SIGN = 1 << 63
#: The writer repeats a vector of at least this many knots (a shorter one
#: costs LZMA less as it is: measured on the corpus at 0.01 mm).
REPEAT_MIN = 3
#: Kind code of an analytic row on a grid: ``GRIDDED + kind`` (2.0, §2.3).
GRIDDED = 128


def _keys(x: np.ndarray) -> list[int]:
    """Per float, its ordered key: the bit pattern as a signed integer when
    not negative, ``-1 - (i + 2^63)`` when negative (-0.0 -> -1, +0.0 -> 0)."""
    return [i if i >= 0 else -1 - (i + _SIGN) for i in x.astype("<f8").view("<i8").tolist()]


def _unkeys(keys: list[int], where: str) -> np.ndarray:
    """The floats of ordered keys (:func:`_keys`), refused outside 64 bits."""
    if any(not -_SIGN <= k < _SIGN for k in keys):
        raise SectionError(f"{where}: a knot residual is out of range")
    bits = [k if k >= 0 else -1 - k - _SIGN for k in keys]
    return np.array(bits, dtype="<i8").view("<f8").astype(np.float64)


def _even_prediction(a: float, b: float, nk: int) -> np.ndarray:
    """Inner knots of an evenly spaced vector from ``a`` to ``b``:
    ``a + j * ((b - a) / (nk - 1))``, j = 1 ... nk - 2, in binary64."""
    h = (np.float64(b) - np.float64(a)) / np.float64(nk - 1)
    j = np.arange(1, nk - 1, dtype=np.float64)
    return np.float64(a) + j * h


class _KnotWriter:
    """The 2.0 coding of a table's knot vectors and weight sets (§2.3): the
    forms, repeat distances and weight references go to the header stream
    ``hdr``, the residuals of evenly spaced vectors to ``res``."""

    def __init__(self, hdr: list[int]) -> None:
        self.hdr = hdr
        self.res: list[int] = []
        self._n = 0
        self._seen: dict[tuple[bytes, bytes], int] = {}
        self._weights: dict[bytes, int] = {}
        self._nw = 0

    def vector(
        self, k: np.ndarray, mu: np.ndarray, knots: list[np.ndarray], mults: list[int]
    ) -> None:
        n, nk = self._n, len(k)
        self._n += 1
        key = (k.astype("<f8").tobytes(), np.asarray(mu, "<i8").tobytes())
        j = self._seen.get(key)
        self._seen[key] = n
        if j is not None and nk >= REPEAT_MIN:
            self.hdr += [K_REPEAT, n - j]
            return
        m = [int(x) for x in mu.tolist()]
        form = K_EXPLICIT
        if nk >= 3:
            with np.errstate(all="ignore"):
                p = _even_prediction(float(k[0]), float(k[-1]), nk)
            if np.isfinite(p).all():
                r = [x - y for x, y in zip(_keys(k[1:-1]), _keys(p))]
                if max(abs(x) for x in r) < EVEN_WRITE:
                    form = K_EVEN
                    knots.append(k[[0, -1]])
                    self.res += r
        if form == K_EXPLICIT:
            knots.append(k)
        if m[0] == m[-1] and all(x == 1 for x in m[1:-1]):
            form |= K_SIMPLE
            mults.append(m[0])
        else:
            mults += m
        self.hdr.append(form)

    def weights(self, w: np.ndarray, out: list[np.ndarray]) -> None:
        key = w.astype("<f8").tobytes()
        j = self._weights.get(key)
        self._weights[key] = self._nw
        self.hdr.append(0 if j is None else self._nw - j)
        if j is None:
            out.append(w.reshape(-1))
        self._nw += 1


def _write_geometry(
    records: list[Geometry],
    dim: int,
    coded: frozenset[int] = frozenset(),
    revision: int = container.REVISION,
) -> bytes:
    """Write one geometry table.  ``dim`` is 3 for surfaces and 3-D curves, 2 for pcurves.

    A row holding the object of an earlier row is a COPY row (the distance
    back to the first row holding it: :func:`model.first_row`).  B-spline
    rows in ``coded`` (first rows of coded records) carry a flag (bit 3 for
    surfaces, bit 2 for curves) and no poles: those are in SNET / CNET.
    From revision 3 (format 2.0) knot vectors and weight sets are coded as
    what they are (:class:`_KnotWriter`).
    """
    kinds: list[int] = []
    copies: list[int] = []
    hdr: list[int] = []
    basis: list[int] = []
    mults: list[int] = []
    kw = _KnotWriter(hdr) if revision >= 3 else None
    gridded = revision >= 3 and dim == 3  # SURF, CRV3: analytic rows may be on a grid
    aval: list[int] = []
    frames: list[np.ndarray] = []
    params: list[np.ndarray] = []
    poles: list[np.ndarray] = []
    weights: list[np.ndarray] = []
    knots: list[np.ndarray] = []
    first = first_row(records)
    for i, r in enumerate(records):
        if first[i] != i:
            kinds.append(COPY)
            copies.append(i - first[i])
            continue
        if isinstance(r, Analytic) and gridded and r.grid:
            kinds.append(GRIDDED + int(r.kind))
            aval += [r.grid, r.mask, *_on_grid(r)]
            off = [j for j in range(3) if not r.mask >> j & 1]
            frames.append(np.concatenate([r.frame[0, off], r.frame[1:].reshape(-1)]))
            params.append(np.delete(r.params, GRID_LENGTHS[r.kind]))
            continue
        kinds.append(int(r.kind))
        if isinstance(r, Analytic):
            frames.append(r.frame.reshape(-1))
            params.append(r.params)
        elif isinstance(r, Derived):
            # a swept surface's basis is in the 3-D curve table: absolute index;
            # other bases precede their row in the same table: distance back
            basis.append(r.basis if r.kind in SWEPT else i - r.basis)
            frames.append(r.frame.reshape(-1))
            params.append(r.params)
        elif isinstance(r, BSplineSurface):
            nu, nv = r.poles.shape[:2]
            flags = int(r.weights is not None) | int(r.uperiodic) << 1 | int(r.vperiodic) << 2
            flags |= int(i in coded) << 3
            hdr += [nu, nv, flags]
            if not r.bezier:
                hdr += [r.udegree, r.vdegree, len(r.uknots), len(r.vknots)]
                if kw is not None:
                    kw.vector(r.uknots, r.umults, knots, mults)
                    kw.vector(r.vknots, r.vmults, knots, mults)
                else:
                    knots += [r.uknots, r.vknots]
                    mults += [*r.umults.tolist(), *r.vmults.tolist()]
            if i not in coded:
                poles.append(r.poles.reshape(-1))
            if r.weights is not None:
                if kw is not None:
                    kw.weights(r.weights, weights)
                else:
                    weights.append(r.weights.reshape(-1))
        elif isinstance(r, BSplineCurve):
            flags = int(r.weights is not None) | int(r.periodic) << 1 | int(i in coded) << 2
            hdr += [len(r.poles), flags]
            if not r.bezier:
                hdr += [r.degree, len(r.knots)]
                if kw is not None:
                    kw.vector(r.knots, r.mults, knots, mults)
                else:
                    knots.append(r.knots)
                    mults += r.mults.tolist()
            if i not in coded:
                poles.append(r.poles.reshape(-1))
            if r.weights is not None:
                if kw is not None:
                    kw.weights(r.weights, weights)
                else:
                    weights.append(r.weights)
    w = BlockWriter()
    w.ints(kinds)
    w.ints(copies)
    w.ints(hdr)
    w.ints(basis)
    w.ints(mults)
    if kw is not None:
        w.ints(kw.res)
    if gridded:
        w.ints(aval)
    for group in (frames, params, poles, weights, knots):
        w.floats(np.concatenate(group) if group else np.zeros(0))
    return bytes(w)


def _on_grid(r: Analytic) -> list[int]:
    """The integers of a record on its grid: the origin's coordinates in its
    mask, then its lengths."""
    q = 2.0 ** (r.grid - 64)
    if r.kind not in GRID_LENGTHS or not GRID_MIN <= r.grid <= GRID_MAX or not 0 <= r.mask < 8:
        raise ValueError(f"{r.kind.name} cannot be on grid {r.grid}")
    on = [j for j in range(3) if r.mask >> j & 1]
    vals = np.concatenate([r.frame[0, on], r.params[list(GRID_LENGTHS[r.kind])]])
    k = vals / q
    if not (np.abs(k) < MAX_GRID_INT).all() or (np.round(k) != k).any():
        raise ValueError(f"a {r.kind.name} is not on its grid {r.grid}")
    return [int(x) for x in k.tolist()]


class _Cursor:
    """Hands out consecutive slices of one decoded array, checking bounds."""

    def __init__(self, a: np.ndarray, name: str) -> None:
        self.a, self.pos, self.name = a, 0, name

    def take(self, n: int) -> np.ndarray:
        if n < 0 or self.pos + n > len(self.a):
            raise SectionError(f"{self.name} stream is too short at value {self.pos}")
        out = self.a[self.pos : self.pos + n]
        self.pos += n
        return out

    def one(self) -> int:
        return int(self.take(1)[0])

    def done(self) -> None:
        if self.pos != len(self.a):
            raise SectionError(f"{self.name} stream has unread values from value {self.pos}")


class _KnotReader:
    """The knot vectors and weight sets of a table, as a file of ``revision``
    codes them (:class:`_KnotWriter` from revision 3)."""

    def __init__(self, r: BlockReader, revision: int, tag: str, hdr: _Cursor) -> None:
        self.new = revision >= 3
        self.hdr = hdr
        self.knots = _Cursor(np.zeros(0), f"{tag} knot")  # set by the caller
        self.mults = _Cursor(np.zeros(0, np.int64), f"{tag} mults")  # set by the caller
        self.res = _Cursor(r.ints() if self.new else np.zeros(0, np.int64), f"{tag} kres")
        self.vectors: list[tuple[np.ndarray, np.ndarray]] = []
        self.wsets: list[np.ndarray] = []

    def vector(self, nk: int, where: str) -> tuple[np.ndarray, np.ndarray]:
        """The next vector's knots and multiplicities (``nk`` of each)."""
        if not self.new:
            return self.knots.take(nk), self.mults.take(nk).copy()
        n = len(self.vectors)
        form = self.hdr.one()
        if form == K_REPEAT:
            d = self.hdr.one()
            if not 1 <= d <= n:
                raise SectionError(f"{where}: a knot vector repeats one that does not exist")
            k, mu = self.vectors[n - d]
            if len(k) != nk:
                raise SectionError(f"{where}: a repeated knot vector has {len(k)} knots, not {nk}")
            mu = mu.copy()
        elif form & ~K_SIMPLE == K_EXPLICIT:
            k = self.knots.take(nk)
            mu = self._mults(form, nk)
        elif form & ~K_SIMPLE == K_EVEN:
            if nk < 3:
                raise SectionError(f"{where}: an evenly spaced knot vector of {nk} knots")
            a, b = self.knots.take(2).tolist()
            r = self.res.take(nk - 2)
            if len(r) and int(np.abs(r).max()) >= EVEN_READ:
                raise SectionError(f"{where}: a knot residual is out of range")
            with np.errstate(all="ignore"):
                p = _even_prediction(a, b, nk)
            if not np.isfinite(p).all():
                raise SectionError(f"{where}: evenly spaced knots are not finite")
            inner = _unkeys([x + y for x, y in zip(_keys(p), r.tolist())], where)
            k = np.concatenate([[a], inner, [b]])
            mu = self._mults(form, nk)
        else:
            raise SectionError(f"{where}: unknown knot vector form {form}")
        self.vectors.append((k, mu))
        return k, mu

    def _mults(self, form: int, nk: int) -> np.ndarray:
        if not form & K_SIMPLE:
            return self.mults.take(nk).copy()
        e = self.mults.one()
        mu = np.ones(nk, np.int64)
        mu[0] = mu[-1] = e
        return mu

    def weights(self, n: int, where: str, take: _Cursor) -> np.ndarray:
        """The next rational row's ``n`` weights."""
        if not self.new:
            return take.take(n)
        d = self.hdr.one()
        if d == 0:
            w = take.take(n)
        elif 1 <= d <= len(self.wsets):
            w = self.wsets[len(self.wsets) - d]
            if w.size != n:
                raise SectionError(f"{where}: repeated weights are {w.size}, not {n}")
        else:
            raise SectionError(f"{where}: weights repeat a set that does not exist")
        self.wsets.append(w.reshape(-1))
        return w.reshape(-1)

    def done(self) -> None:
        self.res.done()


def _read_geometry(
    data: bytes, tag: str, dim: int, revision: int = container.REVISION
) -> list[Geometry]:
    """Read one geometry table (see :func:`_write_geometry`), checking every row.

    Raises
    ------
    SectionError
        A row's kind, header, knots or values do not make a geometry OCCT accepts.
    LimitError
        Coded nets declare more poles than a reader allocates.
    """
    r = BlockReader(data, tag)
    kinds = r.ints()
    copies, hdr, basis, mults = (
        _Cursor(r.ints(), f"{tag} {n}") for n in ("copy", "hdr", "basis", "mults")
    )
    kr = _KnotReader(r, revision, tag, hdr)
    gridded = revision >= 3 and dim == 3
    aval = _Cursor(r.ints() if gridded else np.zeros(0, np.int64), f"{tag} grid values")
    frames, params, poles, weights, knots = (
        _Cursor(r.floats(), f"{tag} {n}") for n in ("frame", "param", "pole", "weight", "knot")
    )
    r.done()
    kr.knots, kr.mults = knots, mults
    finite(frames.a, f"{tag} frames", MAX_COORD)
    finite(params.a, f"{tag} params", MAX_COORD)
    finite(poles.a, f"{tag} poles", MAX_COORD)
    out: list[Geometry] = []
    surface = tag == "SURF"
    coded_poles = 0
    for i, k in enumerate(kinds.tolist()):
        where = f"{tag} row {i}"
        if k == COPY:
            j = i - copies.one()
            if not 0 <= j < i:
                raise SectionError(f"{where} copies a row that does not exist")
            out.append(out[j])
            continue
        on_grid = gridded and GRIDDED <= k < COPY
        try:
            kind = Kind(k - GRIDDED if on_grid else k)
        except ValueError:
            raise SectionError(f"{where}: unknown geometry kind {k}") from None
        if on_grid and kind not in GRID_LENGTHS:
            raise SectionError(f"{where}: a {kind.name} cannot be on a grid")
        if (kind < 16) != surface:
            raise SectionError(f"{where}: kind {kind.name} in the wrong table")
        if kind in _ANALYTIC_SHAPE:
            nf, npar = _ANALYTIC_SHAPE[kind][dim == 2]
            if not on_grid:
                out.append(
                    Analytic(kind, frames.take(nf * dim).reshape(nf, dim), params.take(npar))
                )
                continue
            grid, mask = aval.one(), aval.one()
            if not GRID_MIN <= grid <= GRID_MAX or not 0 <= mask < 8:
                raise SectionError(f"{where}: grid {grid} or mask {mask} is out of range")
            lengths = GRID_LENGTHS[kind]
            on = [j for j in range(3) if mask >> j & 1]
            off = [j for j in range(3) if not mask >> j & 1]
            k = aval.take(len(on) + len(lengths))
            if (np.abs(k) >= MAX_GRID_INT).any():
                raise SectionError(f"{where}: a value on the grid is out of range")
            v = k.astype(np.float64) * np.float64(2.0 ** (grid - 64))
            frame = np.zeros((nf, dim))
            frame[0, on] = v[: len(on)]
            frame[0, off] = frames.take(len(off))
            frame[1:] = frames.take((nf - 1) * dim).reshape(nf - 1, dim)
            par = np.zeros(npar)
            rest = [j for j in range(npar) if j not in lengths]
            par[list(lengths)] = v[len(on) :]
            par[rest] = params.take(len(rest))
            out.append(Analytic(kind, frame, par, grid, mask))
        elif kind in _DERIVED_SHAPE:
            nf, npar = _DERIVED_SHAPE[kind][dim == 2]
            b = basis.one()
            if kind not in SWEPT:
                b = i - b
            if not (b >= 0 if kind in SWEPT else 0 <= b < i):
                raise SectionError(f"{where} refers to a missing basis")
            out.append(Derived(kind, b, frames.take(nf * 3).reshape(nf, 3), params.take(npar)))
        elif kind in (Kind.BSPLINE_SURFACE, Kind.BEZIER_SURFACE):
            nu, nv, flags = (hdr.one() for _ in range(3))
            bez = kind == Kind.BEZIER_SURFACE
            if bez:
                ud, vd, ku, kv = nu - 1, nv - 1, 2, 2
            else:
                ud, vd, ku, kv = (hdr.one() for _ in range(4))
            if min(nu, nv, ku, kv) < 2 or not (1 <= ud and 1 <= vd) or not 0 <= flags < 16:
                raise SectionError(f"{where} has a bad B-spline header")
            if nu > ku * (MAX_DEGREE + 1) or nv > kv * (MAX_DEGREE + 1):
                raise SectionError(f"{where} has more poles than its knots allow")
            if bez:
                if max(ud, vd) > MAX_DEGREE:
                    raise SectionError(f"{where}: degree is out of range")
                uk, vk = np.array([0.0, 1.0]), np.array([0.0, 1.0])
                um, vm = np.array([nu, nu]), np.array([nv, nv])
            else:
                uk, um = kr.vector(ku, f"{where} (u)")
                vk, vm = kr.vector(kv, f"{where} (v)")
                _check_bspline(f"{where} (u)", nu, ud, uk, um, bool(flags & 2))
                _check_bspline(f"{where} (v)", nv, vd, vk, vm, bool(flags & 4))
            if flags & 8:  # coded net: filled in from SNET
                if nu * nv > MAX_NET_POLES or coded_poles + nu * nv > MAX_CODED_POLES:
                    raise LimitError(f"{where}: a coded net of {nu} x {nv} poles is too large")
                coded_poles += nu * nv
                p = np.full((nu, nv, 3), np.nan)
            else:
                p = poles.take(nu * nv * 3).reshape(nu, nv, 3)
            wts = kr.weights(nu * nv, where, weights).reshape(nu, nv) if flags & 1 else None
            if wts is not None and not _weights_ok(wts):
                raise SectionError(
                    f"{where}: weights must be within [{1 / MAX_COORD:g}, {MAX_COORD:g}]"
                )
            out.append(
                BSplineSurface(
                    p, wts, uk, vk, um, vm, ud, vd, bool(flags & 2), bool(flags & 4), bez
                )
            )
        else:  # BSPLINE_CURVE / BEZIER_CURVE
            n, flags = hdr.one(), hdr.one()
            bez = kind == Kind.BEZIER_CURVE
            deg, nk = (n - 1, 2) if bez else (hdr.one(), hdr.one())
            if n < 2 or nk < 2 or deg < 1 or not 0 <= flags < 8:
                raise SectionError(f"{where} has a bad B-spline header")
            if n > nk * (MAX_DEGREE + 1) or (bez and deg > MAX_DEGREE):
                raise SectionError(f"{where} has more poles than its knots allow")
            if bez:
                kn, mu = np.array([0.0, 1.0]), np.array([n, n])
            else:
                kn, mu = kr.vector(nk, where)
            if not bez:
                _check_bspline(where, n, deg, kn, mu, bool(flags & 2))
            if flags & 4:  # coded net: filled in from CNET
                if n > MAX_NET_POLES or coded_poles + n > MAX_CODED_POLES:
                    raise LimitError(f"{where}: a coded curve of {n} poles is too large")
                coded_poles += n
                cp = np.full((n, dim), np.nan)
            else:
                cp = poles.take(n * dim).reshape(n, dim)
            wts = kr.weights(n, where, weights) if flags & 1 else None
            if wts is not None and not _weights_ok(wts):
                raise SectionError(
                    f"{where}: weights must be within [{1 / MAX_COORD:g}, {MAX_COORD:g}]"
                )
            out.append(BSplineCurve(cp, wts, kn, mu, deg, bool(flags & 2), bez))
    for c in (copies, hdr, basis, mults, frames, params, poles, weights, knots, aval):
        c.done()
    kr.done()
    return out


def _weights_ok(w: np.ndarray) -> bool:
    """Every weight within [1/MAX_COORD, MAX_COORD]: OCCT's rational
    evaluation multiplies weights by coordinates (up to MAX_COORD) and sums
    them, and crashes on the overflow (found by the structure-aware fuzzer:
    weights of 1e-300 and 1e300 on poles at 2e100)."""
    with np.errstate(invalid="ignore"):
        return bool(((w >= 1.0 / MAX_COORD) & (w <= MAX_COORD)).all())


# ---------------------------------------------------------------- topology


def _write_locations(m: BRepModel) -> bytes:
    w = BlockWriter()
    w.ints(m.datum_forms)
    w.floats(m.datums.reshape(-1))
    locs = m.locations[1:]
    w.ints([len(loc.datums) for loc in locs])
    w.ints([d for loc in locs for d in loc.datums])
    w.ints([p for loc in locs for p in loc.powers])
    return bytes(w)


def _read_locations(data: bytes, m: BRepModel) -> None:
    r = BlockReader(data, "LOCS")
    forms = r.ints()
    if len(forms) and (forms.min() < 0 or forms.max() > _MAX_TRSF_FORM):
        raise SectionError("LOCS: unknown transformation form")
    m.datum_forms = forms.astype(np.uint8)
    nd = len(m.datum_forms)
    m.datums = r.floats(nd * 12).reshape(nd, 3, 4)
    finite(m.datums, "LOCS datums", MAX_COORD)
    lengths = r.ints()
    total = _counts(lengths, r, "LOCS lengths")
    datums, powers = r.ints(total), r.ints(total)
    r.done()
    if len(datums) and (datums.min() < 0 or datums.max() >= nd):
        raise BadReferenceError("LOCS: a location refers to a missing datum")
    if len(powers) and (np.abs(powers).max() > _MAX_POWER or (powers == 0).any()):
        raise SectionError("LOCS: a location power is zero or out of range")
    ends = np.cumsum(lengths)
    m.locations = [Location((), ())] + [
        Location(tuple(datums[e - n : e].tolist()), tuple(powers[e - n : e].tolist()))
        for n, e in zip(lengths.tolist(), ends.tolist())
    ]


#: Largest ``gp_TrsfForm`` value (``gp_Other``).
_MAX_TRSF_FORM = 8
#: Largest |power| of a location factor (OCCT stores it as a 32-bit integer).
_MAX_POWER = 2**31 - 1


#: The shapes table of the last SHAP written, and its bytes (:func:`_write_shapes`).
_last_shapes: tuple[tuple[Any, ...], bytes] | None = None


def _shapes_key(m: BRepModel) -> tuple[Any, ...]:
    """Everything SHAP is written from: the shapes table, by value."""
    arrays = (m.shape_type, m.shape_flags, m.child_start, m.child_shape, m.child_orient)
    return (
        *((a.dtype.str, a.shape, a.tobytes()) for a in map(np.asarray, (*arrays, m.child_loc))),
        int(m.root_shape),
        int(m.root_orient),
        int(m.root_loc),
    )


def _write_shapes(m: BRepModel) -> bytes:
    """SHAP as format 2.0 lays it out (docs/format.md §2.5.1): a mode byte, then
    the walk's coded stream, or the 1.x arrays for a model the walk does not
    number as it is numbered or, under 512 coded bytes, whose arrays compress
    smaller.

    The last table's bytes are kept: the validity stage's candidates of one
    source differ in their geometry, not in their shapes, and the walk's
    coder is a Python loop (a fifth of a second on NIST_MBE_PMI_2)."""
    global _last_shapes
    key = _shapes_key(m)
    last = _last_shapes
    if last is not None and last[0] == key:
        return last[1]
    out = _write_shapes_now(m)
    _last_shapes = (key, out)
    return out


def _write_shapes_now(m: BRepModel) -> bytes:
    """:func:`_write_shapes`, without the kept table."""
    arrays = bytes([topocode.MODE_ARRAYS]) + _write_shape_arrays(m)
    coded = topocode.encode(m)
    if coded is None:
        return arrays
    coded = topocode.HEAD.pack(topocode.MODE_WALK, len(m.shape_type), len(m.child_shape)) + coded
    # a tiny model whose adaptive contexts never warm up can be smaller in the
    # arrays, once compressed: the smaller of the two is written
    if len(coded) < 512 and _xz(arrays) < _xz(coded):
        return arrays
    return coded


def _xz(raw: bytes) -> int:
    """Bytes of ``raw`` compressed alone (xz -9e)."""
    return len(lzma.compress(raw, preset=9 | lzma.PRESET_EXTREME))


def _write_shape_arrays(m: BRepModel) -> bytes:
    """SHAP as format 1.x lays it out (and 2.0 in mode 0)."""
    w = BlockWriter()
    w.ints(m.shape_type)
    w.ints(m.shape_flags)
    nkids = np.diff(m.child_start)
    w.ints(nkids)
    parent = np.repeat(np.arange(len(m.shape_type)), nkids)
    w.ints(parent - m.child_shape)
    w.ints(m.child_orient)
    w.ints(m.child_loc)
    w.ints([m.root_shape, m.root_orient, m.root_loc])
    return bytes(w)


def _read_shapes(
    data: bytes, m: BRepModel, revision: int = 0, limits: budget.Limits | None = None
) -> None:
    """Read SHAP as the file's ``revision`` lays it out (2.0: a mode byte, then
    the walk's coded stream or the 1.x arrays), checking every reference."""
    if revision < 3:
        _read_shape_arrays(data, m)
        return
    if not data:
        raise SectionError("SHAP: empty section")
    if data[0] == topocode.MODE_ARRAYS:
        _read_shape_arrays(data[1:], m)
        return
    if data[0] != topocode.MODE_WALK or len(data) < topocode.HEAD.size:
        raise SectionError("SHAP: unknown mode or truncated header at offset 0")
    _, n, c = topocode.HEAD.unpack_from(data)
    top = topocode.MAX_ROWS if limits is None else min(topocode.MAX_ROWS, limits.rows)
    if n + c > top:
        raise LimitError(f"SHAP declares {n + c:,} shapes and references, more than {top:,}")
    if n == 0:
        raise BadReferenceError("SHAP: bad root reference")
    depth = None if limits is None else limits.depth
    t = topocode.decode(data[topocode.HEAD.size :], n, c, depth)
    m.shape_type = np.array(t["types"], np.uint8)
    m.shape_flags = np.array(t["flags"], np.uint8)
    m.child_start = np.array(t["start"], np.int64)
    m.child_shape = np.array(t["shape"], np.int64)
    m.child_orient = np.array(t["orient"], np.uint8)
    m.child_loc = np.array(t["loc"], np.int64)
    m.root_shape, m.root_orient, m.root_loc = n - 1, t["root_orient"], t["root_loc"]


def _read_shape_arrays(data: bytes, m: BRepModel) -> None:
    r = BlockReader(data, "SHAP")
    types = r.ints()
    if len(types) and (types.min() < 0 or types.max() > 7):
        raise SectionError("SHAP: unknown shape type")
    m.shape_type = types.astype(np.uint8)
    n = len(m.shape_type)
    flags = r.ints(n)
    if n and (flags.min() < 0 or flags.max() > 255):
        raise SectionError("SHAP: unknown shape flags")
    m.shape_flags = flags.astype(np.uint8)
    nkids = r.ints(n)
    c = _counts(nkids, r, "SHAP child counts")
    back = r.ints(c)
    orient = r.ints(c)
    m.child_loc = r.ints(c)
    m.root_shape, m.root_orient, m.root_loc = r.ints(3).tolist()
    r.done()
    m.child_start = np.concatenate([[0], np.cumsum(nkids)]).astype(np.int64)
    parent = np.repeat(np.arange(n), nkids)
    if c and ((back < 1).any() or (back > parent).any()):
        raise BadReferenceError(
            "SHAP: a shape refers to itself or to a later shape (a cycle, or out of order)"
        )
    if c and (orient.min() < 0 or orient.max() > 3):
        raise SectionError("SHAP: unknown orientation")
    m.child_shape = parent - back
    m.child_orient = orient.astype(np.uint8)
    if not 0 <= m.root_shape < n or not 0 <= m.root_orient <= 3:
        raise BadReferenceError("SHAP: bad root reference")


#: Format 2.0: the mantissas of 2^(c/4), c mod 4 = 0..3 (:func:`quarter_power`).
QUARTERS = tuple(
    float.fromhex(x)
    for x in ("0x1p+0", "0x1.306fe0a31b715p+0", "0x1.6a09e667f3bcdp+0", "0x1.ae89f995ad3adp+0")
)
#: Largest |c| of a tolerance code.
MAX_QUARTER = 4000


def quarter_power(c: np.ndarray) -> np.ndarray:
    """2^(c/4) as format 2.0 computes it: ``ldexp(QUARTERS[c mod 4], floor(c/4))``."""
    c = np.asarray(c, np.int64)
    return np.ldexp(np.array(QUARTERS)[c % 4], c // 4)


def _write_tolerances(w: BlockWriter, tol: np.ndarray) -> None:
    """Format 2.0: tolerances that are 2^(c/4) bit for bit (0 < |c| <= MAX_QUARTER)
    as their codes c, the others (code 0) as floats."""
    codes = np.zeros(len(tol), np.int64)
    pos = tol > 0
    with np.errstate(divide="ignore", invalid="ignore"):
        guess = np.where(pos, np.rint(4 * np.log2(np.where(pos, tol, 1.0))), 0).astype(np.int64)
    guess = np.clip(guess, -MAX_QUARTER, MAX_QUARTER)
    exact = pos & (guess != 0) & (quarter_power(guess).view(np.int64) == tol.view(np.int64))
    codes[exact] = guess[exact]
    w.ints(codes)
    w.floats(tol[~exact])


def _read_tolerances(r: BlockReader, n: int | None, where: str) -> np.ndarray:
    codes = r.ints() if n is None else r.ints(n)
    if len(codes) and np.abs(codes).max() > MAX_QUARTER:
        raise SectionError(f"{where}: a tolerance code is out of range")
    out = quarter_power(codes)
    plain = codes == 0
    out[plain] = r.floats(int(plain.sum()))
    return out


def vertex_grid(tol: float) -> float:
    """Step of the grid lossy vertices are snapped to: every coordinate moves by
    at most h/2, so a vertex by at most tol/2 (``h = tol/√3``)."""
    return tol / np.sqrt(3.0)


def vertex_neighbours(m: BRepModel) -> list[list[int]]:
    """Format 2.0: per vertex row, the vertex rows that are direct children of
    an ``EDGE`` shape it is a direct child of (docs/format.md §2.6)."""
    nv = int((m.shape_type == ShapeType.VERTEX).sum())
    out: list[set[int]] = [set() for _ in range(nv)]
    tidx = m.type_index()
    types, children, start = m.shape_type, m.child_shape, m.child_start
    vertex = int(ShapeType.VERTEX)
    for s in np.flatnonzero(types == ShapeType.EDGE).tolist():
        kids = children[start[s] : start[s + 1]]
        vs = sorted({int(tidx[c]) for c in kids[types[kids] == vertex].tolist()})
        for a in vs:
            out[a].update(b for b in vs if b != a)
    return [sorted(x) for x in out]


def _grid_predictions(nbr: list[list[int]], rows: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Per grid vertex (``rows``, ascending, with grid integers ``q``), its
    prediction: the grid integers of its highest-row grid neighbour before it,
    else of the grid vertex before it (zeros for the first)."""
    pred = np.zeros_like(q)
    done: dict[int, int] = {}  # row -> k
    for k, v in enumerate(rows.tolist()):
        before = [done[u] for u in (nbr[v] if v < len(nbr) else ()) if u in done]
        if before:
            pred[k] = q[max(before)]
        elif k:
            pred[k] = q[k - 1]
        done[v] = k
    return pred


def _grid_from_residuals(nbr: list[list[int]], rows: np.ndarray, res: np.ndarray) -> np.ndarray:
    """The inverse of :func:`_grid_predictions`: grid integers from residuals."""
    q = np.zeros_like(res)
    done: dict[int, int] = {}
    with np.errstate(over="ignore"):
        for k, v in enumerate(rows.tolist()):
            before = [done[u] for u in (nbr[v] if v < len(nbr) else ()) if u in done]
            if before:
                q[k] = q[max(before)] + res[k]
            elif k:
                q[k] = q[k - 1] + res[k]
            else:
                q[k] = res[k]
            done[v] = k
    return q


def _write_vertices(m: BRepModel, tol: float = 0.0) -> bytes:
    """Vertices whose point is a grid point (``vertex_grid``) bit for bit are
    stored as grid integers; the others as floats."""
    w = BlockWriter()
    pts = m.vertex_point
    on_grid = np.zeros(len(pts), bool)
    q = np.zeros_like(pts, dtype=np.int64)
    if tol > 0 and len(pts):
        h = vertex_grid(tol)
        small = (np.abs(pts) < 2.0**50 * h).all(-1)
        q[small] = np.rint(pts[small] / h).astype(np.int64)
        on_grid = small & ((q * h).view(np.int64) == pts.view(np.int64)).all(-1)  # bit for bit
    w.ints(on_grid.astype(np.int64))
    w.floats(pts[~on_grid].reshape(-1))
    rows = np.flatnonzero(on_grid)
    pred = _grid_predictions(vertex_neighbours(m), rows, q[rows]) if len(rows) else q[rows]
    for axis in range(3):
        w.ints(q[rows, axis] - pred[:, axis])
    _write_tolerances(w, m.vertex_tol)
    reps = m.vertex_reps
    w.ints(np.bincount(reps[:, VC.VERTEX], minlength=len(m.vertex_tol)) if len(reps) else [])
    for col in range(1, 5):
        w.ints(reps[:, col])
    w.floats(m.vertex_rep_params.reshape(-1))
    return bytes(w)


def _read_vertices(data: bytes, m: BRepModel, tol: float = 0.0, revision: int = 3) -> None:
    r = BlockReader(data, "VERT")
    kind = r.ints()
    if len(kind) and (kind.min() < 0 or kind.max() > 1):
        raise SectionError("VERT: unknown vertex kind")
    on_grid = kind.astype(bool)
    nv, ng = len(on_grid), int(on_grid.sum())
    pts = np.zeros((nv, 3))
    pts[~on_grid] = r.floats(3 * (nv - ng)).reshape(-1, 3)
    if revision >= 3:
        res = np.stack([r.ints(ng) for _ in range(3)], axis=1)
        q = _grid_from_residuals(vertex_neighbours(m), np.flatnonzero(on_grid), res) if ng else res
    else:
        q = np.stack([r.deltas(ng) for _ in range(3)], axis=1)
    if ng and not tol > 0:
        raise SectionError("VERT: grid vertices need a positive tolerance")
    if ng:
        with np.errstate(over="ignore"):
            pts[on_grid] = q * vertex_grid(tol)
    finite(pts, "VERT points", MAX_COORD)
    m.vertex_point = pts
    m.vertex_tol = _read_tolerances(r, nv, "VERT") if revision >= 3 else r.floats(nv)
    _tolerances(m.vertex_tol, "VERT tolerances")
    per = r.ints()
    if len(per) not in (0, nv):
        raise SectionError("VERT: bad representation counts")
    nrep = _counts(per, r, "VERT representation counts")
    cols = [r.ints(nrep) for _ in range(4)]
    m.vertex_rep_params = r.floats(2 * nrep).reshape(-1, 2)
    r.done()
    finite(m.vertex_rep_params, "VERT parameters", MAX_COORD)
    cols.insert(0, np.repeat(np.arange(len(per)), per))
    m.vertex_reps = np.stack(cols, axis=1).astype(np.int64).reshape(-1, 5)


def edge_candidates(m: BRepModel, cap: float = np.inf) -> list[list[int]]:
    """Format 2.0: per edge row, the surface rows of the faces it bounds (faces
    in ``FACE`` order, each surface row at its first appearance): the
    candidates an ``EDGE`` surface pick names (docs/format.md §2.7).

    Raises
    ------
    LimitError
        The faces' walks visit more than ``cap`` sub-shape references (a
        reader's ``budget.Limits.references``: a shared DAG makes the walks
        quadratic).
    """
    tidx = m.type_index().tolist()
    types = m.shape_type.tolist()
    start, kids = m.child_start.tolist(), m.child_shape.tolist()
    edge, vertex = int(ShapeType.EDGE), int(ShapeType.VERTEX)
    out: list[list[int]] = [[] for _ in range(types.count(edge))]
    work = 0
    faces = [i for i, t in enumerate(types) if t == int(ShapeType.FACE)]
    for f, s in enumerate(faces):
        r = int(m.face_surface[f])
        seen, stack = {s}, [s]
        while stack:
            x = stack.pop()
            work += start[x + 1] - start[x]
            if work > cap:
                raise LimitError(
                    f"EDGE: the faces' walks to their edges pass more than {cap:g} references"
                )
            for c in kids[start[x] : start[x + 1]]:
                if c in seen:
                    continue
                seen.add(c)
                if types[c] == edge:
                    cands = out[tidx[c]]
                    if r not in cands:
                        cands.append(r)
                elif types[c] < edge and types[c] != vertex:
                    stack.append(c)
    return out


def _picks(values: np.ndarray, edges: np.ndarray, cands: list[list[int]]) -> np.ndarray:
    """Per value, its index among its edge's candidates, −1 where it is none."""
    out = np.full(len(values), -1, np.int64)
    for k, (v, e) in enumerate(zip(values.tolist(), edges.tolist())):
        c = cands[e]
        if v in c:
            out[k] = c.index(v)
    return out


def _write_edges(m: BRepModel, how: np.ndarray) -> bytes:
    """EDGE (format 2.0); ``how`` is each representation's range kind
    (``rules.ranges.range_kinds``)."""
    w = BlockWriter()
    _write_tolerances(w, m.edge_tol)
    w.ints(m.edge_flags)
    reps = m.edge_reps
    w.ints(np.bincount(reps[:, EC.EDGE], minlength=len(m.edge_tol)) if len(reps) else [])
    kind = reps[:, EC.KIND]
    w.ints(kind)
    # each column only where the representation kind uses it
    w.deltas(reps[kind == RepKind.CURVE3D, EC.CURVE])  # 3-D curve
    w.deltas(
        reps[(kind == RepKind.ON_SURFACE) | (kind == RepKind.ON_CLOSED_SURFACE), EC.CURVE]
    )  # pcurve
    w.ints(reps[kind == RepKind.ON_CLOSED_SURFACE, EC.CURVE2])  # second pcurve
    # surfaces (2.0): picked among the surfaces of the edge's faces, or escaped
    cands = edge_candidates(m)
    s1, e1 = reps[kind != RepKind.CURVE3D, EC.SURFACE], reps[kind != RepKind.CURVE3D, EC.EDGE]
    s2, e2 = (
        reps[kind == RepKind.ON_TWO_SURFACES, EC.SURFACE2],
        reps[kind == RepKind.ON_TWO_SURFACES, EC.EDGE],
    )
    p1, p2 = _picks(s1, e1, cands), _picks(s2, e2, cands)
    w.ints(p1)
    w.ints(p2)
    w.deltas(np.concatenate([s1[p1 < 0], s2[p2 < 0]]))
    w.ints(reps[:, EC.LOC])  # location
    w.ints(reps[kind == RepKind.ON_TWO_SURFACES, EC.LOC2])  # second location
    cont = (kind == RepKind.ON_CLOSED_SURFACE) | (kind == RepKind.ON_TWO_SURFACES)
    w.ints(m.edge_rep_cont[cont])
    ranged = kind != RepKind.ON_TWO_SURFACES
    w.ints(how[ranged])
    w.floats(m.edge_rep_range[ranged & (how == RANGE_STORED)].reshape(-1))
    on = (kind == RepKind.ON_SURFACE) | (kind == RepKind.ON_CLOSED_SURFACE)
    w.floats(m.edge_rep_uv[on, :4].reshape(-1))
    w.floats(m.edge_rep_uv[kind == RepKind.ON_CLOSED_SURFACE, 4:].reshape(-1))
    return bytes(w)


@dataclass
class _Picks:
    """Format 2.0: EDGE's surface picks, resolved once FACE is read."""

    first: np.ndarray
    second: np.ndarray
    escaped: np.ndarray


def _read_edges(data: bytes, m: BRepModel, revision: int = 3) -> tuple[np.ndarray, _Picks | None]:
    """Fill ``m``'s edge tables; return the range kinds (``rules.ranges.range_kinds``:
    ranges of any kind but ``RANGE_STORED`` are left for ``rules.ranges.resolve_ranges``)
    and, from revision 3, the surface picks (:func:`_resolve_picks`; the
    surfaces are 0 until then)."""
    r = BlockReader(data, "EDGE")
    m.edge_tol = _read_tolerances(r, None, "EDGE") if revision >= 3 else r.floats()
    _tolerances(m.edge_tol, "EDGE tolerances")
    ne = len(m.edge_tol)
    flags = r.ints(ne)
    if ne and (flags.min() < 0 or flags.max() > 7):
        raise SectionError("EDGE: unknown edge flags")
    m.edge_flags = flags.astype(np.uint8)
    per = r.ints()
    if len(per) not in (0, ne):
        raise SectionError("EDGE: bad representation counts")
    q = _counts(per, r, "EDGE representation counts")
    kind = r.ints(q)
    if q and (kind.min() < 0 or kind.max() > 3):
        raise SectionError("EDGE: unknown representation kind")
    reps = np.full((q, 8), -1, np.int64)
    reps[:, EC.EDGE] = np.repeat(np.arange(len(per)), per)
    reps[:, EC.KIND] = kind
    two = kind == RepKind.ON_TWO_SURFACES
    closed = kind == RepKind.ON_CLOSED_SURFACE
    c3 = kind == RepKind.CURVE3D
    pc = ~two & ~c3
    reps[c3, EC.CURVE] = r.deltas(int(c3.sum()))
    reps[pc, EC.CURVE] = r.deltas(int(pc.sum()))
    reps[closed, EC.CURVE2] = r.ints(int(closed.sum()))
    picks = None
    if revision >= 3:
        first, second = r.ints(int((~c3).sum())), r.ints(int(two.sum()))
        if (first < -1).any() or (second < -1).any():
            raise SectionError("EDGE: a surface pick below -1")
        n_esc = int((first == -1).sum() + (second == -1).sum())
        picks = _Picks(first, second, r.deltas(n_esc))
        reps[~c3, EC.SURFACE] = 0
        reps[two, EC.SURFACE2] = 0
    else:
        reps[~c3, EC.SURFACE] = r.deltas(int((~c3).sum()))
        reps[two, EC.SURFACE2] = r.deltas(int(two.sum()))
    reps[:, EC.LOC] = r.ints(q)
    reps[:, EC.LOC2] = 0
    reps[two, EC.LOC2] = r.ints(int(two.sum()))
    m.edge_reps = reps
    cont = r.ints(int((closed | two).sum()))
    if len(cont) and (cont.min() < 0 or cont.max() > 6):
        raise SectionError("EDGE: unknown continuity")
    m.edge_rep_cont = np.zeros(q, np.uint8)
    m.edge_rep_cont[closed | two] = cont
    how = np.full(q, RANGE_ZERO, np.int64)  # kind 3 reps have no range
    how[~two] = r.ints(int((~two).sum()))
    if ((how < 0) | (how > RANGE_VERTICES)).any():
        raise SectionError("EDGE: unknown range kind")
    m.edge_rep_range = np.zeros((q, 2))
    stored = how == RANGE_STORED
    m.edge_rep_range[stored] = r.floats(2 * int(stored.sum())).reshape(-1, 2)
    m.edge_rep_uv = np.zeros((q, 8))
    on = (kind == RepKind.ON_SURFACE) | closed
    m.edge_rep_uv[on, :4] = r.floats(4 * int(on.sum())).reshape(-1, 4)
    m.edge_rep_uv[closed, 4:] = r.floats(4 * int(closed.sum())).reshape(-1, 4)
    r.done()
    # an edge without a 3-D curve (degenerated) has OCCT's default range, ±DBL_MAX
    curveless = (kind == RepKind.CURVE3D) & (reps[:, EC.CURVE] == -1)
    finite(m.edge_rep_range, "EDGE ranges")
    finite(m.edge_rep_range[~curveless], "EDGE ranges", MAX_COORD)
    finite(m.edge_rep_uv, "EDGE uv points", MAX_COORD)
    return how, picks


def _resolve_picks(m: BRepModel, p: _Picks, cap: float) -> None:
    """Set EDGE's surfaces from their picks (format 2.0, docs/format.md §2.7)."""
    cands = edge_candidates(m, cap)
    reps = m.edge_reps
    esc = iter(p.escaped.tolist())
    kind = reps[:, EC.KIND]
    for col, sel, pick in (
        (EC.SURFACE, kind != RepKind.CURVE3D, p.first),
        (EC.SURFACE2, kind == RepKind.ON_TWO_SURFACES, p.second),
    ):
        rows = np.flatnonzero(sel).tolist()
        for q, k in zip(rows, pick.tolist()):
            if k == -1:
                reps[q, col] = next(esc)  # as many as the picks of -1: read so
                continue
            c = cands[int(reps[q, EC.EDGE])]
            if k >= len(c):
                raise BadReferenceError(
                    f"EDGE: representation {q} picks surface {k} of an edge on {len(c)}"
                )
            reps[q, col] = c[k]


#: How an edge representation's range is stored (EDGE, format 0.3; VERTICES 0.4).
RANGE_STORED, RANGE_NATURAL, RANGE_OF_3D, RANGE_ZERO, RANGE_VERTICES = 0, 1, 2, 3, 4


def _write_faces(m: BRepModel) -> bytes:
    w = BlockWriter()
    w.deltas(m.face_surface)
    w.ints(m.face_loc)
    w.floats(m.face_tol)
    w.ints(m.face_natural.astype(np.int64))
    return bytes(w)


def _read_faces(data: bytes, m: BRepModel) -> None:
    r = BlockReader(data, "FACE")
    m.face_surface = r.deltas()
    nf = len(m.face_surface)
    m.face_loc = r.ints(nf)
    m.face_tol = r.floats(nf)
    natural = r.ints(nf)
    r.done()
    _tolerances(m.face_tol, "FACE tolerances")
    if nf and (natural.min() < 0 or natural.max() > 1):
        raise SectionError("FACE: a natural-restriction flag is neither 0 nor 1")
    m.face_natural = natural.astype(bool)


# ---------------------------------------------------------------- coded nets


def coded_rows(records: list[Geometry]) -> list[int]:
    """Rows of the first occurrence of each coded B-spline record (NaN poles after reading)."""
    return [
        i
        for i, (first, g) in enumerate(zip(first_row(records), records))
        if i == first
        and isinstance(g, (BSplineSurface, BSplineCurve))
        and np.isnan(g.poles.flat[0])
    ]


@dataclass
class NetTable:
    """A SNET or CNET section as numbers: per coded row, in row order
    (:func:`coded_rows`), its method, quantizer, level and slope, and its
    integers; the DC coefficients of all of them, in order (how many each
    takes is known only as it is decoded: ``decode.apply``).  ``anchor``
    (``SNET`` from format 2.1): per row, 0 where its first pole is coded
    against the previous net's, k > 0 against the k-th vertex of the first
    face on it (:func:`joins.surface_anchor_candidates`)."""

    method: np.ndarray
    quant: np.ndarray
    level: np.ndarray
    slope: np.ndarray
    ints: list[np.ndarray]
    dcs: np.ndarray
    anchor: np.ndarray | None = None


#: Names of the integer streams of a 2.1 net table (``codec.segments``), in order.
NET_STREAMS = ("points", "residuals", "curve coefficients", "map coefficients", "references")


def _write_nets(
    t: NetTable,
    shapes: list[tuple[int, ...]],
    anchors: bool,
    revision: int = container.REVISION,
) -> bytes:
    """A SNET/CNET section (docs/format.md §2.4); ``shapes``: the coded rows'
    pole arrays' shapes, ``anchors``: whether the table has the anchor column
    (``SNET``, from revision 4)."""
    w = BlockWriter()
    for col in (t.method, t.quant, t.level, t.slope):
        w.ints(col)
    if revision < 4 or not t.ints:  # from revision 4 too, a table of no rows
        w.ints([len(x) for x in t.ints])
        w.ints(np.concatenate(t.ints) if t.ints else [])
        w.floats(t.dcs)
        return bytes(w)
    if anchors:
        w.ints(np.zeros(len(t.ints), np.int64) if t.anchor is None else t.anchor)
    parts: list[list[np.ndarray]] = [[] for _ in range(codec.STREAMS)]
    prev = 0  # an ISO code's surface row is stored against the previous one's
    for k, ints in enumerate(t.ints):
        if int(t.method[k]) == codec.Method.ISO and len(ints):
            ints, prev = np.concatenate([ints[:1] - prev, ints[1:]]), int(ints[0])
        at = 0
        for stream, n in codec.segments(int(t.method[k]), int(t.quant[k]), shapes[k]):
            parts[stream].append(ints[at : at + n])
            at += n
        if at != len(ints):
            raise ValueError(f"net {k} holds {len(ints)} integers, its method {at}")
    for p in parts:
        w.ints(np.concatenate(p) if p else [])
    w.floats(t.dcs)
    return bytes(w)


def _read_nets(
    data: bytes,
    n: int,
    tag: str,
    shapes: list[tuple[int, ...]] | None = None,
    revision: int = container.REVISION,
) -> NetTable:
    """A SNET/CNET section of ``n`` coded rows (of pole arrays ``shapes``); the
    integers split per row: before revision 4 (and in a table of no rows) by
    the stored counts, from it by :func:`codec.segments` from the five
    streams."""
    r = BlockReader(data, tag)
    if revision < 4 or n == 0:  # from revision 4 too, a table of no rows
        method, quant, level, slope, counts = (r.ints(n) for _ in range(5))
        ints = _Cursor(r.ints(), f"{tag} ints")
        dcs = r.floats()
        r.done()
        finite(dcs, f"{tag} DC coefficients", MAX_COORD)
        if (counts < 0).any():
            raise SectionError(f"{tag}: bad net header")
        per = [ints.take(int(c)) for c in counts]
        ints.done()
        return NetTable(method, quant, level, slope, per, dcs)
    if shapes is None or len(shapes) != n:
        raise ValueError("a net table from format 2.1 is read with its rows' shapes")
    method, quant, level, slope = (r.ints(n) for _ in range(4))
    anchor = r.ints(n) if tag == "SNET" else None
    streams = [_Cursor(r.ints(), f"{tag} {name}") for name in NET_STREAMS]
    dcs = r.floats()
    r.done()
    finite(dcs, f"{tag} DC coefficients", MAX_COORD)
    per = []
    prev = 0
    for k in range(n):
        try:
            runs = codec.segments(int(method[k]), int(quant[k]), shapes[k])
        except ValueError as e:
            raise SectionError(f"{tag}: net {k}: {e}") from None
        got = [streams[s].take(c) for s, c in runs]
        one = np.concatenate(got) if got else np.zeros(0, np.int64)
        if int(method[k]) == codec.Method.ISO:
            with np.errstate(over="ignore"):  # a wrapped sum is an out-of-table row
                one[0] += prev
            prev = int(one[0])
        per.append(one)
    for c in streams:
        c.done()
    return NetTable(method, quant, level, slope, per, dcs, anchor)


@dataclass
class Tables:
    """What a container stores besides the model's own tables, for the
    decoder's geometric steps (``decode.apply``): the coded nets, and how
    each edge representation's range is stored (``RANGE_*``)."""

    snet: NetTable
    cnet: NetTable
    range_how: np.ndarray
    #: the coded B-spline records (written with NaN poles: SNET/CNET hold them)
    coded: frozenset[Rec] = frozenset()

    def rows(self, which: Table) -> frozenset[int]:
        """The rows of the coded records of the ``which`` table."""
        return frozenset(k.row for k in self.coded if k.table == which)


# ---------------------------------------------------------------- whole model


def _shapes(records: list[Geometry], rows: list[int]) -> list[tuple[int, ...]]:
    """The shapes of the pole arrays of ``rows``."""
    return [cast(BSplineCurve | BSplineSurface, records[r]).poles.shape for r in rows]


def _net_shapes(records: list[Geometry], t: Tables, which: Table) -> list[tuple[int, ...]]:
    """The shapes of the pole arrays of a table's coded rows (the coded records'
    first rows, in order: the rows of its net table)."""
    coded = t.rows(which)
    first = first_row(records)
    return _shapes(records, [r for r in range(len(records)) if r == first[r] and r in coded])


def model_to_sections(
    m: BRepModel, meta: dict[str, Any], t: Tables, only: Collection[str] | None = None
) -> list[tuple[str, bytes]]:
    """The sections of a container holding ``m`` and the tables ``t`` (made by
    ``writer.tables``: in tolerance mode, ``m`` holds the *decoded* poles of
    the nets ``t`` codes, so that what the decoder rebuilds is ``m``).

    ``only``: the tags wanted (the others are not written; a measure of some
    sections' size needs no more)."""
    meta = {**meta, "unit": m.unit, "source_format": m.source_format}
    tol = float(meta.get("tolerance_mm") or 0.0)
    writers: list[tuple[str, Callable[[], bytes]]] = [
        ("META", lambda: json.dumps(meta, sort_keys=True, separators=(",", ":")).encode()),
        ("LOCS", lambda: _write_locations(m)),
        ("SURF", lambda: _write_geometry(m.surfaces, 3, t.rows(Table.SURFACE))),
        ("SNET", lambda: _write_nets(t.snet, _net_shapes(m.surfaces, t, Table.SURFACE), True)),
        ("CRV3", lambda: _write_geometry(m.curves3d, 3, t.rows(Table.CURVE3D))),
        ("CNET", lambda: _write_nets(t.cnet, _net_shapes(m.curves3d, t, Table.CURVE3D), False)),
        ("CRV2", lambda: _write_geometry(m.curves2d, 2)),
        ("SHAP", lambda: _write_shapes(m)),
        ("VERT", lambda: _write_vertices(m, tol)),
        ("EDGE", lambda: _write_edges(m, t.range_how)),
        ("FACE", lambda: _write_faces(m)),
        *([("SIDE", lambda: _write_sides(m))] if len(m.side_joins) else []),
        *([("PROD", lambda: product.write(m.product))] if m.product is not None else []),
    ]
    return [(tag, write()) for tag, write in writers if only is None or tag in only]


def _write_sides(m: BRepModel) -> bytes:
    """``m.side_joins`` (format 1.1): the count, then per column: the surface
    rows as deltas (they increase), the sides, each leader row as the surface
    row minus it, the leader sides, the reversed flags."""
    w = BlockWriter()
    j = m.side_joins.reshape(-1, 5)
    w.ints([len(j)])
    w.deltas(j[:, 0])
    w.ints(j[:, 1])
    w.ints(j[:, 0] - j[:, 2])
    w.ints(j[:, 3])
    w.ints(j[:, 4])
    return bytes(w)


def _read_sides(data: bytes, m: BRepModel, coded: set[int]) -> None:
    """Read SIDE into ``m.side_joins`` (``decode.apply`` joins the sides),
    checking that each row joins a coded surface row to a surface row."""
    r = BlockReader(data, "SIDE")
    (n,) = r.ints(1)
    if n < 0:
        raise SectionError("SIDE: negative count")
    cols = [r.deltas(int(n)), *(r.ints(int(n)) for _ in range(4))]
    r.done()
    cols[2] = cols[0] - cols[2]
    rows = np.stack(cols, axis=1).astype(np.int64).reshape(-1, 5)
    for k, (b, _, a, _, _) in enumerate(rows.tolist()):
        if b not in coded or not 0 <= a < len(m.surfaces):
            raise BadReferenceError(f"SIDE row {k}: refers to a missing or uncoded surface row")
    m.side_joins = rows


#: The sections of format 1.0, in the order they are written and must be read.
SECTIONS = ("META", "LOCS", "SURF", "SNET", "CRV3", "CNET", "CRV2", "SHAP", "VERT", "EDGE", "FACE")
#: What each revision (``container.VERSIONS``: 1 is format 1.1, 2 is 1.2)
#: adds, after the sections of the revisions before it.
ADDED = {1: ("SIDE",), 2: ("PROD",)}


def layout(revision: int) -> tuple[str, ...]:
    """The sections a file of ``revision`` holds, in order (as far as this reader knows)."""
    return SECTIONS + tuple(t for k, tags in sorted(ADDED.items()) if k <= revision for t in tags)


def check_layout(tags: list[str], revision: int, newer: bool = False) -> None:
    """Check a container's section tags: every section of ``SECTIONS``, in its order.

    A section this reader does not know is refused, except in a file that is
    ``newer`` than the versions this reader knows within format 1 (a 1.y past
    1.2, which no writer makes: 1.x added sections only with a minor bump), where
    it is skipped (docs/format.md, §0).

    Raises
    ------
    CorruptError
        A section is missing, out of order, or unknown.
    """
    order = layout(revision)
    known = [t for t in tags if t in order]
    for t in tags:
        if t not in order and not newer:
            raise CorruptError(f"unknown section {t!r} (position {tags.index(t)})")
    for t in SECTIONS:
        if t not in known:
            raise CorruptError(f"missing section {t}")
    expect = [t for t in order if t in known]  # the sections a later minor added are optional
    if known != expect:
        bad = next(i for i, (a, b) in enumerate(zip(known, expect)) if a != b)
        raise CorruptError(f"section {known[bad]} out of order (position {tags.index(known[bad])})")


def _number(x: Any) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool)


#: Largest META section a reader parses, in bytes (a writer's is ~200).
MAX_META_BYTES = 1 << 16
#: Longest string in META, in characters (``source_name`` is a file name).
MAX_META_TEXT = 1024
#: Most digits of an integer in META (``int()`` of a longer one is refused by
#: Python, and ``source_bytes`` fits 2^53 anyway).
MAX_META_DIGITS = 20
#: Largest ``source_bytes`` (exactly representable as a double).
MAX_SOURCE_BYTES = 2**53


def _meta_int(digits: str) -> int:
    if len(digits.lstrip("-")) > MAX_META_DIGITS:
        raise SectionError(f"META: an integer of {len(digits)} digits is too long")
    return int(digits)


def _meta_constant(name: str) -> float:
    raise SectionError(f"META: {name} is not a number")


def _bad_text(s: str) -> bool:
    """A control character (C0, DEL, C1) or a lone surrogate in ``s``."""
    return any(c < " " or "\x7f" <= c <= "\x9f" or "\ud800" <= c <= "\udfff" for c in s)


def meta_text(s: str) -> str:
    """``s`` as META may hold it: control characters and lone surrogates (a
    file name's undecodable bytes) become U+FFFD, and it is cut to ``MAX_META_TEXT``."""
    s = s[:MAX_META_TEXT]
    return "".join("\ufffd" if _bad_text(c) else c for c in s) if _bad_text(s) else s


def read_meta(raw: bytes) -> dict[str, Any]:
    """The META section's JSON object, its fields checked.

    Raises
    ------
    LimitError
        The section is larger than ``MAX_META_BYTES``.
    SectionError
        Not a JSON object, or a field of the wrong type or value: integers of
        more than ``MAX_META_DIGITS`` digits, NaN or infinities, strings longer
        than ``MAX_META_TEXT`` or holding control characters or lone surrogates.
    """
    if len(raw) > MAX_META_BYTES:
        raise LimitError(f"META: {len(raw)} bytes, more than the {MAX_META_BYTES} a reader parses")
    try:
        meta = json.loads(raw.decode("utf-8"), parse_int=_meta_int, parse_constant=_meta_constant)
    except (UnicodeDecodeError, json.JSONDecodeError, RecursionError):
        raise SectionError("META section is not valid JSON") from None
    if not isinstance(meta, dict):
        raise SectionError("META section is not a JSON object")
    for key in ("unit", "source_format", "mode", "source_name", "writer"):
        v = meta.get(key, "")
        if not isinstance(v, str) and not (key == "mode" and v is None):
            raise SectionError(f"META: {key} is not a string")
        if isinstance(v, str) and (len(v) > MAX_META_TEXT or _bad_text(v)):
            raise SectionError(
                f"META: {key} is longer than {MAX_META_TEXT} characters or holds control "
                "characters or lone surrogates"
            )
    unit = meta.get("unit", "MM")
    if unit not in UNITS_MM:
        raise SectionError(f"META: unknown unit {unit[:20]!r}")
    mode, tol = meta.get("mode"), meta.get("tolerance_mm")
    if mode not in ("lossless", "tolerance"):
        raise SectionError(f"META: unknown mode {str(mode)[:20]!r}")
    if mode == "tolerance" and not (_number(tol) and 0 < cast(float, tol) < MAX_COORD):
        raise SectionError("META: tolerance_mm is not a positive number")
    if mode == "lossless" and tol is not None:
        raise SectionError("META: a lossless container has a tolerance")
    size = meta.get("source_bytes", 0)
    if not (_number(size) and 0 <= size <= MAX_SOURCE_BYTES):
        raise SectionError(f"META: source_bytes is not a number from 0 to {MAX_SOURCE_BYTES}")
    return meta


def tolerance(meta: dict[str, Any]) -> float:
    """The tolerance (mm) a container's META gives, 0.0 if none (lossless)."""
    tol = meta.get("tolerance_mm")
    return float(cast(float, tol)) if _number(tol) else 0.0


def read_sections(
    get: Any,
    revision: int | None = None,
    limits: budget.Limits | None = budget.DEFAULT,
) -> tuple[BRepModel, dict[str, Any], Tables]:
    """The tables of a container from a section lookup ``get(tag) -> bytes``,
    every reference checked: the model (coded poles still NaN, ranges left to
    rules still zero) and the :class:`Tables` for ``decode.apply``.

    ``revision`` is the file's version (``container.Container.revision``;
    default: the one this writer writes): it says which sections there are and
    how each is laid out.
    ``limits`` is the decoding budget (``budget.check_structure``), checked on
    the tables before any net is decoded or any walk over the shapes is made;
    None skips it (a container just written).

    Raises
    ------
    CorruptError
        A section is missing, or a subclass: ``SectionError`` (a section does
        not decode; its tag and where), ``BadReferenceError`` (an index points
        outside its table).
    LimitError
        Coded nets larger than a reader allocates, or a shape past ``limits``.
    """
    with np.errstate(all="ignore"):  # overflows become non-finite values, refused by name
        rev = container.REVISION if revision is None else revision
        return _read_sections(get, rev, limits)


def _optional(get: Any, tag: str) -> bytes | None:
    """A section a later version added, or None where the file has none
    (``get`` is a container's, raising ``CorruptError``, or a dict's)."""
    try:
        return cast(bytes, get(tag))
    except (CorruptError, KeyError):
        return None


def _read_sections(
    get: Any, revision: int, limits: budget.Limits | None
) -> tuple[BRepModel, dict[str, Any], Tables]:
    meta = read_meta(get("META"))
    m = BRepModel()
    m.unit = str(meta.get("unit", "MM"))
    m.source_format = str(meta.get("source_format", "STEP"))
    tol = tolerance(meta)
    _read_locations(get("LOCS"), m)
    m.surfaces = _read_geometry(get("SURF"), "SURF", 3, revision)
    m.curves3d = _read_geometry(get("CRV3"), "CRV3", 3, revision)
    m.curves2d = _read_geometry(get("CRV2"), "CRV2", 2, revision)
    _read_shapes(get("SHAP"), m, revision, limits)
    _read_vertices(get("VERT"), m, tol, revision)
    range_how, picks = _read_edges(get("EDGE"), m, revision)
    _read_faces(get("FACE"), m)
    if picks is not None:
        counts = m.counts()
        if len(m.face_surface) != counts["face"] or len(m.edge_tol) != counts["edge"]:
            raise BadReferenceError("edge or face table does not match the shapes table")
        _resolve_picks(m, picks, np.inf if limits is None else limits.references)
    check_references(m)
    if limits is not None:
        budget.check_structure(m, limits)
    coded_surfaces = coded_rows(m.surfaces)
    snet = _read_nets(
        get("SNET"), len(coded_surfaces), "SNET", _shapes(m.surfaces, coded_surfaces), revision
    )
    sides = _optional(get, "SIDE") if "SIDE" in layout(revision) else None
    if sides is not None:
        _read_sides(sides, m, set(coded_surfaces))
    crows = coded_rows(m.curves3d)
    cnet = _read_nets(get("CNET"), len(crows), "CNET", _shapes(m.curves3d, crows), revision)
    prod = _optional(get, "PROD") if "PROD" in layout(revision) else None
    if prod is not None:
        m.product = product.read(prod, len(m.shape_type))
    return m, meta, Tables(snet, cnet, range_how)


def check_references(m: BRepModel) -> None:
    """Raise ``BadReferenceError`` unless every index in ``m`` points into its table."""
    ns, n3, n2, nl = len(m.surfaces), len(m.curves3d), len(m.curves2d), len(m.locations)
    counts = m.counts()

    def within(a: np.ndarray, lo: int, hi: int, what: str) -> None:
        if len(a) and (a.min() < lo or a.max() >= hi):
            at = int(np.flatnonzero((a < lo) | (a >= hi))[0])
            raise BadReferenceError(f"{what} (entry {at} of its kind) refers to a missing entry")

    for g in m.surfaces:
        if isinstance(g, Derived):
            if g.kind in SWEPT:
                within(np.array([g.basis]), 0, n3, "a swept surface")
    for table, n in ((m.curves3d, n3), (m.curves2d, n2)):
        for g in table:
            if isinstance(g, Derived):
                within(np.array([g.basis]), 0, n, "a derived curve")
    within(m.child_loc, 0, nl, "a sub-shape location")
    within(np.array([m.root_loc]), 0, nl, "the root location")
    if len(m.vertex_tol) != counts["vertex"] or len(m.edge_tol) != counts["edge"]:
        raise BadReferenceError("vertex or edge table does not match the shapes table")
    if len(m.face_surface) != counts["face"]:
        raise BadReferenceError("face table does not match the shapes table")
    within(m.face_surface, 0, ns, "a face surface")
    within(m.face_loc, 0, nl, "a face location")
    reps = m.edge_reps
    kind = reps[:, EC.KIND]
    two = kind == RepKind.ON_TWO_SURFACES
    c3 = kind == RepKind.CURVE3D
    within(reps[c3, EC.CURVE], -1, n3, "an edge curve")
    within(reps[~two & ~c3, EC.CURVE], REBUILD, n2, "an edge pcurve")
    within(reps[kind == RepKind.ON_CLOSED_SURFACE, EC.CURVE2], REBUILD, n2, "a seam pcurve")
    if (reps[~two & ~c3, EC.CURVE] == -1).any() or (
        reps[kind == RepKind.ON_CLOSED_SURFACE, EC.CURVE2] == -1
    ).any():
        raise BadReferenceError("an edge pcurve refers to a missing entry")
    seam = reps[kind == RepKind.ON_CLOSED_SURFACE]
    if ((seam[:, EC.CURVE] == REBUILD) != (seam[:, EC.CURVE2] == REBUILD)).any():
        raise BadReferenceError("a seam has one pcurve stored and the other one computed")
    within(reps[~c3, EC.SURFACE], 0, ns, "an edge surface")
    within(reps[two, EC.SURFACE2], 0, ns, "an edge surface")
    within(reps[:, EC.LOC], 0, nl, "an edge location")
    within(reps[two, EC.LOC2], 0, nl, "an edge location")
    within(m.edge_rep_cont, 0, 7, "a continuity")
    vr = m.vertex_reps
    within(vr[:, VC.KIND], 0, 3, "a vertex representation kind")
    within(vr[vr[:, VC.KIND] == PointRepKind.ON_CURVE, VC.CURVE], 0, n3, "a vertex curve")
    pcurve = vr[:, VC.KIND] == PointRepKind.ON_CURVE_ON_SURFACE
    within(vr[pcurve, VC.CURVE], 0, n2, "a vertex pcurve")
    within(vr[vr[:, VC.KIND] != PointRepKind.ON_CURVE, VC.SURFACE], 0, ns, "a vertex surface")
    within(vr[:, VC.LOC], 0, nl, "a vertex location")
    types = m.shape_type
    within(types, 0, 8, "a shape type")
