"""`EDGE` (§2.7: tolerances, flags, curve representations, surfaces picked
among the edge's faces', ranges by rule) and `FACE` (§2.8)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import BadReferenceError, LimitError, SectionError
from ..model import (
    EC,
    BRepModel,
    RepKind,
    ShapeType,
)
from ..streams import BlockReader, BlockWriter
from .limits import MAX_COORD, _counts, _tolerances, finite
from .vertices import _read_tolerances, _write_tolerances


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
