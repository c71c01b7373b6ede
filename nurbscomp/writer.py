"""Model and net codes -> container sections: the writer's side of
:mod:`nurbscomp.decode`'s steps.

Besides the model's own tables the writer stores what the decoder's steps
need to rebuild it: the range rules (:mod:`nurbscomp.rules.ranges`), and the
net codes in the order and on the origins the decoder will use
(:func:`codec.reorigin`, the anchors of :mod:`nurbscomp.rules.joins`).
"""

from __future__ import annotations

from collections.abc import Collection
from dataclasses import replace
from typing import Any, cast

import numpy as np

from . import codec, serialize, spatial
from .memo import Memo, digest
from .model import BRepModel, BSplineCurve, BSplineSurface, Geometry, Rec, Table, first_row
from .rules import joins
from .rules.nets import net_abscissae
from .rules.ranges import range_kinds
from .serialize import NetTable, Tables


def _net_table(
    records: list[Geometry],
    which: Table,
    codes: dict[Rec, codec.NetCode],
    tol: float,
    anchors: dict[int, np.ndarray] | None = None,
    choices: dict[int, np.ndarray] | None = None,
) -> NetTable:
    """The codes of the coded records of a table (the model's ``which`` table),
    in the order of their first rows.

    Each code is re-based on the origin the decoder will use: the previous
    coded row's decoded first pole (:func:`codec.reorigin`), or the row's
    anchor point where it has one (:func:`joins.anchors`).  With ``choices``
    (``SNET`` from format 2.1: per row, the points of
    :func:`joins.surface_anchor_candidates`), a row is coded against the one
    of them, or the previous pole, whose first integers cost the fewest
    bits (:func:`_anchor_choice`), and the table gets an anchor column.
    """
    anchors = anchors or {}
    order = []
    picked = []
    cornered = []
    origin = None
    for row, first in enumerate(first_row(records)):
        if row == first and Rec(which, row) in codes:
            g = records[row]
            code = codes[Rec(which, row)]
            if code.method == codec.Method.COPY:  # filled last: not on the origin chain
                order.append(code)
                picked.append(0)
                cornered.append([0, 0, 0])
                continue
            k, corners = 0, [0, 0, 0]
            if code.method != codec.Method.ISO:  # an ISO code holds references, no point
                if choices is not None and len(choices.get(row, ())):
                    surface = cast(BSplineSurface, g)
                    code, k, corners = _chosen(
                        code, surface, anchors.get(row, origin), choices[row], tol
                    )
                else:
                    code = codec.reorigin(code, anchors.get(row, origin), tol)
            order.append(code)
            picked.append(k)
            cornered.append(corners)
            poles = cast(BSplineCurve | BSplineSurface, g).poles
            origin = poles.reshape(-1, poles.shape[-1])[0] if code.first is None else code.first

    def col(name: str) -> np.ndarray:
        return np.array([int(getattr(c, name)) for c in order], np.int64)

    return NetTable(
        col("method"),
        col("quant"),
        col("level"),
        col("slope"),
        [c.ints for c in order],
        np.concatenate([c.dcs for c in order]) if order else np.zeros(0),
        None if choices is None else np.array(picked, np.int64),
        None if choices is None else np.array(cornered, np.int64).reshape(-1, 3),
    )


#: :func:`_chosen`'s answers by a digest of all they read: the validity stage
#: packs a part once or more per round, and most of its rows are the same
#: from one round to the next (trj7 at 0.01 mm: 168 surface rows packed 16
#: times, some 0.36 ms each).
_CHOSEN: Memo[tuple[np.ndarray, int, list[int]]] = Memo(20_000)


def _chosen(
    code: codec.NetCode,
    g: BSplineSurface,
    origin: np.ndarray | None,
    points: np.ndarray,
    tol: float,
) -> tuple[codec.NetCode, int, list[int]]:
    """A surface row's code (format 2.1 and 2.10) coded against ``origin``
    (:func:`codec.reorigin`: the previous row's decoded first pole) or the
    cheapest of its anchor candidates ``points`` (:func:`_anchor_choice`),
    its corners against the cheapest of them (:func:`_corner_choice`); with
    the pick (0: the origin) and the corners' picks.  Only the integers
    change, so only they are remembered (:data:`_CHOSEN`)."""

    def make() -> tuple[np.ndarray, int, list[int]]:
        out = codec.reorigin(code, origin, tol)
        k = _anchor_choice(out, points, tol)
        if k:
            out = codec.reorigin(out, points[k - 1], tol)
        corners = [0, 0, 0]
        shape = g.poles.shape
        if out.method in codec.CORNERED:
            grid = codec.corner_grid(out, shape, tol, *net_abscissae(g))
            corners = _corner_choice(out, shape, grid, points, tol)
            at = {c: points[j - 1] for c, j in enumerate(corners, 1) if j}
            out = codec.recorner(out, shape, at, tol, grid)
        out.ints.flags.writeable = False  # shared by every row that asks again
        return out.ints, k, corners

    key = digest(
        *(code.ints, code.dcs, code.origin, origin, points),
        *(g.uknots, g.umults, g.vknots, g.vmults, g.poles.shape, g.udegree, g.vdegree),
        *(int(code.method), int(code.quant), code.level, code.slope, tol),
    )
    ints, k, corners = _CHOSEN.get(key, make)
    return replace(code, ints=ints), k, list(corners)


def _anchor_choice(code: codec.NetCode, points: np.ndarray, tol: float) -> int:
    """0, or k > 0 for the k-th of ``points`` (k, 3): the origin that costs
    ``code``'s first pole the fewest bits (:func:`codec.cost_bits` of its
    first three integers, plus the anchor's own: the previous net's first
    pole on a tie)."""
    h = tol * code.grid
    old = np.zeros(3) if code.origin is None else code.origin
    head = code.ints[:3] + spatial.snap(old, h)
    return _cheapest(code.ints[:3], head, spatial.snap(points, h))


def _cheapest(own: np.ndarray, q: np.ndarray, snapped: np.ndarray) -> int:
    """0, or k > 0 for the k-th of the grid points ``snapped`` (k, 3): what
    codes the grid point ``q`` in the fewest bits (:func:`codec.cost_bits`),
    its integers ``own`` as they are (one bit more, for a pick of 0) or ``q``
    minus that point (plus the pick's own bits); the first on a tie."""
    best, pick = codec.cost_bits(own) + 1, 0
    for k, g in enumerate(snapped, 1):
        bits = codec.cost_bits(q - g) + codec.cost_bits(np.array([k]))
        if bits < best:
            best, pick = bits, k
    return pick


def _corner_choice(
    code: codec.NetCode,
    shape: tuple[int, ...],
    q: np.ndarray,
    points: np.ndarray,
    tol: float,
) -> list[int]:
    """Per corner P0m, Pn0, Pnm of a surface code (format 2.10) whose corners'
    grid integers are ``q`` (:func:`codec.corner_grid`): 0, or k > 0 for the
    k-th of ``points`` (k, 3), the vertex that codes its integers in the
    fewest bits (:func:`codec.cost_bits`, the pick's own counted; as they
    are on a tie)."""
    snapped = spatial.snap(points, tol * code.grid)
    return [_cheapest(codec.corner_ints(code, shape, c), q[c], snapped) for c in (1, 2, 3)]


def _surface_choices(m: BRepModel, codes: dict[Rec, codec.NetCode]) -> dict[int, np.ndarray]:
    """Per coded surface row, the points of its anchor candidates (format 2.1)."""
    rows = [k.row for k in codes if k.table == Table.SURFACE]
    cands = joins.surface_anchor_candidates(m, rows)
    return {r: m.vertex_point[v] for r, v in cands.items()}


def _curve_anchors(m: BRepModel, codes: dict[Rec, codec.NetCode]) -> dict[int, np.ndarray]:
    rows = {k.row for k in codes if k.table == Table.CURVE3D}
    return joins.anchors(m, m.curves3d, rows)


def tables(m: BRepModel, codes: dict[Rec, codec.NetCode] | None, tol: float) -> Tables:
    """What the writer stores besides ``m``'s own tables so that ``decode.apply``
    rebuilds ``m``: the range rules, and the net codes (``codes`` maps
    B-spline records, :class:`model.Rec`, to their codes; ``m`` holds their
    *decoded* poles)."""
    codes = codes or {}
    return Tables(
        _net_table(m.surfaces, Table.SURFACE, codes, tol, None, _surface_choices(m, codes)),
        _net_table(m.curves3d, Table.CURVE3D, codes, tol, _curve_anchors(m, codes)),
        range_kinds(m),
        frozenset(codes),
    )


def model_to_sections(
    m: BRepModel,
    meta: dict[str, Any],
    codes: dict[Rec, codec.NetCode] | None = None,
    only: Collection[str] | None = None,
) -> list[tuple[str, bytes]]:
    """The sections of a container holding ``m`` (:func:`serialize.model_to_sections`
    of ``m`` and its :func:`tables`; ``only``: just the sections of these tags)."""
    tol = float(meta.get("tolerance_mm") or 0.0)
    return serialize.model_to_sections(m, meta, tables(m, codes, tol), only)
