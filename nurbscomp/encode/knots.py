"""Inner knots of coded nets within tol (issue 28 §5): rounded, with a certified bound.

A knot vector that is neither a repeat of an earlier one nor evenly spaced is
written as it is, 8 bytes a knot (docs/format.md §2.3), and the chord-length
knots CAD systems write (8.75782843183719, 13.1367426477558, …) leave LZMA
little to find.  Rounded to a few significant bits, they cost about half as
much, for a move of a small share (``SHARE``) of the net's limit.  Only the
writer changes: the reader takes the knots as they are.

**The bound.**  Let S have knots K and poles P, and S' the same poles on K',
whose inner knots moved (same ends, same multiplicities, still increasing).
Insert into each the knots of the other (Boehm's algorithm, eq. 1: each new
pole is a convex combination of two old ones, and no point moves), so that
both live on one knot vector T, every value at the larger of its two
multiplicities: S = Σ N_i^T Q_i and S' = Σ N_i^T Q'_i.  The basis is
non-negative and sums to one, so

    |S'(u) − S(u)| ≤ max_i |Q'_i − Q_i|                     (:func:`move`)

at every parameter u; for a surface the same holds on T_u × T_v.  The
refined poles are computed in binary64 as rows of the Oslo matrix
(:func:`bspline.refinement`: degree + 1 non-negative weights summing to one
per direction) times the poles, so each is within a few ulps per term of
the largest pole coordinate; :func:`move` adds ``ROUNDING`` ulps per term
and direction.  Clamped ends do not move, so neither do a
surface's boundaries along the direction whose knots did not change.

A rational row (eq. 2) is refined in homogeneous coordinates (w·P, w): on T
the two rows have poles Q, Q' and weights W, W', and the bound is that of
two rational rows on one knot vector, max |Q' − Q| + ε/(1 − ε)·D, ε the
largest |W'/W − 1| and D the largest diagonal of (degree + 1) consecutive
refined poles per direction (:func:`weights.weight_bound`, derived in
:mod:`.weights`).

A coded row whose knots moved is coded on its new knots (its Coons
abscissae and D-map basis come from them, as the decoder's do), and its
certified bound is the code's plus the move (coded again to its limit less
the move where the sum is past the limit, ``nets._code_one``)
(:func:`moved` adds :func:`term` wherever a row is compared with the
source).

**Which vectors.**  Those of clamped B-splines (not periodic, not Bezier)
that the writer would store explicitly, but not on a surface side joined
to another net's (``coincide.twin_sides``: the copy takes the leader's
poles on its own knots).  An iso-boundary curve takes its side's knots as
rounded (``assembly._copy_iso``), a twin curve its leader's mapped onto its
own ends (``assembly._copy_twins``), and a twin and its leader are rounded
both or neither (``links`` of :func:`plan`).  Rows that are not coded
freeze the vectors they use, bit for bit.

**How far.**  One precision for the file (:func:`plan`), so that knots the
source has equal in different vectors stay equal: the coarsest that keeps
every row's move within ``SHARE`` of its limit for the vectors it rounds,
chosen by the size of the rounded vectors.  A 3-D curve's vector is rounded
as places in [0, 1] (``pcurves.unit_curves`` maps free curves there, and
IGES files write knots that are short binary fractions of their span), a
surface's (or one a surface has too) to significant bits.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import fields, replace
from typing import Any

import numpy as np

from .. import bspline, entropy
from ..memo import Memo, digest
from ..model import BSplineCurve, BSplineSurface, Geometry
from ..rules.joins import clamped_curve, clamped_surface
from ..serialize.geometry import evenly_spaced, mapped_knots
from . import weights

#: The share of a row's limit its rounded knots may take.
SHARE = 1.0 / 32

#: Precisions tried (bits after the leading one), coarsest first.
BITS = tuple(range(6, 41, 2))

#: Rounding must save at least this many bytes of the vectors (LZMA alone).
MIN_SAVING = 32

#: ulps of the largest pole coordinate added per term of a refined pole
#: (degree + 1 per direction, :func:`move`), and the ulps of a knot vector's
#: span within which two vectors are one (:func:`term`).
ROUNDING = 4.0

Net = BSplineSurface | BSplineCurve


def rounded(k: np.ndarray, bits: int, unit: bool = False) -> np.ndarray:
    """``k`` with its inner knots rounded (ties to even), its ends as they are.

    Without ``unit``, to ``bits`` bits after the leading one: the knots
    themselves then end in zeros.  With ``unit`` (a 3-D curve's knots, which
    the writer maps onto [0, 1] where nothing holds its parameter,
    ``pcurves.unit_curves``), each knot's place in the vector,
    (k − a)/(b − a), is rounded to a multiple of 2^-bits, and the knot is
    the float nearest to that place's a + q·(b − a) whose place is q bit for
    bit where one is within two ulps: mapped onto [0, 1], the knots are then
    short binary fractions."""
    out = np.array(k, dtype=float)
    inner = out[1:-1]
    if not unit:
        m, e = np.frexp(inner)
        out[1:-1] = np.ldexp(np.rint(np.ldexp(m, bits + 1)), e - bits - 1)
        return out
    a, span = out[0], out[-1] - out[0]
    q = np.ldexp(np.rint(np.ldexp((inner - a) / span, bits)), -bits)
    x = a + q * span
    best, hit = x.copy(), (x - a) / span == q
    for toward in (np.inf, -np.inf):
        c = x
        for _ in range(2):
            c = np.nextafter(c, toward)
            new = ~hit & ((c - a) / span == q)
            best[new], hit = c[new], hit | new
    out[1:-1] = best
    return out


def _packed_form(k: np.ndarray, unit: bool) -> np.ndarray:
    """A vector as the writer stores it: a curve's mapped onto [0, 1]."""
    return (k - k[0]) / (k[-1] - k[0]) if unit else k


def eligible(k: np.ndarray) -> bool:
    """Whether a vector is worth rounding: inner knots, stored explicitly."""
    return len(k) >= 3 and not evenly_spaced(k)


def vectors(g: Net) -> list[np.ndarray]:
    return [g.uknots, g.vknots] if isinstance(g, BSplineSurface) else [g.knots]


def codable(g: object) -> bool:
    """A row whose knots may be rounded: a clamped B-spline (not periodic,
    not Bezier)."""
    if isinstance(g, BSplineSurface):
        return not g.bezier and clamped_surface(g)
    if isinstance(g, BSplineCurve):
        return not g.bezier and clamped_curve(g)
    return False


def homogeneous(g: Net) -> np.ndarray:
    """A row's poles in homogeneous coordinates (w·P, w) where it is rational
    (eq. 2), its poles as they are where not."""
    if g.weights is None:
        return g.poles
    return np.concatenate([g.poles * g.weights[..., None], g.weights[..., None]], -1)


def _union(a: tuple[np.ndarray, np.ndarray], b: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
    """The expanded knot vector holding the vectors ``a`` and ``b`` (distinct
    values, multiplicities), each value at the larger of its multiplicities."""
    values, mu = np.concatenate([a[0], b[0]]), np.concatenate([a[1], b[1]])
    order = np.argsort(values, kind="stable")
    values, mu = values[order], mu[order]
    uniq, start = np.unique(values, return_index=True)
    return np.repeat(uniq, np.maximum.reduceat(mu, start))


def _merged(k1: np.ndarray, k2: np.ndarray, mults: np.ndarray) -> np.ndarray:
    """The expanded knot vector holding both ``k1`` and ``k2`` (distinct values,
    both with ``mults``), each value at the larger of its multiplicities."""
    return _union((k1, mults), (k2, mults))


def _along(
    k: np.ndarray, k2: np.ndarray, mults: np.ndarray, p: np.ndarray, degree: int
) -> tuple[np.ndarray, np.ndarray]:
    """Poles ``p`` (axis 0) on ``k`` and on ``k2``, both refined to their
    merged vector (:func:`bspline.refine`)."""
    if np.array_equal(k, k2):
        return p, p
    target = _merged(k, k2, mults)
    a = bspline.refine(k, mults, p, degree, target)
    return a, bspline.refine(k2, mults, p, degree, target)


def move(g: Net, new: Net) -> float:
    """Certified largest distance between ``g`` and ``g`` on ``new``'s knots
    (module docstring); inf where ``new``'s knots are not ``g``'s moved."""
    if type(g) is not type(new) or not codable(g):
        return float("inf")
    old_v, new_v = vectors(g), vectors(new)
    if any(
        len(a) != len(b) or np.any(np.diff(b) <= 0) or a[0] != b[0] or a[-1] != b[-1]
        for a, b in zip(old_v, new_v)
    ):
        return float("inf")
    if all(np.array_equal(a, b) for a, b in zip(old_v, new_v)):
        return 0.0
    # a rational row is refined in homogeneous coordinates (w·P, w)
    h = homogeneous(g)
    if isinstance(g, BSplineSurface):
        assert isinstance(new, BSplineSurface)
        a, b = _along(g.uknots, new.uknots, g.umults, h, g.udegree)
        a, _ = _along(g.vknots, new.vknots, g.vmults, np.swapaxes(a, 0, 1), g.vdegree)
        _, b = _along(g.vknots, new.vknots, g.vmults, np.swapaxes(b, 0, 1), g.vdegree)
        terms = g.udegree + g.vdegree + 2
    else:
        assert isinstance(new, BSplineCurve)
        a, b = _along(g.knots, new.knots, g.mults, h, g.degree)
        terms = g.degree + 1
    scale = float(np.abs(g.poles).max(initial=0.0))
    ulps = ROUNDING * terms * scale * float(np.finfo(float).eps)
    if g.weights is None:
        return float(np.sqrt(((a - b) ** 2).sum(-1)).max()) + ulps
    # two rational rows on one knot vector: their poles' distance plus what
    # their weights' ratio adds (weights.weight_bound, on the refined net)
    wa, wb = a[..., 3], b[..., 3]
    qa, qb = a[..., :3] / wa[..., None], b[..., :3] / wb[..., None]
    refined = replace(g, poles=qa, weights=wa)
    d = float(np.sqrt(((qa - qb) ** 2).sum(-1)).max())
    return d + weights.weight_bound(refined, wb) + 2 * ulps


def _on(g: Net, vs: list[np.ndarray]) -> Net:
    """``g`` on the knot vectors ``vs`` (u and v, or the curve's)."""
    if isinstance(g, BSplineSurface):
        return replace(g, uknots=vs[0], vknots=vs[1])
    return replace(g, knots=vs[0])


#: Per knot vector (its bytes) to round: the bits, and whether it is rounded
#: as a place in [0, 1] (:func:`rounded`'s ``unit``: only 3-D curves use it).
Plan = dict[bytes, tuple[int, bool]]


def _unit(g: Net, units: dict[bytes, bool] | None, k: np.ndarray) -> bool:
    return units[k.tobytes()] if units is not None else isinstance(g, BSplineCurve)


def with_bits(g: Net, bits: int, units: dict[bytes, bool] | None = None) -> Net:
    """``g`` with each eligible vector rounded to ``bits``, as a place in
    [0, 1] where ``units`` says so (by default, a curve's)."""
    return _on(g, [rounded(k, bits, _unit(g, units, k)) if eligible(k) else k for k in vectors(g)])


def mapped(lead: np.ndarray, own: np.ndarray, reverse: bool) -> np.ndarray:
    """``lead`` (a knot vector), mirrored if ``reverse`` (as
    ``k[-1] + k[0] - k[::-1]``), mapped affinely onto the ends of ``own``,
    which keeps them bit for bit: the knots of a copy (a twin curve) whose
    leader's knots were rounded."""
    return mapped_knots(lead, float(own[0]), float(own[-1]), reverse)


def _back(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``b`` mapped onto the ends of ``a`` where they differ (:func:`mapped`)."""
    return mapped(b, a, False) if a[0] != b[0] or a[-1] != b[-1] else b


def _within(
    sub: tuple[np.ndarray, np.ndarray], full: tuple[np.ndarray, np.ndarray]
) -> np.ndarray | None:
    """Where the vector ``sub`` (distinct knots, multiplicities) is part of
    ``full``: mapped onto ``full``'s ends (:func:`_back`: the writer maps free
    rows onto [0, 1]), each of its knots within ``ROUNDING`` ulps of ``full``'s
    span of a knot of ``full`` that is there at least as often.  Returns
    those knots of ``full`` (``sub`` as ``full`` has it), or None."""
    (k, m), (fk, fm) = sub, full
    if len(k) > len(fk) or len(k) < 2:
        return None
    kb = _back(fk, k)
    at = np.clip(np.searchsorted(fk, kb), 1, len(fk) - 1)
    near = np.where(np.abs(fk[at - 1] - kb) <= np.abs(fk[at] - kb), at - 1, at)
    eps = ROUNDING * float(np.finfo(float).eps) * abs(fk[-1] - fk[0])
    if np.abs(fk[near] - kb).max() > eps or (fm[near] < m).any() or (np.diff(near) <= 0).any():
        return None
    if near[0] != 0 or near[-1] != len(fk) - 1:
        return None
    return fk[near]


def raised(new: Net, original: Net) -> Net | None:
    """``new``, a row whose knot vectors are parts of ``original``'s with fewer
    poles (:mod:`.removal`), refined onto ``original``'s knots by knot
    insertion (eq. 1; in homogeneous coordinates where rational): the same
    curve or surface, row for row comparable with ``original``.  None where
    ``new`` is not such a row."""
    if type(new) is not type(original) or not codable(new) or not codable(original):
        return None
    if new.poles.shape == original.poles.shape:
        return None
    if isinstance(new, BSplineSurface):
        assert isinstance(original, BSplineSurface)
        pairs = [
            ((new.uknots, new.umults), (original.uknots, original.umults), new.udegree),
            ((new.vknots, new.vmults), (original.vknots, original.vmults), new.vdegree),
        ]
        if new.udegree != original.udegree or new.vdegree != original.vdegree:
            return None
    else:
        assert isinstance(original, BSplineCurve)
        if new.degree != original.degree:
            return None
        pairs = [((new.knots, new.mults), (original.knots, original.mults), new.degree)]
    at = [_within(a, b) for a, b, _ in pairs]
    if any(k is None for k in at):
        return None
    h = homogeneous(new)
    for axis, (k, ((_, m), (fk, fm), degree)) in enumerate(zip(at, pairs)):
        assert k is not None
        target = np.repeat(fk, fm)
        h = np.swapaxes(bspline.refine(k, m, np.swapaxes(h, 0, axis), degree, target), 0, axis)
    if new.weights is None:
        out = replace(new, poles=h)
    else:
        out = replace(new, poles=h[..., :3] / h[..., 3:], weights=h[..., 3])
    if isinstance(out, BSplineSurface):
        assert isinstance(original, BSplineSurface)
        return replace(
            out,
            uknots=original.uknots,
            umults=original.umults,
            vknots=original.vknots,
            vmults=original.vmults,
        )
    assert isinstance(original, BSplineCurve)
    return replace(out, knots=original.knots, mults=original.mults)


#: :func:`moved`'s answers, by a digest of the two rows: the validity stage
#: assembles a candidate a round, and most rows are the last round's
#: (trj7 at 0.01 mm: 21,503 measures for some 2,000 distinct pairs).
_MOVED: Memo[float] = Memo(100_000)


#: Per row class, its name and its fields' names (:func:`_digest`).
_FIELDS: dict[type, tuple[str, tuple[str, ...]]] = {}


def _digest(*rows: Net) -> bytes:
    """A digest of every field of ``rows`` (:func:`memo.digest`)."""
    parts: list[Any] = []
    for g in rows:
        kind = _FIELDS.get(type(g))
        if kind is None:
            kind = _FIELDS[type(g)] = (type(g).__name__, tuple(f.name for f in fields(g)))
        parts.append(kind[0])
        parts.extend(getattr(g, name) for name in kind[1])
    return digest(*parts)


def moved(new: Net, original: Net) -> float:
    """Certified distance between ``new`` and ``original`` (the same row, its
    poles, weights and inner knots moved): :func:`weights.moved` (the poles'
    and weights' move, both rows on ``new``'s knots) plus :func:`term`
    (``original`` on both knot vectors).  A row with knots removed
    (:mod:`.removal`) is first :func:`raised` onto ``original``'s knots,
    with ``ROUNDING`` ulps per term and direction for the insertion; inf for
    a row with other poles that is not such a row.  Answered from
    ``_MOVED`` where the same two rows were measured before."""
    return _MOVED.get(_digest(new, original), lambda: _moved(new, original))


def _moved(new: Net, original: Net) -> float:
    if degrees(new) != degrees(original):
        return lowered(new, original)
    if new.poles.shape == original.poles.shape:
        return weights.moved(new, original) + term(original, new)
    up = raised(new, original)
    if up is None:  # other poles, not on a part of the source's knots
        return bridged(new, original)
    scale = float(np.abs(new.poles).max(initial=0.0))
    ulps = ROUNDING * sum(d + 1 for d in degrees(new)) * scale * float(np.finfo(float).eps)
    return weights.moved(up, original) + ulps * (2 if new.weights is not None else 1)


def clamped(g: Net) -> bool:
    """A non-periodic row (B-spline or Bezier) whose end poles are its ends."""
    return clamped_surface(g) if isinstance(g, BSplineSurface) else clamped_curve(g)


def degrees(g: Net) -> tuple[int, ...]:
    """A row's degrees: (u, v) for a surface, (degree,) for a curve."""
    return (g.udegree, g.vdegree) if isinstance(g, BSplineSurface) else (g.degree,)


def directions(g: Net) -> list[tuple[np.ndarray, np.ndarray, int]]:
    """Per direction (u then v, or the curve's), its knots, multiplicities and degree."""
    if isinstance(g, BSplineSurface):
        return [(g.uknots, g.umults, g.udegree), (g.vknots, g.vmults, g.vdegree)]
    return [(g.knots, g.mults, g.degree)]


def lowered(new: Net, original: Net) -> float:
    """Certified distance between ``new``, a non-rational row of lower
    degree in some direction than ``original`` (:func:`removal.removed`: its
    degree lowered, inner knots then perhaps removed or rounded), and
    ``original``: ``new``'s vectors mapped onto ``original``'s ends
    (:func:`_back`: the same point set), both taken to their Bezier form at
    ``original``'s degrees over every knot of either (knot insertion, eq. 1,
    then ``new`` raised, :func:`bspline.elevation`: the same surface or
    curve) and measured pole by pole, as a row with moved poles is (the
    Bezier basis is non-negative and sums to one), with ``2·ROUNDING`` ulps
    per term and direction.  inf where ``new`` is not such a row: another
    type, rational, a degree higher, periodic."""
    if type(new) is not type(original) or new.weights is not None or original.weights is not None:
        return float("inf")
    if not clamped(new) or not clamped(original):
        return float("inf")
    a, b = new.poles, original.poles
    terms = 0
    for axis, ((kn, mn, q), (ko, mo, p)) in enumerate(zip(directions(new), directions(original))):
        kn = _back(ko, kn)  # a vector mapped onto [0, 1] (pcurves.unit_curves), rounded
        if q > p or np.any(np.diff(kn) <= 0) or (mn[1:-1] > q).any() or (mo[1:-1] > p).any():
            return float("inf")
        breaks = np.union1d(kn, ko)  # both in their Bezier form over every knot of either
        e_new = bspline.elevation(kn, mn, q, p, breaks)
        e_old = bspline.elevation(ko, mo, p, p, breaks)
        a = np.swapaxes(np.tensordot(e_new, np.swapaxes(a, 0, axis), axes=(1, 0)), 0, axis)
        b = np.swapaxes(np.tensordot(e_old, np.swapaxes(b, 0, axis), axes=(1, 0)), 0, axis)
        terms += 2 * (p + 1)
    scale = max(float(np.abs(new.poles).max(initial=0.0)), float(np.abs(original.poles).max()))
    ulps = ROUNDING * terms * scale * float(np.finfo(float).eps)
    return float(np.sqrt(((a - b) ** 2).sum(-1)).max()) + ulps


def bridged(new: Net, original: Net) -> float:
    """Certified distance between two rows of one degree whose knot vectors
    neither holds the other (``new`` with knots removed, then rounded,
    ``nets._removed``): each refined onto the union of the two vectors
    (eq. 1: knot insertion moves no point), ``new``'s first mapped onto
    ``original``'s ends (:func:`_back`: the same point set), and measured
    there as a row with moved poles is (:func:`weights.moved`: the refined
    error net, and the weights' term); ``ROUNDING`` ulps per term and
    direction for each refinement.  inf where they are not such rows."""
    if type(new) is not type(original) or not codable(new) or not codable(original):
        return float("inf")
    if (new.weights is None) != (original.weights is None):
        return float("inf")
    if isinstance(new, BSplineSurface):
        assert isinstance(original, BSplineSurface)
        if (new.udegree, new.vdegree) != (original.udegree, original.vdegree):
            return float("inf")
        pairs = [
            ((new.uknots, new.umults), (original.uknots, original.umults), new.udegree),
            ((new.vknots, new.vmults), (original.vknots, original.vmults), new.vdegree),
        ]
    else:
        assert isinstance(original, BSplineCurve)
        if new.degree != original.degree:
            return float("inf")
        pairs = [((new.knots, new.mults), (original.knots, original.mults), new.degree)]
    a, b = homogeneous(new), homogeneous(original)
    on: list[np.ndarray] = []
    for axis, ((k, m), (fk, fm), degree) in enumerate(pairs):
        k = _back(fk, k)
        if np.any(np.diff(k) <= 0) or m[0] != fm[0] or m[-1] != fm[-1]:
            return float("inf")
        target = _union((k, m), (fk, fm))
        a = np.swapaxes(bspline.refine(k, m, np.swapaxes(a, 0, axis), degree, target), 0, axis)
        b = np.swapaxes(bspline.refine(fk, fm, np.swapaxes(b, 0, axis), degree, target), 0, axis)
        on.append(target)
    rows = []
    for h, g in ((a, new), (b, original)):
        row = g if g.weights is None else replace(g, weights=h[..., 3])
        row = replace(row, poles=h if g.weights is None else h[..., :3] / h[..., 3:])
        vs = [np.unique(t, return_counts=True) for t in on]
        if isinstance(row, BSplineSurface):
            row = replace(row, uknots=vs[0][0], umults=vs[0][1], vknots=vs[1][0], vmults=vs[1][1])
        else:
            row = replace(row, knots=vs[0][0], mults=vs[0][1])
        rows.append(row)
    scale = max(float(np.abs(new.poles).max(initial=0.0)), float(np.abs(original.poles).max()))
    terms = sum(d + 1 for _, _, d in pairs)
    ulps = 2 * ROUNDING * terms * scale * float(np.finfo(float).eps)
    return weights.moved(rows[0], rows[1]) + ulps * (2 if new.weights is not None else 1)


def term(original: Net, new: Net) -> float:
    """What ``new``'s knots add to the bound of a row of ``original`` (poles
    and weights aside).

    A vector whose ends differ from ``original``'s is first mapped back onto
    them (``pcurves.unit_curves`` maps free curves onto [0, 1]: the same
    point set).  0 where the vectors are then ``original``'s within a few
    ulps of their span; else :func:`move` (inf for a row whose knots may not
    move)."""
    pairs = list(zip(vectors(original), vectors(new)))
    if all(a is b or np.array_equal(a, b) for a, b in pairs):
        return 0.0
    if any(len(a) != len(b) for a, b in pairs):
        return float("inf")
    back = [_back(a, b) for a, b in pairs]
    eps = float(np.finfo(float).eps)
    if all(
        np.abs(a - b).max(initial=0.0) <= ROUNDING * eps * abs(a[-1] - a[0])
        for (a, _), b in zip(pairs, back)
    ):
        return 0.0
    return move(original, _on(original, back))


def need(g: Net, limit: float, units: dict[bytes, bool] | None = None) -> int | None:
    """The fewest bits (of ``BITS``) whose rounding (:func:`with_bits`) moves
    ``g`` by at most ``SHARE`` of ``limit``; None where none does or nothing
    is eligible."""
    if not codable(g) or not any(eligible(k) for k in vectors(g)):
        return None
    # the move shrinks with the bits (by about half a bit): bisect BITS
    lo, hi = 0, len(BITS)
    while lo < hi:
        mid = (lo + hi) // 2
        if move(g, with_bits(g, BITS[mid], units)) <= SHARE * limit:
            hi = mid
        else:
            lo = mid + 1
    return BITS[lo] if lo < len(BITS) else None


def plan(
    rows: Iterable[tuple[Geometry, float | None]],
    links: Iterable[tuple[Geometry, Geometry]] = (),
) -> Plan:
    """The vectors to round, and how (:data:`Plan`).

    One precision for all, so that knots the source has equal in different
    vectors (a curve split in two) stay equal: the one of ``BITS`` whose
    vectors, LZMA'd together as the writer stores them, are smallest.  A
    vector is rounded as a place in [0, 1] where only 3-D curves use it, so
    that one a surface has too stays bit for bit the surface's.  The size is
    that of every vector of ``rows``, rounded or not (a rounded vector may
    have matched one that stays).  A vector
    that some row using it needs more bits for (:func:`need`), or that a row
    whose limit is None uses (a row that must keep its knots), stays as it
    is.  Vectors of two rows in ``links`` (a twin curve and its leader,
    which the copy follows) are rounded both or neither.  Empty where
    rounding saves less than ``MIN_SAVING`` bytes.
    """
    nets = [(g, lim) for g, lim in rows if isinstance(g, (BSplineSurface, BSplineCurve))]
    by_key: dict[bytes, np.ndarray] = {}
    units: dict[bytes, bool] = {}
    for g, _ in nets:
        for k in vectors(g):
            key = k.tobytes()
            by_key[key] = k
            units[key] = units.get(key, True) and isinstance(g, BSplineCurve)
    want: dict[bytes, int | None] = {}
    for g, limit in nets:
        b = None if limit is None else need(g, limit, units)
        for k in vectors(g):
            if eligible(k):
                key = k.tobytes()
                prev = want.get(key, 0)
                want[key] = None if b is None or prev is None else max(prev, b)
    _join(want, links)
    if not any(b is not None for b in want.values()):
        return {}
    # every vector, so that a rounded one no longer matching a vector kept as
    # it is (bit for bit, or in part) counts
    exact = _packed(_packed_form(by_key[key], units[key]) for key in by_key)
    best, size = 0, float(exact)
    for bits in BITS:
        moving = {key for key, b in want.items() if b is not None and b <= bits}
        cost = _packed(
            _packed_form(
                rounded(by_key[key], bits, units[key]) if key in moving else by_key[key],
                units[key],
            )
            for key in by_key
        )
        if cost < size:
            best, size = bits, cost
    if not best or exact - size < MIN_SAVING:
        return {}
    return {k: (best, units[k]) for k, b in want.items() if b is not None and b <= best}


def _join(want: dict[bytes, int | None], links: Iterable[tuple[Geometry, Geometry]]) -> None:
    """Give the vectors of linked rows, in place, one answer: the most bits
    any of them needs, None (kept) where one is kept or not in ``want``."""
    parent: dict[bytes, bytes] = {}

    def root(k: bytes) -> bytes:
        while parent.get(k, k) != k:
            k = parent[k]
        return k

    for a, b in links:
        if isinstance(a, (BSplineSurface, BSplineCurve)) and isinstance(b, type(a)):
            for x, y in zip(vectors(a), vectors(b)):
                parent[root(x.tobytes())] = root(y.tobytes())
    groups: dict[bytes, list[bytes]] = {}
    for k in parent:
        groups.setdefault(root(k), []).append(k)
    for r, ks in groups.items():
        ks = [*ks, r] if r not in ks else ks
        bits = [want.get(k) for k in ks]
        one = None if any(b is None for b in bits) else max(bits)  # type: ignore[type-var]
        for k in ks:
            if k in want:
                want[k] = one


def _packed(vs: Iterable[np.ndarray]) -> int:
    raw = b"".join(np.ascontiguousarray(k, "<f8").tobytes() for k in vs)
    return entropy.lzma_size(raw, strong=True)


def apply_reduced(h: Net, source: Net, kplan: Plan) -> tuple[Net, float]:
    """``h`` (``source`` with inner knots removed, ``nets._removed``) with its
    vectors rounded as ``kplan`` rounds ``source``'s, and its certified
    distance from ``source`` (:func:`bridged`); ``h`` and inf where nothing
    is planned or a rounded vector is no longer increasing."""
    if not codable(h):
        return h, float("inf")
    keys = [k.tobytes() for k in vectors(source)]
    if not any(k in kplan for k in keys):
        return h, float("inf")
    vs = [rounded(k, *kplan[key]) if key in kplan else k for k, key in zip(vectors(h), keys)]
    if any(np.any(np.diff(k) <= 0) for k in vs):
        return h, float("inf")
    new = _on(h, vs)
    return new, bridged(new, source)


def apply(g: Net, kplan: Plan, limit: float) -> tuple[Net, float]:
    """``g`` with its vectors rounded as ``kplan`` says, and its move; ``g``
    itself and 0 where nothing is planned or the move is past ``SHARE`` of
    ``limit``."""
    if not codable(g):
        return g, 0.0
    vs = vectors(g)
    if not any(k.tobytes() in kplan for k in vs):
        return g, 0.0
    new = _on(g, [rounded(k, *kplan[k.tobytes()]) if k.tobytes() in kplan else k for k in vs])
    d = move(g, new)
    if d > SHARE * limit:
        return g, 0.0
    return new, d
