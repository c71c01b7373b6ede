"""How far an offset surface moves when its basis is coded (issue 28 §1).

An offset surface is O = S + d·N, with N = n / |n| and n = S_u × S_v
(OCCT's ``Geom_OffsetSurface``).  Its basis S, a non-rational B-spline coded
as S' = S + E (E the B-spline on S's knots whose poles are the pole errors
e_ij, eq. 1), moves it by

    |O' − O| ≤ |E| + |d|·|N' − N| ≤ |E| + 2|d|·|n' − n| / |n|

(two unit vectors: |a/|a| − b/|b|| ≤ 2|a − b| / |b|), where

    n' − n = E_u × S'_v + S_u × E_v,    |S'_v| ≤ |S_v| + |E_v|.

Each factor but the last is bounded by a control net, by the convex hull of
a B-spline (eq. 1): |E| ≤ b = max |e_ij|; E_u is the B-spline of degree p − 1
whose poles are p (e_(i+1)j − e_ij) / (u_(i+p+1) − u_(i+1)), so |E_u| ≤ c_u·b
with c_u = max 2p / (u_(i+p+1) − u_(i+1)); S_u's own poles of that form bound
|S_u| by s_u.  Only |n| needs a bound from below over the domain: |n| is
sampled on a grid of ``PER_SPAN`` points per knot span, less the most it can
change between a point and its nearest sample (|n_u| ≤ |S_uu||S_v| +
|S_u||S_uv|, |n_v| likewise, each factor the largest of the derivative's
poles acting on that span: a control net's bound again).  So,
for every b,

    |O' − O| ≤ gain(b)·b,   gain(b) = 1 + 2|d| (c_u s_v + s_u c_v + c_u c_v b) / n_min,

a certified bound like the nets' own (docs/design.md §4).  ``nets.code_model``
codes an offset's basis within tol / gain(tol) (:func:`limit`), and the
face's bound is :func:`moved` of the decoded basis.  Nothing here imports OCP.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np

from .. import bspline
from ..memo import Memo, digest
from ..model import (
    EC,
    Analytic,
    BRepModel,
    BSplineCurve,
    BSplineSurface,
    Derived,
    Geometry,
    Kind,
    RepKind,
)

#: Samples per knot span (each direction) where |S_u × S_v| is taken, tried
#: in turn until the bound from below is positive.
PER_SPAN = (8, 32)
#: A box of parameters (u0, u1, v0, v1).
Box = tuple[float, float, float, float]
#: An offset's basis is coded only where the gain at tol is at most this
#: (a far larger one is a basis nearly degenerate somewhere: exact).
MAX_GAIN = 1024.0


@dataclass(frozen=True)
class Terms:
    """The control-net bounds of a basis: c_u, c_v (|E_u| ≤ c_u·b), s_u, s_v
    (|S_u| ≤ s_u), and n_min ≤ |S_u × S_v| over the domain."""

    cu: float
    cv: float
    su: float
    sv: float
    n_min: float

    def gain(self, d: float, b: float) -> float:
        """gain(b) of the module docstring, for an offset by ``d``."""
        top = self.cu * self.sv + self.su * self.cv + self.cu * self.cv * b
        return 1.0 + 2.0 * abs(d) * top / self.n_min


def _hodograph(p: np.ndarray, t: np.ndarray, degree: int, axis: int) -> tuple[np.ndarray, float]:
    """The derivative's poles along ``axis`` of poles ``p`` on the expanded
    knots ``t`` (degree ``degree``), and max 2·degree / span over its terms
    (0 for a zero span: that basis function vanishes)."""
    q = np.moveaxis(p, axis, 0)
    n = q.shape[0]
    span = t[degree + 1 : degree + n] - t[1:n]
    scale = np.divide(degree, span, out=np.zeros_like(span), where=span > 0)
    d = (q[1:] - q[:-1]) * scale.reshape(-1, *([1] * (q.ndim - 1)))
    return np.moveaxis(d, 0, axis), 2.0 * float(scale.max(initial=0.0))


def _norm_max(p: np.ndarray) -> float:
    return float(np.sqrt((p * p).sum(-1)).max(initial=0.0)) if p.size else 0.0


def _bezier(p: np.ndarray, t: np.ndarray, degree: int, axis: int, breaks: np.ndarray):
    """The poles along ``axis`` of the same B-spline (expanded knots ``t``)
    cut into Bezier pieces at ``breaks`` (every inner knot among them):
    piece c's poles are c·degree … c·degree + degree; None where a knot of
    ``t`` is repeated past ``degree`` inside (a break in the curve)."""
    inner = breaks[1:-1]
    if len(inner) and np.unique(t[(t > breaks[0]) & (t < breaks[-1])], return_counts=True)[1].max(
        initial=0
    ) > max(degree, 1):
        return None
    target = np.concatenate(
        [
            np.full(degree + 1, breaks[0]),
            np.repeat(inner, max(degree, 1)),
            np.full(degree + 1, breaks[-1]),
        ]
    )
    if degree == 0:  # one pole per piece: the pieces' values at their middles
        target = np.concatenate([[breaks[0]], inner, [breaks[-1]]])
    first, w = bspline.refinement(t, target, degree)
    q = np.moveaxis(p, axis, 0)
    rows = q[first[:, None] + np.arange(w.shape[1])[None, :]]
    out = np.einsum("jk,jk...->j...", w, rows)
    return np.moveaxis(out, 0, axis)


def _product_weights(m: int, n: int) -> np.ndarray:
    """W[l, i, k] = C(m, i) C(n, k) / C(m + n, l) where i + k = l, else 0:
    the Bernstein coefficients of a product of two polynomials of degrees m
    and n are Σ W[l, i, k] a_i b_k."""
    w = np.zeros((m + n + 1, m + 1, n + 1))
    for i in range(m + 1):
        for k in range(n + 1):
            w[i + k, i, k] = math.comb(m, i) * math.comb(n, k) / math.comb(m + n, i + k)
    return w


def _pieces(q: np.ndarray, du: int, dv: int, nu: int, nv: int) -> np.ndarray:
    """Bezier poles (du+1, dv+1) of each of nu × nv pieces: (nu, nv, du+1, dv+1, 3)."""
    iu = np.arange(nu)[:, None] * du + np.arange(du + 1)[None, :]
    iv = np.arange(nv)[:, None] * dv + np.arange(dv + 1)[None, :]
    return q[iu[:, None, :, None], iv[None, :, None, :]]


def _n_min(
    p: np.ndarray, tu: np.ndarray, tv: np.ndarray, pu: int, pv: int, per: int, box: Box
) -> float:
    """A bound from below of |n| = |S_u × S_v| over the cells of the domain
    that meet ``box`` (u0, u1, v0, v1).  Each knot
    span is cut into ``per`` equal parts, and S_u and S_v written as Bezier
    patches on the cells (knot insertion, eq. 1); n is then a polynomial
    patch of degrees (2 pu − 1, 2 pv − 1) on each cell whose Bernstein
    coefficients are sums of cross products of theirs.  For a unit ν (n at the
    cell's middle, as the coefficients' mean), n·ν ≥ the smallest c·ν of its
    coefficients c (the convex hull), and |n| ≥ n·ν.  The smallest over the
    cells, less a rounding slack; negative where some cell's is not positive."""
    su_p, _ = _hodograph(p, tu, pu, 0)
    sv_p, _ = _hodograph(p, tv, pv, 1)
    tu1, tv1 = tu[1:-1], tv[1:-1]

    def breaks(t: np.ndarray, degree: int, n: int) -> np.ndarray:
        ends = np.unique(t[degree : n + 1])
        cuts = [np.linspace(a, b, per + 1)[:-1] for a, b in zip(ends[:-1], ends[1:])]
        return np.concatenate([*cuts, ends[-1:]])

    bu, bv = breaks(tu, pu, p.shape[0]), breaks(tv, pv, p.shape[1])
    a = _bezier(su_p, tu1, pu - 1, 0, bu)
    a = None if a is None else _bezier(a, tv, pv, 1, bv)
    b = _bezier(sv_p, tu, pu, 0, bu)
    b = None if b is None else _bezier(b, tv1, pv - 1, 1, bv)
    if a is None or b is None:
        return -1.0
    nu, nv = len(bu) - 1, len(bv) - 1
    da, db = (
        _pieces(a, max(pu - 1, 1) if pu > 1 else 0, pv, nu, nv),
        _pieces(b, pu, max(pv - 1, 1) if pv > 1 else 0, nu, nv),
    )
    iu = np.flatnonzero((bu[1:] >= box[0]) & (bu[:-1] <= box[1]))
    iv = np.flatnonzero((bv[1:] >= box[2]) & (bv[:-1] <= box[3]))
    if not len(iu) or not len(iv):
        return -1.0
    da, db = da[iu][:, iv], db[iu][:, iv]
    x = np.cross(da[:, :, :, :, None, None, :], db[:, :, None, None, :, :, :])
    wu, wv = _product_weights(pu - 1, pu), _product_weights(pv, pv - 1)
    c = np.einsum("pqijklx,aik,bjl->pqabx", x, wu, wv)
    mean = c.mean(axis=(2, 3))
    length = np.sqrt((mean * mean).sum(-1))
    if not (length > 0).all() or not np.isfinite(c).all():
        return -1.0
    nu_ = mean / length[..., None]
    low = np.einsum("pqabx,pqx->pqab", c, nu_).min(axis=(2, 3))
    slack = 1e-9 * float(np.sqrt((c * c).sum(-1)).max())
    return float(low.min()) - slack


def _insert(
    t: np.ndarray, q: np.ndarray, p: int, x: float, side: Literal["left", "right"]
) -> tuple[np.ndarray, np.ndarray]:
    """Knot ``x`` inserted once into the B-spline of flat knots ``t`` and poles
    ``q`` (along axis 0), of degree ``p`` (Boehm; eq. 1): its span is the one
    ``x`` opens (``side`` "right") or closes ("left")."""
    k = int(np.searchsorted(t, x, side=side)) - 1
    i = np.arange(k - p + 1, k + 1)
    alpha = ((x - t[i]) / (t[i + p] - t[i])).reshape(-1, *([1] * (q.ndim - 1)))
    mid = (1 - alpha) * q[i - 1] + alpha * q[i]
    return np.concatenate([t[: k + 1], [x], t[k + 1 :]]), np.concatenate(
        [q[: k - p + 1], mid, q[k:]]
    )


def _direction(
    p: np.ndarray, knots: np.ndarray, mults: np.ndarray, degree: int, periodic: bool, axis: int
) -> tuple[np.ndarray, np.ndarray] | None:
    """Poles and flat knots of the same surface, clamped along ``axis`` over
    [knots[0], knots[-1]]: as they are where it is clamped already; a
    periodic direction written out over one period (OCCT's flat sequence
    starts degree + 1 − mults[0] knots before the first, and the first
    degree poles come again after the last) and its ends inserted to
    multiplicity degree (each new pole a convex combination of two).  None
    for an unclamped, non-periodic direction."""
    if not periodic:
        if mults[0] != degree + 1 or mults[-1] != degree + 1:
            return None
        return p, np.repeat(knots, mults).astype(float)
    q = np.moveaxis(p, axis, 0)
    n, period = q.shape[0], float(knots[-1] - knots[0])
    inner = np.repeat(knots[:-1], mults[:-1]).astype(float)
    lead = degree + 1 - int(mults[0])
    if len(inner) != n or not 0 <= lead <= degree:
        return None
    t = np.concatenate([inner[n - lead :] - period, inner, inner[: 2 * degree + 1 - lead] + period])
    qe = np.concatenate([q, q[:degree]])
    a, b = float(knots[0]), float(knots[-1])
    while (t == a).sum() < degree:
        t, qe = _insert(t, qe, degree, a, "right")
    while (t == b).sum() < degree:
        t, qe = _insert(t, qe, degree, b, "left")
    s, e = int(np.flatnonzero(t == a)[0]), int(np.flatnonzero(t == b)[0])
    flat = np.concatenate([[a], t[s : e + degree], [b]])
    return np.moveaxis(qe[s - 1 : e], 0, axis), flat


def _terms(g: BSplineSurface, box: Box) -> Terms | None:
    if g.weights is not None or min(g.udegree, g.vdegree) < 1:
        return None
    pu, pv = g.udegree, g.vdegree
    along_u = _direction(np.asarray(g.poles, float), g.uknots, g.umults, pu, g.uperiodic, 0)
    along_v = (
        None if along_u is None else _direction(along_u[0], g.vknots, g.vmults, pv, g.vperiodic, 1)
    )
    if along_u is None or along_v is None:
        return None
    p, tu, tv = along_v[0], along_u[1], along_v[1]
    # a periodic direction's pcurves may lie a period off: all of it counts
    box = (
        *((-math.inf, math.inf) if g.uperiodic else box[:2]),
        *((-math.inf, math.inf) if g.vperiodic else box[2:]),
    )
    su_p, cu = _hodograph(p, tu, pu, 0)
    sv_p, cv = _hodograph(p, tv, pv, 1)
    n_min = -1.0
    for per in PER_SPAN:
        n_min = _n_min(p, tu, tv, pu, pv, per, box)
        if n_min > 0:
            break
    if not (n_min > 0 and math.isfinite(n_min) and math.isfinite(cu) and math.isfinite(cv)):
        return None
    return Terms(cu, cv, _norm_max(su_p), _norm_max(sv_p), n_min)


#: :func:`terms` by a digest of the row (the rounds ask again).
_TERMS: Memo[Terms | None] = Memo(1_000)


def terms(g: BSplineSurface, box: Box) -> Terms | None:
    """The bounds of the module docstring for basis ``g`` over ``box`` (its
    faces' parameters, :func:`face_box`); None where there are none: a
    rational, periodic or unclamped row, a degree 0, or a surface whose
    |S_u × S_v| has no positive bound from below there."""
    key = digest(g.poles, g.uknots, g.vknots, g.umults, g.vmults, g.udegree, g.vdegree, box)
    return _TERMS.get(key, lambda: _terms(g, box))


def offsets_by_basis(surfaces: list[Geometry]) -> dict[int, float]:
    """Per surface row that is the direct basis of an offset surface, the
    largest |d| of its offsets."""
    out: dict[int, float] = {}
    for s in surfaces:
        if isinstance(s, Derived) and s.kind == Kind.OFFSET_SURFACE:
            out[s.basis] = max(out.get(s.basis, 0.0), abs(float(s.params[0])))
    return out


def limit(g: BSplineSurface, d: float, tol: float, box: Box) -> float | None:
    """The pole bound within which basis ``g`` of an offset by ``d`` is coded
    so that the offset moves by at most tol over ``box``: tol / gain(tol);
    None where the gain is not bounded or past ``MAX_GAIN``."""
    t = terms(g, box)
    if t is None:
        return None
    k = t.gain(d, tol)
    return tol / k if k <= MAX_GAIN else None


def moved(source: Geometry, decoded: Geometry, d: float, box: Box) -> float:
    """Certified bound of how far the offset by ``d`` of ``source`` moves over
    ``box`` when its basis is ``decoded``: gain(b)·b, b the largest pole
    move; inf where the two rows are not the same but for their poles, or no
    bound holds."""
    if not (isinstance(source, BSplineSurface) and isinstance(decoded, BSplineSurface)):
        return math.inf
    same = (
        decoded.weights is None
        and (source.udegree, source.vdegree) == (decoded.udegree, decoded.vdegree)
        and source.poles.shape == decoded.poles.shape
        and all(
            np.array_equal(a, b)
            for a, b in (
                (source.uknots, decoded.uknots),
                (source.vknots, decoded.vknots),
                (source.umults, decoded.umults),
                (source.vmults, decoded.vmults),
            )
        )
    )
    if not same:
        return math.inf
    b = float(np.sqrt(((decoded.poles - source.poles) ** 2).sum(-1)).max(initial=0.0))
    if b == 0:
        return 0.0
    t = terms(source, box)
    return math.inf if t is None else t.gain(d, b) * b


def _curve_box(table: list[Geometry], c: int, first: float, last: float) -> Box | None:
    """A box holding 2-D curve ``c`` over [first, last]: a B-spline's poles
    (the convex hull), a line's ends, a circle's or an ellipse's whole; None
    for any other curve."""
    g = table[c]
    if isinstance(g, Derived):  # a trimmed curve's parameters are its basis's
        return _curve_box(table, g.basis, first, last) if g.kind == Kind.TRIMMED_CURVE else None
    if isinstance(g, BSplineCurve):
        lo, hi = g.poles.min(axis=0), g.poles.max(axis=0)
        return float(lo[0]), float(hi[0]), float(lo[1]), float(hi[1])
    if isinstance(g, Analytic) and g.kind == Kind.LINE:
        ends = g.frame[0][None, :] + np.array([[first], [last]]) * g.frame[1][None, :]
        lo, hi = ends.min(axis=0), ends.max(axis=0)
        return float(lo[0]), float(hi[0]), float(lo[1]), float(hi[1])
    if isinstance(g, Analytic) and g.kind in (Kind.CIRCLE, Kind.ELLIPSE):
        r = float(g.params.max())
        x, y = g.frame[0][:2]
        return float(x - r), float(x + r), float(y - r), float(y + r)
    return None


def face_box(m: BRepModel, basis: int) -> Box:
    """The parameters the faces on offsets of surface row ``basis`` reach: the
    box of their pcurves (a face's region lies inside its boundary's box),
    the whole plane where a pcurve has no box (:func:`_curve_box`)."""
    rows = {
        r
        for r, g in enumerate(m.surfaces)
        if isinstance(g, Derived) and g.kind == Kind.OFFSET_SURFACE and g.basis == basis
    }
    reps = m.edge_reps
    kind = reps[:, EC.KIND]
    on = ((kind == RepKind.ON_SURFACE) | (kind == RepKind.ON_CLOSED_SURFACE)) & np.isin(
        reps[:, EC.SURFACE], list(rows)
    )
    whole = (-math.inf, math.inf, -math.inf, math.inf)
    boxes = []
    for q in np.flatnonzero(on).tolist():
        first, last = m.edge_rep_range[q].tolist()
        cols = (EC.CURVE, EC.CURVE2) if kind[q] == RepKind.ON_CLOSED_SURFACE else (EC.CURVE,)
        for col in cols:
            c = int(reps[q, col])
            b = _curve_box(m.curves2d, c, first, last) if c >= 0 else None
            if b is None:
                return whole
            boxes.append(b)
    if not boxes:
        return whole
    a = np.array(boxes)
    return float(a[:, 0].min()), float(a[:, 1].max()), float(a[:, 2].min()), float(a[:, 3].max())
