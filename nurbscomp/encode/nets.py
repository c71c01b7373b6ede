"""Which records of a model are coded, and how (docs/design.md §2, ``encode/``).

:func:`code_model` runs the per-net search of :mod:`nurbscomp.codec`
(:func:`codec.encode_net`, the paper's §6) once on each distinct B-spline
surface and 3-D B-spline curve, each held to its :func:`feature_limit`.
Coincident curves and surface sides are found first (:mod:`nurbscomp.rules.joins`):
a copy is not coded, it follows its leader.  :func:`tighten` codes records
again below their limit, for the validity stage.  :func:`face_records`,
:func:`edge_records` and :func:`kinked_records` name the records a face or an
edge stands on.

Still exact in this version: analytic geometry, and B-splines under an offset
(an offset of a moved geometry can move by more than its poles did).
"""

from __future__ import annotations

import collections
from collections.abc import Iterable, Sequence, Set
from dataclasses import dataclass, field, replace
from typing import Any, TypeVar, cast

import numpy as np

from .. import codec, serialize
from ..memo import Memo, digest
from ..model import (
    EC,
    BRepModel,
    BSplineCurve,
    BSplineSurface,
    Derived,
    Geometry,
    Kind,
    Rec,
    RepKind,
    ShapeType,
    Table,
    faces_around,
    first_row,
    records,
)
from ..rules import joins
from ..rules.nets import net_abscissae, net_basis
from ..serialize import SWEPT
from ..serialize.geometry import evenly_spaced
from . import coincide, deviation, knots, offsets, removal, weights


def resolve_row(table: list[Geometry], i: int, through: tuple[Kind, ...]) -> int:
    """The row of the record under row ``i``, following the bases of ``through`` kinds."""
    g = table[i]
    while isinstance(g, Derived) and g.kind in through:
        i = g.basis
        g = table[i]
    return i


def _offset_bases(
    table: list[Geometry], which: Table, offset: Kind, through: tuple[Kind, ...]
) -> set[Rec]:
    """Records under an offset: they must stay exact (an offset of a
    moved geometry moves by more than the poles did)."""
    first = first_row(table)
    out: set[Rec] = set()
    for g in table:
        if isinstance(g, Derived) and g.kind == offset:
            r = g.basis
            while True:
                out.add(Rec(which, first[r]))
                b = table[r]
                if isinstance(b, Derived) and b.kind in (*through, offset):
                    r = b.basis
                else:
                    break
    return out


def _offset_limits(m: BRepModel, srec: list[Rec], tol: float) -> dict[Rec, float]:
    """The B-spline rows that are only the basis of offset surfaces (no face
    lies on them, no other record derives from them), each with the pole
    bound its code is held to so that its offsets move by at most tol
    (:func:`offsets.limit`); a row with no such bound is not listed (it stays
    exact, :func:`_offset_bases`)."""
    by_basis = offsets.offsets_by_basis(m.surfaces)
    used = {srec[r] for r in m.face_surface.tolist()}
    used |= {  # a trimmed surface's basis (a swept one's is a curve)
        srec[g.basis]
        for g in m.surfaces
        if isinstance(g, Derived) and g.kind == Kind.TRIMMED_SURFACE
    }
    out: dict[Rec, float] = {}
    for r, d in sorted(by_basis.items()):
        g, k = m.surfaces[r], srec[r]
        if not isinstance(g, BSplineSurface) or k in used or k in out:
            continue
        # every offset of this record counts (a record may be several rows)
        d = max(dd for rr, dd in by_basis.items() if srec[rr] == k)
        lim = offsets.limit(g, d, tol, offsets.face_box(m, r))
        if lim is not None:
            out[k] = min(lim, feature_limit(g.poles, tol))
    return out


@dataclass
class Coded:
    """Every codable record of a model, coded once: ``record -> (code, decoded)``
    (:class:`~nurbscomp.model.Rec`, of the source's tables)."""

    surfaces: dict[Rec, tuple[codec.NetCode, Geometry]]
    curves: dict[Rec, tuple[codec.NetCode, Geometry]]
    tol: float
    #: curve record -> (surface row, side, reversed): copied from a decoded surface
    iso: dict[Rec, coincide.IsoSource] = field(default_factory=dict)
    #: every vertex snapped to the vertex grid (used where all its edges' curves are
    #: coded): its cluster's first vertex's grid point (:func:`coincide.vertex_clusters`)
    vgrid: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    #: coded records held to a limit below tol (:func:`feature_limit`, :func:`tighten`)
    fine: set[Rec] = field(default_factory=set)
    #: records coded again, tighter, and how many times (:func:`tighten`)
    tight: dict[Rec, int] = field(default_factory=dict)
    #: curve record -> (leader row, reversed): a copy of a coincident curve
    #: (:func:`coincide.twin_curves`), not coded itself
    twins: dict[Rec, tuple[int, int]] = field(default_factory=dict)
    #: (surface row, side) -> ((leader row, side), reversed): a side set to the
    #: leader's decoded side (:func:`coincide.twin_sides`)
    sides: dict[tuple[int, int], tuple[tuple[int, int], int]] = field(default_factory=dict)
    #: curve row -> its placement in the model's frame (:func:`joins.curve_placements`)
    where: dict[int, np.ndarray] = field(default_factory=dict)
    #: per vertex, the first vertex of its cluster
    vlead: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    #: records no code is within tol for (``codec.NoCodeError``): kept exact
    uncodable: set[Rec] = field(default_factory=set)
    #: the precision rational rows' weights are rounded to (:func:`weights.file_bits`),
    #: None: exact
    wbits: int | None = None
    #: the knot vectors rounded, and how (:func:`knots.plan`)
    kplan: knots.Plan = field(default_factory=dict)
    #: the reaches of the source's analytic rows (:func:`analytic.reaches`), once made
    reach: tuple[dict[int, float], dict[int, float]] | None = None
    #: the source's directions that are one (:func:`analytic.same_directions`), once made
    same: dict[bytes, np.ndarray] | None = None
    #: surface record -> the directions (0: u) it may lose inner knots in
    #: (:mod:`.removal`)
    removable: dict[Rec, tuple[int, ...]] = field(default_factory=dict)
    #: record -> its code with every knot, for each record that lost knots
    spares: dict[Rec, tuple[codec.NetCode, Geometry]] = field(default_factory=dict)
    #: the surface methods searched (``codec.SURFACE_SEARCH``, or the paper's)
    searched: tuple[codec.Method, ...] = codec.SURFACE_SEARCH
    #: records coded with the pole bound, not the refined one (:func:`rigid`)
    rigid: set[Rec] = field(default_factory=set)
    #: surface records coded without ``SPATIAL2`` (:func:`plain`)
    plained: set[Rec] = field(default_factory=set)
    #: records :func:`.assembly.assemble` keeps exact: past their limit once
    #: pinned and joined, whatever their code (``assembly.PAST_TIGHTER``)
    held: set[Rec] = field(default_factory=set)
    #: (curve record, its anchors' bytes, limit) -> its code between those
    #: anchors (``codec.Method.ANCHORED``), or None: none fits
    #: (``assembly._anchor_curves``; kept from candidate to candidate)
    anchored: dict[tuple[Rec, bytes, float], tuple[codec.NetCode, Geometry] | None] = field(
        default_factory=dict
    )

    def with_every_knot(self) -> Coded:
        """These codes with every record that lost knots back on its code
        with every knot, and no knot removed from now on (:func:`tighten`)."""
        back = set(self.spares)
        return replace(
            self,
            surfaces={**self.surfaces, **self.spares},
            removable={},
            spares={},
            rigid=self.rigid - back,  # a spare is coded as the record first was
            plained=self.plained - back,
            held=self.held - back,
        )


#: A coded net moves by at most this fraction of its size (:func:`feature_limit`).
FEATURE_FRACTION = 0.25


def _polyline(p: np.ndarray) -> np.ndarray:
    """Lengths of the polylines along the first axis of ``p`` (..., n, dim) -> (...)."""
    return np.sqrt((np.diff(p, axis=-2) ** 2).sum(-1)).sum(-1)


#: :func:`feature_limit`'s answers by a digest of the poles and tol: the
#: validity stage asks again for the same rows in every round's assembly
#: (bearing.iges at 0.01 mm: 69,514 asks, 20 µs each).
_LIMITS: Memo[float] = Memo(100_000)


def feature_limit(poles: np.ndarray, tol: float) -> float:
    """The bound a net is coded to: tol, or less on a feature smaller than tol.

    A curve's size is its control polygon's length; a surface's, the shorter of
    its longest u- and v-rows of poles.  A net moves by at most
    ``FEATURE_FRACTION`` of its size (and at least tol/1024): a face whose
    edges are shorter than tol would otherwise be coded out of shape, and a
    STEP reader re-projecting its edges adds or drops edges there (measured
    on an IGES file whose 213 faces have edges of 2-10 µm, at tol 10 µm).
    """
    return _LIMITS.get(digest(poles, tol), lambda: _feature_limit(poles, tol))


def _feature_limit(poles: np.ndarray, tol: float) -> float:
    if poles.ndim == 3:
        size = min(_polyline(np.swapaxes(poles, 0, 1)).max(), _polyline(poles).max())
    else:
        size = float(_polyline(poles))
    return float(np.clip(FEATURE_FRACTION * size, tol / 1024, tol))


#: Whether a code's bound is measured on the refined error net
#: (:mod:`.deviation`) rather than as its largest pole error.
SPREAD = True


#: Rows of at least this many poles are tried as arcs (``codec.ARCS``): the
#: first arc continuation is the fifth pole's.
ARC_POLES = 5


def arc_methods(g: BSplineSurface | BSplineCurve) -> tuple[codec.Method, ...]:
    """The arc methods (format 2.14) worth trying on ``g``: a rational
    surface's directions of degree 2 with at least :data:`ARC_POLES` poles,
    where a circle or a conic written as a B-spline has its arcs."""
    if not isinstance(g, BSplineSurface) or g.weights is None:
        return ()
    return tuple(
        m
        for m, axis in codec.ARCS.items()
        if (g.udegree, g.vdegree)[axis] == 2 and g.poles.shape[axis] >= ARC_POLES
    )


def _net_code(
    g: BSplineSurface | BSplineCurve,
    tol: float,
    methods: tuple[codec.Method, ...],
    origin: np.ndarray | None,
    limit: float,
    spread: bool = True,
) -> tuple[codec.NetCode, np.ndarray]:
    """``g``'s poles coded within ``limit`` (:func:`codec.encode_net`, on the
    abscissae and basis of ``g``'s knots, as the decoder's; with ``SPREAD``,
    and ``spread``, each trial's bound measured on its refined error net,
    :mod:`.deviation`), and the decoded poles."""
    s, t = net_abscissae(g)
    basis = net_basis(g)
    if codec.Method.SPATIAL in methods:  # the arcs before SPATIAL2: it may skip trials then
        arcs = arc_methods(g)
        at = methods.index(codec.Method.SPATIAL2) if codec.Method.SPATIAL2 in methods else None
        methods = (*methods, *arcs) if at is None else (*methods[:at], *arcs, *methods[at:])
    code = codec.encode_net(
        g.poles,
        s,
        t,
        tol,
        methods,
        paper=False,
        origin=origin,
        basis=basis,
        limit=limit,
        measure=deviation.measure(g) if SPREAD and spread else None,
    )
    net, _ = codec.decode_net(code, g.poles.shape, s, t, tol, origin, basis)
    return replace(code, first=net.reshape(-1, net.shape[-1])[0]), net


def _code_one(
    g: BSplineSurface | BSplineCurve,
    tol: float,
    methods: tuple[codec.Method, ...],
    paper: bool,
    origin: np.ndarray | None,
    limit: float,
    wbits: int | None = None,
    kplan: knots.Plan | None = None,
    removable: tuple[int, ...] = (),
    spare: list[tuple[codec.NetCode, Geometry]] | None = None,
    spread: bool = True,
) -> tuple[codec.NetCode, Geometry]:
    """One record's code (:func:`codec.encode_net`) and the record as decoded.

    ``paper`` widens the surface search to every method of the paper (the
    caller's ``methods``); the paper's quantizer is never used: the format
    reserves it (docs/format.md §2.4), so ``encode_net`` is never asked for it.

    With ``wbits``, a rational record's weights are rounded to that precision
    (:func:`weights.rounded`) where their term of the bound
    (:func:`weights.weight_bound`) fits between the code's bound and
    ``limit``: the poles are coded as they would be with exact weights, and the
    code's bound is the sum.  Not under a D-map, whose basis holds the weights
    (eq. 18).

    With ``kplan`` (:func:`knots.plan`), a record's inner knots
    are rounded as planned (:func:`knots.apply`, a move of at most
    :data:`knots.SHARE` of ``limit``), and its poles coded on the rounded
    knots (eq. 1: the decoder's abscissae and basis come from them) to
    ``limit``; the code's bound is the code's plus the move.  Only where that
    sum is past ``limit`` is it coded again to ``limit`` less the move (a
    quarter-octave step finer, where the bound was that near the limit), and
    where no code fits the record keeps its knots.

    With ``removable`` (directions, 0: u), a surface is also coded with inner
    knots of those directions removed (:func:`_removed`, :mod:`.removal`),
    and that code is kept where its estimated size (:func:`_size`) is
    smaller; the code with every knot is then appended to ``spare``.

    ``spread``: bounds measured on the refined error net (:func:`_net_code`).
    The code returned remembers ``limit`` (``NetCode.limit``)."""
    tries = [(g, 0.0, limit)]
    if kplan:
        rounded, kterm = knots.apply(g, kplan, limit)
        if rounded is not g:
            tries = [(rounded, kterm, limit), (rounded, kterm, limit - kterm), *tries]
    for h, kterm, room in tries:  # the last is g as it is
        try:
            code, net = _net_code(h, tol, methods, origin, room, spread)
        except codec.NoCodeError:
            if h is g:
                raise
            continue
        if code.bound + kterm <= limit:
            code = replace(code, bound=code.bound + kterm)
            break
    # rounded knots: the bound measured against the source row (knots.moved)
    was = g if h is not g else None
    out = _rounded_weights(replace(code, limit=limit), g, replace(h, poles=net), wbits, limit, was)
    if removable:
        fewer = _removed(g, tol, methods, origin, limit, wbits, removable, spread, kplan)
        # a lowered row only where it saves a good share: moved to the edge of
        # its budget, it may cost the validity stage more than it saves
        gain = LOWERED_GAIN if fewer is not None and _lowered(fewer[1], g) else 1.0
        if fewer is not None and _size(fewer, _left_knot_bits(fewer[1], g)) < gain * _size(out):
            if spare is not None:
                spare.append(out)
            return fewer
    return out


def _rounded_weights(
    code: codec.NetCode,
    base: BSplineSurface | BSplineCurve,
    decoded: BSplineSurface | BSplineCurve,
    wbits: int | None,
    limit: float,
    source: BSplineSurface | BSplineCurve | None = None,
) -> tuple[codec.NetCode, Geometry]:
    """``decoded`` (the rational row ``base`` as coded) with ``base``'s weights
    rounded to ``wbits`` (:mod:`.weights`) where their term fits between the
    code's bound and ``limit``.  Not under a D-map, whose basis holds the
    weights (eq. 18).  ``source``: the row ``base`` was made from by removing
    knots, which the new bound is measured against (:func:`knots.moved`)."""
    if wbits is None or code.method == codec.Method.DMAP:
        return code, decoded
    if base.weights is None:
        return code, decoded
    w = weights.rounded(base.weights, wbits)
    if code.bound + weights.weight_bound(base, w) > limit:
        return code, decoded  # (a shortcut: the poles' term hardly moves with the weights)
    rounded = replace(decoded, weights=w)
    # the poles' term on the rounded weights' basis, and the weights' own
    bound = weights.moved(rounded, base) if source is None else knots.moved(rounded, source)
    if bound <= limit:
        return replace(code, bound=bound), rounded
    return code, decoded


#: Whether surfaces may lose inner knots (:mod:`.removal`).
REMOVAL = True

#: Whether coded 3-D curves may lose inner knots too (:mod:`.removal`).
CURVE_REMOVAL = True

#: The share of a surface's limit its removed knots may take (:mod:`.removal`).
REMOVAL_SHARE = 0.5

#: What a knot is taken to cost against a code's estimated bits
#: (:func:`_size`): its float, about half of it left by the entropy stage.
KNOT_BITS = 32.0


#: What a curve's inner knot left as the source has it (knots removed: not
#: rounded, :mod:`.knots`) is taken to cost: a float LZMA finds little in.
RAW_KNOT_BITS = 64.0


def _size(coded: tuple[codec.NetCode, Geometry], curve_knot: float = KNOT_BITS) -> float:
    """A coded row's estimated bits: its code's, its knots' and its weights'
    (a curve's inner knots at ``curve_knot`` bits each, none where the writer
    codes them as evenly spaced: docs/format.md §2.3, forms 2 and 6)."""
    code, g = coded
    w = getattr(g, "weights", None)
    bits = code.bits + KNOT_BITS * (0 if w is None else w.size)
    if isinstance(g, BSplineCurve):
        return bits + (0.0 if evenly_spaced(g.knots) else curve_knot * (len(g.knots) - 2))
    n = len(g.uknots) + len(g.vknots) if isinstance(g, BSplineSurface) else 0
    return bits + KNOT_BITS * n


#: Whether a row's knots left after removal are rounded as its source's
#: would be (:func:`knots.apply_reduced`, bound by :func:`knots.bridged`).
ROUND_REDUCED = True


def _left_knot_bits(h: Geometry, g: Geometry) -> float:
    """What a knot left on ``h`` (``g`` with knots removed) is taken to cost:
    ``RAW_KNOT_BITS`` where they are ``g``'s, ``KNOT_BITS`` where rounded."""
    kept = all(
        np.isin(a, b).all()
        for a, b in zip(knots.vectors(cast(Any, h)), knots.vectors(cast(Any, g)))
    )
    return RAW_KNOT_BITS if kept else KNOT_BITS


#: The share of a row's estimated bits with every knot (:func:`_size`) its
#: code of lowered degree must come under to be kept (:func:`_code_one`):
#: bearing.iges, its patches of degree 4 to 6 lowered within 0.001 mm for
#: 1% of the nets' bytes, came out 30 bytes larger at 0.01 mm after three
#: more validity rounds (9,840 bytes; 9,793 with this share, 9,810 with
#: nothing lowered), and a sixth slower.
LOWERED_GAIN = 0.95


def _lowered(h: Geometry, g: Geometry) -> bool:
    """Whether ``h`` (``g`` with knots removed or degree lowered) is of lower degree."""
    return knots.degrees(cast(Any, h)) != knots.degrees(cast(Any, g))


#: Codes tried for a row of lowered degree (:func:`_removed`): its bound is
#: measured against the source (:func:`knots.lowered`), which the sum of the
#: code's and the lowering's bounds need not exceed; each try gives the code
#: the room left less the excess.
LOWERED_TRIES = 3


def _removed(
    g: BSplineSurface | BSplineCurve,
    tol: float,
    methods: tuple[codec.Method, ...],
    origin: np.ndarray | None,
    limit: float,
    wbits: int | None,
    axes: tuple[int, ...],
    spread: bool = True,
    kplan: knots.Plan | None = None,
) -> tuple[codec.NetCode, Geometry] | None:
    """``g`` with inner knots of directions ``axes`` removed within
    ``REMOVAL_SHARE`` of ``limit`` (:func:`removal.removed`), its knots left
    then rounded as ``kplan`` rounds ``g``'s where that adds at most
    ``knots.SHARE`` of ``limit`` (:func:`knots.apply_reduced`), coded to the
    rest of it; None where no knot goes or no code fits."""
    r = removal.removed(g, REMOVAL_SHARE * limit, axes)
    if r is None:
        return None
    h, d = r
    if kplan and ROUND_REDUCED:  # its knots rounded as the source's would be
        hr, dr = knots.apply_reduced(h, g, kplan)
        if dr <= d + knots.SHARE * limit:
            h, d = hr, dr
    lower = _lowered(h, g)
    room = limit - d
    for _ in range(LOWERED_TRIES if lower else 1):
        try:
            code, net = _net_code(h, tol, methods, origin, room, spread)
        except codec.NoCodeError:
            return None
        bound = code.bound + d
        if lower:  # measured as every later step measures it (knots.lowered)
            bound = knots.moved(replace(h, poles=net), g)
        if bound <= limit:
            break
        room -= bound - limit
        if room <= 0:
            return None
    else:
        return None
    coded = replace(code, bound=bound, limit=limit)
    return _rounded_weights(coded, h, replace(h, poles=net), wbits, limit, g)


def _code_table(
    table: list[Geometry],
    which: Table,
    tol: float,
    keep: set[Rec],
    methods: tuple[codec.Method, ...],
    paper: bool,
    anchors: dict[Rec, np.ndarray] | None = None,
    limits: dict[Rec, float] | None = None,
    uncodable: set[Rec] | None = None,
    wbits: int | None = None,
    kplan: knots.Plan | None = None,
    removable: dict[Rec, tuple[int, ...]] | None = None,
    spares: dict[Rec, tuple[codec.NetCode, Geometry]] | None = None,
    rigid: Set[Rec] = frozenset(),
) -> dict[Rec, tuple[codec.NetCode, Geometry]]:
    """Code each distinct B-spline record of ``table`` (see :func:`code_model`),
    those of ``rigid`` with the pole bound;
    ``anchors`` maps records to :func:`joins.anchors` points, ``limits``
    to a limit below :func:`feature_limit`'s.  A record no code is within its
    limit for is left out (exact) and added to ``uncodable``.  Records of
    ``removable`` may lose inner knots (:func:`_code_one`); where they do,
    their code with every knot goes to ``spares``."""
    out: dict[Rec, tuple[codec.NetCode, Geometry]] = {}
    origin = None
    for k, g in zip(records(table, which), table):
        if k in out or k in keep or not isinstance(g, (BSplineSurface, BSplineCurve)):
            continue
        at = (anchors or {}).get(k, origin)
        limit = feature_limit(g.poles, tol)
        limit = min(limit, (limits or {}).get(k, limit))
        try:
            spare: list[tuple[codec.NetCode, Geometry]] = []
            out[k] = _code_one(
                g,
                tol,
                methods,
                paper,
                at,
                limit,
                wbits,
                kplan,
                (removable or {}).get(k, ()),
                spare,
                spread=k not in rigid,
            )
            if spare and spares is not None:
                spares[k] = spare[0]
        except codec.NoCodeError:  # doubles too coarse for the steps here: exact
            if uncodable is not None:
                uncodable.add(k)
            continue
        origin = out[k][0].first
    return out


#: A record a STEP reader mends (``validity.lossy_target``) is coded again,
#: this many times tighter, before it is kept exact.
TIGHTER = 8


def recode(
    coded: Coded,
    k: Rec,
    g: BSplineSurface | BSplineCurve,
    methods: tuple[codec.Method, ...],
    origin: np.ndarray | None,
    limit: float,
) -> tuple[codec.NetCode, Geometry]:
    """Record ``k`` (the source's row ``g``) coded again to ``limit``, as
    ``coded`` codes its records (weights, knots rounded or removed)."""
    return _code_one(
        g,
        coded.tol,
        methods,
        False,
        origin,
        limit,
        coded.wbits,
        coded.kplan,
        coded.removable.get(k, ()),
        spread=k not in coded.rigid,
    )


def tighten(coded: Coded, m: BRepModel, recs: Iterable[Rec], level: int = 1) -> None:
    """Code the records ``recs`` of ``m`` (the source) again to
    1/``TIGHTER``^``level`` of their limit, in place (those already that
    tight, and those not coded, are left).

    Their vertices then stay where they are (``coded.fine``).  A record's
    first pole is coded against the origin it had; the container re-bases it
    on the chain as written (:func:`codec.reorigin`).
    """
    for k in recs:
        surface = k.table == Table.SURFACE
        done = coded.surfaces if surface else coded.curves
        methods: tuple[codec.Method, ...] = codec.TIGHT_SEARCH if surface else codec.CURVE_METHODS
        g = m.surfaces[k.row] if surface else m.curves3d[k.row]
        if k in done and coded.tight.get(k, 0) < level:
            assert isinstance(g, (BSplineSurface, BSplineCurve))
            code = done[k][0]
            # never looser than it is (a twin leader may be held below its own limit)
            floor = max(code.bound, coded.tol / 1024)
            limit = min(feature_limit(g.poles, coded.tol) / TIGHTER**level, floor)
            try:
                done[k] = recode(coded, k, g, methods, code.origin, limit)
            except codec.NoCodeError:  # as tight as doubles allow here: the code it has
                continue
            coded.fine.add(k)
            coded.tight[k] = level


def plain(coded: Coded, m: BRepModel, recs: Iterable[Rec]) -> set[Rec]:
    """Code the surface records of ``recs`` whose code is ``SPATIAL2`` (or
    another of ``codec.CHOSEN``) again, to the limit they had, without
    them (``codec.TIGHT_SEARCH``), in place; return those recoded.  Those
    codes leave each pole anywhere within
    its bound, not on its nearest grid point; where the rebuilt B-rep has a
    fault near such a net, the validity stage tries this first: it costs
    less than a net 64 times tighter or stored pcurves.
    """
    out = set()
    for k in recs:
        if k.table != Table.SURFACE or k not in coded.surfaces:
            continue
        code = coded.surfaces[k][0]
        if code.method not in codec.CHOSEN:
            continue
        g = m.surfaces[k.row]
        assert isinstance(g, BSplineSurface)
        limit = feature_limit(g.poles, coded.tol) / TIGHTER ** coded.tight.get(k, 0)
        if code.limit is not None:  # never looser than it was coded to (a twin leader,
            limit = min(limit, code.limit)  # a net coded tighter for a far pin)
        try:
            coded.surfaces[k] = recode(coded, k, g, codec.TIGHT_SEARCH, code.origin, limit)
        except codec.NoCodeError:
            continue
        out.add(k)
        coded.plained.add(k)
    return out


def rigid(coded: Coded, m: BRepModel, recs: Iterable[Rec]) -> bool:
    """Code the records ``recs`` of ``m`` (the source) again with the pole
    bound (each trial's bound its largest pole error, as the decoder's pins
    and joined sides assume), to the limit each was coded to, in place;
    whether any was.

    A net coded to the refined bound (:mod:`.deviation`) may have poles far
    past its limit where the basis averages their errors.  A pin that sets
    a corner to its vertex, or a side set to its leader's, then changes
    errors the average relied on, and the row may end past its limit
    (``assembly.assemble`` finds those).  With the pole bound a pinned
    corner or a copied side moves no pole further than the limit.
    """
    changed = False
    for k in recs:
        surface = k.table == Table.SURFACE
        done = coded.surfaces if surface else coded.curves
        if k in coded.rigid or k not in done:
            continue
        coded.rigid.add(k)
        code = done[k][0]
        g = m.surfaces[k.row] if surface else m.curves3d[k.row]
        assert isinstance(g, (BSplineSurface, BSplineCurve))
        limit = code.limit if code.limit is not None else feature_limit(g.poles, coded.tol)
        methods: tuple[codec.Method, ...] = codec.CURVE_METHODS
        if surface:
            plain_only = k in coded.plained or k in coded.tight
            methods = codec.TIGHT_SEARCH if plain_only else coded.searched
        try:
            done[k] = recode(coded, k, g, methods, code.origin, limit)
        except codec.NoCodeError:
            continue
        coded.spares.pop(k, None)
        changed = True
    return changed


def _limit(g: Geometry, tol: float) -> float:
    """:func:`feature_limit` of a B-spline row (tol for any other)."""
    return feature_limit(g.poles, tol) if isinstance(g, (BSplineSurface, BSplineCurve)) else tol


TRIM_S = (Kind.TRIMMED_SURFACE,)
TRIM_C = (Kind.TRIMMED_CURVE,)


def code_model(
    m: BRepModel,
    tol: float,
    paper: bool = False,
    points: np.ndarray | None = None,
    sewn: Sequence[tuple[int, int]] = (),
    spread: bool = True,
    offsets_coded: bool = True,
) -> Coded:
    """Run the per-net search (:func:`codec.encode_net`) on every B-spline surface
    and 3-D curve of ``m`` that may move (not under an offset, but for an
    offset's basis no face lies on, within what the offset allows:
    :func:`_offset_limits`; not even those without ``offsets_coded``).

    With ``spread``, a code's bound is measured on its refined error net
    (:mod:`.deviation`) but for the surfaces with joined sides; without,
    every record takes the pole bound (``Coded.rigid``).

    A curve whose ends the decoder would pin to vertices too far from the
    original ends (:func:`joins.overreaching`) is left exact.

    Boundaries that coincide within ``coincide.TWIN_EPS`` (or tol/64) are coded
    once: a side of a net shared with an earlier net's side
    (:func:`coincide.twin_sides`) becomes that side after decoding, and a curve
    that is an earlier curve (:func:`coincide.twin_curves`) a copy of it.  The
    first of each is coded to a limit that leaves its copies within theirs.
    ``points`` (edges sampled along their ranges, :func:`occ.edge_points`)
    finds coincident edges, and ``sewn`` (pairs of edges the free-edge
    measure's sewing joins, :func:`occ.sewn_edge_pairs`) edges that meet in
    part or within their tolerances; those no copy covers (another
    representation of the same curve, a boundary cut elsewhere) keep their
    curves exact (:func:`_lonely_curves`).

    Surface nets are searched with ``codec.SURFACE_SEARCH``, or with every
    method of the paper when ``paper`` is set (methods 5 and 7 too; never the
    paper's quantizer, which the format reserves).
    """
    eps = min(coincide.TWIN_EPS, tol / 64)
    srec, crec = records(m.surfaces, Table.SURFACE), records(m.curves3d, Table.CURVE3D)
    keep_s = _offset_bases(m.surfaces, Table.SURFACE, Kind.OFFSET_SURFACE, TRIM_S)
    # bases coded within what their offsets allow
    held = _offset_limits(m, srec, tol) if offsets_coded else {}
    keep_s -= set(held)
    srows0 = first_rows(
        {k for k, g in zip(srec, m.surfaces) if isinstance(g, BSplineSurface)} - keep_s
    )
    plain_rows = {k.row for k in held}  # coded as they are: no sides, knots, removal
    twin = coincide.twin_sides(m.surfaces, sorted(srows0 - plain_rows), eps)
    sides = _affordable(m.surfaces, twin, tol)
    # where faces share an edge, its tolerance covers their coding errors: no
    # side needs joining there (joining would only move them off their other edges)
    on = _edges_by_surface(m)
    sides = {k: v for k, v in sides.items() if not on[k[0]] & on[v.leader[0]]}
    keep_c = _offset_bases(m.curves3d, Table.CURVE3D, Kind.OFFSET_CURVE, TRIM_C)
    candidates = {k for k, g in zip(crec, m.curves3d) if isinstance(g, BSplineCurve)}
    crows = first_rows(candidates - keep_c)
    wbits = weights.file_bits(
        (g, feature_limit(g.poles, tol))
        for table, rows in ((m.surfaces, srows0), (m.curves3d, crows))
        for g in (cast(BSplineSurface | BSplineCurve, table[r]) for r in sorted(rows))
    )
    searched = codec.SURFACE_METHODS if paper else codec.SURFACE_SEARCH
    # knots rounded where nothing copies the row (:mod:`.knots`): not on joined
    # sides; an iso-boundary curve takes its side's knots (assembly._copy_iso),
    # a twin its leader's (assembly._copy_twins)
    joined = {r for k, v in sides.items() for r in (k[0], v.leader[0])}
    # a side set to its leader's keeps the leader's pole errors, which the
    # follower's own refined bound did not average: both take the pole bound
    rigid = {srec[r] for r in joined} | set(held) if spread else {*srec, *crec}
    iso_eps = min(eps, coincide.ISO_EPS)
    copied = coincide.iso_sources(m, crows, srows0, iso_eps)
    where = joins.curve_placements(m)
    pairs = coincide.twin_curves(m.curves3d, crows, eps, set(copied), where)
    sfirst, cfirst = first_row(m.surfaces), first_row(m.curves3d)
    kplan = knots.plan(
        [
            *(
                (
                    g,
                    _limit(g, tol)
                    if sfirst[r] in srows0 and sfirst[r] not in joined | plain_rows
                    else None,
                )
                for r, g in enumerate(m.surfaces)
            ),
            *(
                (g, _limit(g, tol) if cfirst[c] in crows else None)
                for c, g in enumerate(m.curves3d)
                if cfirst[c] not in copied  # an iso copy takes its side's knots
            ),
        ],
        [(m.curves3d[c], m.curves3d[t.leader]) for c, t in pairs.items()],
    )
    uncodable: set[Rec] = set()
    # knots removed along no joined side (:mod:`.removal`): sides 0 and 1
    # run along v, 2 and 3 along u
    along: dict[int, set[int]] = collections.defaultdict(set)
    for (b, j), v in sides.items():
        along[b].add(j // 2)
        along[v.leader[0]].add(v.leader[1] // 2)
    spares: dict[Rec, tuple[codec.NetCode, Geometry]] = {}
    removable = (
        {
            srec[r]: tuple(axis for axis in (0, 1) if 1 - axis not in along[r])
            for r in srows0 - plain_rows
        }
        if REMOVAL
        else {}
    )
    surfaces = _code_table(
        m.surfaces,
        Table.SURFACE,
        tol,
        keep_s,
        searched,
        paper,
        limits={**_leader_limits(m.surfaces, srec, sides, tol), **held},
        uncodable=uncodable,
        wbits=wbits,
        kplan=kplan,
        removable=removable,
        spares=spares,
        rigid=rigid,
    )
    h = serialize.vertex_grid(tol)
    # vertices at one point (within TWIN_VERTEX) snap as one: to their first's grid point
    lead = coincide.vertex_clusters(m.vertex_point, coincide.TWIN_VERTEX)
    vgrid = np.rint(m.vertex_point[lead] / h).astype(np.int64) * h  # as the decoder reads it
    snapped: Any = replace(m)
    snapped.vertex_point = vgrid
    decoded_s = [surfaces[k][1] if k in surfaces else g for k, g in zip(srec, m.surfaces)]
    srows = first_rows(surfaces)
    radius = joins.pin_radii(srec, {k: c for k, (c, _) in surfaces.items()}, tol)
    followers = {b for b, _ in sides}
    for r in sorted(_far_pinned(m, snapped, decoded_s, srows, tol, radius)):
        k = srec[r]
        # not a net with a side set to its leader's: those corners are the leader's
        closer = (
            None
            if r in followers
            else _pinned_closer(m, snapped, k, surfaces[k], tol, searched, paper, wbits, kplan)
        )
        if closer is None:
            surfaces.pop(k)
        else:  # coded to suit, with every knot
            surfaces[k] = closer
            spares.pop(k, None)
    # a near copy within half its limit: the surface is coded to the rest
    iso = _affordable(
        m.curves3d, coincide.iso_sources(m, crows, first_rows(surfaces), iso_eps), tol
    )
    iso_recs = {crec[c]: src for c, src in iso.items()}
    twins = coincide.twin_curves(m.curves3d, crows, eps, set(iso), where)
    twins = _affordable(m.curves3d, twins, tol)
    if points is not None:  # coincident edges no copy covers: their curves stay exact
        lonely = _lonely_curves(m, points, twins, iso, sides, sewn)
        keep_c = keep_c | {crec[r] for r in lonely}
        iso = {c: v for c, v in iso.items() if c not in lonely}
        iso_recs = {crec[c]: src for c, src in iso.items()}
        twins = {c: v for c, v in twins.items() if c not in lonely}
    twin_recs = {crec[c]: (r, rev) for c, (r, rev, _) in twins.items()}
    limits = _leader_limits(m.curves3d, crec, twins, tol)
    # a surface whose boundary a copy takes is coded to suit: a near copy
    # moves by its distance more, a twin of that copy by the twins' distance
    needs = [(c, src.surface, src.distance) for c, src in iso.items() if src.distance > 0]
    needs += [
        (c, iso[r].surface, d + iso[r].distance) for c, (r, _, d) in twins.items() if r in iso
    ]
    for c, s, d in needs:
        need = feature_limit(cast(BSplineCurve, m.curves3d[c]).poles, tol) - d
        sk = srec[s]
        code = surfaces[sk][0] if sk in surfaces else None
        if code is not None and code.bound > need:
            sg = m.surfaces[s]
            assert isinstance(sg, BSplineSurface)
            try:
                surfaces[sk] = _code_one(sg, tol, searched, paper, code.origin, need, wbits, kplan)
                spares.pop(sk, None)  # coded to suit, with every knot
            except codec.NoCodeError:
                del surfaces[sk]
                uncodable.add(sk)
    at = joins.anchors(m, m.curves3d, crows)
    if REMOVAL and CURVE_REMOVAL:
        # not a twin's leader (its copies take its poles), nor a curve whose
        # knot vector another row has (a sweep's, a loft's: stored once)
        leaders = {r for r, _, _ in twins.values()}
        shared = _shared_vectors(m, srows0, crows)
        removable.update(
            {
                crec[c]: (0,)
                for c in crows
                if c not in leaders and _vector_keys(m.curves3d[c])[0] not in shared
            }
        )
    coded = Coded(
        surfaces,
        _code_table(
            m.curves3d,
            Table.CURVE3D,
            tol,
            keep_c | set(iso_recs) | set(twin_recs),
            codec.CURVE_METHODS,
            paper,
            {crec[r]: a for r, a in at.items()},
            limits,
            uncodable,
            wbits,
            kplan,
            removable=removable,
            rigid=rigid,
        ),
        tol,
        iso_recs,
        vgrid,
        twins=twin_recs,
        where=where,
        vlead=lead,
        sides={k: (lead_side, rev) for k, (lead_side, rev, _) in sides.items()},
        uncodable=uncodable,
        wbits=wbits,
        kplan=kplan,
        removable=removable,
        spares={k: v for k, v in spares.items() if k in surfaces},
        searched=searched,
        rigid=set(rigid),
    )
    decoded = [coded.curves[k][1] if k in coded.curves else g for k, g in zip(crec, m.curves3d)]
    rows = {i for i, k in enumerate(crec) if k in coded.curves}
    for c in sorted(_overreaching(m, snapped, decoded, rows, tol)):
        closer = _ends_closer(m, snapped, coded, crec[c], decoded)
        if closer is None:
            coded.curves.pop(crec[c], None)
        else:
            coded.curves[crec[c]] = closer
    for recs, table in ((srec, m.surfaces), (crec, m.curves3d)):
        for k, g in zip(recs, table):
            if isinstance(g, (BSplineSurface, BSplineCurve)) and feature_limit(g.poles, tol) < tol:
                coded.fine.add(k)
    return coded


def _far_pinned(
    m: BRepModel,
    snapped: BRepModel,
    decoded: list[Geometry],
    rows: Set[int],
    tol: float,
    radius: dict[int, float],
) -> set[int]:
    """The coded surface rows of ``rows`` (``decoded``: the table as decoded)
    that the decoder would pin (:func:`joins.surface_corner_pins`, ``radius``
    by row) to a vertex further than tol from the source's corner, the
    vertex exact (``m``) or on the vertex grid (``snapped``)."""
    out = set()
    for mm in (m, snapped):  # a pin may go to the exact or to the snapped vertex
        for r, pins in joins.surface_corner_pins(mm, decoded, set(rows), tol, radius).items():
            g = m.surfaces[r]
            assert isinstance(g, BSplineSurface)
            if any(
                np.sqrt(((g.poles[joins.CORNERS[k]] - mm.vertex_point[v]) ** 2).sum()) > tol
                for k, v in pins
            ):
                out.add(r)
    return out


#: A surface whose corner the decoder would pin to a vertex further than tol
#: from the source's corner is coded this many times tighter, up to
#: :data:`FAR_PIN_TRIES` times, until its pin radius (the step of its
#: corners' grid, :func:`joins.pin_radius`) no longer reaches that vertex;
#: else it stays exact.
FAR_PIN_TIGHTER = 4
FAR_PIN_TRIES = 3


def _pinned_closer(
    m: BRepModel,
    snapped: BRepModel,
    k: Rec,
    coded: tuple[codec.NetCode, Geometry],
    tol: float,
    methods: tuple[codec.Method, ...],
    paper: bool,
    wbits: int | None,
    kplan: knots.Plan | None,
) -> tuple[codec.NetCode, Geometry] | None:
    """Record ``k`` (a surface :func:`_far_pinned` names, ``coded`` as it is)
    coded :data:`FAR_PIN_TIGHTER` times tighter at a time, with every knot,
    until no corner of it is pinned to a vertex further than tol from its own
    (:func:`_far_pinned` on the table with only this row decoded so); None
    where no code gets there.  Not for a net with a side set to its leader's
    (those corners are the leader's decoded ones)."""
    g = m.surfaces[k.row]
    assert isinstance(g, BSplineSurface)
    code = coded[0]
    limit = code.limit if code.limit is not None else feature_limit(g.poles, tol)
    for _ in range(FAR_PIN_TRIES):
        limit /= FAR_PIN_TIGHTER
        try:
            out = _code_one(g, tol, methods, paper, code.origin, limit, wbits, kplan)
        except codec.NoCodeError:
            return None
        rows = {i for i, kk in enumerate(records(m.surfaces, Table.SURFACE)) if kk == k}
        decoded = [out[1] if i in rows else s for i, s in enumerate(m.surfaces)]
        radius = joins.pin_radii([k], {k: out[0]}, tol)
        if not _far_pinned(m, snapped, decoded, {k.row}, tol, {k.row: radius[0]}):
            return out
    return None


def _overreaching(
    m: BRepModel, snapped: BRepModel, decoded: list[Geometry], rows: Set[int], tol: float
) -> set[int]:
    """:func:`joins.overreaching` with the vertices exact (``m``) or on the
    vertex grid (``snapped``)."""
    return joins.overreaching(m, decoded, set(rows), tol) | joins.overreaching(
        snapped, decoded, set(rows), tol
    )


def _ends_closer(
    m: BRepModel,
    snapped: BRepModel,
    coded: Coded,
    k: Rec,
    decoded: list[Geometry],
) -> tuple[codec.NetCode, Geometry] | None:
    """Curve record ``k``, whose decoded end the decoder would pin to a vertex
    further than tol from the source's end (:func:`_overreaching`; an end is
    pinned where its decoded pole is within tol of the vertex), coded again to
    half of what the source's end lies past tol from that vertex, so that its
    decoded end cannot come within tol of it; None where that is no bound a
    code reaches, or the new code is still pinned so (the record then stays
    exact, as before)."""
    g = m.curves3d[k.row]
    assert isinstance(g, BSplineCurve)
    code = coded.curves[k][0]
    tol = coded.tol
    far = [
        d
        for mm in (m, snapped)
        for pins in joins.curve_end_pins(mm, decoded, {k.row}, tol).values()
        for i, v in pins
        if (d := float(np.sqrt(((g.poles[0 if i == 0 else -1] - mm.vertex_point[v]) ** 2).sum())))
        > tol
    ]
    if code.limit is None or not far:
        return None
    gap = min(far)
    limit = min(code.limit, (gap - tol) / 2)
    try:
        out = recode(coded, k, g, codec.CURVE_METHODS, code.origin, limit)
    except codec.NoCodeError:
        return None
    rows = {i for i, kk in enumerate(records(m.curves3d, Table.CURVE3D)) if kk == k}
    again = [out[1] if i in rows else c for i, c in enumerate(decoded)]
    return None if _overreaching(m, snapped, again, {k.row}, tol) else out


def _vector_keys(g: Geometry) -> list[bytes]:
    """A B-spline row's knot vectors (u then v, or the curve's), each its
    knots and multiplicities bit for bit."""
    if isinstance(g, BSplineSurface):
        pairs = [(g.uknots, g.umults), (g.vknots, g.vmults)]
    else:
        assert isinstance(g, BSplineCurve)
        pairs = [(g.knots, g.mults)]
    return [
        np.asarray(k, np.float64).tobytes() + np.asarray(u, np.int64).tobytes() for k, u in pairs
    ]


def _shared_vectors(m: BRepModel, srows: Set[int], crows: Set[int]) -> set[bytes]:
    """Knot vectors (:func:`_vector_keys`) that more than one of the coded
    surface directions and 3-D curves have."""
    rows = [m.surfaces[r] for r in sorted(srows)] + [m.curves3d[c] for c in sorted(crows)]
    keys = collections.Counter(key for g in rows for key in _vector_keys(g))
    return {k for k, n in keys.items() if n > 1}


#: Edges whose points agree within this (mm) meet in the source: the sewing
#: tolerance of the free-edge measure, with room for the sampling.
COINCIDENT = 1e-6


def _lonely_curves(
    m: BRepModel,
    points: np.ndarray,
    twins: dict[int, coincide.Twin],
    iso: dict[int, coincide.IsoSource],
    sides: dict[tuple[int, int], coincide.Twin],
    sewn: Sequence[tuple[int, int]] = (),
) -> set[int]:
    """3-D curve rows of coincident edges (:func:`coincide.coincident_edges`) and
    of edges that meet in part (``sewn``: pairs of model edges) that would be
    coded apart: neither one curve, nor a copy and its leader (or two copies
    of one), nor the iso-boundaries of two joined sides.  Kept exact, they
    keep meeting (trj3 at 0.1: a closed curve given twice, with its poles in
    another order; a thick loft written as faces-mode IGES at 1e-5, whose
    top face's boundary is cut elsewhere than its sides': 40 new free edges
    at 0.01 mm otherwise)."""
    curve_of: dict[int, int] = {}
    reps = m.edge_reps
    for q in np.flatnonzero(reps[:, EC.KIND] == RepKind.CURVE3D).tolist():
        curve_of.setdefault(int(reps[q, EC.EDGE]), int(reps[q, EC.CURVE]))
    lead = {c: r for c, (r, _, _) in twins.items()}
    side_lead = {k: v.leader for k, v in sides.items()}

    def root(c: int) -> tuple[str, Any]:
        """What a curve's decoded poles come from: a copy's leader's source,
        an iso-boundary's (joined) side, or the curve itself."""
        c = lead.get(c, c)
        if c in iso:
            k = (iso[c].surface, iso[c].side)
            return ("side", side_lead.get(k, k))
        return ("curve", c)

    out: set[int] = set()
    for e1, e2 in sorted({*coincide.coincident_edges(points, COINCIDENT), *sewn}):
        r1, r2 = curve_of.get(e1, -1), curve_of.get(e2, -1)
        if r1 < 0 or r2 < 0 or r1 == r2:
            continue
        g1, g2 = m.curves3d[r1], m.curves3d[r2]
        if not (isinstance(g1, BSplineCurve) or isinstance(g2, BSplineCurve)):
            continue  # analytic curves are exact
        if root(r1) == root(r2):
            continue
        out |= {r for r, g in ((r1, g1), (r2, g2)) if isinstance(g, BSplineCurve)}
    return out


def _edges_by_surface(m: BRepModel) -> dict[int, set[int]]:
    """Per surface row, the edges of the faces on it."""
    out: dict[int, set[int]] = collections.defaultdict(set)
    for e, fs in enumerate(faces_around(m, ShapeType.EDGE)):
        for f in fs:
            out[int(m.face_surface[f])].add(e)
    return out


#: What :func:`_affordable` sorts: twin pairs, or near iso-boundary copies.
_Near = TypeVar("_Near", coincide.Twin, coincide.IsoSource)


def _affordable(table: list[Geometry], pairs: dict[Any, _Near], tol: float) -> dict[Any, _Near]:
    """The twin pairs (``{member: (leader, reversed, distance)}``, keys a row or
    (row, side)), or the near iso-boundary copies (``{curve row: IsoSource}``),
    whose distance is at most half the member's limit: the leader (the
    surface) is coded to the rest (:func:`_leader_limits`, :func:`code_model`)."""
    return {
        k: v
        for k, v in pairs.items()
        if v.distance <= feature_limit(poles_of(table[_row(k)]), tol) / 2
    }


def _leader_limits(
    table: list[Geometry], recs: list[Rec], pairs: dict[Any, coincide.Twin], tol: float
) -> dict[Rec, float]:
    """``{leader record: limit}``: a leader coded to this leaves each copy of it,
    which moves by the leader's bound plus their distance, within the copy's limit.
    ``recs``: per row of ``table``, its record."""
    out: dict[Rec, float] = {}
    for k, (lead, _, d) in pairs.items():
        key = recs[_row(lead)]
        own = out.get(key, feature_limit(poles_of(table[_row(lead)]), tol))
        out[key] = min(own, feature_limit(poles_of(table[_row(k)]), tol) - d)
    return out


def _row(key: int | tuple[int, int]) -> int:
    """The table row of a twin key: a curve row, or a (surface row, side)."""
    return key[0] if isinstance(key, tuple) else key


def poles_of(g: Geometry) -> np.ndarray:
    """The poles of a coded record (a B-spline curve or surface)."""
    return cast(BSplineCurve | BSplineSurface, g).poles


def first_rows(recs: Iterable[Rec], which: Table | None = None) -> set[int]:
    """The rows of ``recs`` (the rows where they first occur), of the ``which``
    table only when given."""
    return {k.row for k in recs if which is None or k.table == which}


def face_records(m: BRepModel) -> list[Rec]:
    """Per face, the record it moves with: its surface (trimmed -> basis), for
    a swept surface the swept curve (trimmed -> basis), for an offset surface
    its basis."""
    sfirst, cfirst = first_row(m.surfaces), first_row(m.curves3d)
    out = []
    for r in m.face_surface.tolist():
        r = resolve_row(m.surfaces, r, TRIM_S)
        g = m.surfaces[r]
        if isinstance(g, Derived) and g.kind in SWEPT:
            out.append(Rec(Table.CURVE3D, cfirst[resolve_row(m.curves3d, g.basis, TRIM_C)]))
        elif isinstance(g, Derived) and g.kind == Kind.OFFSET_SURFACE:
            out.append(Rec(Table.SURFACE, sfirst[g.basis]))  # it moves with its basis
        else:
            out.append(Rec(Table.SURFACE, sfirst[r]))
    return out


def edge_records(m: BRepModel) -> list[Rec | None]:
    """Per edge, its 3-D curve's record (trimmed -> basis), or None."""
    cfirst = first_row(m.curves3d)
    out: list[Rec | None] = [None] * len(m.edge_tol)
    reps = m.edge_reps
    for q in np.flatnonzero(reps[:, EC.KIND] == RepKind.CURVE3D).tolist():
        if reps[q, EC.CURVE] >= 0:
            row = resolve_row(m.curves3d, int(reps[q, EC.CURVE]), TRIM_C)
            out[reps[q, EC.EDGE]] = Rec(Table.CURVE3D, cfirst[row])
    return out


def kinked_records(m: BRepModel) -> set[Rec]:
    """B-splines with an interior knot of multiplicity ≥ degree.

    Such a knot is only C0 by its knots; the original's poles around it are
    usually aligned (G1).  Coding breaks the alignment, and a STEP reader then
    splits the edge or face there, changing the topology.
    """
    out = set()
    every = [
        *zip(records(m.surfaces, Table.SURFACE), m.surfaces),
        *zip(records(m.curves3d, Table.CURVE3D), m.curves3d),
    ]
    for k, g in every:
        if isinstance(g, BSplineCurve) and not g.bezier:
            if (g.mults[1:-1] >= g.degree).any():
                out.add(k)
        elif isinstance(g, BSplineSurface) and not g.bezier:
            if (g.umults[1:-1] >= g.udegree).any() or (g.vmults[1:-1] >= g.vdegree).any():
                out.add(k)
    return out
