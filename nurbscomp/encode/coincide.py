"""Which records coincide: the encoder's choices of what to code once.

Curves that are a surface's boundary bit for bit (:func:`iso_sources`),
curves and net sides that are another's up to ``eps`` (:func:`twin_curves`,
:func:`twin_sides`), vertices and edges that meet (:func:`vertex_clusters`,
:func:`coincident_edges`).  These are heuristics of the encoder: the format
stores what they chose (ISO and COPY codes, SIDE rows), so changing them
changes only what new containers hold, never what old ones decode to.  The
rules both sides run on what they chose are in :mod:`nurbscomp.rules.joins`.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any, NamedTuple, cast

import numpy as np

from .. import bspline
from ..model import (
    EC,
    BRepModel,
    BSplineCurve,
    BSplineSurface,
    Geometry,
    RepKind,
    ShapeType,
    faces_around,
)
from ..nearby import close_pairs, pairs_within
from ..rules.joins import (
    SIDES,
    boundary,
    clamped_curve,
    clamped_surface,
    placed,
    side_knots,
)


class IsoSource(NamedTuple):
    """Where an iso-boundary curve comes from (:func:`iso_sources`): side
    ``side`` of the net of surface row ``surface``, reversed if ``reversed``;
    its poles that side's up to ``distance`` (0: bit for bit)."""

    surface: int
    side: int
    reversed: int
    distance: float = 0.0


class Twin(NamedTuple):
    """A member of a twin pair (:func:`twin_curves`, :func:`twin_sides`): it is
    its ``leader`` (a curve row, or a (surface row, side)), reversed if
    ``reversed``, up to ``distance``."""

    leader: Any
    reversed: int
    distance: float


def iso_sources(
    m: BRepModel, curve_rows: set[int], surface_rows: set[int], eps: float = 0.0
) -> dict[int, IsoSource]:
    """Curves that are a boundary of a surface on the same edge, up to ``eps``.

    Returns ``{curve row: (surface row, side, reversed, distance)}`` for each
    curve row in ``curve_rows`` that an unlocated edge uses over its whole
    range or a part of it, whose degree, knots and weights are those of the
    boundary, and whose poles are those of ``boundary(surface poles, side,
    reversed)``, bit for bit or each within ``eps`` (the largest distance is
    ``distance``: the encoder codes the surface within the curve's limit less
    it, ``encode.nets.code_model``), for the surface (in ``surface_rows``,
    clamped, unlocated face) of a face on that edge.  Such a curve is not
    coded: the decoder copies it from the decoded surface, so the two meet
    exactly (docs/design.md §4, "shared iso-boundaries coded once").  A part
    of the range is what a boolean leaves of a loft's or a sweep's side (the
    face trimmed, its surface not): the copy is the whole side, the edge's
    range picks the part.
    """
    faces_of = faces_around(m, ShapeType.EDGE)
    out: dict[int, IsoSource] = {}
    reps = m.edge_reps
    for q in np.flatnonzero(reps[:, EC.KIND] == RepKind.CURVE3D).tolist():
        c = int(reps[q, EC.CURVE])
        if c not in curve_rows or c in out or reps[q, EC.LOC] != 0:
            continue
        g = m.curves3d[c]
        if not isinstance(g, BSplineCurve) or not clamped_curve(g):
            continue
        first, last = (0.0, 1.0) if g.bezier else (g.knots[0], g.knots[-1])
        lo, hi = m.edge_rep_range[q].tolist()
        if not first <= lo < hi <= last:
            continue
        e = int(reps[q, EC.EDGE])
        for f in faces_of[e]:
            r = int(m.face_surface[f])
            hit = _boundary_match(g, m.surfaces[r], eps) if r in surface_rows else None
            if hit is not None and m.face_loc[f] == 0:
                out[c] = IsoSource(r, *hit)
                break
    return out


def _boundary_match(g: BSplineCurve, s: Geometry, eps: float) -> tuple[int, int, float] | None:
    """(side, reversed, distance) where curve ``g``'s poles are a boundary of
    ``s``'s within ``eps`` (the first bit for bit, else the nearest), its
    degree, knots and weights that boundary's bit for bit; or None."""
    if not clamped_surface(s):
        return None
    assert isinstance(s, BSplineSurface)
    best: tuple[int, int, float] | None = None
    for side in range(SIDES):
        along_u = side >= 2  # columns run along u
        deg = s.udegree if along_u else s.vdegree
        w = s.weights
        wrow = None if w is None else boundary(w[..., None], side, False)[:, 0]
        for rev in (0, 1):
            p = boundary(s.poles, side, bool(rev))
            if p.shape != g.poles.shape:
                continue
            d = (
                0.0
                if np.array_equal(p, g.poles)
                else float(np.sqrt(((p - g.poles) ** 2).sum(-1)).max())
            )
            if d > eps or (best is not None and d >= best[2]):
                continue
            wr = None if wrow is None else (wrow[::-1] if rev else wrow)
            if (wr is None) != (g.weights is None):
                continue
            if wr is not None and not np.array_equal(wr, cast(np.ndarray, g.weights)):
                continue
            if g.bezier != s.bezier or (not g.bezier and g.degree != deg):
                continue
            if not g.bezier:
                kn, mu = side_knots(s, side, bool(rev))
                if not (np.array_equal(kn, g.knots) and np.array_equal(mu, g.mults)):
                    continue
            if d == 0.0:
                return side, rev, d
            best = (side, rev, d)
    return best


# ------------------------------------------------------------ coincident curves and vertices

#: Vertices closer than this (mm; OCCT's Precision::Confusion, the sewing
#: tolerance of the free-edge measure) are one point to the encoder: they
#: move together or stay together (:func:`vertex_clusters`).
TWIN_VERTEX = 1e-7


def vertex_clusters(points: np.ndarray, eps: float) -> np.ndarray:
    """Per point, the first point of its cluster (points linked by distances ≤ eps).

    Separate vertices at one place (the corners of an IGES surface model's
    faces, of a STEP file's unshared edges) must land at one place again, or
    the faces part there.
    """
    n = len(points)
    if n == 0:
        return np.zeros(0, np.int64)
    return first_of_components(n, pairs_within(points, eps))


def first_of_components(n: int, pairs: np.ndarray) -> np.ndarray:
    """Per node of a graph of ``n`` nodes and edges ``pairs`` (k, 2), the
    smallest node of its connected component."""
    first = np.arange(n, dtype=np.int64)
    if not len(pairs):
        return first
    a, b = pairs[:, 0].astype(np.int64), pairs[:, 1].astype(np.int64)
    while True:  # each pass takes every edge's smaller label to both ends
        low = np.minimum(first[a], first[b])
        before = first.copy()
        np.minimum.at(first, a, low)
        np.minimum.at(first, b, low)
        first = first[first]  # and follows labels to their own labels
        if np.array_equal(first, before):
            return first


#: :func:`nearest` compares every pair up to this many (points x queries).
_NEAREST_MAX = 1 << 21


def nearest(points: np.ndarray, queries: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per row of ``queries``, the distance to the nearest row of ``points`` and
    its index, as a k-d tree's ``query`` gives them.  Up to
    :data:`_NEAREST_MAX` pairs by brute force, in blocks (no import of
    scipy.spatial; of equal distances, the first point); beyond, by scipy's
    k-d tree (a model of thousands of faces, where its import is cheap)."""
    p = np.asarray(points, np.float64)
    q = np.asarray(queries, np.float64)
    if len(p) * len(q) > _NEAREST_MAX:
        from scipy.spatial import cKDTree

        d, i = cKDTree(p).query(q)
        return np.asarray(d, np.float64), np.asarray(i, np.int64)
    dist, idx = np.empty(len(q)), np.empty(len(q), np.int64)
    step = max(1, (1 << 20) // max(1, len(p)))
    for i in range(0, len(q), step):
        d2 = ((q[i : i + step, None, :] - p[None, :, :]) ** 2).sum(-1)
        k = d2.argmin(axis=1)
        idx[i : i + step] = k
        dist[i : i + step] = np.sqrt(d2[np.arange(len(k)), k])
    return dist, idx


#: Curves whose poles agree within this (mm) are one boundary, coded once
#: (:func:`twin_curves`); capped at tol/64 so the copy costs little of tol.
TWIN_EPS = 1e-6
#: The farthest (mm) an edge curve's poles may be from its surface's side
#: for the curve to be copied from the decoded side (:func:`iso_sources`).
ISO_EPS = 1e-9


@dataclass(frozen=True)
class _Run:
    """A row of poles with what makes it a curve: a B-spline curve, or one side of a net."""

    poles: np.ndarray  # (n, 3)
    weights: np.ndarray | None  # (n,)
    knots: np.ndarray  # flat knot vector mapped onto [0, 1]
    degree: int


def _flat_unit(knots: np.ndarray, mults: np.ndarray) -> np.ndarray:
    """A flat knot vector mapped onto [0, 1]."""
    k = np.repeat(np.asarray(knots, float), np.asarray(mults, int))
    span = k[-1] - k[0]
    return (k - k[0]) / span if span > 0 else k * 0.0


def _curve_run(g: BSplineCurve) -> _Run:
    n = len(g.poles)
    ends = (np.array([0.0, 1.0]), np.array([n, n])) if g.bezier else (g.knots, g.mults)
    return _Run(g.poles, g.weights, _flat_unit(*ends), g.degree)


def _side_run(g: BSplineSurface, side: int) -> _Run:
    """Side ``side`` of a clamped net (``SIDES``) as a curve of its own."""
    nu, nv = g.poles.shape[:2]
    if side < 2:  # a row: along v
        n, knots, mults, degree = nv, g.vknots, g.vmults, g.vdegree
    else:
        n, knots, mults, degree = nu, g.uknots, g.umults, g.udegree
    if g.bezier:
        knots, mults, degree = np.array([0.0, 1.0]), np.array([n, n]), n - 1
    w = None if g.weights is None else boundary(g.weights[..., None], side, False)[:, 0]
    return _Run(boundary(g.poles, side, False), w, _flat_unit(knots, mults), degree)


def _twins(a: _Run, b: _Run, eps: float) -> tuple[int, float] | None:
    """(reversed, distance) when ``b`` is ``a``'s point set up to ``eps``: same
    degree, pole count and weights, knots equal (or mirrored) up to an affine
    map, poles within ``eps`` in the same (or reversed) order; else None."""
    if a.degree != b.degree or a.poles.shape != b.poles.shape or len(a.knots) != len(b.knots):
        return None
    if (a.weights is None) != (b.weights is None):
        return None
    for rev in (0, 1):
        pb = b.poles[::-1] if rev else b.poles
        kb = (1.0 - b.knots[::-1]) if rev else b.knots
        # knots as far apart as a text file's digits leave them (IGES writes
        # ~1e-10): then the two curves are compared point by point
        gap = np.abs(kb - a.knots).max(initial=0.0)
        if gap > 1e-8:
            continue
        if b.weights is not None and not np.array_equal(
            b.weights[::-1] if rev else b.weights, cast(np.ndarray, a.weights)
        ):
            continue
        d = float(np.sqrt(((pb - a.poles) ** 2).sum(-1)).max())
        if d <= eps and (gap == 0 or _apart(a, replace(b, poles=pb, knots=kb)) <= eps):
            return rev, d
    return None


def _apart(a: _Run, b: _Run) -> float:
    """Largest distance between two runs of the same size and weights at points
    spread over [0, 1] (rational ones evaluated in homogeneous form)."""
    t = np.linspace(0.0, 1.0, 4 * len(a.poles) + 8)

    def points(r: _Run) -> np.ndarray:
        c = r.poles if r.weights is None else np.c_[r.poles * r.weights[:, None], r.weights]
        return bspline.points(r.knots, c, r.degree, t)

    pa, pb = points(a), points(b)
    if a.weights is not None:
        pa, pb = pa[:, :3] / pa[:, 3:], pb[:, :3] / pb[:, 3:]
    d = np.sqrt(((pa - pb) ** 2).sum(-1))
    return float(np.nanmax(d)) if np.isfinite(d).any() else np.inf


def _pair_up(
    runs: list[tuple[Any, _Run]],
    eps: float,
    leaders_only: set[Any] = frozenset(),  # type: ignore[assignment]
) -> dict[Any, Twin]:
    """``{member key: Twin(leader key, reversed, distance)}`` over ``runs`` (in key
    order): each run that is an earlier run up to ``eps`` (:func:`_twins`),
    the earlier being the first of its kind and no member itself.  Keys in
    ``leaders_only`` are never members."""
    if len(runs) < 2:
        return {}
    ends = np.array([np.concatenate([r.poles[0], r.poles[-1]]) for _, r in runs])
    # candidates: runs whose ends (or swapped ends) are within 2 eps, a superset
    # of the twins (ends within eps each: sqrt(2) eps), which _twins sorts out
    nearby = _near_ends(ends, 2 * eps)
    out: dict[Any, Twin] = {}
    for i, (key, a) in enumerate(runs):
        if key in out:
            continue
        for j in nearby[i]:
            other, b = runs[j]
            if j <= i or other in out or other in leaders_only:
                continue
            hit = _twins(a, b, eps)
            if hit is not None:
                out[other] = Twin(key, *hit)
    return out


def _near_ends(ends: np.ndarray, r: float) -> list[list[int]]:
    """Per row of ``ends`` (a curve's two end points, shape (n, 6)), the rows
    within ``r`` of it or of it with its ends swapped, in order (itself among
    them): all that a k-d tree's two ball queries find, perhaps more."""
    n = len(ends)
    both = np.concatenate([ends, np.concatenate([ends[:, 3:], ends[:, :3]], 1)])
    pairs = close_pairs(both, r)
    if pairs is None:
        from scipy.spatial import cKDTree

        tree = cKDTree(ends)
        return [
            sorted(set(tree.query_ball_point(e, r)) | set(tree.query_ball_point(both[n + i], r)))
            for i, e in enumerate(ends)
        ]
    # a pair of swapped rows is the pair of the rows; a row and a swapped row
    # are within r when the row and the other swapped are
    out: list[set[int]] = [{i} for i in range(n)]
    for a, b in (pairs % n).tolist():
        out[a].add(b)
        out[b].add(a)
    return [sorted(x) for x in out]


def coincident_edges(points: np.ndarray, eps: float) -> list[tuple[int, int]]:
    """Pairs (i, j), i < j, of rows of ``points`` (edges sampled along their
    ranges, :func:`occ.edge_points`, shape (E, n, 3)) that run through the same
    points within ``eps``, in the same or the opposite direction."""
    ok = np.isfinite(points).all(axis=(1, 2))
    rows = np.flatnonzero(ok)
    if len(rows) < 2:
        return []
    mid = points[rows, points.shape[1] // 2]
    # candidates: middles within 2 eps (a pair within eps everywhere, either
    # way round, has them within sqrt(3) eps when the middle sample is one
    # point of both directions: an odd number of samples)
    near = close_pairs(mid, 2 * eps) if points.shape[1] % 2 else None
    if near is None:
        from scipy.spatial import cKDTree

        candidates = sorted(cKDTree(mid).query_pairs(2 * eps))
    else:
        candidates = [(a, b) for a, b in near.tolist()]
    out = []
    for a, b in candidates:
        i, j = int(rows[a]), int(rows[b])
        pi, pj = points[i], points[j]
        if np.abs(pi - pj).max() <= eps or np.abs(pi - pj[::-1]).max() <= eps:
            out.append((i, j))
    return out


def twin_curves(
    curves: list[Geometry],
    rows: set[int],
    eps: float,
    iso: set[int] = frozenset(),  # type: ignore[assignment]
    where: dict[int, np.ndarray] | None = None,
) -> dict[int, Twin]:
    """Rows of ``rows`` whose B-spline curve is another row's up to ``eps``, in
    the model's frame.

    Returns ``{member row: Twin(leader row, reversed, distance)}``.  Faces of an
    IGES surface model (and of many STEP files) meet along separate edges
    whose curves coincide, often with their poles reversed, and each face may
    have a frame of its own: coded independently, they would part by up to
    tol, opening the gap the paper's shared boundaries prevent.  A member is
    decoded as a copy of its leader's final poles (``Method.COPY``), moved by
    the two placements (:func:`copy_matrix`).  Rows in ``iso`` (copies of a
    surface's boundary, :func:`iso_sources`) lead first and are never members.
    ``where`` is :func:`curve_placements`; rows without one are left out
    (with ``where`` None, every curve is where its poles are).
    """
    order = sorted(rows, key=lambda r: (r not in iso, r))
    runs = []
    for r in order:
        g = curves[r]
        if not isinstance(g, BSplineCurve) or g.periodic or g.poles.shape[1] != 3:
            continue
        if where is not None and r not in where:
            continue
        run = _curve_run(g)
        if where is not None:
            run = replace(run, poles=placed(run.poles, where[r]))
        runs.append((r, run))
    return _pair_up(runs, eps, iso)


def twin_sides(
    surfaces: list[Geometry], rows: list[int], eps: float
) -> dict[tuple[int, int], Twin]:
    """Sides of clamped nets in ``rows`` that are an earlier side up to ``eps``.

    Returns ``{(member row, side): Twin((leader row, side), reversed, distance)}``.
    Untrimmed patches of a surface model meet along their natural boundaries;
    each side is then set to its leader's decoded side (the SIDE section), so
    neighbouring nets, and the iso-boundary curves copied from them, meet
    exactly.  A degenerate side (all poles at one point) is left alone.
    """
    runs = []
    for r in sorted(rows):
        g = surfaces[r]
        if not clamped_surface(g):
            continue
        assert isinstance(g, BSplineSurface)
        for side in range(SIDES):
            run = _side_run(g, side)
            if np.ptp(run.poles, axis=0).max() > eps:
                runs.append(((r, side), run))
    return _pair_up(runs, eps)
