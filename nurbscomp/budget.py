"""The decoding budget: how much a container's tables expand, computed from the
tables alone, before anything is built (docs/format.md §4, "Budget").

A container is small; the shape it describes need not be.  Sharing makes a
tree of sub-shape references out of a DAG (a compound holding the one below
it twice, 40 levels deep, is 2^40 references), coded nets have poles that no
byte backs, a pcurve the decoder computes costs no byte at all, and an IGES
writer flattens every instance.  :func:`expansion` measures all of that with
one pass over the shapes table in each direction (sub-shapes precede their
parents, so the table is its own topological order: no recursion, no
revisiting), and :func:`check_structure` refuses what is past :class:`Limits`.

Counts are capped at ``CAP`` while they are summed, so that a hostile DAG
costs no big-integer arithmetic.
"""

from __future__ import annotations

import dataclasses
from collections import Counter
from dataclasses import dataclass

import numpy as np

from .errors import CorruptError, LimitError, SectionError
from .model import (
    EC,
    REBUILD,
    Analytic,
    BRepModel,
    BSplineCurve,
    BSplineSurface,
    Derived,
    Geometry,
    Kind,
    RepKind,
    ShapeType,
    first_row,
)

#: Counts stop growing here (far past every limit).
CAP = 1 << 62

# Bytes an output file spends, measured on the corpus (STEP and IGES written by
# OCCT from decoded containers, docs/format.md §4): a pole or knot is a few
# numbers of ~20 characters, a topological or geometric entity a line.
_POLE_BYTES = 75
_NUMBER_BYTES = 20
_ENTITY_BYTES = 120
#: An instance (a located reference) in STEP: its assembly entities.
_INSTANCE_BYTES = 5 * _ENTITY_BYTES


#: Deepest nesting a scaled limit allows: OCCT walks nested shapes
#: recursively (measured: 30,000 levels decode and write, 100,000 crash its
#: STEP writer's stack).
DEPTH_CEILING = 10_000


@dataclass(frozen=True)
class Limits:
    """What a reader decodes at most (``--limit-scale K`` multiplies each by K).

    Measured on the public corpus (11 files, docs/format.md §4): at most
    10,482 references, depth 7, 44,620 poles and knots, 2,050 pcurves (if
    every one were left out) and 48 million units of projection work,
    estimated outputs of 8 MB and 160 bytes per container byte.
    """

    #: Rows of the tables the decoder loops over (shapes, sub-shape
    #: references, edge and vertex representations, geometry rows, location
    #: factors), checked
    #: before any loop: the sections may declare up to 256 MB of them.
    rows: int = 1_000_000
    #: Sub-shape references with sharing unfolded: what OCCT's explorers,
    #: counters and writers walk (95x the corpus's largest).
    references: int = 1_000_000
    #: Longest chain of sub-shape references (OCCT walks it recursively).
    depth: int = 1_000
    #: Poles and knots of every distinct B-spline OCCT builds (90x).
    poles: int = 4_000_000
    #: Longest chain of geometry rows built on one another (a trimmed or
    #: offset surface or curve on its basis; OCCT evaluates them recursively).
    bases: int = 100
    #: Pcurves the decoder computes (``occ.topology.rebuild_pcurves``), one per
    #: representation and face it projects onto (100x).
    pcurves: int = 200_000
    #: Work of those projections (:func:`pcurves_to_compute`): per
    #: projection, the points OCCT samples on the edge's 3-D curve
    #: (:func:`curve_samples`, at least 23) times the surface's work per point,
    #: its poles x (u degree + 1) x (v degree + 1) (16 for an analytic
    #: surface; :func:`_swept_work` for a swept one; a trimmed or offset
    #: surface costs what its basis does).  Measured: at most 47 ns a unit
    #: where a hostile container puts the curves off their surfaces (each
    #: point then searched over the whole surface), 1-4 ns where they lie on
    #: them (trj7 at 0.01 mm: 48 million units, 0.4 s).  At most
    #: ``projection`` units whatever the container's size (3.8 s at worst),
    #: or ``projection_ratio`` per byte of the container if that is more.
    projection: int = 80_000_000
    projection_ratio: int = 8_000
    #: Estimated output size (STEP and BREP write instances once, IGES
    #: flattens them): at most ``output_ratio`` bytes per byte of the
    #: container, but ``output_floor`` whatever the container's size, and
    #: never more than ``output_bytes``.
    output_ratio: int = 2_000
    output_floor: int = 32 << 20
    output_bytes: int = 2 << 30
    #: An output estimate the container's writer declared (:meth:`admit`).
    output_declared: int = 0

    def scaled(self, k: float) -> Limits:
        """Every limit times ``k`` (the CLI's ``--limit-scale``); the depth at
        most ``DEPTH_CEILING``."""
        if not k > 0:
            raise ValueError("the limit scale must be positive")
        out = {f.name: int(getattr(self, f.name) * k) for f in dataclasses.fields(self)}
        out["depth"] = min(out["depth"], max(self.depth, DEPTH_CEILING))
        return Limits(**out)

    def sized(self, container_bytes: int) -> Limits:
        """The limits for a container of ``container_bytes``: projection work
        up to ``projection_ratio`` per byte if that is above ``projection``
        (a real container's bytes back its pcurves' work; a hostile one's do
        not)."""
        work = max(self.projection, self.projection_ratio * container_bytes)
        return dataclasses.replace(self, projection=work)

    def output(self, container_bytes: int) -> int:
        """Largest estimated output a container of ``container_bytes`` may give."""
        sized = max(self.output_floor, self.output_ratio * container_bytes, self.output_declared)
        return min(self.output_bytes, sized)

    def admit(self, declared: dict[str, int]) -> Limits:
        """The limits raised to what the container's writer declared it decodes
        into (META ``decoded``, :func:`declare`), each at most ``CEILING``
        times its default (the depth at most ``DEPTH_CEILING``): every
        container ``compress`` writes decodes with the default limits, and a
        hostile one that declares more than it holds is still bounded."""
        out: dict[str, int] = {}
        for name in ("rows", "references", "depth", "poles", "bases"):
            if name in declared:
                top = getattr(DEFAULT, name) * CEILING
                top = min(top, DEPTH_CEILING) if name == "depth" else top
                out[name] = max(getattr(self, name), min(declared[name], top))
        size = max(declared.get("step_bytes", 0), declared.get("iges_bytes", 0))
        out["output_declared"] = max(self.output_declared, min(size, self.output_bytes))
        return dataclasses.replace(self, **out)


DEFAULT = Limits()

#: A writer's declaration (:meth:`Limits.admit`) raises a limit to at most
#: this many times its default: 16 million references, 64 million poles.
CEILING = 16
#: What a writer declares of its model (META ``decoded``): the measures of the
#: source itself.  Pcurves to compute are the writer's choice, held to the
#: default limits (``pipeline.verify_encoded``), and are not declared.
DECLARED = ("rows", "references", "depth", "poles", "bases", "step_bytes", "iges_bytes")
#: The most a reader admits of any declaration: what ``compress`` may write.
ADMITTED = DEFAULT.admit(dict.fromkeys(DECLARED, CAP))


@dataclass(frozen=True)
class Expansion:
    """What the tables expand into (see :class:`Limits` for each field)."""

    references: int
    depth: int
    poles: int
    bases: int
    pcurves: int
    projection: int
    step_bytes: int
    iges_bytes: int


@dataclass
class _Table:
    """Per row of a geometry table: output bytes, bases deep, projection work;
    and the poles and knots of its distinct B-spline records."""

    bytes: list[int]
    depth: list[int]
    work: list[int]
    poles: int


def _basis(table: list[Geometry], row: int, kinds: tuple[Kind, ...]) -> Geometry | None:
    """The record under row ``row`` of a curve table, through derived rows of
    ``kinds`` to their bases (None for a row out of range)."""
    g = table[row] if 0 <= row < len(table) else None
    for _ in range(len(table)):  # a chain of bases ends (checked on reading)
        if not (isinstance(g, Derived) and g.kind in kinds):
            break
        g = table[g.basis] if 0 <= g.basis < len(table) else None
    return g


def _swept_work(curves: list[Geometry], row: int) -> int:
    """Projection work per sampled point onto a surface of revolution or of
    linear extrusion of 3-D curve ``row``: n^2 (d + 1)^3 / 4 for a basis of n
    poles and degree d (through trimmed and offset curves to their basis; 16
    for an analytic one).  OCCT's point inversion onto such a surface grows
    that fast: a revolution of a 30-pole curve of degree 25 takes 43 ms a
    point, of a 60-pole one of degree 9, 24 ms (docs/format.md §4)."""
    g = _basis(curves, row, (Kind.TRIMMED_CURVE, Kind.OFFSET_CURVE))
    if not isinstance(g, BSplineCurve):
        return 16
    n = len(g.poles)
    d = n - 1 if g.bezier else g.degree
    return max(16, n * n * (d + 1) ** 3 // 4)


def _table(table: list[Geometry], curves: list[Geometry] | None = None) -> _Table:
    """One pass in row order: a derived row's basis precedes it (checked on
    reading), so its figures are known when the row is reached (memoised:
    chains of bases cost one step a row).  A swept surface's basis is a 3-D
    curve, counted with the curves; ``curves`` (the 3-D curve table, for a
    surface table) gives its projection work (:func:`_swept_work`)."""
    out = _Table([], [], [], 0)
    for i, (first, g) in enumerate(zip(first_row(table), table)):
        if isinstance(g, (BSplineSurface, BSplineCurve)):
            n = g.poles.size // g.poles.shape[-1]
            k = len(g.uknots) + len(g.vknots) if isinstance(g, BSplineSurface) else len(g.knots)
            b = n * _POLE_BYTES + (n if g.weights is not None else 0) * _NUMBER_BYTES
            out.bytes.append(b + 2 * k * _NUMBER_BYTES + _ENTITY_BYTES)
            out.depth.append(1)
            if isinstance(g, BSplineSurface):
                nu, nv = g.poles.shape[:2]
                du, dv = (nu - 1, nv - 1) if g.bezier else (g.udegree, g.vdegree)
                out.work.append(nu * nv * (du + 1) * (dv + 1))
            else:
                out.work.append(16)
            if i == first:  # a record's later rows (COPY rows) hold nothing more
                out.poles += n + k
            continue
        assert isinstance(g, (Analytic, Derived))
        own = _ENTITY_BYTES + (g.frame.size + g.params.size) * _NUMBER_BYTES
        if isinstance(g, Derived) and g.kind not in (Kind.REVOLUTION, Kind.EXTRUSION):
            out.bytes.append(min(own + out.bytes[g.basis], CAP))
            out.depth.append(out.depth[g.basis] + 1)
            out.work.append(out.work[g.basis])
        else:
            out.bytes.append(own)
            out.depth.append(1)
            if isinstance(g, Derived) and curves is not None:
                out.work.append(_swept_work(curves, g.basis))
            else:
                out.work.append(16)
    return out


def _shape_costs(m: BRepModel) -> list[int]:
    """Bytes an output spends on each shape itself (its entity and its geometry)."""
    surf, c3, c2 = (_table(t).bytes for t in (m.surfaces, m.curves3d, m.curves2d))
    types = m.shape_type.tolist()
    tidx = m.type_index().tolist()
    edge_bytes = [_ENTITY_BYTES] * len(m.edge_tol)
    for e, kind, c1, c2b in m.edge_reps[:, :4].tolist():
        if kind == RepKind.CURVE3D and 0 <= c1 < len(c3):
            edge_bytes[e] += c3[c1]
        elif kind in (RepKind.ON_SURFACE, RepKind.ON_CLOSED_SURFACE):
            for c in (c1, c2b):
                if 0 <= c < len(c2):
                    edge_bytes[e] += c2[c]
    face_bytes = [_ENTITY_BYTES + surf[s] for s in m.face_surface.tolist()]
    out = []
    for s, t in enumerate(types):
        if t == ShapeType.FACE:
            out.append(face_bytes[tidx[s]])
        elif t == ShapeType.EDGE:
            out.append(edge_bytes[tidx[s]])
        else:
            out.append(_ENTITY_BYTES)
    return out


def expansion(m: BRepModel) -> Expansion:
    """What ``m``'s tables expand into; ``m``'s references must be checked
    (``serialize.check_references``: every child precedes its parent)."""
    n = len(m.shape_type)
    start = m.child_start.tolist()
    kids = m.child_shape.tolist()
    located = (m.child_loc != 0).tolist()
    # bottom-up (children first): the size of each shape's unfolded tree, its depth
    size = [1] * n
    depth = [1] * n
    for s in range(n):
        a, b = start[s], start[s + 1]
        if a == b:
            continue
        total, deep = 1, 0
        for c in kids[a:b]:
            total += size[c]
            deep = max(deep, depth[c])
        size[s] = min(total, CAP)
        depth[s] = deep + 1
    # top-down (parents first): the paths from the root to each shape, all of
    # them (IGES flattens) and those within one instance (STEP writes a shape
    # under a located reference once, as an instance)
    paths = [0] * n
    inst = [0] * n  # within-instance paths, then the shape's own count
    top = [False] * n  # under a located reference: an instance of its own
    root = m.root_shape
    if 0 <= root < n:
        paths[root] = 1
        top[root] = True
    cost = _shape_costs(m)
    step = 0
    for s in range(n - 1, -1, -1):
        if not paths[s]:
            continue
        inst[s] = min(inst[s] + top[s], CAP)
        step = min(step + inst[s] * cost[s], CAP)
        for k in range(start[s], start[s + 1]):
            c = kids[k]
            paths[c] = min(paths[c] + paths[s], CAP)
            if located[k]:
                top[c] = True
                step = min(step + inst[s] * _INSTANCE_BYTES, CAP)
            else:
                inst[c] = min(inst[c] + inst[s], CAP)
    iges = sum(min(p * b, CAP) for p, b in zip(paths, cost))
    tables = [_table(m.surfaces, m.curves3d), _table(m.curves3d), _table(m.curves2d)]
    poles = sum(t.poles for t in tables)
    bases = max((d for t in tables for d in t.depth), default=0)
    pcurves, projection = pcurves_to_compute(m, tables[0].work)
    return Expansion(
        references=size[root] if 0 <= root < n else 0,
        depth=max(depth, default=0),
        poles=poles,
        bases=bases,
        pcurves=pcurves,
        projection=projection,
        step_bytes=min(step, CAP),
        iges_bytes=min(iges, CAP),
    )


#: Points OCCT samples on a 3-D curve to project it, at least
#: (``ShapeConstruct_ProjectCurveOnSurface::Perform``'s ``NCONTROL``).
SAMPLES = 23


def curve_samples(table: list[Geometry], row: int) -> int:
    """Points OCCT samples on 3-D curve ``row`` to project it
    (``ShapeConstruct_ProjectCurveOnSurface::Perform``), at most: 23, or, on
    a B-spline (or a trimmed curve on one), (degree + 1) per knot interval
    that meets the edge's range, rounded up to 23 + 22k.  Every interval is
    counted: the ranges are not all known before the nets are decoded
    (``rules.ranges.resolve_ranges``), and the corpus's edges mostly run over
    their whole curve.  Each point is one inversion onto the surface: a
    Newton step from the point before, or a search over the whole surface
    where that fails."""
    g = _basis(table, row, (Kind.TRIMMED_CURVE,))
    if not isinstance(g, BSplineCurve) or g.bezier:
        return SAMPLES
    need = (len(g.knots) - 1) * (g.degree + 1)
    steps = max(0, -(-(need - SAMPLES) // (SAMPLES - 1)))
    return SAMPLES + (SAMPLES - 1) * steps


def edge_samples(m: BRepModel, edges: set[int]) -> dict[int, int]:
    """:func:`curve_samples` for the 3-D curve of each edge of ``edges`` (its
    first 3-D curve representation, the one ``BRep_Tool::Curve`` gives), and
    ``SAMPLES`` for an edge without one."""
    out = dict.fromkeys(edges, SAMPLES)
    seen: set[int] = set()
    reps = m.edge_reps
    for e, c in reps[reps[:, EC.KIND] == RepKind.CURVE3D][:, [EC.EDGE, EC.CURVE]].tolist():
        if e in out and e not in seen and c >= 0:
            seen.add(e)
            out[e] = curve_samples(m.curves3d, c)
    return out


def projections(m: BRepModel, work: list[int] | None = None) -> list[tuple[int, int, int]]:
    """What ``occ.topology.rebuild_pcurves`` projects: per edge representation
    whose pcurve is left out (in row order), its row, the faces with its
    surface row and location (it is projected onto each), and its work
    (``Limits.projection``): those faces times the surface's ``work`` per
    point (per surface row, as :func:`_table` gives it) times the points
    sampled on the edge's 3-D curve (:func:`curve_samples`).  Rows that no
    face takes are left out."""
    if work is None:
        work = _table(m.surfaces, m.curves3d).work
    faces = Counter(zip(m.face_surface.tolist(), m.face_loc.tolist()))
    reps = m.edge_reps
    rows = np.flatnonzero(
        (reps[:, EC.KIND] != RepKind.CURVE3D) & (reps[:, EC.CURVE] == REBUILD)
    ).tolist()
    todo = reps[rows][:, [EC.EDGE, EC.SURFACE, EC.LOC]].tolist()
    samples = edge_samples(m, {e for e, _, _ in todo})
    out = []
    for q, (e, s, loc) in zip(rows, todo):
        n = faces.get((s, loc), 0)
        if n and 0 <= s < len(work):
            out.append((q, n, min(n * work[s] * samples[e], CAP)))
    return out


def pcurves_to_compute(m: BRepModel, work: list[int] | None = None) -> tuple[int, int]:
    """The number of projections (:func:`projections`) and their work."""
    count = total = 0
    for _, n, w in projections(m, work):
        count += n
        total = min(total + w, CAP)
    return count, total


def degenerate_rows(table: list[Geometry]) -> list[bool]:
    """Per row of a surface table: whether it is a B-spline or Bezier surface
    whose poles all lie on one line (or at one point), or a trimmed or offset
    surface on such a basis.  Such a surface has no area: no face lies on it,
    and OCCT's projection onto it is the costliest there is (a 30 x 30 net of
    degree 25: 2.1 s a pcurve, against 72 ms for the same net made a plane
    and 0.25-0.45 ms for a corpus pcurve).  Weights are ignored (the surface
    lies in the poles' convex hull either way); non-finite poles (a coded net
    not decoded yet) count as not degenerate."""
    out: list[bool] = []
    for g in table:
        if isinstance(g, BSplineSurface):
            p = g.poles.reshape(-1, g.poles.shape[-1])
            if not np.isfinite(p).all():
                out.append(False)
                continue
            q = p - p.mean(axis=0)
            ev = np.linalg.eigvalsh(q.T @ q)  # ascending
            out.append(bool(ev[-2] <= 1e-18 * ev[-1]))  # a second axis below 1e-9 of the first
        elif isinstance(g, Derived) and g.kind not in (Kind.REVOLUTION, Kind.EXTRUSION):
            out.append(out[g.basis] if 0 <= g.basis < len(out) else False)
        else:
            out.append(False)
    return out


def check_projections(m: BRepModel) -> None:
    """Refuse a model that leaves a pcurve to compute (§2.8) on a surface
    with no area (:func:`degenerate_rows`): checked once the nets are
    decoded, before OCCT builds anything.

    Raises
    ------
    CorruptError
        One line naming the surface row.
    """
    reps = m.edge_reps
    todo = reps[(reps[:, EC.KIND] != RepKind.CURVE3D) & (reps[:, EC.CURVE] == REBUILD)]
    if not len(todo):
        return
    rows = sorted({int(r) for r in todo[:, 4].tolist()})
    flat = degenerate_rows(m.surfaces)
    for r in rows:
        if 0 <= r < len(flat) and flat[r]:
            raise CorruptError(
                f"a pcurve is to be computed on surface row {r}, whose poles lie on one line "
                "(a surface with no area)"
            )


def declare(m: BRepModel) -> dict[str, int]:
    """What ``m`` decodes into, for META ``decoded`` (``DECLARED``): only the
    measures past what a reader admits anyway (the default limits, the
    output's floor), so that a container within them spends no byte on it."""
    e = expansion(m)
    every = {"rows": table_rows(m), **{k: getattr(e, k) for k in DECLARED if k != "rows"}}
    allowed = {k: getattr(DEFAULT, k, DEFAULT.output_floor) for k in DECLARED}
    return {k: v for k, v in every.items() if v > allowed[k]}


def declared(meta: dict[str, object]) -> dict[str, int]:
    """META's ``decoded`` (absent: nothing declared).

    Raises
    ------
    SectionError
        Not an object of non-negative integers.
    """
    d = meta.get("decoded", {})
    if not isinstance(d, dict):
        raise SectionError("META: decoded is not an object")
    out = {}
    for k, v in d.items():
        if not isinstance(v, int) or isinstance(v, bool) or v < 0:
            raise SectionError("META: decoded holds a value that is not a count")
        if k in DECLARED:
            out[k] = v
    return out


def table_rows(m: BRepModel) -> int:
    """Rows of the tables the decoder loops over: shapes, sub-shape
    references, edge and vertex representations, geometry rows, location factors."""
    rows = len(m.shape_type) + len(m.child_shape) + len(m.edge_reps) + len(m.vertex_reps)
    rows += len(m.surfaces) + len(m.curves3d) + len(m.curves2d)
    return rows + sum(len(loc.datums) for loc in m.locations)


def _refuse(value: int, what: str, limit: int) -> LimitError:
    shown = f"{value:,}" if value < CAP else f"more than {CAP:,}"
    return LimitError(
        f"the shape holds {shown} {what}, more than the {limit:,} a reader decodes "
        "(--limit-scale raises the limits)"
    )


def check_structure(m: BRepModel, limits: Limits = DEFAULT) -> Expansion:
    """Refuse a model whose references, depth, poles or pcurves are past ``limits``.

    Raises
    ------
    LimitError
        One line naming the measure, its value and the limit.
    """
    rows = table_rows(m)
    if rows > limits.rows:
        raise _refuse(
            rows, "table rows (shapes, references, representations, geometry)", limits.rows
        )
    e = expansion(m)
    for name, what in (
        ("depth", "levels of nested sub-shapes"),
        ("references", "sub-shape references once sharing is unfolded"),
        ("poles", "poles and knots"),
        ("bases", "levels of geometry on geometry (trimmed, offset bases)"),
        ("pcurves", "pcurves to compute"),
        (
            "projection",
            "units of work projecting them (points x poles x degrees of their surfaces)",
        ),
    ):
        if getattr(e, name) > getattr(limits, name):
            raise _refuse(getattr(e, name), what, getattr(limits, name))
    return e


def check_output(
    m: BRepModel, fmt: str, container_bytes: int, limits: Limits = DEFAULT
) -> Expansion:
    """Refuse a model whose ``fmt`` output (``"STEP"``, ``"IGES"``, ``"BREP"``)
    is estimated past ``limits.output(container_bytes)``.

    Raises
    ------
    LimitError
        One line with the estimate and the limit.
    """
    e = expansion(m)
    size = e.iges_bytes if fmt == "IGES" else e.step_bytes
    limit = limits.output(container_bytes)
    if size > limit:
        raise LimitError(
            f"the {fmt} output would take about {size:,} bytes, more than the {limit:,} a "
            f"reader writes from a container of {container_bytes:,} bytes "
            "(--limit-scale raises the limits)"
        )
    return e
