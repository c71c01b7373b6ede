"""Columns of byte strings held as one buffer and offsets (issue 29's decoders).

A text model's decoder makes hundreds of thousands of short values (ids,
references, numbers) and lays them out between the pieces of a skeleton.
Made one ``bytes`` object each and joined, they cost more than the rest of
the decode; a :class:`Column` keeps them in one buffer with each item's start
and size, so that printing, picking and joining are numpy operations.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..errors import CorruptError

#: 10**k for k = 0 ... 19, as uint64 (every power of ten that one holds).
POW10 = np.array([10**k for k in range(20)], dtype=np.uint64)


class Column(NamedTuple):
    """Items ``buf[start[i] : start[i] + size[i]]``."""

    buf: bytes
    start: np.ndarray
    size: np.ndarray

    def __len__(self) -> int:
        return len(self.start)

    def items(self) -> list[bytes]:
        """The items as ``bytes`` objects."""
        b = self.buf
        return [b[a : a + n] for a, n in zip(self.start.tolist(), self.size.tolist())]


def of_items(items: list[bytes]) -> Column:
    """A column of ``items``."""
    size = np.fromiter(map(len, items), np.int64, len(items))
    return Column(b"".join(items), np.cumsum(size) - size, size)


def split(buf: bytes, n: int, what: str, sep: int = ord(",")) -> Column:
    """The ``n`` items of ``buf`` cut at ``sep`` (none for ``n`` = 0: an empty buffer).

    Raises
    ------
    CorruptError
        ``buf`` does not hold exactly ``n`` items.
    """
    if n == 0:
        if buf:
            raise CorruptError(f"{what} stream should be empty")
        return Column(b"", np.zeros(0, np.int64), np.zeros(0, np.int64))
    cuts = np.flatnonzero(np.frombuffer(buf, np.uint8) == sep)
    if len(cuts) != n - 1:
        raise CorruptError(f"{len(cuts) + 1} {what}, the skeleton has {n}")
    start = np.r_[np.int64(0), cuts + 1]
    end = np.r_[cuts, np.int64(len(buf))]
    return Column(buf, start, end - start)


def ints(values: np.ndarray, prefix: bytes) -> Column:
    """``prefix`` and the decimal digits of each value (≥ 0, below 10**19).

    Raises
    ------
    CorruptError
        A negative value.
    """
    n = len(values)
    if n and int(values.min()) < 0:
        raise CorruptError("a negative entity number")
    v = values.astype(np.uint64)
    ndig = np.maximum(np.searchsorted(POW10, v, side="right"), 1).astype(np.int64)
    p = len(prefix)
    size = ndig + p
    end = np.cumsum(size)
    start = end - size
    buf = np.empty(int(end[-1]) if n else 0, np.uint8)
    for j, c in enumerate(prefix):
        buf[start + j] = c
    put_digits(buf, start + p, v, ndig)
    return Column(buf.tobytes(), start, size)


def put_digits(
    buf: np.ndarray,
    first: np.ndarray,
    v: np.ndarray,
    ndig: np.ndarray,
    point: np.ndarray | None = None,
) -> None:
    """Write the ``ndig[i]`` decimal digits of ``v[i]`` (uint64, zero-padded
    on the left; places past 10**19 are zeros) into ``buf`` from ``first[i]``,
    one pass per place; where ``point[i]`` ≥ 0, one byte is left out after
    the first ``point[i]`` digits (a decimal point's place).

    The items are taken longest first, so that the items a place reaches are
    a prefix of that order (slices, no masks), and each digit is ``q - 10·(q
    // 10)`` (numpy divides by a constant fast, but its ``%`` is slow): 2.3x
    the speed of a masked pass per place on a stream of 60,000 numbers."""
    if not len(v):
        return
    order = np.argsort(-ndig, kind="stable")
    nd = ndig[order]
    q = v[order].astype(np.uint64)
    last = first[order] + nd - 1  # where the last digit goes
    # from place ``cut`` on (counted from the right) the digits are left of the point
    cut = None
    if point is not None:
        pt = point[order]
        has = pt >= 0
        last += has
        cut = np.where(has, nd - pt, np.iinfo(np.int64).max)
    width = int(nd[0])
    reach = np.searchsorted(-nd, -np.arange(1, width + 1), side="right")  # items with > p digits
    ten = np.uint64(10)
    for place in range(width):
        k = int(reach[place])
        q, last = q[:k], last[:k]
        q10 = q // ten
        at = last - place
        if cut is not None:
            cut = cut[:k]
            at -= cut <= place
        buf[at] = (q - q10 * ten).astype(np.uint8) + np.uint8(ord("0"))
        q = q10


def concat(cols: list[Column]) -> Column:
    """The items of ``cols``, one column after the other."""
    offsets = np.cumsum([0, *(len(c.buf) for c in cols)])
    return Column(
        b"".join(c.buf for c in cols),
        np.concatenate(
            [c.start + o for c, o in zip(cols, offsets.tolist())] or [np.zeros(0, np.int64)]
        ),
        np.concatenate([c.size for c in cols] or [np.zeros(0, np.int64)]),
    )


def take(col: Column, index: np.ndarray) -> Column:
    """The items ``index`` of ``col``, in that order."""
    return Column(col.buf, col.start[index], col.size[index])


def fill(skel: bytes, holes: np.ndarray, values: Column) -> np.ndarray:
    """``skel`` with the byte at each of ``holes`` (ascending) replaced by
    the item of ``values`` of the same rank, as one uint8 array: the pieces
    between the holes and the items interleaved, in one gather."""
    n = len(holes)
    start = np.empty(2 * n + 1, np.int64)
    size = np.empty(2 * n + 1, np.int64)
    start[0] = 0
    start[2::2] = holes + 1
    size[0:-1:2] = holes
    size[-1] = len(skel)
    size[0::2] -= start[0::2]
    start[1::2] = values.start + len(skel)
    size[1::2] = values.size
    return gather(Column(skel + values.buf, start, size))


def join(col: Column) -> bytes:
    """The items of ``col`` one after the other, as one ``bytes``."""
    return gather(col).tobytes()


def gather(col: Column) -> np.ndarray:
    """The items of ``col`` one after the other, as one uint8 array."""
    size = col.size
    total = int(size.sum())
    if not total:
        return np.zeros(0, np.uint8)
    # int32 offsets where they fit: a fifth faster than int64 on a 1 MB text
    kind = np.int32 if max(total, len(col.buf)) < 1 << 31 else np.int64
    at = np.repeat((col.start - (np.cumsum(size) - size)).astype(kind), size)
    at += np.arange(total, dtype=kind)
    # np.take: half the time of indexing with ``[at]`` on a 1 MB text
    return np.take(np.frombuffer(col.buf, np.uint8), at)
