"""`SNET` / `CNET` (§2.4: the coded nets' tables, laid out in streams by kind)
and `SIDE` (§2.10: net sides set to another net's side)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import cast

import numpy as np

from .. import codec, container
from ..errors import BadReferenceError, SectionError
from ..model import (
    BRepModel,
    BSplineCurve,
    BSplineSurface,
    Geometry,
    Rec,
    Table,
    first_row,
)
from ..streams import BlockReader, BlockWriter
from .geometry import _Cursor
from .limits import MAX_COORD, finite

# ---------------------------------------------------------------- coded nets


def coded_rows(records: list[Geometry]) -> list[int]:
    """Rows of the first occurrence of each coded B-spline record (NaN poles after reading)."""
    return [
        i
        for i, (first, g) in enumerate(zip(first_row(records), records))
        if i == first
        and isinstance(g, (BSplineSurface, BSplineCurve))
        and np.isnan(g.poles.flat[0])
    ]


@dataclass
class NetTable:
    """A SNET or CNET section as numbers: per coded row, in row order
    (:func:`coded_rows`), its method, quantizer, level and slope, and its
    integers; the DC coefficients of all of them, in order (how many each
    takes is known only as it is decoded: ``decode.apply``).  ``anchor``
    (``SNET`` from format 2.1): per row, 0 where its first pole is coded
    against the previous net's, k > 0 against the k-th vertex of the first
    face on it (:func:`joins.surface_anchor_candidates`).  ``corners``
    (``SNET`` from format 2.10): per row, for its corners P0m, Pn0, Pnm, 0 or
    k > 0 as ``anchor`` (n, 3): the corner's integers are coded against that
    vertex."""

    method: np.ndarray
    quant: np.ndarray
    level: np.ndarray
    slope: np.ndarray
    ints: list[np.ndarray]
    dcs: np.ndarray
    anchor: np.ndarray | None = None
    corners: np.ndarray | None = None


#: Format 2.10: the first revision whose ``SNET`` has the corners column.
CORNERS = container.VERSIONS.index((2, 10))
#: Names of the integer streams of a 2.1 net table (``codec.segments``), in order.
NET_STREAMS = ("points", "residuals", "curve coefficients", "map coefficients", "references")


def _write_nets(
    t: NetTable,
    shapes: list[tuple[int, ...]],
    anchors: bool,
    revision: int = container.REVISION,
) -> bytes:
    """A SNET/CNET section (docs/format.md §2.4); ``shapes``: the coded rows'
    pole arrays' shapes, ``anchors``: whether the table has the anchor column
    (``SNET``, from revision 4)."""
    w = BlockWriter()
    for col in (t.method, t.quant, t.level, t.slope):
        w.ints(col)
    if revision < 4 or not t.ints:  # from revision 4 too, a table of no rows
        w.ints([len(x) for x in t.ints])
        w.ints(np.concatenate(t.ints) if t.ints else [])
        w.floats(t.dcs)
        return bytes(w)
    if anchors:
        w.ints(np.zeros(len(t.ints), np.int64) if t.anchor is None else t.anchor)
        if revision >= CORNERS:
            corners = np.zeros(3 * len(t.ints), np.int64) if t.corners is None else t.corners
            w.ints(np.asarray(corners).reshape(-1))
    parts: list[list[np.ndarray]] = [[] for _ in range(codec.STREAMS)]
    prev = 0  # an ISO code's surface row is stored against the previous one's
    for k, ints in enumerate(t.ints):
        if int(t.method[k]) == codec.Method.ISO and len(ints):
            ints, prev = np.concatenate([ints[:1] - prev, ints[1:]]), int(ints[0])
        at = 0
        for stream, n in codec.segments(int(t.method[k]), int(t.quant[k]), shapes[k]):
            parts[stream].append(ints[at : at + n])
            at += n
        if at != len(ints):
            raise ValueError(f"net {k} holds {len(ints)} integers, its method {at}")
    for p in parts:
        w.ints(np.concatenate(p) if p else [])
    w.floats(t.dcs)
    return bytes(w)


def _read_nets(
    data: bytes,
    n: int,
    tag: str,
    shapes: list[tuple[int, ...]] | None = None,
    revision: int = container.REVISION,
) -> NetTable:
    """A SNET/CNET section of ``n`` coded rows (of pole arrays ``shapes``); the
    integers split per row: before revision 4 (and in a table of no rows) by
    the stored counts, from it by :func:`codec.segments` from the five
    streams."""
    r = BlockReader(data, tag)
    if revision < 4 or n == 0:  # from revision 4 too, a table of no rows
        method, quant, level, slope, counts = (r.ints(n) for _ in range(5))
        ints = _Cursor(r.ints(), f"{tag} ints")
        dcs = r.floats()
        r.done()
        finite(dcs, f"{tag} DC coefficients", MAX_COORD)
        if (counts < 0).any():
            raise SectionError(f"{tag}: bad net header")
        per = [ints.take(int(c)) for c in counts]
        ints.done()
        return NetTable(method, quant, level, slope, per, dcs)
    if shapes is None or len(shapes) != n:
        raise ValueError("a net table from format 2.1 is read with its rows' shapes")
    method, quant, level, slope = (r.ints(n) for _ in range(4))
    anchor = r.ints(n) if tag == "SNET" else None
    corners = r.ints(3 * n).reshape(n, 3) if tag == "SNET" and revision >= CORNERS else None
    streams = [_Cursor(r.ints(), f"{tag} {name}") for name in NET_STREAMS]
    dcs = r.floats()
    r.done()
    finite(dcs, f"{tag} DC coefficients", MAX_COORD)
    per = []
    prev = 0
    for k in range(n):
        try:
            runs = codec.segments(int(method[k]), int(quant[k]), shapes[k])
        except ValueError as e:
            raise SectionError(f"{tag}: net {k}: {e}") from None
        got = [streams[s].take(c) for s, c in runs]
        one = np.concatenate(got) if got else np.zeros(0, np.int64)
        if int(method[k]) == codec.Method.ISO:
            with np.errstate(over="ignore"):  # a wrapped sum is an out-of-table row
                one[0] += prev
            prev = int(one[0])
        per.append(one)
    for c in streams:
        c.done()
    return NetTable(method, quant, level, slope, per, dcs, anchor, corners)


@dataclass
class Tables:
    """What a container stores besides the model's own tables, for the
    decoder's geometric steps (``decode.apply``): the coded nets, and how
    each edge representation's range is stored (``RANGE_*``)."""

    snet: NetTable
    cnet: NetTable
    range_how: np.ndarray
    #: the coded B-spline records (written with NaN poles: SNET/CNET hold them)
    coded: frozenset[Rec] = frozenset()

    def rows(self, which: Table) -> frozenset[int]:
        """The rows of the coded records of the ``which`` table."""
        return frozenset(k.row for k in self.coded if k.table == which)


# ---------------------------------------------------------------- whole model


def _shapes(records: list[Geometry], rows: list[int]) -> list[tuple[int, ...]]:
    """The shapes of the pole arrays of ``rows``."""
    return [cast(BSplineCurve | BSplineSurface, records[r]).poles.shape for r in rows]


def _net_shapes(records: list[Geometry], t: Tables, which: Table) -> list[tuple[int, ...]]:
    """The shapes of the pole arrays of a table's coded rows (the coded records'
    first rows, in order: the rows of its net table)."""
    coded = t.rows(which)
    first = first_row(records)
    return _shapes(records, [r for r in range(len(records)) if r == first[r] and r in coded])


def _write_sides(m: BRepModel) -> bytes:
    """``m.side_joins`` (format 1.1): the count, then per column: the surface
    rows as deltas (they increase), the sides, each leader row as the surface
    row minus it, the leader sides, the reversed flags."""
    w = BlockWriter()
    j = m.side_joins.reshape(-1, 5)
    w.ints([len(j)])
    w.deltas(j[:, 0])
    w.ints(j[:, 1])
    w.ints(j[:, 0] - j[:, 2])
    w.ints(j[:, 3])
    w.ints(j[:, 4])
    return bytes(w)


def _read_sides(data: bytes, m: BRepModel, coded: set[int]) -> None:
    """Read SIDE into ``m.side_joins`` (``decode.apply`` joins the sides),
    checking that each row joins a coded surface row to a surface row."""
    r = BlockReader(data, "SIDE")
    (n,) = r.ints(1)
    if n < 0:
        raise SectionError("SIDE: negative count")
    cols = [r.deltas(int(n)), *(r.ints(int(n)) for _ in range(4))]
    r.done()
    cols[2] = cols[0] - cols[2]
    rows = np.stack(cols, axis=1).astype(np.int64).reshape(-1, 5)
    for k, (b, _, a, _, _) in enumerate(rows.tolist()):
        if b not in coded or not 0 <= a < len(m.surfaces):
            raise BadReferenceError(f"SIDE row {k}: refers to a missing or uncoded surface row")
    m.side_joins = rows


#: The sections of format 1.0, in the order they are written and must be read.
