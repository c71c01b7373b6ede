"""`VERT` (§2.6): vertex points (exact, or on the vertex grid predicted from
their neighbours), tolerances on a quarter-power scale, point representations."""

from __future__ import annotations

import numpy as np

from .. import container, entropy
from ..errors import SectionError
from ..model import (
    VC,
    BRepModel,
    ShapeType,
)
from ..nearby import pairs_within
from ..streams import BlockReader, BlockWriter
from .limits import MAX_COORD, _counts, _tolerances, finite

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


#: Per vertex row, its quads (format 2.6): (x, y, z) rows, x and z its
#: neighbours on a four-edge wire, y the opposite corner.
Quads = dict[int, list[tuple[int, int, int]]]


def vertex_quads(m: BRepModel) -> Quads:
    """Format 2.6: the quads of docs/format.md §2.6 ("Quad faces"): for each
    wire of exactly four edges, each with two distinct vertices, in which
    consecutive edges (cyclically) share exactly one vertex and the four
    shared vertices c0..c3 are distinct, the triple (c[i-1], c[i+2], c[i+1])
    of each c[i], in wire order."""
    out: Quads = {}
    tidx = m.type_index()
    types, children, start = m.shape_type, m.child_shape, m.child_start
    vertex = int(ShapeType.VERTEX)
    for w in np.flatnonzero(types == ShapeType.WIRE).tolist():
        kids = children[start[w] : start[w + 1]]
        if len(kids) != 4 or (types[kids] != ShapeType.EDGE).any():
            continue
        ends = []
        for e in kids.tolist():
            vk = children[start[e] : start[e + 1]]
            ends.append({int(tidx[c]) for c in vk[types[vk] == vertex].tolist()})
        shared = [ends[i] & ends[(i + 1) % 4] for i in range(4)]
        if any(len(x) != 2 for x in ends) or any(len(s) != 1 for s in shared):
            continue
        c = [min(s) for s in shared]
        if len(set(c)) != 4:
            continue
        for i in range(4):
            out.setdefault(c[i], []).append((c[i - 1], c[(i + 2) % 4], c[(i + 1) % 4]))
    return out


def _prediction(
    v: int, k: int, done: dict[int, int], q: np.ndarray, nbr: list[list[int]], quads: Quads
) -> np.ndarray | None:
    """The prediction of the ``k``-th grid vertex, row ``v`` (docs/format.md
    §2.6), from the grid integers ``q`` of the grid vertices ``done`` (row ->
    k) before it: the parallelogram of its first quad whose three other
    corners are done (format 2.6: ``quads``), else its highest-row grid
    neighbour's, else the grid vertex's before it (None for the first)."""
    for x, y, z in quads.get(v, ()):
        if x in done and y in done and z in done:
            return q[done[x]] + q[done[z]] - q[done[y]]
    before = [done[u] for u in (nbr[v] if v < len(nbr) else ()) if u in done]
    if before:
        return q[max(before)]
    return q[k - 1] if k else None


def _grid_predictions(
    nbr: list[list[int]], rows: np.ndarray, q: np.ndarray, quads: Quads | None = None
) -> np.ndarray:
    """Per grid vertex (``rows``, ascending, with grid integers ``q``), its
    prediction (:func:`_prediction`; zeros for the first)."""
    pred = np.zeros_like(q)
    done: dict[int, int] = {}  # row -> k
    with np.errstate(over="ignore"):
        for k, v in enumerate(rows.tolist()):
            p = _prediction(v, k, done, q, nbr, quads or {})
            if p is not None:
                pred[k] = p
            done[v] = k
    return pred


def _grid_from_residuals(
    nbr: list[list[int]], rows: np.ndarray, res: np.ndarray, quads: Quads | None = None
) -> np.ndarray:
    """The inverse of :func:`_grid_predictions`: grid integers from residuals."""
    q = np.zeros_like(res)
    done: dict[int, int] = {}
    with np.errstate(over="ignore"):
        for k, v in enumerate(rows.tolist()):
            p = _prediction(v, k, done, q, nbr, quads or {})
            q[k] = res[k] if p is None else p + res[k]
            done[v] = k
    return q


#: Format 2.5: the exponent e of the offsets of kind-2 vertices this writer
#: writes (docs/format.md §2.6): multiples of 2**-32 mm, ~2.3e-10.
TWIN_EXP = -32
#: A kind-2 vertex's reference is sought within this distance of it.
TWIN_REACH = 2.0**-20


def twin_offset(ref: np.ndarray, k: np.ndarray, e: int = TWIN_EXP) -> np.ndarray:
    """Format 2.5: the point of a kind-2 vertex, ``ref + ldexp(k, e)`` per
    coordinate (one binary64 addition; the offset is exact)."""
    return ref + np.ldexp(np.asarray(k, np.int64).astype(np.float64), e)


def _twin_refs(pts: np.ndarray, e: int = TWIN_EXP) -> tuple[np.ndarray, np.ndarray]:
    """Per vertex, the row of its kind-2 reference (-1 where none) and the offsets.

    A vertex at the point of an earlier one takes the first such (offset 0);
    any other, the lowest row within :data:`TWIN_REACH` of it (and below it)
    from which :func:`twin_offset` gives its point bit for bit.  The
    distances are sought among distinct points only, so that many vertices at
    one point cost one k-d tree entry, not pairs among all of them."""
    n = len(pts)
    ref = np.full(n, -1, np.int64)
    k = np.zeros((n, 3), np.int64)
    if n < 2 or not np.isfinite(pts).all():
        return ref, k
    _, first, inv = np.unique(pts, axis=0, return_index=True, return_inverse=True)
    home = first[inv.ravel()]
    # bit for bit: -0.0 and 0.0 are one point to np.unique, and -0.0 + 0.0 is 0.0
    same = twin_offset(pts[home], np.zeros((n, 3), np.int64), e)
    dup = (home < np.arange(n)) & (same.view(np.int64) == pts.view(np.int64)).all(-1)
    ref[dup] = home[dup]
    rows = np.sort(first)
    pairs = pairs_within(pts[rows], TWIN_REACH)
    if not len(pairs):
        return ref, k
    lo, hi = rows[pairs.min(1)], rows[pairs.max(1)]
    kk = np.rint(np.ldexp(pts[hi] - pts[lo], -e)).astype(np.int64)
    good = (twin_offset(pts[lo], kk, e).view(np.int64) == pts[hi].view(np.int64)).all(-1)
    if not good.any():
        return ref, k
    lo, hi, kk = lo[good], hi[good], kk[good]
    order = np.lexsort((lo, hi))  # per vertex, its lowest reference first
    lo, hi, kk = lo[order], hi[order], kk[order]
    take = np.r_[True, hi[1:] != hi[:-1]]
    ref[hi[take]] = lo[take]
    k[hi[take]] = kk[take]
    return ref, k


#: Format 2.13: a vertex off the vertex grid may lie on the binary grid
#: 2**(floor(log2 tol) - BINARY_BITS) (where ``encode.assembly._fine_points``
#: rounds a vertex that cannot snap: on a feature finer than tol, or beside a
#: vertex it would land on); it is then stored as integers on that grid
#: (kind 3), predicted as kind 1 is.
BINARY_BITS = 10


def binary_exponent(tol: float) -> int:
    """Format 2.13: the exponent of the binary grid of kind-3 vertices this
    writer writes for ``tol`` (docs/format.md §2.6)."""
    return int(np.floor(np.log2(tol))) - BINARY_BITS


def _on_step(pts: np.ndarray, step: float) -> tuple[np.ndarray, np.ndarray]:
    """Per point, whether every coordinate is k·``step`` bit for bit (|k| <
    2^50), and the integers k."""
    q = np.zeros_like(pts, dtype=np.int64)
    small = (np.abs(pts) < 2.0**50 * step).all(-1)
    q[small] = np.rint(pts[small] / step).astype(np.int64)
    on = small & ((q * step).view(np.int64) == pts.view(np.int64)).all(-1)  # bit for bit
    return on, q


def _write_vertices(m: BRepModel, tol: float = 0.0) -> bytes:
    """Vertices at a bit-exact offset from an earlier one (format 2.5) are
    stored as that offset, where the section then compresses smaller (LZMA
    alone: a few vertices at one point cost LZMA less as repeated floats
    than as references; generated faces-mode IGES parts lost up to 51 bytes);
    those whose point is a grid point (``vertex_grid``) bit for bit as grid
    integers; of the others, those on the binary grid of
    :func:`binary_exponent` as its integers (format 2.13), where that is
    smaller too; the rest as floats."""
    pts = m.vertex_point
    on_grid = np.zeros(len(pts), bool)
    q = np.zeros_like(pts, dtype=np.int64)
    binary, e = np.zeros(len(pts), bool), 0
    if tol > 0 and len(pts):
        on_grid, q = _on_step(pts, vertex_grid(tol))
        e = binary_exponent(tol)
        if -1074 <= e <= 0:
            binary, qb = _on_step(pts, float(np.ldexp(1.0, e)))
            binary &= ~on_grid
            q = np.where(binary[:, None], qb, q)
    ref, k = _twin_refs(pts)
    near = (vertex_neighbours(m), vertex_quads(m)) if (on_grid | binary).any() else ([], {})
    none = np.zeros(len(pts), bool)
    twin = ref >= 0
    kept: list[tuple[int, bytes]] = []  # (LZMA size alone, section), in trial order
    for tw in (none, twin) if twin.any() else (none,):
        bi = binary & ~tw
        grids = [(none, e, q)]
        if bi.any():
            grids.append((bi, e, q))
            ec = coarsest_exponent(pts[bi], e)
            if ec > e:
                qc = _on_step(pts, float(np.ldexp(1.0, ec)))[1]
                grids.append((bi, ec, np.where(bi[:, None], qc, q)))
        # the grids weighed with the references as distances, then the best
        # of them with the references as differences (the choices hardly
        # depend on each other, and each trial is an LZMA run)
        trials = [
            _vertex_arrays(m, on_grid & ~tw, qb, ref, k, tw, near, b, eb) for b, eb, qb in grids
        ]
        sizes = [entropy.xz_size(raw) for raw in trials]
        i = sizes.index(min(sizes))  # the first of the smallest
        kept.append((sizes[i], trials[i]))
        if tw.any():
            b, eb, qb = grids[i]
            raw = _vertex_arrays(m, on_grid & ~tw, qb, ref, k, tw, near, b, eb, True)
            kept.append((entropy.xz_size(raw), raw))
    return min(kept, key=lambda s: s[0])[1]  # the first of the smallest


def coarsest_exponent(pts: np.ndarray, e: int) -> int:
    """The largest exponent from ``e`` to 0 whose binary grid 2**exponent holds
    every one of ``pts`` bit for bit (``pts`` lie on 2**``e``'s).  A part's
    vertices that no coding moved (a plate's, at 3.5 or 40 mm) lie on a grid
    far coarser than the tolerance's: their integers there are smaller, and
    the same whatever the tolerance (a plate of 48 filleted bosses, 150 faces:
    `VERT` 252 bytes at 0.01 mm and 276 at 0.1 mm on the tolerance's grid)."""
    for ec in range(0, e, -1):
        if _on_step(pts, float(np.ldexp(1.0, ec)))[0].all():
            return ec
    return e


def _write_predicted(
    w: BlockWriter, near: tuple[list[list[int]], Quads], rows: np.ndarray, q: np.ndarray
) -> None:
    """The x, y and z residuals of the integers ``q`` of the vertices ``rows``
    (kind 1, or kind 3) against their predictions among themselves."""
    pred = _grid_predictions(near[0], rows, q[rows], near[1]) if len(rows) else q[rows]
    for axis in range(3):
        w.ints(q[rows, axis] - pred[:, axis])


def _vertex_arrays(
    m: BRepModel,
    on_grid: np.ndarray,
    q: np.ndarray,
    ref: np.ndarray,
    k: np.ndarray,
    twin: np.ndarray,
    near: tuple[list[list[int]], Quads],
    binary: np.ndarray,
    e: int,
    deltas: bool = False,
) -> bytes:
    """The section with the vertices of ``twin`` as kind 2 (their references
    as differences from the previous one's where ``deltas``, format 2.18, else
    as distances back), of ``on_grid`` as kind 1 (predicted from ``near``: the
    model's vertex neighbours and quads), of ``binary`` as kind 3 (integers
    ``q`` on the grid 2**``e``, predicted so)."""
    w = BlockWriter()
    pts = m.vertex_point
    w.ints(np.select([twin, binary, on_grid], [2, 3, 1], 0))
    w.floats(pts[~on_grid & ~twin & ~binary].reshape(-1))
    _write_predicted(w, near, np.flatnonzero(on_grid), q)
    if binary.any():
        w.ints([e])
        _write_predicted(w, near, np.flatnonzero(binary), q)
    tw = np.flatnonzero(twin)
    if len(tw):
        w.ints(np.diff(ref[tw], prepend=0) if deltas else tw - ref[tw])
        w.ints([TWIN_EXP, int(deltas)])
        for axis in range(3):
            w.ints(k[tw, axis])
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
    top = 3 if revision >= container.SHORT else 2 if revision >= 8 else 1
    if len(kind) and (kind.min() < 0 or kind.max() > top):
        raise SectionError("VERT: unknown vertex kind")
    on_grid, twin, binary = kind == 1, kind == 2, kind == 3
    nv, ng = len(on_grid), int(on_grid.sum())
    pts = np.zeros((nv, 3))
    plain = kind == 0
    pts[plain] = r.floats(3 * int(plain.sum())).reshape(-1, 3)
    near: tuple[list[list[int]], Quads] = ([], {})
    if ng or binary.any():  # quads from 2.6
        near = (vertex_neighbours(m), vertex_quads(m) if revision >= container.COMPACT else {})
    if revision >= 3:
        q = _read_predicted(r, near, np.flatnonzero(on_grid))
    else:
        q = np.stack([r.deltas(ng) for _ in range(3)], axis=1)
    if ng and not tol > 0:
        raise SectionError("VERT: grid vertices need a positive tolerance")
    if ng:
        with np.errstate(over="ignore"):
            pts[on_grid] = q * vertex_grid(tol)
    if binary.any():
        e = int(r.ints(1)[0])
        if not -1074 <= e <= 0:
            raise SectionError("VERT: the binary grid's exponent is out of range")
        qb = _read_predicted(r, near, np.flatnonzero(binary))
        if (np.abs(qb) >= 2**53).any():
            raise SectionError("VERT: an integer on the binary grid is out of range")
        pts[binary] = np.ldexp(qb.astype(np.float64), e)
    if revision >= 8:
        _read_twins(r, pts, np.flatnonzero(twin), revision >= container.TWIN_DELTAS)
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


def _read_predicted(
    r: BlockReader, near: tuple[list[list[int]], Quads], rows: np.ndarray
) -> np.ndarray:
    """The integers of the vertices ``rows`` (kind 1, or kind 3) from their x,
    y and z residuals (the inverse of :func:`_write_predicted`)."""
    res = np.stack([r.ints(len(rows)) for _ in range(3)], axis=1)
    return _grid_from_residuals(near[0], rows, res, near[1]) if len(rows) else res


def _read_twins(r: BlockReader, pts: np.ndarray, rows: np.ndarray, modes: bool = False) -> None:
    """Format 2.5: the points of the kind-2 vertices (``rows``), each at its
    offset from its reference, in row order (docs/format.md §2.6); from 2.18
    (``modes``) the references as distances back or as differences from the
    previous one's, as the exponent's second integer says."""
    n = len(rows)
    if not n:
        return
    back = r.ints(n)
    e = r.ints(2 if modes else 1)
    k = np.stack([r.ints(n) for _ in range(3)], axis=1)
    if modes and int(e[1]) not in (0, 1):
        raise SectionError("VERT: unknown reference mode")
    if modes and int(e[1]) == 1:
        # each difference below 2^31 in size: their sums cannot overflow
        if (np.abs(back) >= 2**31).any():
            raise SectionError("VERT: a vertex's reference is not an earlier vertex")
        ref = np.cumsum(back)
        if (ref >= rows).any():
            raise SectionError("VERT: a vertex's reference is not an earlier vertex")
    else:
        ref = rows - back
        if (back < 1).any():
            raise SectionError("VERT: a vertex's reference is not an earlier vertex")
    if (ref < 0).any():
        raise SectionError("VERT: a vertex's reference is not an earlier vertex")
    if not -1074 <= int(e[0]) <= 0:
        raise SectionError("VERT: the offsets' exponent is out of range")
    if (np.abs(k) >= 2**53).any():
        raise SectionError("VERT: an offset is out of range")
    off = np.ldexp(k.astype(np.float64), int(e[0]))
    done = ~np.isin(ref, rows)  # references of kind 0 or 1: all at once
    pts[rows[done]] = pts[ref[done]] + off[done]
    for j in np.flatnonzero(~done).tolist():  # a reference of kind 2: in row order
        pts[rows[j]] = pts[ref[j]] + off[j]
