"""The search: the cheapest code of a net within its tolerance (``encode_net``).

Each setting of a ladder is tried through the coder's one closed-loop
:func:`coder._code` (:func:`_try`); on small nets the tolerance quantizer's
ladders are computed for every rung at once (:class:`_Rungs`,
:class:`_CoonsRungs`), by the same operations, and what the trials of one net
share is computed once (``coder._Memo``).  Both give the same codes, bit for
bit (tests/test_codec.py).  The encoder's side only: a decoder needs
:mod:`.coder` alone.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Sequence

import numpy as np

from .. import coons, dct, dmap, spatial
from .coder import (
    ARCS,
    BICUBIC,
    COONS_METHODS,
    LIFTED,
    MAX_INT,
    PAPER_BITS,
    SLOPES,
    SURFACE_METHODS,
    Method,
    NetCode,
    NoCodeError,
    Quant,
    _Boundary,
    _BoundaryRungs,
    _chord_weights,
    _code,
    _first,
    _ladder_settings,
    _Memo,
    _Stepper,
    _tol_ladder,
    _tol_table,
    _Unusable,
    _Writer,
    cost_bits,
    ladder,
    lifted_weights,
    pole_bounds,
)


def _try(
    p: np.ndarray,
    s: np.ndarray | None,
    t: np.ndarray | None,
    tol: float,
    method: Method,
    st: _Stepper,
    origin: np.ndarray,
    basis: dmap.Basis | None = None,
    dfit: np.ndarray | None = None,
    memo: _Memo | None = None,
    bound: float | None = None,
) -> NetCode | None:
    w = _Writer(st, dfit, memo)
    w.bound = bound
    try:
        dec = _code(w, p, method, s, t, origin, basis)
    except _Unusable:
        return None
    ints = np.concatenate(w.ints) if w.ints else np.zeros(0, np.int64)
    dcs = np.concatenate(w.dcs) if w.dcs else np.zeros(0)
    bound = float((memo.bounds if memo else pole_bounds)((dec - p)[None])[0])
    bits = w.bits() + 64 * len(dcs)
    return NetCode(method, st.quant, st.level, st.slope, ints, dcs, bound, bits, origin.copy())


# ---------------------------------------------------------------- ladders


class _Trials:
    """The rungs of one ladder, each tried through :func:`_try` when first asked for."""

    def __init__(
        self,
        p: np.ndarray,
        s: np.ndarray | None,
        t: np.ndarray | None,
        tol: float,
        method: Method,
        settings: Sequence[_Stepper],
        origin: np.ndarray,
        basis: dmap.Basis | None = None,
        dfit: np.ndarray | None = None,
        memo: _Memo | None = None,
    ) -> None:
        self.p, self.s, self.t, self.tol, self.method = p, s, t, tol, method
        self.settings, self.origin = settings, origin
        self.basis, self.dfit, self.memo = basis, dfit, memo
        self.codes: dict[int, NetCode | None] = {}

    def code(self, i: int) -> NetCode | None:
        """Rung ``i``'s code (None: the setting cannot code the net)."""
        if i not in self.codes:
            self.codes[i] = _try(
                self.p,
                self.s,
                self.t,
                self.tol,
                self.method,
                self.settings[i],
                self.origin,
                self.basis,
                self.dfit,
                self.memo,
            )
        return self.codes[i]

    def bound(self, i: int) -> float | None:
        """Rung ``i``'s certified bound (None: unusable)."""
        c = self.code(i)
        return None if c is None else c.bound


#: Grid ladders (:class:`_Rungs`) of nets of up to this many values are
#: computed at once; a larger net's trials cost their arithmetic.
RUNGS_MAX = 768


def _rungs_apply(p: np.ndarray, method: Method, settings: Sequence[_Stepper]) -> bool:
    """Whether :class:`_Rungs` computes this ladder (else :class:`_Trials`)."""
    if method not in (*_GRID_METHODS, *_CHORDS) or p.size > RUNGS_MAX:
        return False
    if not _tol_ladder(tuple(settings)):
        return False
    # a chord's DCT by the matrix product only (dct.dct1)
    return method not in _CHORDS or (p.ndim == 2 and len(p) - 2 <= dct.MATRIX_MAX)


_GRID_METHODS = (Method.SPATIAL, Method.DELTA)
#: Curve methods that code the inner poles against the chord of the ends.
_CHORDS = (Method.CHORD, Method.ANCHORED)


class _Batch:
    """A ladder whose rungs' bounds and integers were all computed at once (by
    a subclass); a rung's code is made when first asked for."""

    def __init__(self, method: Method, settings: Sequence[_Stepper], origin: np.ndarray) -> None:
        self.method, self.settings, self.origin = method, settings, origin
        self.bounds: list[float | None] = [None] * len(settings)
        self.ints: dict[int, np.ndarray] = {}
        self.codes: dict[int, NetCode] = {}

    def bound(self, i: int) -> float | None:
        """Rung ``i``'s certified bound (None: unusable)."""
        return self.bounds[i]

    def code(self, i: int) -> NetCode | None:
        """Rung ``i``'s code (None: unusable)."""
        bound = self.bounds[i]
        if bound is None:
            return None
        if i not in self.codes:
            st, ints = self.settings[i], self.ints[i].copy()
            self.codes[i] = NetCode(
                self.method,
                st.quant,
                st.level,
                st.slope,
                ints,
                np.zeros(0),
                bound,
                cost_bits(ints),
                self.origin.copy(),
            )
        return self.codes[i]


class _Rungs(_Batch):
    """Every rung of a ``SPATIAL``, ``DELTA``, ``CHORD`` or ``ANCHORED`` ladder with the
    tolerance quantizer, computed at once: on small nets numpy's cost per
    call, not the arithmetic, is what a trial costs.

    Each value is made by the same floating-point operations as :func:`_code`
    through a :class:`_Writer` (snap, residuals, chord, DCT as the same
    matrix product per rung, steps, rounding, decoded poles, bound), so the
    bounds and codes are those of :func:`_try`, bit for bit
    (``tests/test_codec.py``).  A code is made only for a rung asked for.
    """

    def __init__(
        self,
        p: np.ndarray,
        method: Method,
        settings: Sequence[_Stepper],
        origin: np.ndarray,
        memo: _Memo | None = None,
    ) -> None:
        super().__init__(method, settings, origin)
        hs = [st.grid for st in settings]
        if method == Method.ANCHORED:  # the ends are the anchors on every rung
            self._anchored(p, settings, origin, memo)
            return
        chord = method == Method.CHORD
        pts = p[[0, -1]] if chord else p
        amax = np.abs(pts).max()
        use = [i for i, h in enumerate(hs) if amax <= MAX_INT * h]  # NaN fails too
        if not use:
            return
        h = np.array([hs[i] for i in use])
        # what does not depend on the slope is shared by the net's ladders
        key = (int(method), *h.tolist())
        if memo is not None and key in memo.rungs:
            q, head = memo.rungs[key]
        else:
            q, head = _grid_rungs(pts, h, origin, chord)
            if memo is not None:
                memo.rungs[key] = (q, head)
        dec = q * h.reshape(-1, *([1] * pts.ndim))
        good = [True] * len(use)
        if chord:
            slope = SLOPES[settings[0].slope]
            dec, qc, ok = _curve_rungs(p, dec[:, 0], dec[:, 1], h, slope, memo, "chord")
            head = np.concatenate([head, qc], axis=1)
            good = ok.tolist()
        # as in _try
        bounds = (memo.bounds if memo else pole_bounds)(dec - p).tolist()
        for j, i in enumerate(use):
            if good[j]:
                self.bounds[i] = bounds[j]
                self.ints[i] = head[j]

    def _anchored(
        self, p: np.ndarray, settings: Sequence[_Stepper], origin: np.ndarray, memo: _Memo | None
    ) -> None:
        """The rungs of an ``ANCHORED`` ladder: :func:`_curve_rungs` between
        the anchors, which no rung moves."""
        h = np.array([st.grid for st in settings])
        r = len(h)
        a = np.broadcast_to(origin[0], (r, p.shape[1]))
        b = np.broadcast_to(origin[1], (r, p.shape[1]))
        slope = SLOPES[settings[0].slope]
        dec, qc, ok = _curve_rungs(p, a, b, h, slope, memo, "anchored")
        bounds = (memo.bounds if memo else pole_bounds)(dec - p).tolist()
        for i in np.flatnonzero(ok).tolist():
            self.bounds[i] = bounds[i]
            self.ints[i] = qc[i]


def _grid_rungs(
    pts: np.ndarray, h: np.ndarray, origin: np.ndarray, against: bool
) -> tuple[np.ndarray, np.ndarray]:
    """Grid integers of ``pts`` for each step of ``h`` (R, ...), and each
    step's integers as :meth:`_Writer.grid` (``against``: corners, a chord's
    ends) or :meth:`_Writer.predicted` (``SPATIAL``, ``DELTA``) records them (R, k)."""
    r = len(h)
    q = np.rint(pts / h.reshape(-1, *([1] * pts.ndim))).astype(np.int64)
    qo = np.rint(np.atleast_2d(origin) / h[:, None, None]).astype(np.int64)
    if against:
        n = qo.shape[1]  # as _against
        ints = np.concatenate([q[:, :n] - qo, q[:, n:] - q[:, :1]], axis=1)
        return q, ints.reshape(r, -1)
    if q.ndim == 4:  # spatial.residuals, on each rung
        a = q.copy()
        a[:, 1:] -= q[:, :-1]
        res = a.copy()
        res[:, :, 1:] -= a[:, :, :-1]
    else:  # _residuals of a curve, on each rung
        res = q.copy()
        res[:, 1:] -= 2 * q[:, :-1]
        res[:, 2:] += q[:, :-2]
    flat = res.reshape(r, -1, pts.shape[-1])
    flat[:, 0] -= qo[:, 0]
    return q, flat.reshape(r, -1)


def _curve_rungs(
    p: np.ndarray,
    a: np.ndarray,
    b: np.ndarray,
    h: np.ndarray,
    slope: float,
    memo: _Memo | None,
    which: str,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`_curve` on each rung: the curve ``p`` between decoded ends
    ``a``, ``b`` (R, dim) on the grids of steps ``h`` (R,), DCT coefficients
    quantized with steps (1 + slope·k)·h (eq. 5-10).

    Returns the decoded curves (R, n+1, dim), their coefficients' integers
    (R, (n-1)·dim) and which rungs can code them (R,) (integers in range).
    The chords and DCTs do not depend on the slope: the net's ``memo`` keeps
    them under ``which``.
    """
    n, r = len(p) - 1, len(h)
    if n < 2:
        return np.stack([a, b], axis=1), np.zeros((r, 0), np.int64), np.ones(r, bool)
    key = (which, *h.tolist())
    if memo is not None and key in memo.rung_chords:
        d, chords = memo.rung_chords[key]
    else:
        g, f = _chord_weights(n)
        chords = g * a[:, None] + f * b[:, None]  # as _chord, on each rung
        d = dct.dct1_rows(p[1:-1] - chords)
        if memo is not None:
            memo.rung_chords[key] = (d, chords)
    w = _tol_table((n - 1,), 1.0, slope)[0]
    steps = w[None] * h[:, None, None]  # (1 + slope·k)·Δ, as dct.tol_steps
    good = (np.abs(d) <= MAX_INT * steps).all(axis=(1, 2))
    with np.errstate(invalid="ignore"):  # rungs whose integers overflow are dropped
        qc = np.rint(d / steps).astype(np.int64)
    inner = chords + dct.idct1_rows(qc * steps)
    return np.concatenate([a[:, None], inner, b[:, None]], axis=1), qc.reshape(r, -1), good


def _boundary_rungs(
    p: np.ndarray, settings: Sequence[_Stepper], origin: np.ndarray, memo: _Memo
) -> _BoundaryRungs:
    """:func:`_boundary` on every rung of a ladder at once: corners on the
    grid, then the four curves between them (the same operations as
    :func:`_Rungs` uses for a chord's ends and inner poles), kept in ``memo``
    (see :func:`_trial_boundaries` for the trials')."""
    hs = [st.grid for st in settings]
    known = memo.boundary_rungs.get((settings[0].slope, *hs))
    if known is not None:
        return known
    corners = p[[0, 0, -1, -1], [0, -1, 0, -1]]
    amax = np.abs(corners).max()
    use = [i for i, h in enumerate(hs) if amax <= MAX_INT * h]  # NaN fails too
    h = np.array([hs[i] for i in use])
    if not use:
        out = _BoundaryRungs([], h, (), np.zeros((0, 0), np.int64))
        memo.boundary_rungs[(settings[0].slope, *hs)] = out
        return out
    q, ints = _grid_rungs(corners, h, origin, True)
    c = q * h[:, None, None]
    slope = SLOPES[settings[0].slope]
    parts, good, curves = [ints], np.ones(len(use), bool), []
    for which, row, i0, i1 in (
        ("u0", p[0], 0, 1),
        ("u1", p[-1], 2, 3),
        ("v0", p[:, 0], 0, 2),
        ("v1", p[:, -1], 1, 3),
    ):
        curve, qc, ok = _curve_rungs(row, c[:, i0], c[:, i1], h, slope, memo, which)
        curves.append(curve)
        parts.append(qc)
        good &= ok
    every = np.concatenate(parts, axis=1)
    ok = np.flatnonzero(good)
    out = _BoundaryRungs(
        [use[j] for j in ok.tolist()], h[ok], tuple(cv[ok] for cv in curves), every[ok]
    )
    memo.boundary_rungs[(settings[0].slope, *hs)] = out
    return out


def _trial_boundaries(
    p: np.ndarray, settings: Sequence[_Stepper], origin: np.ndarray, memo: _Memo
) -> None:
    """Each rung's boundary of :func:`_boundary_rungs` into ``memo.boundaries``,
    where the trials of a ladder :class:`_CoonsRungs` does not compute find
    them (None: unusable)."""
    b = _boundary_rungs(p, settings, origin, memo)
    at = {i: j for j, i in enumerate(b.use)}
    for i, st in enumerate(settings):
        key = (int(st.quant), st.level, st.slope)
        if key in memo.boundaries:
            continue
        j = at.get(i)
        if j is None:
            memo.boundaries[key] = None
            continue
        u0, u1, v0, v1 = (cv[j] for cv in b.curves)
        memo.boundaries[key] = _Boundary((u0, u1, v0, v1), (b.ints[j].copy(),), ())


class _CoonsRungs(_Batch):
    """Every rung of a ``BOUNDARY``, ``BOUNDARY3``, ``DDMAP`` or ``DDMAP3``
    ladder with the tolerance quantizer at once (as :class:`_Rungs`): the
    boundaries of :func:`_boundary_rungs`, their Coons nets (eq. 11; the
    nets take leading axes) and the DD-map's DCT (eq. 26-27, the same matrix
    products per rung), so bounds and codes are those of :func:`_try`."""

    def __init__(
        self,
        p: np.ndarray,
        s: np.ndarray,
        t: np.ndarray,
        method: Method,
        settings: Sequence[_Stepper],
        origin: np.ndarray,
        memo: _Memo,
    ) -> None:
        super().__init__(method, settings, origin)
        b = _boundary_rungs(p, settings, origin, memo)
        if not b.use:
            return
        bicubic = method in BICUBIC
        key = (settings[0].slope, bicubic, *[st.grid for st in settings])
        if key not in memo.rung_nets:
            if memo.blends is None:
                memo.blends = coons.Blends(s, t)
            blend = coons.bicubic_net if bicubic else coons.coons_net
            u0, u1, v0, v1 = b.curves
            memo.rung_nets[key] = blend(u0, u1, v0, v1, s, t, memo.blends)
        net, ints = memo.rung_nets[key], b.ints
        use, good = b.use, [True] * len(b.use)
        nu, nv = p.shape[:2]
        if method in (Method.DDMAP, Method.DDMAP3) and nu > 2 and nv > 2:
            net = net.copy()
            inner = net[:, 1:-1, 1:-1]
            d = dct.dct2_rows(p[1:-1, 1:-1] - inner)
            w = _tol_table((nu - 2, nv - 2), 1.0, SLOPES[settings[0].slope])[0]
            steps = w[None] * b.h[:, None, None, None]  # (1 + slope·(k+l))·Δ, as dct.tol_steps
            good = (np.abs(d) <= MAX_INT * steps).all(axis=(1, 2, 3)).tolist()
            with np.errstate(invalid="ignore"):  # rungs whose integers overflow are dropped
                qd = np.rint(d / steps).astype(np.int64)
            net[:, 1:-1, 1:-1] = inner + dct.idct2_rows(qd * steps)
            ints = np.concatenate([ints, qd.reshape(len(qd), -1)], axis=1)
        # as in _try
        bounds = memo.bounds(net - p).tolist()
        for j, i in enumerate(use):
            if good[j]:
                self.bounds[i] = bounds[j]
                self.ints[i] = ints[j]


#: The methods of ``COONS_METHODS`` (a net's boundary first, :func:`_boundary`) whose
#: ladders :class:`_CoonsRungs` computes at once (the D-map's
#: least squares go rung by rung).
_BATCHED_COONS = (Method.BOUNDARY, Method.DDMAP, Method.BOUNDARY3, Method.DDMAP3)


def _boundary_rungs_apply(p: np.ndarray, method: Method, settings: Sequence[_Stepper]) -> bool:
    """Whether :func:`_boundary_rungs` codes this ladder's boundaries."""
    if method not in COONS_METHODS or p.ndim != 3 or p.size > RUNGS_MAX:
        return False
    if not _tol_ladder(tuple(settings)):
        return False
    return max(p.shape[:2]) - 2 <= dct.MATRIX_MAX


def _passing(
    p: np.ndarray,
    s: np.ndarray | None,
    t: np.ndarray | None,
    tol: float,
    method: Method,
    settings: Sequence[_Stepper],
    origin: np.ndarray,
    keep: int = 3,
    basis: dmap.Basis | None = None,
    dfit: np.ndarray | None = None,
    limit: float | None = None,
    memo: _Memo | None = None,
) -> list[NetCode]:
    """The first ``keep`` codes within ``limit`` (default tol) along a coarse-to-fine ladder.

    The error shrinks (nearly) monotonically along the ladder, so the first
    passing rung is found by bisection; the ``keep`` rungs from there on are
    all returned, since a finer step sometimes codes smaller.
    """
    limit = tol if limit is None else limit
    runs: _Rungs | _CoonsRungs | _Trials
    if memo is not None and _boundary_rungs_apply(p, method, settings):
        if method in _BATCHED_COONS and s is not None and t is not None:
            runs = _CoonsRungs(p, s, t, method, settings, origin, memo)
        else:
            _trial_boundaries(p, settings, origin, memo)
            runs = _Trials(p, s, t, tol, method, settings, origin, basis, dfit, memo)
    elif _rungs_apply(p, method, settings):
        runs = _Rungs(p, method, settings, origin, memo)
    else:
        runs = _Trials(p, s, t, tol, method, settings, origin, basis, dfit, memo)

    def ok(i: int) -> bool:
        b = runs.bound(i)
        return b is not None and b <= limit

    lo, hi = 0, len(settings) - 1
    if not ok(hi):
        return []
    while lo < hi:  # first passing rung in [lo, hi]
        mid = (lo + hi) // 2
        if ok(mid):
            hi = mid
        else:
            lo = mid + 1
    out = []
    for i in range(lo, min(lo + keep, len(settings))):
        if ok(i):
            c = runs.code(i)
            assert c is not None
            out.append(c)
    return out


#: Methods that differ from ``BOUNDARY`` only in a net's interior.
_INTERIOR_METHODS = (Method.DDMAP, Method.DMAP, Method.BOUNDARY3, Method.DDMAP3)

#: Largest interior (poles) the D-map is tried on.
DMAP_MAX_INTERIOR = 900


def _dmap_applies(p: np.ndarray, basis: dmap.Basis | None) -> bool:
    if basis is None or p.ndim != 3:
        return False
    inner = (p.shape[0] - 2) * (p.shape[1] - 2)
    return 0 < inner <= DMAP_MAX_INTERIOR


#: ``SPATIAL2`` rungs tried on a net: from :data:`EXTRAPOLATED_COARSER` rungs
#: coarser than the first whose nearest grid points all fit the bound
#: (h·√3/2 ≤ bound), this many in all.  Measured on the corpus's 865 nets
#: coded ``SPATIAL`` at 0.01 mm (their integers through the entropy stage):
#: that first rung alone, 8.90 bits per pole; the cheapest of it and the five
#: finer ones by :func:`cost_bits`, 8.94 (each finer rung alone: 9.34, 9.70,
#: 9.96 ...); of five from two rungs coarser, 9.14 (where a coarser grid
#: passes, its residuals have less room to be chosen in).
EXTRAPOLATED_RUNGS = 1
EXTRAPOLATED_COARSER = 0
#: Nets of more poles than this are not tried with ``SPATIAL2``: the choice
#: is a pass over the net's anti-diagonals per rung (a 300 x 300 net took
#: 4 s for two rungs, where ``SPATIAL``'s whole ladder took 0.5 s).
EXTRAPOLATED_MAX = 20_000
#: The share of a net's bound its ``SPATIAL2`` residuals are chosen within
#: (the certified bound is still the whole limit: the corners, and poles
#: with no grid point inside, go to their nearest grid point).  A net whose
#: every pole sits at its full bound leaves nothing to the edges that lie on
#: its surface: the validity stage then keeps pcurves (trj3 at 0.01 mm: 12,368
#: bytes with the whole bound, 11,464 with 0.75, 11,647 with 0.5, against
#: 11,640 without ``SPATIAL2``).  Six corpus files at 0.01 mm: 112,416 bytes
#: with 1.0, 112,063 with 0.75, 113,240 without.
RD_SHARE = 0.75


#: With a measure tighter than the pole bound (``encode_net``'s ``measure``),
#: ``SPATIAL2`` is also tried on rungs up to this many coarser than the first
#: whose nearest grid points all fit, each with its residuals chosen within
#: these multiples of the limit (poles may then move past the limit where the
#: basis averages their errors; the measure of the whole net decides).
#: Measured on trj7's 338 nets at 0.01 mm (Exp-Golomb bits, the measure on
#: nets cut 8 times a span): the pole bound's rung alone 140,902; up to 3
#: coarser with 0.75, 1.0 and 1.5, 124,642; up to 5 with 0.75 to 2.0, 125,186.
SPREAD_COARSER = 3
SPREAD_SHARES = (RD_SHARE, 1.0, 1.5)


def _first_fit(tol: float, rungs: tuple[int, ...], limit: float) -> int | None:
    """The first of ``rungs`` (exponents e, steps tol·2^(e/4)) whose nearest
    grid points all fit ``limit`` (h·√3/2 ≤ limit), or None."""
    return next(
        (i for i, e in enumerate(rungs) if tol * 2.0 ** (e / 4) * math.sqrt(3) / 2 <= limit), None
    )


def _extrapolated_codes(
    p: np.ndarray,
    tol: float,
    rungs: tuple[int, ...],
    origin: np.ndarray,
    limit: float,
    memo: _Memo | None = None,
    method: Method = Method.SPATIAL2,
    s: np.ndarray | None = None,
    t: np.ndarray | None = None,
) -> list[NetCode]:
    """``SPATIAL2`` codes (or those of a ``LIFTED`` method, on the net's
    abscissae ``s``, ``t``) of a net within ``limit`` on the rungs of
    :data:`EXTRAPOLATED_RUNGS` (and, with a measure, :data:`SPREAD_COARSER`
    and :data:`SPREAD_SHARES`): the residuals of all trials chosen at once
    (:func:`spatial.rd_extrapolate`), with the grid points each trial's
    integers decode to (the decoder's, :func:`_unextrapolated`: the closed
    loop computes the same integers), and every trial's bound certified on
    its net in one call to the measure, as :func:`_try` certifies one."""
    if p.shape[0] * p.shape[1] > EXTRAPOLATED_MAX:
        return []
    memo = memo or _Memo()
    fit = _first_fit(tol, rungs, limit)
    if fit is None:
        return []
    start = max(0, fit - EXTRAPOLATED_COARSER)
    trials = [(i, RD_SHARE) for i in range(start, min(start + EXTRAPOLATED_RUNGS, len(rungs)))]
    if memo.measure is not None:
        first = max(0, fit - SPREAD_COARSER)
        trials += [
            (i, share)
            for i in range(first, fit + 1)
            for share in SPREAD_SHARES
            if (i, share) not in trials
        ]
    amax = np.abs(p).max()
    settings = []
    for i, share in trials:
        st = _ladder_settings(Quant.TOL, rungs[i : i + 1], 0, tol)[0]
        if amax <= MAX_INT * st.grid:  # NaN fails too
            settings.append((st, share))
    if not settings:
        return []
    h = np.array([st.grid for st, _ in settings])
    shares = np.array([share for _, share in settings])
    o = _first(origin)
    qo = np.stack([spatial.snap(o, x) for x in h])
    w = lifted_weights(method, s, t) if method in LIFTED else None
    # the closed loop's grid points are the decoder's (tests/test_lifted.py,
    # tests/test_codec.py): every trial's net is measured in one call
    if w is None:
        res, grids = spatial.rd_extrapolate(p, h, shares * limit, qo)
    else:
        res, grids = spatial.rd_lifted(p, h, shares * limit, qo, *w)
    usable = [k for k in range(len(settings)) if np.abs(res[k]).max() <= MAX_INT]
    if not usable:
        return []
    nets = grids[usable] * h[usable].reshape(-1, 1, 1, 1)
    bounds = memo.bounds(nets - p[None]).tolist()
    out = []
    for k, bound in zip(usable, bounds):
        if bound <= limit:
            st = settings[k][0]
            ints = res[k].reshape(-1)
            out.append(
                NetCode(
                    method,
                    st.quant,
                    st.level,
                    0,
                    ints,
                    np.zeros(0),
                    bound,
                    cost_bits(ints),
                    origin.copy(),
                )
            )
    return out


#: The share of its estimate (nearest grid points) that a lifted code's
#: residuals chosen within the bound may come down to: it is tried only where
#: that would beat the best code found before it.  Measured on 104 trials
#: (ec_turbine, trj3, occ22470 at 0.01 mm): the chosen residuals cost 0.98
#: of the estimate (median), 0.85 at the 10th percentile.
LIFTED_HOPE = 0.85


def _lifted_choice(
    p: np.ndarray,
    s: np.ndarray | None,
    t: np.ndarray | None,
    tol: float,
    rungs: tuple[int, ...],
    limit: float,
) -> tuple[Method, float] | None:
    """The lifted method (format 2.14) worth a trial on a net beside
    ``SPATIAL2``, and its estimated bits: of the orders along u and v, the
    one whose residuals on the nearest grid points of the first rung that
    fits (:func:`spatial.lifted_residuals`) cost fewest Exp-Golomb bits, if
    fewer than ``SPATIAL2``'s (:func:`spatial.extrapolate`).  Measured on the
    corpus's B-spline nets at 0.01 mm (nearest grid points, Exp-Golomb): the
    cheapest of the nine and ``SPATIAL2`` take 9 % fewer bits than the
    cheaper of ``SPATIAL`` and ``SPATIAL2`` (bug32596 33 %, occ22470 41 %,
    ec_turbine 16 %, trj7 5 %)."""
    if s is None or t is None or p.shape[0] * p.shape[1] > EXTRAPOLATED_MAX:
        return None
    fit = _first_fit(tol, rungs, limit)
    if fit is None:
        return None
    h = tol * 2.0 ** (rungs[fit] / 4)
    if not np.abs(p).max() <= MAX_INT * h:  # NaN fails too
        return None
    q = spatial.snap(p, h)

    def bits(r: np.ndarray) -> float:
        return float(spatial.eg_bits(r.reshape(-1, 3)[1:]).sum())

    ws = {o: spatial.node_weights(s, o) for o in spatial.ORDERS}
    wt = {o: spatial.node_weights(t, o) for o in spatial.ORDERS}
    trials = spatial.lifted_trials(q, ws, wt)
    cost = {m: bits(trials[orders]) for m, orders in LIFTED.items()}
    best = min(cost, key=lambda m: (cost[m], int(m)))
    return (best, cost[best]) if cost[best] < bits(spatial.extrapolate(q)) else None


def encode_net(
    p: np.ndarray,
    s: np.ndarray | None,
    t: np.ndarray | None,
    tol: float,
    methods: tuple[Method, ...] = SURFACE_METHODS,
    paper: bool = False,
    origin: np.ndarray | None = None,
    basis: dmap.Basis | None = None,
    limit: float | None = None,
    measure: Callable[[np.ndarray], np.ndarray] | None = None,
) -> NetCode:
    """The cheapest code of a net whose certified bound is ≤ tol (or ``limit``).

    Parameters
    ----------
    p : ndarray, shape (nu, nv, 3), or (n, dim) for a curve
    s, t : ndarray, shapes (nu,), (nv,), or None for a curve
        Normalised Greville abscissae (:func:`coons.unit_abscissae`), the
        Coons blending abscissae.
    tol : float
    methods : tuple of Method
        ``SURFACE_METHODS`` for nets, ``CURVE_METHODS`` for curves.
    paper : bool
        Also try the paper's quantizer (eq. 10, 27).  Off by default: on the
        corpus it was never the cheapest at 0.001, 0.01 or 0.1 mm, and it
        costs a third of the search time.
    origin : ndarray, shape (dim,) or (2, dim), optional
        A point the decoder knows (the previous net's decoded first pole, or
        the vertex a curve's first pole is pinned to): the net's first pole is
        coded against it.  A second row (a curve's other vertex) is what the
        chord method codes the last pole against.
    basis : dmap.Basis, optional
        Knots, degrees and weights of a clamped, non-periodic surface: with
        it, the D-map is tried too (nets with an interior of at most
        ``DMAP_MAX_INTERIOR`` poles; its dense least squares grows fast).
    limit : float, optional
        A bound below tol this net is held to (a feature smaller than tol,
        see :func:`nurbscomp.encode.nets.feature_limit`); steps stay multiples
        tol·2^(e/4) of the container's tol, with e going further down.
    measure : callable, optional
        The certified bound of error nets (R, *p.shape) -> (R,) (the
        encoder's :func:`nurbscomp.encode.deviation.measure`: the error net
        refined on the row's knots).  By default each net's largest pole
        error.  With one, ``SPATIAL2`` also tries coarser rungs
        (:data:`SPREAD_COARSER`).

    Raises
    ------
    NoCodeError
        No code is within the bound.

    Notes
    -----
    For each method and quantizer setting, steps are tried from coarse to fine
    and the first few within tolerance are kept; the cheapest of all wins.
    ``SPATIAL``/``DELTA`` with e ≤ 0 always pass (|P - P'| ≤ tol·√3/2), so a
    code is always found when they are among ``methods``.
    """
    o = np.zeros(p.shape[-1]) if origin is None else origin
    limit = tol if limit is None else min(limit, tol)
    rungs = ladder(tol, limit)
    best: NetCode | None = None
    memo = _Memo(measure=measure)
    if p.ndim == 3 and min(p.shape[:2]) <= 2:
        # no interior: every Coons method decodes to the boundary method's net
        # with the same integers, and the first of equal codes is kept anyway
        methods = tuple(m for m in methods if m not in _INTERIOR_METHODS)

    def keep(codes: Iterable[NetCode]) -> None:
        """The cheapest so far stays (the first of equal codes)."""
        nonlocal best
        for c in codes:
            if best is None or c.bits < best.bits:
                best = c

    for method in methods:
        if method == Method.SPATIAL2:
            if p.ndim == 3:
                keep(_extrapolated_codes(p, tol, rungs, o, limit, memo))
                lifted = _lifted_choice(p, s, t, tol, rungs, limit)
                # a trial only where its estimate may beat the best code so far
                if lifted is not None and (best is None or lifted[1] * LIFTED_HOPE < best.bits):
                    keep(_extrapolated_codes(p, tol, rungs, o, limit, memo, lifted[0], s, t))
            continue
        if method in LIFTED:  # asked for by name (the search tries them with SPATIAL2)
            if p.ndim == 3 and s is not None and t is not None:
                keep(_extrapolated_codes(p, tol, rungs, o, limit, memo, method, s, t))
            continue
        dfit = None
        if method == Method.DMAP:
            if not _dmap_applies(p, basis):
                continue
            assert basis is not None and s is not None and t is not None
            # fitted once, to the exact boundaries (eq. 18-24); each rung then
            # applies it along the normals of its own decoded Coons net
            exact = coons.coons_net(p[0], p[-1], p[:, 0], p[:, -1], s, t)
            dfit = dmap.fit(p, exact, basis)
        ladders: list[Sequence[_Stepper]] = []
        if method in (Method.SPATIAL, Method.DELTA, *ARCS):
            ladders.append(_ladder_settings(Quant.TOL, rungs, 0, tol))
        else:
            # a slope only weighs DCT coefficients k+l > 0: nets whose curves
            # have at most one coefficient (3 poles a side, an interior of at
            # most 1 x 1) code the same with every slope, so only with 0 (a
            # code of equal bits found later never replaces the first)
            flat = max(p.shape[:-1]) <= 3
            for k in range(1 if flat else len(SLOPES)):
                ladders.append(_ladder_settings(Quant.TOL, rungs, k, tol))
            if paper:
                ladders.append(_ladder_settings(Quant.PAPER, PAPER_BITS, 0, tol))
        for settings in ladders:
            keep(
                _passing(
                    p,
                    s,
                    t,
                    tol,
                    method,
                    settings,
                    o,
                    basis=basis,
                    dfit=dfit,
                    limit=limit,
                    memo=memo,
                )
            )
    if best is None:
        raise NoCodeError(f"no code within {limit} among {[m.name for m in methods]}")
    return best
