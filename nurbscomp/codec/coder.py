"""The surface codec: code a B-spline control net within a tolerance, and prove it.

Methods, weighed against each other on every face by :func:`encode_net`:

* ``SPATIAL`` — closed-loop parallelogram prediction on a grid (PRC's way,
  :mod:`nurbscomp.spatial`);
* ``SPATIAL2`` (format 2.0) — closed-loop linear extrapolation along u and v
  on the grid (second differences, :func:`spatial.extrapolate`), each
  residual chosen, within the net's bound, as the cheapest of the grid points
  near the pole (:func:`spatial.rd_extrapolate`): a rate–distortion choice
  under the certified bound.  Not the paper's (its §3 predicts from the
  Coons net); on smooth nets the second differences of the poles are
  smaller than the parallelogram rule's residuals;
* ``BOUNDARY`` — the paper's "no difference data": four boundary curves coded
  as chord differences + DCT + quantization (eq. 4-10), the interior predicted
  by the Coons net of the *decoded* boundaries (eq. 11);
* ``DDMAP`` — as ``BOUNDARY``, plus the interior differences to the Coons net
  (the DD-map, eq. 12; xyz only, weights exact) through a 2-D DCT and
  quantization (eq. 26-27);
* ``BOUNDARY3``, ``DDMAP3`` — as ``BOUNDARY`` and ``DDMAP`` with the paper's
  bicubically blended Coons net (eq. 11, :func:`coons.bicubic_net`) as the
  predictor: the choice between the two blends is made per face;
* ``DMAP`` — as ``BOUNDARY``, plus one least-squares distance per interior
  pole along the Coons surface's normal (the D-map, eq. 14-25,
  :mod:`nurbscomp.dmap`), through the same 2-D DCT and quantization.  It
  needs the knots (a :class:`dmap.Basis`); clamped, non-periodic nets only;
* ``ARCS_V``, ``ARCS_U`` (format 2.14) — each pole on its nearest grid
  point, the rows along v (u) predicted as chains of equal-angle quadratic
  arcs, the way a rational quadratic B-spline writes a circle
  (:func:`spatial.arc_residuals`); the encoder tries them on rational nets
  of degree 2 along the rows (``encode.nets.arc_methods``).  Not the
  paper's: its Coons net of coded boundaries does not know circles;
* ``ORDERS_11`` … ``ORDERS_33`` (format 2.14) — as ``SPATIAL2``, but each
  pole extrapolated along v, and its row's error along u, by the polynomial
  of degree 0 to 2 through the poles before it at the net's Greville
  abscissae (eq. 17, the abscissae the Coons methods use), not at equal
  steps (:func:`spatial.rd_lifted`).  The search tries the orders whose
  estimate is cheapest, beside ``SPATIAL2`` (``search._lifted_choice``).

Two quantizers: the paper's ``(1+k+l)·D00/2^a`` (eq. 10, 27; D00 sent as a
float) and a tolerance-driven ``(1+slope·(k+l))·Δ`` with Δ = tol·2^(e/4).
The format holds the second only: the paper's (``Quant.PAPER``) is reserved
(no writer ever wrote it; docs/format.md §2.4), and stays here for the
codec's own experiments (``encode_net(paper=True)``).

Knots, degrees and weights are kept exactly, so the decoded surface is the
same convex combination of the decoded poles, and max |S - S'| ≤ max_i
|P_i - P'_i| (docs/design.md §4).  That maximum is each code's certified ``bound``; the
search keeps the cheapest code whose bound is ≤ tol.

Everything here is numpy on plain arrays: nets are (nu, nv, 3).

The search tries each setting of a ladder through the same :func:`_code` the
decoder runs (:func:`_try`); on small nets the tolerance quantizer's ladders
are computed for every rung at once instead (:class:`_Rungs`,
:class:`_CoonsRungs`), by the same operations, and what the trials of one net
share is computed once (:class:`_Memo`).  Both give the same codes, bit for
bit (tests/test_codec.py).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from enum import IntEnum

import numpy as np

from .. import coons, dct, dmap, spatial


class Method(IntEnum):
    """Per-net coding method.  Values are stored: never renumber."""

    SPATIAL = 0  # surfaces: parallelogram rule on the grid
    BOUNDARY = 1  # surfaces: boundary curves + Coons, no difference data
    DDMAP = 2  # surfaces: boundary curves + Coons + DD-map
    DELTA = 3  # curves: linear extrapolation (second differences) on the grid
    CHORD = 4  # curves: ends on the grid, chord differences + DCT (eq. 5-10)
    DMAP = 5  # surfaces: boundary curves + Coons + D-map (eq. 14-25)
    ISO = 6  # curves: a copy of a decoded surface's boundary (ints: surface row, side, reversed)
    BOUNDARY3 = 7  # surfaces: as BOUNDARY, with the bicubically blended Coons net
    DDMAP3 = 8  # surfaces: as DDMAP, with the bicubically blended Coons net
    COPY = 9  # curves: another row's final poles (ints: this row minus it, reversed); format 1.1
    # surfaces: linear extrapolation along u and v on the grid, residuals chosen
    # within the bound (spatial.rd_extrapolate); format 2.0
    SPATIAL2 = 10
    # curves: ends at the row's two anchors (its edge's vertices, as decoded),
    # chord differences + DCT (eq. 5-10) between them; format 2.10
    ANCHORED = 11
    # surfaces: the rows along v (12) or u (13) predicted as chains of
    # equal-angle quadratic arcs (spatial.arc_residuals), nearest grid points;
    # format 2.14
    ARCS_V = 12
    ARCS_U = 13
    # surfaces: extrapolation along v, then of the rows' errors along u, of
    # the orders in the name (1: the pole before, 2: the line, 3: the
    # parabola through the poles before) at the net's Greville abscissae
    # (spatial.rd_lifted); format 2.14
    ORDERS_11 = 14
    ORDERS_12 = 15
    ORDERS_13 = 16
    ORDERS_21 = 17
    ORDERS_22 = 18
    ORDERS_23 = 19
    ORDERS_31 = 20
    ORDERS_32 = 21
    ORDERS_33 = 22


SURFACE_METHODS = (
    Method.SPATIAL,
    Method.BOUNDARY,
    Method.DDMAP,
    Method.DMAP,
    Method.BOUNDARY3,
    Method.DDMAP3,
)
#: The surface methods the encoder searches unless asked for the paper's whole
#: set (``paper``).  ``DMAP`` and ``BOUNDARY3`` are left out: over six corpus
#: files at 0.01 mm (1,156 coded surface nets) they were the cheapest code of 1
#: and 2 nets, 62 bits in all, for 15% of the search time (the D-map's least
#: squares are the dearest trials).  The decoder reads every method.
SURFACE_SEARCH = (Method.SPATIAL, Method.BOUNDARY, Method.DDMAP, Method.DDMAP3, Method.SPATIAL2)
#: The surface methods of a net coded again for a fault of the rebuilt B-rep
#: (``encode.nets.plain``, ``encode.nets.tighten``): ``SPATIAL2`` leaves its
#: poles anywhere within their bound, and is what ``plain`` takes away.
TIGHT_SEARCH = tuple(m for m in SURFACE_SEARCH if m != Method.SPATIAL2)
#: The surface methods a ``SNET`` of format 2.0 (revision 3) may hold.
SURFACE_METHODS_2 = (*SURFACE_METHODS, Method.SPATIAL2)
#: The arc methods (format 2.14), by the direction their rows run along.
ARCS = {Method.ARCS_U: 0, Method.ARCS_V: 1}
#: The methods that extrapolate on the abscissae (format 2.14), by their
#: orders along u and v.
LIFTED = {Method[f"ORDERS_{a}{b}"]: (a, b) for a in spatial.ORDERS for b in spatial.ORDERS}
#: The methods whose residuals the encoder chooses within a net's bound (the
#: others round each pole to its nearest grid point).
CHOSEN = (Method.SPATIAL2, *LIFTED)
#: The surface methods a ``SNET`` of format 2.14 (revision 17) may hold.
SURFACE_METHODS_14 = (*SURFACE_METHODS_2, *ARCS, *LIFTED)
#: Surface methods whose integers are one grid residual per pole, in net order.
GRID_CODES = (Method.SPATIAL, *CHOSEN, *ARCS)
#: Surface codes that do not depend on the knots (the boundary, map and
#: lifted methods use the Greville abscissae).
KNOTLESS = (Method.SPATIAL, Method.SPATIAL2, *ARCS)
#: Methods that predict the interior with the bicubically blended Coons net.
BICUBIC = (Method.BOUNDARY3, Method.DDMAP3)
#: Methods that code a net's corners, its boundary curves between them, and a
#: Coons net of those (with or without difference data).
COONS_METHODS = (Method.BOUNDARY, Method.DDMAP, Method.DMAP, Method.BOUNDARY3, Method.DDMAP3)
#: Surface methods whose corners may be coded against vertices (format 2.10).
CORNERED = (*GRID_CODES, *COONS_METHODS)
#: The curve methods the encoder searches with a row's origin or anchors.
CURVE_METHODS = (Method.DELTA, Method.CHORD)
#: Every method whose integers code a curve's poles: with ``ANCHORED``, which
#: the encoder tries once the vertices are final (``encode.assembly``).
CURVE_CODES = (*CURVE_METHODS, Method.ANCHORED)
#: Every method a CNET row may hold: the coders, and copies of decoded poles
#: (``ANCHORED`` from format 2.10 only: ``decode``).
CURVE_COPIES = (*CURVE_CODES, Method.ISO, Method.COPY)


class Quant(IntEnum):
    TOL = 0  # (1 + slope·(k+l))·Δ, Δ = tol·2^(e/4)
    PAPER = 1  # (1+k+l)·D00/2^a, eq. 10 and 27; reserved by the format: never in a container


#: Largest integer a code may hold (keeps every product exact in float64).
MAX_INT = 2**40


class NoCodeError(ValueError):
    """No code of a net is within its bound: where a double's spacing nears
    the quantizer's step (a net far from the origin, a tolerance near the
    source's own precision), rounding breaks even ``SPATIAL``'s guarantee.
    The encoder then keeps the net exact (``encode.nets``)."""


class _Unusable(Exception):
    """A quantizer setting that cannot code this net (its integers would overflow)."""


#: Exponents e tried for steps tol·2^(e/4), coarsest first (a net held to a
#: limit below tol goes on down, :func:`ladder`).
E_LADDER = tuple(range(8, -13, -1))


def ladder(tol: float, limit: float) -> tuple[int, ...]:
    """Exponents e to try for a net held to ``limit`` ≤ tol: ``E_LADDER``, moved
    down by the quarter-octaves from tol to limit."""
    down = max(0, int(np.ceil(4 * np.log2(tol / limit)))) if limit > 0 else 0
    return tuple(e - down for e in E_LADDER)


SLOPES = (0.0, 1.0)
#: Bit depths a tried with the paper's quantizer, coarsest first.
PAPER_BITS = tuple(range(1, 31))


@dataclass(frozen=True)
class NetCode:
    """One coded control net.

    Attributes
    ----------
    method, quant : Method, Quant
    level : int
        ``e`` of the step tol·2^(e/4) (TOL), or ``a`` (PAPER).
    slope : int
        Index into ``SLOPES`` (TOL only).
    ints : ndarray of int64
        All integers of the code, in decoding order.
    dcs : ndarray of float64
        DC coefficients sent with the PAPER quantizer.
    bound : float
        Certified bound on how far the net's row moves: its largest pole
        displacement, or the encoder's tighter measure
        (``encode_net``'s ``measure``).
    bits : float
        Estimated coded size (Exp-Golomb length of the integers + 64 per float).
    origin : ndarray or None
        The point the first pole was coded against (see :func:`reorigin`).
    first : ndarray or None
        The decoded first pole, the origin of the next net in its table.  Set
        by the caller; the decoded net may change afterwards (curve ends are
        pinned to vertices, :mod:`nurbscomp.rules.joins`) but the chain uses this.
    limit : float or None
        The bound the encoder held the code to (not stored in a container).
    """

    method: Method
    quant: Quant
    level: int
    slope: int
    ints: np.ndarray
    dcs: np.ndarray
    bound: float
    bits: float
    origin: np.ndarray | None = None
    first: np.ndarray | None = None
    limit: float | None = None

    @property
    def grid(self) -> float:
        """Step of the grid the first pole is snapped to, as a multiple of tol."""
        return 2.0 ** (self.level / 4) if self.quant == Quant.TOL else 1.0


def reorigin(code: NetCode, origin: np.ndarray | None, tol: float) -> NetCode:
    """The same code with its first pole coded against ``origin`` instead.

    Every method codes its first grid point as "grid point - grid(origin)" in
    its first ``dim`` integers, and the decoded net does not depend on the
    origin, so only those integers change.  The chord method codes its last
    pole against a second origin row when there is one: the next ``dim``.
    Both codes' origins must then have two rows.  An ``ANCHORED`` code's net
    is made from its anchors: they must stay the same, bit for bit.
    """
    old = np.zeros(3) if code.origin is None else code.origin
    new = np.zeros(_first(old).shape) if origin is None else origin
    if code.method == Method.ANCHORED:  # its net is made from its anchors: they stay
        if not np.array_equal(old, new):
            raise ValueError("an anchored curve's anchors cannot move")
        return replace(code, origin=new.copy())
    dim = len(_first(old))
    h = tol * code.grid
    ints = code.ints.copy()
    ints[:dim] += spatial.snap(_first(old), h) - spatial.snap(_first(new), h)
    if code.method == Method.CHORD and (old.ndim == 2) != (new.ndim == 2):
        raise ValueError("a chord code's end anchor cannot be added or dropped")
    if code.method == Method.CHORD and old.ndim == 2:
        ints[dim : 2 * dim] += spatial.snap(old[1], h) - spatial.snap(new[1], h)
    return replace(code, ints=ints, origin=None if origin is None else origin.copy())


def _first(origin: np.ndarray) -> np.ndarray:
    """The point a net's first pole is coded against (an origin may also carry
    the anchor of a curve's last pole, as a second row)."""
    return origin if origin.ndim == 1 else origin[0]


#: Codes of up to this many integers are costed in Python (``int.bit_length``):
#: on the short codes of real nets numpy's per-call overhead dominates.
_SHORT = 96


def cost_bits(q: np.ndarray) -> float:
    """Exp-Golomb length of zig-zag mapped integers: a proxy for the entropy coder.

    Zig-zag maps v to z = 2|v| - (v < 0), whose code has 2·floor(log2(z+1)) + 1
    bits; floor(log2(z+1)) is (z+1).bit_length() - 1.  Every term is an
    integer, so the sum is exact in either branch (the same float).
    """
    if q.size <= _SHORT:
        return float(
            sum(2 * (2 * v + 1 if v >= 0 else -2 * v).bit_length() - 1 for v in q.tolist())
        )
    z = np.abs(q).astype(np.float64) * 2 - (q < 0)
    return float(np.sum(2 * np.floor(np.log2(z + 1.0)) + 1))


# ---------------------------------------------------------------- one quantizer setting


class _Stepper:
    """Quantizer steps for one setting, for curves (1-D) and maps (2-D)."""

    def __init__(self, quant: Quant, level: int, slope: int, tol: float) -> None:
        self.quant, self.level, self.slope, self.tol = quant, level, slope, tol
        #: Step of the grid the corners are snapped to.
        self.grid = tol * 2.0 ** (level / 4) if quant == Quant.TOL else tol

    def steps(self, shape: tuple[int, ...], dc: np.ndarray) -> np.ndarray:
        if self.quant == Quant.TOL:
            return _tol_table(shape, self.grid, SLOPES[self.slope])[0]
        return dct.paper_steps(shape, dc, self.level)


@functools.lru_cache(maxsize=1024)
def _ladder_settings(
    quant: Quant, levels: tuple[int, ...], slope: int, tol: float
) -> tuple[_Stepper, ...]:
    """The settings of a ladder, made once (they hold no state)."""
    return tuple(_Stepper(quant, e, slope, tol) for e in levels)


@functools.lru_cache(maxsize=1024)
def _tol_ladder(settings: tuple[_Stepper, ...]) -> bool:
    """Whether a ladder (of :func:`_ladder_settings`) has the tolerance
    quantizer and steps > 0 throughout."""
    return all(st.quant == Quant.TOL and st.grid > 0 for st in settings)


@functools.lru_cache(maxsize=4096)
def _tol_table(shape: tuple[int, ...], delta: float, slope: float) -> tuple[np.ndarray, np.ndarray]:
    """:func:`dct.tol_steps` (read-only), and MAX_INT times them: the largest
    magnitudes they may quantize.  Every trial of a net at one setting, and
    every net of one shape, uses the same steps."""
    steps = dct.tol_steps(shape, delta, slope)
    limit = MAX_INT * np.where(steps > 0, steps, np.inf)
    steps.setflags(write=False)
    limit.setflags(write=False)
    return steps, limit


@dataclass
class _BoundaryRungs:
    """A ladder's boundaries, coded on every rung at once (:func:`_boundary_rungs`)."""

    use: list[int]  # the rungs whose boundaries can be coded
    h: np.ndarray  # their grid steps
    curves: tuple[np.ndarray, ...]  # decoded u0, u1, v0, v1 of each, (R, k, 3)
    ints: np.ndarray  # their integers, (R, K)


def largest_norms(a: np.ndarray) -> np.ndarray:
    """The largest Euclidean norm of the vectors (last axis) of each item of
    ``a`` (R, ..., dim) -> (R,).  The squares are added coordinate by
    coordinate, in the order ``(a * a).sum(-1)`` adds them (the same bits),
    and the root taken of the largest sum alone (it is monotone): six times
    faster on a refined error net than summing along the last axis."""
    sq = a[..., 0] * a[..., 0]
    for k in range(1, a.shape[-1]):
        sq = sq + a[..., k] * a[..., k]
    return np.sqrt(sq.reshape(len(a), -1).max(axis=1))


def pole_bounds(err: np.ndarray) -> np.ndarray:
    """The pole bound of each error net of ``err`` (R, ..., dim): its largest
    pole error (a bound on every point's move by eq. 1's convex hull)."""
    return largest_norms(err)


@dataclass
class _Memo:
    """What the trials of one net share (encoder only).

    Each entry depends on the net, its origin and the grid step h or the
    whole quantizer setting, and on nothing else a trial varies: it is
    computed once per net, not once per method, slope and trial.  Arrays held
    here are read-only.
    """

    #: coded boundaries by quantizer setting: every Coons method codes the
    #: same corners and curves first (None: unusable there)
    boundaries: dict[tuple[int, int, int], _Boundary | None] = field(default_factory=dict)
    #: points snapped by :meth:`_Writer.grid`, by (which points, h): their
    #: integers, the bits of those, and the decoded points (None: unusable)
    grids: dict[tuple[str, float], tuple[np.ndarray, float, np.ndarray] | None] = field(
        default_factory=dict
    )
    #: a curve's chord (eq. 5) and the DCT of its inner poles' differences to
    #: it (eq. 6-9), by (which curve, h): its ends are decoded on that grid
    chords: dict[tuple[str, float], tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)
    #: Coons nets of coded boundaries, by (quantizer setting, bicubic)
    nets: dict[tuple[int, int, int, bool], np.ndarray] = field(default_factory=dict)
    #: the Coons blends at the net's abscissae
    blends: coons.Blends | None = None
    #: :class:`_Rungs`' grid integers and codes' integers, by (method, *steps)
    rungs: dict[tuple[float, ...], tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)
    #: :func:`_boundary_rungs`' boundaries, by (slope, *steps)
    boundary_rungs: dict[tuple[float, ...], _BoundaryRungs] = field(default_factory=dict)
    #: :class:`_CoonsRungs`' Coons nets, by (slope, bicubic, *steps)
    rung_nets: dict[tuple[float, ...], np.ndarray] = field(default_factory=dict)
    #: :class:`_Rungs`' chord DCTs and chords, by (method, *steps)
    rung_chords: dict[tuple[float, ...], tuple[np.ndarray, np.ndarray]] = field(
        default_factory=dict
    )
    #: the certified bound of error nets (R, *net shape) -> (R,): by default
    #: each net's largest pole error; the encoder's is tighter
    #: (``encode.deviation``: the error net refined on the row's knots)
    measure: Callable[[np.ndarray], np.ndarray] | None = None

    def bounds(self, err: np.ndarray) -> np.ndarray:
        """The certified bound of each error net of ``err`` (R, ..., dim)."""
        return (self.measure or pole_bounds)(err)


class _Writer:
    """Encoder side: quantize, record integers and DCs, return the decoded values."""

    def __init__(
        self,
        stepper: _Stepper,
        dfit: np.ndarray | None = None,
        memo: _Memo | None = None,
    ) -> None:
        self.st = stepper
        self.ints: list[np.ndarray] = []
        #: bits of each of ``ints`` where known already (:func:`cost_bits`; a
        #: sum of integers, so they add up exactly)
        self.costs: list[float | None] = []
        self.dcs: list[np.ndarray] = []
        self.dfit = dfit  # the D-map fitted once to the exact boundaries' Coons net
        self.memo = memo
        #: the bound ``SPATIAL2`` chooses its residuals within (:meth:`extrapolated`)
        self.bound: float | None = None

    def add(self, ints: np.ndarray, bits: float | None = None) -> None:
        """Record integers of the code (and their bits, if known)."""
        self.ints.append(ints)
        self.costs.append(bits)

    def bits(self, start: int = 0) -> float:
        """:func:`cost_bits` of the integers recorded from ``start`` on (part by part)."""
        parts = zip(self.ints[start:], self.costs[start:], strict=True)
        return float(sum(cost_bits(i) if c is None else c for i, c in parts))

    def coeffs(self, d: np.ndarray) -> np.ndarray:
        shape = d.shape[:-1]
        dc = d.reshape(-1, d.shape[-1])[0]
        if self.st.quant == Quant.TOL and self.st.grid > 0:
            # steps of the tolerance quantizer are then all > 0: none collapsed
            steps, limit = _tol_table(shape, self.st.grid, SLOPES[self.st.slope])
            if not (np.abs(d) <= limit).all():
                raise _Unusable
            q = np.rint(d / steps).astype(np.int64)
            self.add(q.reshape(-1))
            return q * steps
        steps = self.st.steps(shape, dc)
        if not np.all(np.abs(d) <= MAX_INT * np.where(steps > 0, steps, np.inf)):
            raise _Unusable  # a collapsed paper step (D00 ~ 0) would overflow
        q = dct.quantize(d, steps)
        out = dct.dequantize(q, steps)
        if self.st.quant == Quant.PAPER:
            flat_q, flat_out = q.reshape(-1, d.shape[-1]), out.reshape(-1, d.shape[-1])
            flat_out[0] = dc  # D00 is sent; round(D00/Q00) = 2^a carries nothing
            self.dcs.append(dc.copy())
            self.add(flat_q[1:].reshape(-1))
        else:
            self.add(q.reshape(-1))
        return out

    def predicted(self, p: np.ndarray, origin: np.ndarray, axis: int | None = None) -> np.ndarray:
        """Grid snap + closed-loop prediction (parallelogram for nets, line for
        curves; with ``axis``, ``ARCS_U``/``ARCS_V``'s rows of arcs along it,
        :func:`spatial.arc_residuals`).  Each pole goes to its nearest grid point, and
        the decoder predicts from the same grid integers by the same
        operations, so the net returned is what it decodes."""
        h = self.st.grid
        if not np.abs(p).max() <= MAX_INT * h:  # NaN fails too
            raise _Unusable
        q = spatial.snap(p, h)
        r = _residuals(q) if axis is None else spatial.arc_residuals(q, axis)
        r.reshape(-1, p.shape[-1])[0] -= spatial.snap(_first(origin), h)
        if axis is not None and not np.abs(r).max() <= MAX_INT:
            raise _Unusable  # an arc prediction of a wild net may land anywhere
        self.add(r.reshape(-1))
        return q * h

    def extrapolated(
        self, p: np.ndarray, origin: np.ndarray, weights: _Weights | None = None
    ) -> np.ndarray:
        """``SPATIAL2``: residuals of linear extrapolation along u and v
        (:func:`spatial.rd_extrapolate`), each pole anywhere within
        ``self.bound``; with ``weights`` (u, v) the lifted methods'
        (:func:`spatial.rd_lifted`).  The net returned is the decoder's
        (:func:`_unextrapolated` of the integers stored)."""
        h = self.st.grid
        bound = self.bound
        if bound is None or not np.abs(p).max() <= MAX_INT * h:  # NaN fails too
            raise _Unusable
        if h * math.sqrt(3) / 2 > bound:  # a pole's nearest grid point may not fit
            raise _Unusable
        qo = spatial.snap(_first(origin), h)[None]
        hs = np.array([h])
        if weights is None:
            ints = spatial.rd_extrapolate(p, hs, bound, qo)[0][0].reshape(-1)
        else:
            ints = spatial.rd_lifted(p, hs, bound, qo, *weights)[0][0].reshape(-1)
        if not np.abs(ints).max() <= MAX_INT:
            raise _Unusable
        self.add(ints)
        return _unextrapolated(ints, p.shape, origin, h, weights=weights)

    def grid(self, p: np.ndarray, origin: np.ndarray, which: str = "") -> np.ndarray:
        """Snap points (k, 3) to the grid; code the first against ``origin`` (the
        first two against its rows if it has two), the rest against the first.

        ``which`` names the points for the net's :class:`_Memo` (every setting
        with the same grid step codes them alike).
        """
        h = self.st.grid
        memo = self.memo.grids if self.memo is not None and which else None
        key = (which, h)
        if memo is not None and key in memo:
            hit = memo[key]
            if hit is None:
                raise _Unusable
            self.add(hit[0], hit[1])
            return hit[2]
        if not np.abs(p).max() <= MAX_INT * h:  # NaN fails too
            if memo is not None:
                memo[key] = None
            raise _Unusable
        q = spatial.snap(p, h)
        ints = _against(q, spatial.snap(origin, h)).reshape(-1)
        out = q * h
        if memo is not None:
            ints.setflags(write=False)
            out.setflags(write=False)
            bits = cost_bits(ints)
            memo[key] = (ints, bits, out)
            self.add(ints, bits)
        else:
            self.add(ints)
        return out


class _Reader:
    """Decoder side: the same calls as ``_Writer``, fed from the stored integers.

    ``corners`` (format 2.10): surface corners 1-3 (``CORNERS`` order) whose
    integers are coded against these points' grid points."""

    def __init__(
        self,
        stepper: _Stepper,
        ints: np.ndarray,
        dcs: np.ndarray,
        corners: dict[int, np.ndarray] | None = None,
    ) -> None:
        self.st = stepper
        self.ints, self.ipos = ints, 0
        self.dcs, self.dpos = dcs, 0
        self.corners = {k: spatial.snap(v, stepper.grid) for k, v in (corners or {}).items()}

    def _take(self, n: int) -> np.ndarray:
        if self.ipos + n > len(self.ints):
            raise ValueError("net code is too short")
        out = self.ints[self.ipos : self.ipos + n]
        self.ipos += n
        return out

    def coeffs(self, like: np.ndarray) -> np.ndarray:
        shape, c = like.shape[:-1], like.shape[-1]
        if self.st.quant == Quant.PAPER:
            dc = self.dcs[self.dpos : self.dpos + c]
            if len(dc) != c:
                raise ValueError("net code is missing DC coefficients")
            self.dpos += c
            steps = self.st.steps(shape, dc)
            q = np.concatenate([np.zeros(c, np.int64), self._take(like.size - c)])
            out = dct.dequantize(q.reshape(like.shape), steps)
            out.reshape(-1, c)[0] = dc
            return out
        steps = self.st.steps(shape, np.zeros(c))
        return dct.dequantize(self._take(like.size).reshape(like.shape), steps)

    def grid(self, like: np.ndarray, origin: np.ndarray, which: str = "") -> np.ndarray:
        h = self.st.grid
        d = self._take(like.size).reshape(like.shape)
        q = _unagainst(d, spatial.snap(origin, h))
        if which == "corners":  # a Coons net's corners P00, P0m, Pn0, Pnm
            for k, g in self.corners.items():
                q[k] = d[k] + g
        return q * h

    def predicted(
        self, like: np.ndarray, origin: np.ndarray, axis: int | None = None
    ) -> np.ndarray:
        h = self.st.grid
        r = self._take(like.size).reshape(like.shape).copy()
        r.reshape(-1, like.shape[-1])[0] += spatial.snap(_first(origin), h)
        integrate = _integrate if axis is None else _arc_integrator(axis)
        if self.corners and r.ndim == 3:
            r = _cornered(r, integrate, self.corners)
        return integrate(r) * h

    def extrapolated(
        self, like: np.ndarray, origin: np.ndarray, weights: _Weights | None = None
    ) -> np.ndarray:
        return _unextrapolated(
            self._take(like.size), like.shape, origin, self.st.grid, self.corners, weights
        )


def _arc_integrator(axis: int) -> Callable[[np.ndarray], np.ndarray]:
    """:func:`spatial.arc_integrate` along ``axis``, as one argument's function."""
    return functools.partial(spatial.arc_integrate, axis=axis)


def _grid_integrator(
    method: Method, s: np.ndarray | None = None, t: np.ndarray | None = None
) -> Callable[[np.ndarray], np.ndarray]:
    """The decoder's grid integers of a grid code's residuals (``GRID_CODES``;
    ``s``, ``t``: the net's abscissae, for the lifted methods)."""
    if method == Method.SPATIAL:
        return spatial.integrate
    if method == Method.SPATIAL2:
        return spatial.unextrapolate
    if method in LIFTED:
        return _lifted_integrator(lifted_weights(method, s, t))
    return _arc_integrator(ARCS[method])


#: The weights along u and along v of a lifted code (:func:`lifted_weights`).
_Weights = tuple[np.ndarray, np.ndarray]


def lifted_weights(method: Method, s: np.ndarray | None, t: np.ndarray | None) -> _Weights:
    """The prediction weights along u and v of a lifted method on a net of
    abscissae ``s``, ``t`` (:func:`spatial.node_weights`)."""
    if s is None or t is None:
        raise ValueError(f"method {method.name} needs the net's abscissae")
    ou, ov = LIFTED[method]
    return spatial.node_weights(s, ou), spatial.node_weights(t, ov)


def _lifted_integrator(w: _Weights) -> Callable[[np.ndarray], np.ndarray]:
    """:func:`spatial.lifted_integrate` with weights ``w``, as one argument's function."""
    return functools.partial(spatial.lifted_integrate, wu=w[0], wv=w[1])


def corner_at(k: int, nu: int, nv: int) -> tuple[int, int]:
    """Where corner ``k`` of a net (nu, nv) is, in the order P00, P0m, Pn0, Pnm
    (``rules.joins.CORNERS``)."""
    return ((0, 0), (0, nv - 1), (nu - 1, 0), (nu - 1, nv - 1))[k]


def _cornered(
    r: np.ndarray, integrate: Callable[[np.ndarray], np.ndarray], corners: dict[int, np.ndarray]
) -> np.ndarray:
    """Grid residuals (nu, nv, 3) of a ``SPATIAL`` or ``SPATIAL2`` net whose
    anchored corners (format 2.10; k -> its vertex's grid point) hold the
    corner's grid point minus that point: the residuals ``integrate`` takes.

    Corner by corner in net order, its residual is set so that the integrated
    value there is the vertex's grid point plus what was stored (each
    integration gives a residual weight 1 at its own place, and a corner
    depends on no later one)."""
    r = r.copy()
    nu, nv = r.shape[:2]
    with np.errstate(over="ignore"):  # a wrapped sum fails the checks of the poles
        for k in sorted(corners):
            i, j = corner_at(k, nu, nv)
            stored = r[i, j].copy()
            r[i, j] = 0
            r[i, j] = corners[k] + stored - integrate(r)[i, j]
    return r


def corner_grid(
    code: NetCode,
    shape: tuple[int, ...],
    tol: float,
    s: np.ndarray | None = None,
    t: np.ndarray | None = None,
) -> np.ndarray:
    """The grid integers (4, 3) of a surface code's corners, in ``CORNERS``
    order, as decoded against ``code.origin`` (:func:`reorigin`); ``s``,
    ``t``: the net's abscissae (the lifted methods need them)."""
    h = tol * code.grid
    o = spatial.snap(_first(np.zeros(3) if code.origin is None else code.origin), h)
    nu, nv = shape[:2]
    if code.method in GRID_CODES:
        r = code.ints.reshape(shape).copy()
        r[0, 0] += o
        with np.errstate(over="ignore"):
            q = _grid_integrator(code.method, s, t)(r)
        return np.array([q[corner_at(k, nu, nv)] for k in range(4)])
    if code.method in COONS_METHODS:
        head = code.ints[:3] + o
        return np.concatenate([head[None], code.ints[3:12].reshape(3, 3) + head])
    raise ValueError(f"method {code.method.name} has no corners to anchor")


def recorner(
    code: NetCode,
    shape: tuple[int, ...],
    corners: dict[int, np.ndarray],
    tol: float,
    grid: np.ndarray | None = None,
    s: np.ndarray | None = None,
    t: np.ndarray | None = None,
) -> NetCode:
    """The same surface code with corners ``k`` of ``corners`` (1-3, in
    ``CORNERS`` order -> a point) coded against those points' grid points
    (format 2.10): the decoded net is the same.  ``code.origin`` must be the
    origin the container codes it against (:func:`reorigin`); ``grid``: its
    :func:`corner_grid`, if known (else made on the abscissae ``s``, ``t``)."""
    if not corners:
        return code
    h = tol * code.grid
    q = corner_grid(code, shape, tol, s, t) if grid is None else grid
    ints = code.ints.copy()
    for k, v in corners.items():
        at = _corner_place(code, shape, k)
        ints[at : at + 3] = q[k] - spatial.snap(v, h)
    return replace(code, ints=ints)


def _corner_place(code: NetCode, shape: tuple[int, ...], k: int) -> int:
    """Where the three integers of corner ``k`` (1-3) of a surface code start."""
    if code.method in GRID_CODES:
        i, j = corner_at(k, *shape[:2])
        return (i * shape[1] + j) * 3
    return 3 * k


def corner_ints(code: NetCode, shape: tuple[int, ...], k: int) -> np.ndarray:
    """The three integers that code corner ``k`` (1-3) of a surface code."""
    at = _corner_place(code, shape, k)
    return code.ints[at : at + 3]


def _unextrapolated(
    ints: np.ndarray,
    shape: tuple[int, ...],
    origin: np.ndarray,
    h: float,
    corners: dict[int, np.ndarray] | None = None,
    weights: _Weights | None = None,
) -> np.ndarray:
    """The net of a ``SPATIAL2`` code's integers (with ``weights``, a
    lifted one's; docs/format.md §2.4): the decoder's side, run by the
    encoder on what it stores too (``corners``: see :func:`_cornered`)."""
    r = ints.reshape(shape).copy()
    r[0, 0] += spatial.snap(_first(origin), h)
    integrate = spatial.unextrapolate if weights is None else _lifted_integrator(weights)
    if corners:
        r = _cornered(r, integrate, corners)
    return integrate(r) * h


def _against(q: np.ndarray, qo: np.ndarray) -> np.ndarray:
    """Grid points (k, 3) as: the first len(qo) minus the rows of ``qo``, the
    others minus the first."""
    qo = np.atleast_2d(qo)
    n = len(qo)
    return np.concatenate([q[:n] - qo, q[n:] - q[:1]])


def _unagainst(d: np.ndarray, qo: np.ndarray) -> np.ndarray:
    qo = np.atleast_2d(qo)
    head = d[: len(qo)] + qo
    return np.concatenate([head, d[len(qo) :] + head[:1]])


# ---------------------------------------------------------------- boundary + Coons


def _curve(
    io: _Writer | _Reader, p: np.ndarray, a: np.ndarray, b: np.ndarray, which: str = ""
) -> np.ndarray:
    """Code one boundary curve's inner poles against the chord of its decoded ends.

    Eq. 5-6: R_i = (1-(i+1)/n)·P0 + (i+1)/n·Pn, V_i = P_{i+1} - R_i; then DCT
    (eq. 8-9) and quantization (eq. 10).  ``a`` and ``b`` are the *decoded*
    end poles (closed loop), ``p`` the curve's poles (its ends unused).
    ``which`` names the curve for the encoder's :class:`_Memo`: its ends are
    then those :meth:`_Writer.grid` decoded on the setting's grid, so the
    chord and the DCT depend on the grid step alone.
    """
    n = len(p) - 1
    if n < 2:
        return np.array([a, b])
    if isinstance(io, _Writer):
        memo = io.memo.chords if io.memo is not None and which else None
        key = (which, io.st.grid)
        if memo is not None and key in memo:
            chord, d = memo[key]
        else:
            chord = _chord(a, b, n)
            d = dct.dct1(p[1:-1] - chord)
            if memo is not None:
                chord.setflags(write=False)
                d.setflags(write=False)
                memo[key] = (chord, d)
        v = io.coeffs(d)
    else:
        chord = _chord(a, b, n)
        v = io.coeffs(np.empty((n - 1, p.shape[1])))
    return np.concatenate([a[None], chord + dct.idct1(v), b[None]])


def _chord(a: np.ndarray, b: np.ndarray, n: int) -> np.ndarray:
    """R_i = (1-(i+1)/n)·a + (i+1)/n·b, i = 0..n-2 (eq. 5)."""
    g, f = _chord_weights(n)
    return g * a + f * b


@functools.lru_cache(maxsize=256)
def _chord_weights(n: int) -> tuple[np.ndarray, np.ndarray]:
    """1 - (i+1)/n and (i+1)/n, i = 0..n-2, as columns (read-only)."""
    f = (np.arange(1, n) / n)[:, None]
    g = 1 - f
    f.setflags(write=False)
    g.setflags(write=False)
    return g, f


@dataclass
class _Boundary:
    """A net's four boundary curves as decoded, and the integers and DCs that
    code them (with the corners) under one quantizer setting."""

    curves: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]
    ints: tuple[np.ndarray, ...]
    dcs: tuple[np.ndarray, ...]
    bits: float | None = None  # cost_bits of the integers, once asked for


def _boundary(
    io: _Writer | _Reader, p: np.ndarray, origin: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Code a net's corners on the grid, then its boundary curves (eq. 5-10)
    between them; return the decoded curves u0, u1, v0, v1.

    The encoder codes them once per quantizer setting of a net
    (``_Memo.boundaries``): every Coons method begins with the same code.
    """
    cache = io.memo.boundaries if isinstance(io, _Writer) and io.memo is not None else None
    key = (int(io.st.quant), io.st.level, io.st.slope)
    if cache is not None and key in cache:
        assert isinstance(io, _Writer)
        hit = cache[key]
        if hit is None:
            raise _Unusable
        io.ints.extend(hit.ints)
        if hit.bits is None:
            hit.bits = float(sum(cost_bits(i) for i in hit.ints))
        io.costs.extend([hit.bits] + [0.0] * (len(hit.ints) - 1))
        io.dcs.extend(hit.dcs)
        return hit.curves
    n_ints, n_dcs = (len(io.ints), len(io.dcs)) if isinstance(io, _Writer) else (0, 0)
    try:
        corners = p[[0, 0, -1, -1], [0, -1, 0, -1]]
        c = io.grid(
            corners if isinstance(io, _Writer) else np.empty_like(corners), origin, "corners"
        )
        curves = (
            _curve(io, p[0], c[0], c[1], "u0"),
            _curve(io, p[-1], c[2], c[3], "u1"),
            _curve(io, p[:, 0], c[0], c[2], "v0"),
            _curve(io, p[:, -1], c[1], c[3], "v1"),
        )
    except _Unusable:
        if cache is not None:
            cache[key] = None
        raise
    if cache is not None:
        assert isinstance(io, _Writer)
        ints = tuple(io.ints[n_ints:])
        bits = io.bits(n_ints)
        io.costs[n_ints:] = [bits] + [0.0] * (len(ints) - 1)
        cache[key] = _Boundary(curves, ints, tuple(io.dcs[n_dcs:]), bits)
    return curves


def _coons_code(
    io: _Writer | _Reader,
    p: np.ndarray,
    s: np.ndarray,
    t: np.ndarray,
    method: Method,
    origin: np.ndarray,
    basis: dmap.Basis | None = None,
) -> np.ndarray:
    """Code a net as corners + boundary curves + (for DDMAP, DMAP) difference
    data; return the decoded net."""
    u0, u1, v0, v1 = _boundary(io, p, origin)
    blend = coons.bicubic_net if method in BICUBIC else coons.coons_net
    if isinstance(io, _Writer) and io.memo is not None:
        # BOUNDARY and DDMAP (BOUNDARY3 and DDMAP3) predict with the same net
        key = (int(io.st.quant), io.st.level, io.st.slope, method in BICUBIC)
        if key not in io.memo.nets:
            if io.memo.blends is None:
                io.memo.blends = coons.Blends(s, t)
            io.memo.nets[key] = blend(u0, u1, v0, v1, s, t, io.memo.blends)
        net = io.memo.nets[key].copy()
    else:
        net = blend(u0, u1, v0, v1, s, t)
    nu, nv = p.shape[:2]
    if method in (Method.DDMAP, Method.DDMAP3) and nu > 2 and nv > 2:
        inner = net[1:-1, 1:-1]
        if isinstance(io, _Writer):
            w = io.coeffs(dct.dct2(p[1:-1, 1:-1] - inner))
        else:
            w = io.coeffs(np.empty_like(inner))
        net[1:-1, 1:-1] = inner + dct.idct2(w)
    elif method == Method.DMAP:
        if basis is None or nu < 3 or nv < 3:
            raise ValueError("a D-map needs the knots of a net with an interior")
        if isinstance(io, _Writer):
            d = io.dfit if io.dfit is not None else dmap.fit(p, net, basis)
            w = io.coeffs(dct.dct2(d[..., None]))
        else:
            w = io.coeffs(np.empty((nu - 2, nv - 2, 1)))
        net = dmap.apply(net, dct.idct2(w)[..., 0], basis)
    return net


def _residuals(q: np.ndarray) -> np.ndarray:
    """Prediction residuals of grid integers: parallelogram rule on a net (nu, nv, 3),
    linear extrapolation 2·P[i-1] - P[i-2] on a curve (n, 3)."""
    if q.ndim == 3:
        return spatial.residuals(q)
    # r[i] = q[i] - 2·q[i-1] + q[i-2], terms before the first taken as 0 (exact: integers)
    r = q.copy()
    r[1:] -= 2 * q[:-1]
    r[2:] += q[:-2]
    return r


def _integrate(r: np.ndarray) -> np.ndarray:
    if r.ndim == 3:
        return spatial.integrate(r)
    return np.cumsum(np.cumsum(r, axis=0), axis=0)


def _code(
    io: _Writer | _Reader,
    p: np.ndarray,
    method: Method,
    s: np.ndarray | None,
    t: np.ndarray | None,
    origin: np.ndarray,
    basis: dmap.Basis | None = None,
) -> np.ndarray:
    """Run one method through the writer (encode) or the reader (decode); return the net.

    The encoder and the decoder share this function, so what the encoder
    measures is exactly what the decoder will rebuild (closed loop).
    """
    if method in (Method.SPATIAL, Method.DELTA):
        return io.predicted(p, origin)
    if method in CHOSEN:
        if p.ndim != 3 or io.st.quant != Quant.TOL or io.st.slope != 0:
            raise ValueError(
                "the extrapolating spatial code is for surface nets on the tolerance grid"
            )
        w = lifted_weights(method, s, t) if method in LIFTED else None
        return io.extrapolated(p, origin, w)
    if method in ARCS:
        if p.ndim != 3:
            raise ValueError("the arc codes are for surface nets")
        return io.predicted(p, origin, ARCS[method])
    if method == Method.CHORD:
        ends = p[[0, -1]]
        c = io.grid(ends if isinstance(io, _Writer) else np.empty_like(ends), origin, "ends")
        return _curve(io, p, c[0], c[1], "chord")
    if method == Method.ANCHORED:  # the ends are the anchors themselves: no integers
        return _curve(io, p, origin[0], origin[1], "anchored")
    assert s is not None and t is not None
    return _coons_code(io, p, s, t, method, origin, basis)


# ---------------------------------------------------------------- stored streams (2.1)

#: The streams a format 2.1 ``SNET``/``CNET`` splits the codes' integers into
#: (docs/format.md §2.4): points on the grid against an origin or another
#: point (a net's first pole, a Coons net's corners, a chord's ends); grid
#: residuals (``SPATIAL``, ``SPATIAL2``, ``DELTA``); the DCT coefficients of
#: curves (a chord, a Coons net's boundary curves); those of a net's interior
#: (DD-map, D-map); references (``ISO``, ``COPY``).  Integers of one kind are
#: alike, and LZMA codes each kind's run better than the codes one after the
#: other: on the corpus at 0.01 mm, 74,372 bytes (SNET + CNET, xz alone) in
#: these streams against 76,120 in one (``benchmarks/net_streams.py``).
POS, GRID, CURVE, MAP, REF = range(5)
STREAMS = 5


def segments(method: int, quant: int, shape: tuple[int, ...]) -> list[tuple[int, int]]:
    """The integers of a code of ``method`` and ``quant`` for a net of ``shape``,
    in the code's order, as (stream, count) runs: what :func:`_code` records.

    Raises
    ------
    ValueError
        The method or quantizer is unknown, or does not apply to the shape.
    """
    m, q = Method(method), Quant(quant)
    dim = shape[-1]
    surface = len(shape) == 3
    paper = q == Quant.PAPER

    def coeffs(k: int, c: int) -> int:  # _Writer.coeffs: the DC is sent as a float
        return k * c - (c if paper else 0)

    if m in (Method.ISO, Method.COPY):
        if surface:
            raise ValueError(f"method {m.name} does not apply to this net")
        return [(REF, 3 if m == Method.ISO else 2)]
    if m in CURVE_CODES and surface or m not in CURVE_CODES and not surface:
        raise ValueError(f"method {m.name} does not apply to this net")
    size = int(np.prod(shape))
    if m in (*GRID_CODES, Method.DELTA):
        return [(POS, min(dim, size)), (GRID, size - min(dim, size))]
    if m == Method.CHORD:
        n = shape[0]
        return [(POS, 2 * dim), (CURVE, coeffs(n - 2, dim) if n > 2 else 0)]
    if m == Method.ANCHORED:
        n = shape[0]
        return [(CURVE, coeffs(n - 2, dim) if n > 2 else 0)]
    nu, nv = shape[:2]
    out = [(POS, 12)]
    for n in (nv, nv, nu, nu):
        out.append((CURVE, coeffs(n - 2, 3) if n > 2 else 0))
    if m in (Method.DDMAP, Method.DDMAP3) and nu > 2 and nv > 2:
        out.append((MAP, coeffs((nu - 2) * (nv - 2), 3)))
    elif m == Method.DMAP:
        if nu < 3 or nv < 3:
            raise ValueError("a D-map needs the knots of a net with an interior")
        out.append((MAP, coeffs((nu - 2) * (nv - 2), 1)))
    return out


# ---------------------------------------------------------------- encode / decode


def decode_net(
    code: NetCode,
    shape: tuple[int, ...],
    s: np.ndarray | None,
    t: np.ndarray | None,
    tol: float,
    origin: np.ndarray | None = None,
    basis: dmap.Basis | None = None,
    corners: dict[int, np.ndarray] | None = None,
) -> tuple[np.ndarray, int]:
    """The decoded net of a code (the decoder's only entry point), and the DCs it used.

    ``corners`` (format 2.10, surface nets): corners 1-3 (``CORNERS`` order)
    coded against these points (:func:`recorner`).

    ``shape`` is (nu, nv, 3) for a surface net, (n, dim) for a curve.
    ``origin`` must be the point the encoder was given (the previous net's
    decoded first pole, or None).  ``code.dcs`` may run past what the net
    needs; the count used is returned.

    Raises
    ------
    ValueError
        The code's integers do not fit the net's shape, or the method does not.
    """
    curve = len(shape) == 2
    if (code.method in CURVE_CODES) != curve or (code.method == Method.SPATIAL2 and curve):
        raise ValueError(f"method {code.method.name} does not apply to this net")
    if code.method == Method.ANCHORED and (origin is None or np.ndim(origin) != 2):
        raise ValueError("an anchored curve needs its two anchors")
    o = np.zeros(shape[-1]) if origin is None else origin
    if corners and (code.method not in CORNERED or not set(corners) <= {1, 2, 3}):
        raise ValueError("only a surface net's corners 1-3 are anchored")
    st = _Stepper(code.quant, code.level, code.slope, tol)
    rd = _Reader(st, code.ints, code.dcs, corners)
    net = _code(rd, np.empty(shape), code.method, s, t, o, basis)
    if rd.ipos != len(code.ints):
        raise ValueError("net code has unread values")
    return net, rd.dpos
