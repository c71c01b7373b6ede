"""Pairs of points within a distance of each other, without scipy where it can.

A sweep in numpy along the best axis finds them for the point sets CAD files
hold; where the points pile up, a k-d tree does.  Used by the encoder
(``encode.coincide``: twin vertices, coincident edges) and by the writer of
format 2.5's kind-2 vertices (``serialize.vertices``).
"""

from __future__ import annotations

import numpy as np

#: Relative slack of :func:`close_pairs` over the distance asked: far above
#: the few ulps by which two ways of summing squared differences can differ.
_SLACK = 1e-9
#: :func:`close_pairs` sweeps piled-up points too while it has at most this
#: many pairs to look at, and no row more than :data:`_SWEEP_RUN` of them.
_SWEEP_MAX = 1 << 22
_SWEEP_RUN = 1024


def close_pairs(points: np.ndarray, r: float, budget: int = 64) -> np.ndarray | None:
    """Pairs (i, j), i < j, sorted, of rows of ``points`` (shape (n, d)) that
    are within ``r`` of each other: every pair within ``r`` as scipy's
    ``cKDTree.query_pairs(r)`` finds it, and perhaps pairs a hair beyond
    (``_SLACK``); shape (k, 2).  None when the points pile up (more than
    ``budget`` per point within ``r`` along every axis, and more than
    :data:`_SWEEP_MAX` in all or :data:`_SWEEP_RUN` for one point: the
    sweep's numpy passes grow with those) or are not finite: then ask a k-d
    tree.  (bearing.iges at 0.01 mm: 925 vertices, 100 a point.)

    A sweep in numpy along the axis with the fewest pairs within ``r``: no
    import of scipy.spatial (0.1 to 0.3 s, most of a small file's compress).
    """
    n = len(points)
    if n < 2:
        return np.zeros((0, 2), np.int64)
    pts = np.asarray(points, np.float64).reshape(n, -1)
    if not np.isfinite(pts).all():
        return None  # as the tree takes them (or refuses them)
    lim = r * (1 + _SLACK)
    lim2 = lim * lim
    # (pairs to look at, the most for one row, axis, order)
    best: tuple[int, int, int, np.ndarray] | None = None
    for axis in range(pts.shape[1]):
        order = np.argsort(pts[:, axis], kind="stable")
        xs = pts[order, axis]
        ahead = np.searchsorted(xs, xs + lim, side="right") - np.arange(n) - 1
        work = int(ahead.sum())
        if best is None or work < best[0]:
            best = (work, int(ahead.max()), axis, order)
    assert best is not None
    work, run, axis, order = best
    if work > budget * n and (work > _SWEEP_MAX or run > _SWEEP_RUN):
        return None
    p = pts[order]
    xs = p[:, axis]
    found = []
    live = np.arange(n)
    k = 1
    while True:  # row i and row i + k of the sorted rows; a row out of reach stays out
        live = live[live + k < n]
        live = live[xs[live + k] - xs[live] <= lim]
        if not len(live):
            break
        d2 = ((p[live + k] - p[live]) ** 2).sum(-1)
        near = live[d2 <= lim2]
        found.append(np.stack([order[near], order[near + k]], 1))
        k += 1
    if not found:
        return np.zeros((0, 2), np.int64)
    pairs = np.sort(np.concatenate(found), axis=1).astype(np.int64)
    return pairs[np.lexsort((pairs[:, 1], pairs[:, 0]))]


def pairs_within(points: np.ndarray, r: float) -> np.ndarray:
    """Pairs (i, j), i < j, sorted, of rows of ``points`` within ``r`` of each
    other: :func:`close_pairs` cut to ``r`` (:func:`within`), or a k-d tree's
    where the points pile up."""
    near = close_pairs(points, r)
    if near is not None:
        return within(points, near, r)
    from scipy.spatial import cKDTree

    near = cKDTree(points).query_pairs(r, output_type="ndarray")
    return near[np.lexsort((near[:, 1], near[:, 0]))] if len(near) else near.reshape(0, 2)


def within(points: np.ndarray, pairs: np.ndarray, r: float) -> np.ndarray:
    """The rows of ``pairs`` (of :func:`close_pairs`) whose points are within ``r``."""
    p = np.asarray(points, np.float64).reshape(len(points), -1)
    d2 = ((p[pairs[:, 0]] - p[pairs[:, 1]]) ** 2).sum(-1)
    return pairs[d2 <= r * r]
