"""`EDGE` (§2.7: tolerances, flags, curve representations, surfaces picked
among the edge's faces', ranges by rule) and `FACE` (§2.8)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import container
from ..errors import BadReferenceError, LimitError, SectionError
from ..model import (
    EC,
    Analytic,
    BRepModel,
    Derived,
    Geometry,
    Kind,
    RepKind,
    ShapeType,
)
from ..streams import BlockReader, BlockWriter
from .limits import MAX_COORD, _counts, _tolerances, finite
from .vertices import _read_tolerances, _write_tolerances

#: How an edge representation's range is stored (EDGE, format 0.3; VERTICES 0.4).
RANGE_STORED, RANGE_NATURAL, RANGE_OF_3D, RANGE_ZERO, RANGE_VERTICES = 0, 1, 2, 3, 4
#: How many range kinds there are: format 2.11 stores a range kind less its
#: prediction, modulo this.
RANGE_KINDS = RANGE_VERTICES + 1
#: Format 2.11: the first revision whose EDGE predicts its representations'
#: kinds and range kinds and leaves out the end points of computed pcurves.
PREDICTED = container.VERSIONS.index((2, 11))
#: Per edge row, faces and their references (:func:`edge_uses`, :func:`pcurve_faces`).
Uses = list[list[tuple[int, int]]]


def edge_uses(m: BRepModel, cap: float = np.inf) -> Uses:
    """Per edge row, the faces it bounds, in ``FACE`` order, each with how
    many times its walk references the edge (2 for a seam): the walk from a
    face's shape visits every shape below it once (wires, and shells or
    compounds in between; not edges' vertices) and counts each reference to
    the edge in their child lists (docs/format.md §2.7).

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
    out: Uses = [[] for _ in range(types.count(edge))]
    work = 0
    faces = [i for i, t in enumerate(types) if t == int(ShapeType.FACE)]
    for f, s in enumerate(faces):
        seen, stack = {s}, [s]
        count: dict[int, int] = {}
        while stack:
            x = stack.pop()
            work += start[x + 1] - start[x]
            if work > cap:
                raise LimitError(
                    f"EDGE: the faces' walks to their edges pass more than {cap:g} references"
                )
            for c in kids[start[x] : start[x + 1]]:
                if types[c] == edge:
                    count[c] = count.get(c, 0) + 1
                elif c not in seen and types[c] < edge and types[c] != vertex:
                    seen.add(c)
                    stack.append(c)
        for c, n in count.items():
            out[tidx[c]].append((f, n))
    return out


def edge_candidates(m: BRepModel, cap: float = np.inf, uses: Uses | None = None) -> list[list[int]]:
    """Format 2.0: per edge row, the surface rows of the faces it bounds (faces
    in ``FACE`` order, each surface row at its first appearance): the
    candidates an ``EDGE`` surface pick names (docs/format.md §2.7).
    ``cap``: as :func:`edge_uses`; ``uses``: its result, if already made."""
    out: list[list[int]] = []
    for u in edge_uses(m, cap) if uses is None else uses:
        cands: list[int] = []
        for f, _ in u:
            r = int(m.face_surface[f])
            if r not in cands:
                cands.append(r)
        out.append(cands)
    return out


#: Format 2.11: the surface kinds whose faces a writer predicts to hold no
#: pcurve, as a mask of bits ``1 << Kind`` (the default: planes, as OCCT's
#: STEP reader leaves them; a shape made by OCCT's modelling algorithms has
#: pcurves on planes too, and takes 0: :func:`bare_kinds`).
BARE = 1 << Kind.PLANE


def _face_kinds(m: BRepModel) -> list[int]:
    """Per face row, the kind of its surface row (a B-spline or Bezier
    surface counted as a B-spline), -1 where the row is outside the table."""

    def kind(g: Geometry) -> int:
        return int(g.kind) if isinstance(g, (Analytic, Derived)) else int(Kind.BSPLINE_SURFACE)

    kinds = [kind(g) for g in m.surfaces]
    return [kinds[r] if 0 <= r < len(kinds) else -1 for r in m.face_surface.tolist()]


def pcurve_faces(m: BRepModel, uses: Uses, bare: int = BARE) -> Uses:
    """Format 2.11: per edge row, the faces of ``uses`` (:func:`edge_uses`)
    predicted to hold a pcurve of it, with their uses: those that reference
    it twice or more, and those whose surface row's kind is not in ``bare``."""
    kinds = _face_kinds(m)
    held = [k < 0 or not bare >> k & 1 for k in kinds]
    return [[(f, n) for f, n in u if n >= 2 or held[f]] for u in uses]


def bare_kinds(m: BRepModel, uses: Uses) -> int:
    """Format 2.11: the mask of surface kinds whose faces mostly hold no pcurve
    of the edges they reference once (a writer's choice: any mask decodes)."""
    kinds = _face_kinds(m)
    reps = m.edge_reps
    on = np.flatnonzero(reps[:, EC.KIND] == RepKind.ON_SURFACE)
    has = set(zip(reps[on, EC.EDGE].tolist(), reps[on, EC.SURFACE].tolist()))
    votes = np.zeros((32, 2), np.int64)
    for e, u in enumerate(uses):
        for f, n in u:
            if n == 1 and kinds[f] >= 0:
                votes[kinds[f], int((e, int(m.face_surface[f])) in has)] += 1
    return sum(1 << k for k in range(32) if votes[k, 0] > votes[k, 1])


def regular_edges(m: BRepModel, uses: Uses) -> int:
    """Format 2.11: 1 if most edges between two faces have a regularity record
    (OCCT's STEP and IGES readers encode one on every such edge; a shape
    made by its modelling algorithms has none), else 0."""
    two = np.zeros(len(uses), bool)
    reps = m.edge_reps
    two[reps[reps[:, EC.KIND] == RepKind.ON_TWO_SURFACES, EC.EDGE]] = True
    between = np.array([len(u) == 2 for u in uses], bool)
    return int(2 * int((two & between).sum()) >= int(between.sum()))


def curves_last(m: BRepModel) -> int:
    """Format 2.11: 1 if most edges with a 3-D curve and a pcurve list the
    3-D curve after their pcurves (OCCT's IGES reader builds an edge of a
    trimmed surface from its pcurve and adds the 3-D curve after), else 0."""
    reps = m.edge_reps
    kind, edge = reps[:, EC.KIND], reps[:, EC.EDGE]
    pc = (kind == RepKind.ON_SURFACE) | (kind == RepKind.ON_CLOSED_SURFACE)
    first_pc = np.full(len(m.edge_tol), -1, np.int64)
    first_3d = np.full(len(m.edge_tol), -1, np.int64)
    rows = np.arange(len(reps))
    for sel, out in ((pc, first_pc), (kind == RepKind.CURVE3D, first_3d)):
        e, at = np.unique(edge[sel], return_index=True)  # each edge's first such row
        out[e] = rows[sel][at]
    both = (first_pc >= 0) & (first_3d >= 0)
    return int(2 * int((first_3d[both] > first_pc[both]).sum()) > int(both.sum()))


def predicted_kinds(
    uses: Uses,
    faces: Uses,
    regular: int = 1,
    last: int = 0,
) -> list[list[int]]:
    """Format 2.11: per edge row, the kinds its representations are predicted
    to have (docs/format.md §2.7, "Predicted representations"): a 3-D curve;
    per face it bounds (``uses``, :func:`edge_uses`) predicted to hold one
    (``faces``, :func:`pcurve_faces`), a pcurve on a closed surface where
    the face references it twice or more, else a pcurve; and, if
    ``regular``, a regularity record where it bounds exactly two faces; the
    3-D curve after the pcurves if ``last``."""
    out = []
    for u, held in zip(uses, faces):
        kinds = [int(RepKind.ON_CLOSED_SURFACE if n >= 2 else RepKind.ON_SURFACE) for _, n in held]
        kinds.insert(len(kinds) if last else 0, int(RepKind.CURVE3D))
        if regular and len(u) == 2:
            kinds.append(int(RepKind.ON_TWO_SURFACES))
        out.append(kinds)
    return out


def predicted_picks(
    m: BRepModel, faces: Uses, cands: list[list[int]]
) -> tuple[np.ndarray, np.ndarray]:
    """Format 2.11: the predicted surface picks of the representations of
    kinds 1-3 and of the second surfaces of kind 3, in representation order:
    the j-th pcurve of an edge on the j-th face predicted to hold one
    (``faces``, :func:`pcurve_faces`; 0 past them), a regularity record's on
    candidates 0 and 1 (0 if there is one)."""
    reps = m.edge_reps
    kind, edge = reps[:, EC.KIND].tolist(), reps[:, EC.EDGE].tolist()
    first: list[int] = []
    second: list[int] = []
    seen: dict[int, int] = {}
    for k, e in zip(kind, edge):
        if k == RepKind.CURVE3D:
            continue
        if k == RepKind.ON_TWO_SURFACES:
            first.append(0)
            second.append(int(len(cands[e]) > 1))
            continue
        j = seen.get(e, 0)
        seen[e] = j + 1
        fs = faces[e]
        first.append(cands[e].index(int(m.face_surface[fs[j][0]])) if j < len(fs) else 0)
    return np.array(first, np.int64), np.array(second, np.int64)


def _unpredict(
    p: np.ndarray, pred: np.ndarray, edges: np.ndarray, cands: list[list[int]]
) -> np.ndarray:
    """Format 2.11: picks as stored: −1 (escaped) as it is, another pick as
    its difference from its prediction modulo the edge's candidates."""
    n = np.array([len(cands[e]) for e in edges.tolist()], np.int64)
    return np.where(p < 0, p, (p - pred) % np.maximum(n, 1))


def predicted_ranges(m: BRepModel, kind: np.ndarray, curve: np.ndarray) -> np.ndarray:
    """Format 2.11: per representation, its predicted range kind: zeros
    (``RANGE_ZERO``) for a pcurve, from the vertices (``RANGE_VERTICES``) for
    a 3-D curve whose ``CRV3`` row is a line or a circle, the curve's own
    (``RANGE_NATURAL``) for another 3-D curve, stored for none (−1)."""
    out = np.full(len(kind), RANGE_ZERO, np.int64)
    n3 = len(m.curves3d)
    for q in np.flatnonzero(kind == RepKind.CURVE3D).tolist():
        c = int(curve[q])
        if not 0 <= c < n3:
            out[q] = RANGE_STORED
            continue
        g = m.curves3d[c]
        conic = isinstance(g, Analytic) and g.kind in (Kind.LINE, Kind.CIRCLE)
        out[q] = RANGE_VERTICES if conic else RANGE_NATURAL
    return out


def _picks(values: np.ndarray, edges: np.ndarray, cands: list[list[int]]) -> np.ndarray:
    """Per value, its index among its edge's candidates, −1 where it is none."""
    out = np.full(len(values), -1, np.int64)
    for k, (v, e) in enumerate(zip(values.tolist(), edges.tolist())):
        c = cands[e]
        if v in c:
            out[k] = c.index(v)
    return out


def _write_edges(m: BRepModel, how: np.ndarray, revision: int = container.REVISION) -> bytes:
    """EDGE (format 2.0; from revision ``PREDICTED``, 2.11, kinds and range
    kinds by prediction); ``how`` is each representation's range kind
    (``rules.ranges.range_kinds``)."""
    w = BlockWriter()
    _write_tolerances(w, m.edge_tol)
    w.ints(m.edge_flags)
    reps = m.edge_reps
    kind = reps[:, EC.KIND]
    uses = edge_uses(m)
    on = (kind == RepKind.ON_SURFACE) | (kind == RepKind.ON_CLOSED_SURFACE)
    if revision >= PREDICTED:
        # a pcurve of range kind 3 has no end points in 2.11: one whose end
        # points are not zeros has its range (zeros) stored instead
        how = np.where(on & (how == RANGE_ZERO) & (m.edge_rep_uv != 0).any(1), RANGE_STORED, how)
        per = np.bincount(reps[:, EC.EDGE], minlength=len(m.edge_tol))
        first = np.concatenate([[0], np.cumsum(per)]).tolist()
        kinds = [kind[a:b].tolist() for a, b in zip(first[:-1], first[1:])]
        bare, regular, last = bare_kinds(m, uses), regular_edges(m, uses), curves_last(m)
        faces = pcurve_faces(m, uses, bare)
        predicted = predicted_kinds(uses, faces, regular, last)
        odd = [e for e, k in enumerate(predicted) if kinds[e] != k]
        w.ints([bare, regular, last])
        w.deltas(odd)
        w.ints(per[odd])
        w.ints([k for e in odd for k in kinds[e]])
    else:
        w.ints(np.bincount(reps[:, EC.EDGE], minlength=len(m.edge_tol)) if len(reps) else [])
        w.ints(kind)
    # each column only where the representation kind uses it
    w.deltas(reps[kind == RepKind.CURVE3D, EC.CURVE])  # 3-D curve
    w.deltas(reps[on, EC.CURVE])  # pcurve
    w.ints(reps[kind == RepKind.ON_CLOSED_SURFACE, EC.CURVE2])  # second pcurve
    # surfaces (2.0): picked among the surfaces of the edge's faces, or escaped
    cands = edge_candidates(m, uses=uses)
    s1, e1 = reps[kind != RepKind.CURVE3D, EC.SURFACE], reps[kind != RepKind.CURVE3D, EC.EDGE]
    s2, e2 = (
        reps[kind == RepKind.ON_TWO_SURFACES, EC.SURFACE2],
        reps[kind == RepKind.ON_TWO_SURFACES, EC.EDGE],
    )
    p1, p2 = _picks(s1, e1, cands), _picks(s2, e2, cands)
    if revision >= PREDICTED:
        pred1, pred2 = predicted_picks(m, faces, cands)
        w.ints(_unpredict(p1, pred1, e1, cands))
        w.ints(_unpredict(p2, pred2, e2, cands))
    else:
        w.ints(p1)
        w.ints(p2)
    w.deltas(np.concatenate([s1[p1 < 0], s2[p2 < 0]]))
    w.ints(reps[:, EC.LOC])  # location
    w.ints(reps[kind == RepKind.ON_TWO_SURFACES, EC.LOC2])  # second location
    cont = (kind == RepKind.ON_CLOSED_SURFACE) | (kind == RepKind.ON_TWO_SURFACES)
    w.ints(m.edge_rep_cont[cont])
    ranged = kind != RepKind.ON_TWO_SURFACES
    if revision >= PREDICTED:
        w.ints(((how - predicted_ranges(m, kind, reps[:, EC.CURVE])) % RANGE_KINDS)[ranged])
        on &= how != RANGE_ZERO
    else:
        w.ints(how[ranged])
    w.floats(m.edge_rep_range[ranged & (how == RANGE_STORED)].reshape(-1))
    w.floats(m.edge_rep_uv[on, :4].reshape(-1))
    w.floats(m.edge_rep_uv[on & (kind == RepKind.ON_CLOSED_SURFACE), 4:].reshape(-1))
    return bytes(w)


@dataclass
class _Picks:
    """Format 2.0: EDGE's surface picks, resolved once FACE is read."""

    first: np.ndarray
    second: np.ndarray
    escaped: np.ndarray
    #: (2.11) the faces' uses of the edges (:func:`edge_uses`), and those
    #: predicted to hold pcurves (:func:`pcurve_faces`): the picks are stored
    #: against their predictions (:func:`predicted_picks`)
    uses: Uses | None = None
    faces: Uses | None = None


def _read_edges(
    data: bytes, m: BRepModel, revision: int = 3, cap: float = np.inf
) -> tuple[np.ndarray, _Picks | None]:
    """Fill ``m``'s edge tables; return the range kinds (``rules.ranges.range_kinds``:
    ranges of any kind but ``RANGE_STORED`` are left for ``rules.ranges.resolve_ranges``)
    and, from revision 3, the surface picks (:func:`_resolve_picks`; the
    surfaces are 0 until then).  From revision ``PREDICTED`` (2.11) the
    predictions need ``SURF``, ``CRV3``, ``SHAP`` and ``FACE`` read first;
    ``cap`` bounds the faces' walks (:func:`edge_uses`)."""
    r = BlockReader(data, "EDGE")
    m.edge_tol = _read_tolerances(r, None, "EDGE") if revision >= 3 else r.floats()
    _tolerances(m.edge_tol, "EDGE tolerances")
    ne = len(m.edge_tol)
    flags = r.ints(ne)
    if ne and (flags.min() < 0 or flags.max() > 7):
        raise SectionError("EDGE: unknown edge flags")
    m.edge_flags = flags.astype(np.uint8)
    uses = faces = None
    if revision >= PREDICTED:
        per, kind, uses, faces = _read_kinds(r, m, ne, cap)
    else:
        per = r.ints()
        if len(per) not in (0, ne):
            raise SectionError("EDGE: bad representation counts")
        kind = r.ints(_counts(per, r, "EDGE representation counts"))
    q = len(kind)
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
        picks = _Picks(first, second, r.deltas(n_esc), uses, faces)
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
    on = (kind == RepKind.ON_SURFACE) | closed
    if revision >= PREDICTED:  # (2.11) a range kind less its prediction
        how[~two] = ((how + predicted_ranges(m, kind, reps[:, EC.CURVE])) % RANGE_KINDS)[~two]
        on &= how != RANGE_ZERO  # a computed pcurve's end points are zeros
    m.edge_rep_range = np.zeros((q, 2))
    stored = how == RANGE_STORED
    m.edge_rep_range[stored] = r.floats(2 * int(stored.sum())).reshape(-1, 2)
    m.edge_rep_uv = np.zeros((q, 8))
    m.edge_rep_uv[on, :4] = r.floats(4 * int(on.sum())).reshape(-1, 4)
    m.edge_rep_uv[on & closed, 4:] = r.floats(4 * int((on & closed).sum())).reshape(-1, 4)
    r.done()
    # an edge without a 3-D curve (degenerated) has OCCT's default range, ±DBL_MAX
    curveless = (kind == RepKind.CURVE3D) & (reps[:, EC.CURVE] == -1)
    finite(m.edge_rep_range, "EDGE ranges")
    finite(m.edge_rep_range[~curveless], "EDGE ranges", MAX_COORD)
    finite(m.edge_rep_uv, "EDGE uv points", MAX_COORD)
    return how, picks


def _read_kinds(
    r: BlockReader, m: BRepModel, ne: int, cap: float
) -> tuple[np.ndarray, np.ndarray, Uses, Uses]:
    """Format 2.11: the representations per edge and their kinds, from the
    predictions (:func:`predicted_kinds`) and the edges that differ from them
    (docs/format.md §2.7, "Predicted representations")."""
    n_faces = int((m.shape_type == ShapeType.FACE).sum())
    if len(m.face_surface) != n_faces or ne != int((m.shape_type == ShapeType.EDGE).sum()):
        raise BadReferenceError("edge or face table does not match the shapes table")
    uses = edge_uses(m, cap)
    bare, regular, last = r.ints(3).tolist()
    if not (0 <= bare < 1 << 32 and regular in (0, 1) and last in (0, 1)):
        raise SectionError("EDGE: the predictions' settings are out of range")
    faces = pcurve_faces(m, uses, bare)
    kinds = predicted_kinds(uses, faces, regular, last)
    odd = r.deltas()
    if len(odd) and (odd.min() < 0 or odd.max() >= ne or (np.diff(odd) <= 0).any()):
        raise SectionError("EDGE: the edges off their prediction are not increasing edge rows")
    per = r.ints(len(odd))
    given = r.ints(_counts(per, r, "EDGE representation counts"))
    at = 0
    for e, n in zip(odd.tolist(), per.tolist()):
        kinds[e] = given[at : at + n].tolist()
        at += n
    counts = np.array([len(k) for k in kinds], np.int64)
    if int(counts.sum()) > r.remaining:  # every representation stores its location
        raise SectionError("EDGE: more representations than the section holds")
    return counts, np.array([k for ks in kinds for k in ks], np.int64), uses, faces


def _resolve_picks(m: BRepModel, p: _Picks, cap: float) -> None:
    """Set EDGE's surfaces from their picks (format 2.0, docs/format.md §2.7)."""
    cands = edge_candidates(m, cap, p.uses)
    reps = m.edge_reps
    esc = iter(p.escaped.tolist())
    kind = reps[:, EC.KIND]
    zero = np.zeros(len(reps), np.int64)
    pred1, pred2 = (zero, zero) if p.faces is None else predicted_picks(m, p.faces, cands)
    for col, sel, pick, pred in (
        (EC.SURFACE, kind != RepKind.CURVE3D, p.first, pred1),
        (EC.SURFACE2, kind == RepKind.ON_TWO_SURFACES, p.second, pred2),
    ):
        rows = np.flatnonzero(sel).tolist()
        for q, k, d in zip(rows, pick.tolist(), pred.tolist()):
            if k == -1:
                reps[q, col] = next(esc)  # as many as the picks of -1: read so
                continue
            c = cands[int(reps[q, EC.EDGE])]
            if k >= len(c):
                raise BadReferenceError(
                    f"EDGE: representation {q} picks surface {k} of an edge on {len(c)}"
                )
            reps[q, col] = c[(k + d) % len(c)]


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
