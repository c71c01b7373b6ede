"""The geometry tables `SURF`, `CRV3`, `CRV2` (docs/format.md §2.3): kinds,
knot vectors by form, weights, analytic rows on grids, COPY rows."""

from __future__ import annotations

from typing import Any

import numpy as np

from .. import container, entropy
from ..errors import LimitError, SectionError
from ..model import (
    Analytic,
    BSplineCurve,
    BSplineSurface,
    Derived,
    Geometry,
    Kind,
    first_row,
)
from ..streams import BlockReader, BlockWriter
from .limits import MAX_CODED_POLES, MAX_COORD, MAX_DEGREE, MAX_NET_POLES, _check_bspline, finite

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


# ---------------------------------------------------------------- geometry tables


#: Knot vector forms (format 2.0, docs/format.md §2.3): explicit, a repeat
#: of an earlier vector, evenly spaced (ends and ulp residuals); plus
#: ``SIMPLE``: multiplicities e, 1, ..., 1, e coded as e.
K_EXPLICIT, K_REPEAT, K_EVEN, K_SIMPLE = 0, 1, 2, 4
#: Knot form bit (format 2.12): the vector runs from 0.0 to 1.0, ends not
#: stored (``pcurves.unit_curves`` maps free curves onto [0, 1]).
K_UNIT = 8
#: Format 2.12: the first revision with :data:`K_UNIT` and weights on a grid.
UNIT_KNOTS = container.VERSIONS.index((2, 12))
#: Knot vector form (format 2.17): an earlier vector, mirrored or not,
#: mapped onto this one's ends (:func:`mapped_knots`).
K_MAPPED = 3
#: Format 2.17: the first revision with :data:`K_MAPPED`.
MAPPED_KNOTS = container.VERSIONS.index((2, 17))
#: The writer maps a vector from one of this many latest earlier vectors of
#: its knot count (2.17), and only a vector of at least :data:`MAPPED_MIN` knots.
MAPPED_REACH = 16
MAPPED_MIN = 8
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
#: Kind code of a 3-D line through its edge's vertices, with no values (2.2, §2.3).
THROUGH = 176
#: Kind codes of a 3-D circle through its edge's vertex about its face's axis,
#: its normal along the axis or against it, with no values (2.4, §2.3).
CIRCLE_ALONG, CIRCLE_AGAINST = 177, 178
#: Kind code of a plane whose origin is a vertex of its first face, with its
#: directions only (2.7, §2.3; ``rules.joins.face_points``).
PLANE_THROUGH = 179
#: Kind codes of a cylinder whose axis is its radius from a vertex of its
#: first face, against its X, Y, −X or −Y direction (2.7, §2.3): its
#: directions and radius only.
CYLINDER_THROUGH = 180
#: Format 2.7: the first revision with :data:`PLANE_THROUGH` and
#: :data:`CYLINDER_THROUGH` rows.
PLANES_THROUGH = container.VERSIONS.index((2, 7))


#: The ends of a :data:`K_UNIT` vector, bit for bit (+0.0 and 1.0).
_UNIT_ENDS = np.array([0.0, 1.0], "<f8").tobytes()


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


def mapped_knots(lead: np.ndarray, a: float, b: float, mirrored: bool) -> np.ndarray:
    """The knot vector ``lead``, mirrored if ``mirrored`` (``c - lead[::-1]``,
    ``c = lead[-1] + lead[0]``), mapped affinely onto the ends ``a``, ``b``,
    which it keeps bit for bit (docs/format.md §2.3, form 3, 2.17): in
    binary64, ``a + (t - t[0]) * ((b - a) / (t[-1] - t[0]))``."""
    t = (lead[-1] + lead[0]) - lead[::-1] if mirrored else np.asarray(lead, np.float64)
    out = np.float64(a) + (t - t[0]) * ((np.float64(b) - np.float64(a)) / (t[-1] - t[0]))
    out[0], out[-1] = a, b
    return out


def _even_prediction(a: float, b: float, nk: int) -> np.ndarray:
    """Inner knots of an evenly spaced vector from ``a`` to ``b``:
    ``a + j * ((b - a) / (nk - 1))``, j = 1 ... nk - 2, in binary64."""
    h = (np.float64(b) - np.float64(a)) / np.float64(nk - 1)
    j = np.arange(1, nk - 1, dtype=np.float64)
    return np.float64(a) + j * h


def _even_residuals(k: np.ndarray) -> list[int] | None:
    """The ulp residuals of a vector the writer codes as evenly spaced (§2.3:
    3 knots or more, every |residual| below ``EVEN_WRITE``), else None."""
    if len(k) < 3:
        return None
    with np.errstate(all="ignore"):
        p = _even_prediction(float(k[0]), float(k[-1]), len(k))
    if not np.isfinite(p).all():
        return None
    r = [x - y for x, y in zip(_keys(k[1:-1]), _keys(p))]
    return r if max(abs(x) for x in r) < EVEN_WRITE else None


def evenly_spaced(k: np.ndarray) -> bool:
    """Whether the writer codes the knot vector ``k`` as evenly spaced."""
    return _even_residuals(np.asarray(k, float)) is not None


class _KnotWriter:
    """The 2.0 coding of a table's knot vectors and weight sets (§2.3): the
    forms, repeat distances and weight references go to the header stream
    ``hdr``, the residuals of evenly spaced vectors to ``res``."""

    def __init__(self, hdr: list[int], revision: int = container.REVISION) -> None:
        self.hdr = hdr
        self.unit = revision >= UNIT_KNOTS
        self.res: list[int] = []
        self._n = 0
        self._seen: dict[tuple[bytes, bytes], int] = {}
        self.mapped = revision >= MAPPED_KNOTS
        #: per knot count, the latest vectors (number, knots, multiplicities)
        self._by_count: dict[int, list[tuple[int, np.ndarray, np.ndarray]]] = {}
        self._weights: dict[bytes, int] = {}
        self._nw = 0

    def vector(
        self,
        k: np.ndarray,
        mu: np.ndarray,
        knots: list[np.ndarray],
        mults: list[int],
        degree: int,
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
        ends = k[[0, -1]]
        unit = self.unit and ends.astype("<f8").tobytes() == _UNIT_ENDS
        r = _even_residuals(k)
        source = None if r is not None else self._source(n, k, mu)
        if source is not None:  # 2.17: mapped from an earlier vector
            self.hdr += [K_MAPPED | (K_UNIT if unit else 0), *source]
            if not unit:
                knots.append(ends)
            return
        if r is not None:
            form = K_EVEN
            if not unit:
                knots.append(ends)
            self.res += r
        if form == K_EXPLICIT:
            knots.append(k[1:-1] if unit else k)
        if unit:
            form |= K_UNIT
        if m[0] == m[-1] and all(x == 1 for x in m[1:-1]):
            form |= K_SIMPLE
            mults.append(m[0] - (degree + 1) if self.unit else m[0])
        elif self.unit:
            mults += [m[0] - (degree + 1), *m[1:-1], m[-1] - (degree + 1)]
        else:
            mults += m
        self.hdr.append(form)

    def _source(self, n: int, k: np.ndarray, mu: np.ndarray) -> tuple[int, int] | None:
        """(distance back, mirrored) of an earlier vector that maps onto
        ``k`` and its multiplicities ``mu`` bit for bit (form 3, 2.17), or
        None; vector ``n`` is remembered for the later ones."""
        if not self.mapped or len(k) < MAPPED_MIN:
            return None
        seen = self._by_count.setdefault(len(k), [])
        a, b = float(k[0]), float(k[-1])
        with np.errstate(all="ignore"):
            out = next(
                (
                    (n - j, mirrored)
                    for j, lead, lmu in reversed(seen)
                    for mirrored in (0, 1)
                    if np.array_equal(lmu[::-1] if mirrored else lmu, mu)
                    and np.array_equal(mapped_knots(lead, a, b, bool(mirrored)), k)
                ),
                None,
            )
        seen.append((n, k, np.asarray(mu)))
        del seen[:-MAPPED_REACH]
        return out

    def weights(self, w: np.ndarray, out: list[np.ndarray]) -> None:
        key = w.astype("<f8").tobytes()
        j = self._weights.get(key)
        self._weights[key] = self._nw
        self.hdr.append(0 if j is None else self._nw - j)
        if j is None:
            out.append(np.atleast_2d(w))  # a set's shape: its grid prediction runs by rows
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
    kw = _KnotWriter(hdr, revision) if revision >= 3 else None
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
        if isinstance(r, Analytic) and r.through and r.kind in (Kind.PLANE, Kind.CYLINDER):
            top = 1 if r.kind == Kind.PLANE else 4
            if revision < PLANES_THROUGH or dim != 3 or not 1 <= r.through <= top:
                raise ValueError("only format 2.7 has planes and cylinders through a vertex")
            plane = r.kind == Kind.PLANE
            kinds.append(PLANE_THROUGH if plane else CYLINDER_THROUGH + r.through - 1)
            frames.append(r.frame[1:].reshape(-1))
            params.append(r.params)
            continue
        if isinstance(r, Analytic) and r.through:
            if not dim == 3 or not (
                (revision >= 5 and r.kind == Kind.LINE and r.through == 1)
                or (revision >= 7 and r.kind == Kind.CIRCLE and r.through in (1, -1))
            ):
                raise ValueError(
                    "only a 3-D line (format 2.2) or circle (2.4) goes through its vertices"
                )
            kinds.append(
                THROUGH
                if r.kind == Kind.LINE
                else CIRCLE_ALONG
                if r.through == 1
                else CIRCLE_AGAINST
            )
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
                    kw.vector(r.uknots, r.umults, knots, mults, r.udegree)
                    kw.vector(r.vknots, r.vmults, knots, mults, r.vdegree)
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
                    kw.vector(r.knots, r.mults, knots, mults, r.degree)
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
    for group in (frames, params, poles):
        w.floats(np.concatenate(group) if group else np.zeros(0))
    flat = np.concatenate([x.reshape(-1) for x in weights]) if weights else np.zeros(0)
    b = weight_grid(weights) if revision >= UNIT_KNOTS and weights else None
    if b is not None:
        res = np.concatenate([grid_residuals(x, b).reshape(-1) for x in weights])
        b = b if _lzma_size(res, True) < _lzma_size(flat, False) else None
    if b is None:
        w.floats(flat)
    else:  # 2.12: the grid, then the residuals
        w.ints(np.r_[b, res])
    w.floats(np.concatenate(knots) if knots else np.zeros(0))
    return bytes(w)


#: Weight grids 2^-b a table may take (2.12): b in 0 ... 1074.
WEIGHT_GRID_MAX = 1074


def weight_grid(sets: list[np.ndarray]) -> int | None:
    """The least ``b`` (0 ... :data:`WEIGHT_GRID_MAX`) with every weight of
    ``sets`` an integer multiple ``k`` of 2^-b, |k| < 2^53, or None."""
    w = np.concatenate([x.reshape(-1) for x in sets])
    if not len(w) or not np.isfinite(w).all() or (w == 0).any():
        return None
    mant, exp = np.frexp(w)  # w = mant * 2^exp, 0.5 <= |mant| < 1: a 53-bit integer * 2^(exp - 53)
    m = np.abs(mant * 2.0**53).astype(np.int64)
    tz = np.array([(int(x) & -int(x)).bit_length() - 1 for x in m.tolist()])
    b = max(0, int((53 - exp - tz).max()))
    if b > WEIGHT_GRID_MAX:
        return None
    with np.errstate(over="ignore"):  # a grid fine enough for one weight overflows another
        k = np.ldexp(w, b)
    if not (np.abs(k) < 2.0**53).all() or (np.rint(k) != k).any():
        return None
    return b


def _one(b: int) -> int:
    """The prediction of a weight set's first integer on the grid 2^-b: the
    weight 1.0 where it is on the grid within range (b ≤ 52), else 0."""
    return 1 << b if b <= 52 else 0


def grid_residuals(w: np.ndarray, b: int) -> np.ndarray:
    """The residuals of a weight set (rows of a 2-D array) on the grid 2^-b
    (docs/format.md §2.3, "Weights on a grid"): the inverse of
    :func:`grid_weights`."""
    k = np.ldexp(w, b).astype(np.int64)
    r = k.copy()
    r[:, 0] -= np.r_[_one(b), k[:-1, 0]]
    r[:, 1:2] -= k[:, :1]
    r[:, 2:] -= 2 * k[:, 1:-1] - k[:, :-2]
    return r


def grid_weights(r: np.ndarray, b: int, where: str) -> np.ndarray:
    """A weight set (rows of a 2-D array) from its residuals ``r`` on the grid
    2^-b: each row's first integer predicted by the row before's first (the
    first by :func:`_one`), its second by its first, the others by
    linear extrapolation; 64-bit sums, wrapping."""
    r = np.asarray(r, np.int64)
    with np.errstate(over="ignore"):
        k = np.empty_like(r)
        k[:, 0] = np.cumsum(r[:, 0]) + np.int64(_one(b))
        steps = np.cumsum(r[:, 1:], axis=1)  # first differences along the row
        k[:, 1:] = k[:, :1] + np.cumsum(steps, axis=1)
    if not (np.abs(k) < (1 << 53)).all():
        raise SectionError(f"{where}: a weight on its grid is out of range")
    return np.ldexp(k.astype(np.float64), -b)


def _lzma_size(a: np.ndarray, ints: bool) -> int:
    """Bytes of one array, written as the writer would and LZMA-compressed
    alone: the writer's choice between floats and a weight grid."""
    w = BlockWriter()
    if ints:
        w.ints(a)
    else:
        w.floats(a)
    return entropy.lzma_size(bytes(w))


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
        self._values: list[Any] | None = None  # ``a`` as Python numbers, for :meth:`one`

    def take(self, n: int) -> np.ndarray:
        if n < 0 or self.pos + n > len(self.a):
            raise SectionError(f"{self.name} stream is too short at value {self.pos}")
        out = self.a[self.pos : self.pos + n]
        self.pos += n
        return out

    def one(self) -> int:
        """The next value, as an int (a list lookup: a table's headers are
        read one value at a time, tens of thousands of them)."""
        if self.pos >= len(self.a):
            raise SectionError(f"{self.name} stream is too short at value {self.pos}")
        if self._values is None:
            self._values = self.a.tolist()
        self.pos += 1
        return int(self._values[self.pos - 1])

    def done(self) -> None:
        if self.pos != len(self.a):
            raise SectionError(f"{self.name} stream has unread values from value {self.pos}")


class _KnotReader:
    """The knot vectors and weight sets of a table, as a file of ``revision``
    codes them (:class:`_KnotWriter` from revision 3)."""

    def __init__(self, r: BlockReader, revision: int, tag: str, hdr: _Cursor) -> None:
        self.new = revision >= 3
        self.unit = revision >= UNIT_KNOTS
        self.mapped = revision >= MAPPED_KNOTS
        self.hdr = hdr
        self.knots = _Cursor(np.zeros(0), f"{tag} knot")  # set by the caller
        self.mults = _Cursor(np.zeros(0, np.int64), f"{tag} mults")  # set by the caller
        self.res = _Cursor(r.ints() if self.new else np.zeros(0, np.int64), f"{tag} kres")
        self.vectors: list[tuple[np.ndarray, np.ndarray]] = []
        self.wsets: list[np.ndarray] = []
        #: the table's weight grid b (2.12), None: weights as floats
        self.wgrid: int | None = None

    @property
    def _unit(self) -> int:
        """The form bits besides :data:`K_SIMPLE` this file may set."""
        return K_UNIT if self.unit else 0

    def vector(self, nk: int, where: str, degree: int) -> tuple[np.ndarray, np.ndarray]:
        """The next vector's knots and multiplicities (``nk`` of each), of a
        row of ``degree``."""
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
        elif self.mapped and form & ~self._unit == K_MAPPED:
            d, mirrored = self.hdr.one(), self.hdr.one()
            if not 1 <= d <= n or mirrored not in (0, 1):
                raise SectionError(f"{where}: a mapped knot vector refers to none")
            lead, lmu = self.vectors[n - d]
            if len(lead) != nk:
                raise SectionError(f"{where}: a mapped knot vector has {len(lead)} knots, not {nk}")
            a, b = (0.0, 1.0) if form & K_UNIT else self.knots.take(2).tolist()
            with np.errstate(all="ignore"):
                k = mapped_knots(lead, a, b, bool(mirrored))
            if not np.isfinite(k).all():
                raise SectionError(f"{where}: mapped knots are not finite")
            mu = (lmu[::-1] if mirrored else lmu).copy()
        elif form & ~(K_SIMPLE | self._unit) == K_EXPLICIT:
            if form & K_UNIT:
                if nk < 2:
                    raise SectionError(f"{where}: a unit knot vector of {nk} knots")
                k = np.concatenate([[0.0], self.knots.take(nk - 2), [1.0]])
            else:
                k = self.knots.take(nk)
            mu = self._mults(form, nk, degree)
        elif form & ~(K_SIMPLE | self._unit) == K_EVEN:
            if nk < 3:
                raise SectionError(f"{where}: an evenly spaced knot vector of {nk} knots")
            a, b = (0.0, 1.0) if form & K_UNIT else self.knots.take(2).tolist()
            r = self.res.take(nk - 2)
            if len(r) and int(np.abs(r).max()) >= EVEN_READ:
                raise SectionError(f"{where}: a knot residual is out of range")
            with np.errstate(all="ignore"):
                p = _even_prediction(a, b, nk)
            if not np.isfinite(p).all():
                raise SectionError(f"{where}: evenly spaced knots are not finite")
            inner = _unkeys([x + y for x, y in zip(_keys(p), r.tolist())], where)
            k = np.concatenate([[a], inner, [b]])
            mu = self._mults(form, nk, degree)
        else:
            raise SectionError(f"{where}: unknown knot vector form {form}")
        self.vectors.append((k, mu))
        return k, mu

    def _mults(self, form: int, nk: int, degree: int) -> np.ndarray:
        if not form & K_SIMPLE:
            mu = self.mults.take(nk).copy()
            if self.unit:  # the ends as offsets from degree + 1 (2.12)
                mu[[0, -1]] += degree + 1
            return mu
        e = self.mults.one() + (degree + 1 if self.unit else 0)
        mu = np.ones(nk, np.int64)
        mu[0] = mu[-1] = e
        return mu

    def weights(self, shape: tuple[int, int], where: str, take: _Cursor) -> np.ndarray:
        """The next rational row's weights, (nu, nv) of a surface, (1, n) of a
        curve, flat."""
        n = shape[0] * shape[1]
        if not self.new:
            return take.take(n)
        d = self.hdr.one()
        if d == 0 and self.wgrid is not None:
            w = grid_weights(take.take(n).reshape(shape), self.wgrid, where)
        elif d == 0:
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
    frames, params, poles = (_Cursor(r.floats(), f"{tag} {n}") for n in ("frame", "param", "pole"))
    if revision >= UNIT_KNOTS and r.next_is_ints():  # 2.12: weights on a grid
        wints = r.ints()
        if not len(wints) or not 0 <= int(wints[0]) <= WEIGHT_GRID_MAX:
            raise SectionError(f"{tag}: a weight grid of {wints[:1].tolist()}")
        kr.wgrid = int(wints[0])
        weights = _Cursor(wints[1:], f"{tag} weight")
    else:
        weights = _Cursor(r.floats(), f"{tag} weight")
    knots = _Cursor(r.floats(), f"{tag} knot")
    r.done()
    kr.knots, kr.mults = knots, mults
    finite(frames.a, f"{tag} frames", MAX_COORD)
    # ±Precision::Infinite() itself: the bounds of a trimmed surface's
    # untrimmed direction (OCCT's booleans make cylinders trimmed in u only)
    finite(params.a, f"{tag} params", MAX_COORD, at_most=True)
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
        if k == THROUGH and revision >= 5 and tag == "CRV3":
            # its frame comes from its edge's vertices (decode.apply): NaN until then
            out.append(Analytic(Kind.LINE, np.full((2, 3), np.nan), np.zeros(0), through=1))
            continue
        if k in (CIRCLE_ALONG, CIRCLE_AGAINST) and revision >= 7 and tag == "CRV3":
            # its frame and radius come from its edge's vertex and face (decode.apply)
            sense = 1 if k == CIRCLE_ALONG else -1
            out.append(
                Analytic(Kind.CIRCLE, np.full((3, 3), np.nan), np.full(1, np.nan), through=sense)
            )
            continue
        if PLANE_THROUGH <= k < CYLINDER_THROUGH + 4 and revision >= PLANES_THROUGH and surface:
            # its origin comes from a vertex of its first face (decode.apply): NaN until then
            frame = np.concatenate([np.full((1, 3), np.nan), frames.take(9).reshape(3, 3)])
            if k == PLANE_THROUGH:
                out.append(Analytic(Kind.PLANE, frame, np.zeros(0), through=1))
            else:
                radius = params.take(1)
                if not radius[0] > 0:
                    raise SectionError(f"{where}: a cylinder's radius must be positive")
                out.append(Analytic(Kind.CYLINDER, frame, radius, through=k - CYLINDER_THROUGH + 1))
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
                uk, um = kr.vector(ku, f"{where} (u)", ud)
                vk, vm = kr.vector(kv, f"{where} (v)", vd)
                _check_bspline(f"{where} (u)", nu, ud, uk, um, bool(flags & 2))
                _check_bspline(f"{where} (v)", nv, vd, vk, vm, bool(flags & 4))
            if flags & 8:  # coded net: filled in from SNET
                if nu * nv > MAX_NET_POLES or coded_poles + nu * nv > MAX_CODED_POLES:
                    raise LimitError(f"{where}: a coded net of {nu} x {nv} poles is too large")
                coded_poles += nu * nv
                p = np.full((nu, nv, 3), np.nan)
            else:
                p = poles.take(nu * nv * 3).reshape(nu, nv, 3)
            wts = kr.weights((nu, nv), where, weights).reshape(nu, nv) if flags & 1 else None
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
                kn, mu = kr.vector(nk, where, deg)
            if not bez:
                _check_bspline(where, n, deg, kn, mu, bool(flags & 2))
            if flags & 4:  # coded net: filled in from CNET
                if n > MAX_NET_POLES or coded_poles + n > MAX_CODED_POLES:
                    raise LimitError(f"{where}: a coded curve of {n} poles is too large")
                coded_poles += n
                cp = np.full((n, dim), np.nan)
            else:
                cp = poles.take(n * dim).reshape(n, dim)
            wts = kr.weights((1, n), where, weights) if flags & 1 else None
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
