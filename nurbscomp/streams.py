"""Typed arrays <-> one byte string, laid out for the entropy coder.

A block is a sequence of arrays.  Each array is written as a 6-byte header,
``kind:u8 width:u8 count:u32``, then ``count * width`` bytes:

* kind 0, integers: zig-zag mapped, stored in the narrowest unsigned width
  (1, 2, 4 or 8 bytes) that holds them, byte planes split (all low bytes,
  then the next...);
* kind 1, float64: IEEE-754 little-endian, as they are.

Splitting integer byte planes ("shuffle", as in Blosc and HDF5) puts the
mostly-zero high bytes together.  Floats are *not* shuffled: measured on the
corpus, whole 8-byte values repeat (a vertex, its curves' end poles, its
surfaces' corner poles), and LZ matches on whole values save more than the
shuffled exponents do (1.08 MB against 1.42 MB).  The reader checks each declared
length against the bytes that remain before it allocates, and raises
``SectionError`` (a ``CorruptError``) naming the section and the byte offset.
"""

from __future__ import annotations

import struct

import numpy as np

from .errors import CorruptError, SectionError, TruncatedError

_HEAD = struct.Struct("<BBI")
INT, FLOAT = 0, 1


def _shuffle(b: np.ndarray, width: int) -> bytes:
    return b.reshape(-1, width).T.tobytes()


def _unshuffle(data: bytes, width: int, count: int) -> np.ndarray:
    return np.frombuffer(data, np.uint8).reshape(width, count).T.copy()


def zigzag(x: np.ndarray) -> np.ndarray:
    """Signed -> unsigned: 0, -1, 1, -2 ... -> 0, 1, 2, 3 ..."""
    x = x.astype(np.int64)
    return ((x << 1) ^ (x >> 63)).astype(np.uint64)


def unzigzag(u: np.ndarray) -> np.ndarray:
    u = u.astype(np.uint64)
    return ((u >> np.uint64(1)).astype(np.int64)) ^ -((u & np.uint64(1)).astype(np.int64))


def varint(n: int) -> bytes:
    """``n`` (≥ 0) as LEB128: seven bits a byte, low group first."""
    if n < 0:
        raise ValueError("varint of a negative number")
    out = bytearray()
    while True:
        b = n & 0x7F
        n >>= 7
        if n:
            out.append(b | 0x80)
        else:
            out.append(b)
            return bytes(out)


def read_varint(data: bytes | memoryview, pos: int) -> tuple[int, int]:
    """The LEB128 integer at ``pos`` and the position after it (at most 9 bytes).

    Raises
    ------
    TruncatedError
        ``data`` ends inside the integer.
    CorruptError
        More than 9 bytes (a value past 2**63).
    """
    n = shift = 0
    for k in range(9):
        if pos + k >= len(data):
            raise TruncatedError(f"varint at offset {pos} runs past the end")
        b = data[pos + k]
        n |= (b & 0x7F) << shift
        if not b & 0x80:
            return n, pos + k + 1
        shift += 7
    raise CorruptError(f"varint at offset {pos} is longer than 9 bytes")


class BlockWriter:
    """Collects arrays; ``bytes()`` gives the block."""

    def __init__(self) -> None:
        self._parts: list[bytes] = []

    def ints(self, x: np.ndarray | list[int]) -> None:
        u = zigzag(np.asarray(x, np.int64).reshape(-1))
        top = int(u.max()) if len(u) else 0
        width = 1 if top < 1 << 8 else 2 if top < 1 << 16 else 4 if top < 1 << 32 else 8
        b = u.astype(f"<u{width}").view(np.uint8)
        self._parts.append(_HEAD.pack(INT, width, len(u)) + _shuffle(b, width))

    def deltas(self, x: np.ndarray | list[int]) -> None:
        """An index array as differences from the previous entry (first from 0):
        indices that mostly step by one cost a byte of zeros-and-ones each."""
        self.ints(np.diff(np.asarray(x, np.int64).reshape(-1), prepend=0))

    def floats(self, x: np.ndarray | list[float]) -> None:
        f = np.ascontiguousarray(np.asarray(x, "<f8").reshape(-1))
        self._parts.append(_HEAD.pack(FLOAT, 8, len(f)) + f.tobytes())

    def __bytes__(self) -> bytes:
        return b"".join(self._parts)


class BlockReader:
    """Reads arrays back in the order they were written."""

    def __init__(self, data: bytes, name: str) -> None:
        self._data = data
        self._pos = 0
        self._name = name

    def _next(self, kind: int) -> tuple[int, int, bytes]:
        if self._pos + _HEAD.size > len(self._data):
            raise SectionError(
                f"section {self._name} ends inside an array header at offset {self._pos}"
            )
        k, width, count = _HEAD.unpack_from(self._data, self._pos)
        at = self._pos
        self._pos += _HEAD.size
        if k != kind or width not in (1, 2, 4, 8) or (k == FLOAT and width != 8):
            raise SectionError(f"section {self._name}: bad array header at offset {at}")
        end = self._pos + width * count
        if end > len(self._data):
            raise SectionError(f"section {self._name}: array at offset {at} overruns the section")
        raw = self._data[self._pos : end]
        self._pos = end
        return width, count, raw

    def ints(self, count: int | None = None) -> np.ndarray:
        at = self._pos
        width, n, raw = self._next(INT)
        if count is not None and n != count:
            raise SectionError(
                f"section {self._name}: expected {count} integers, found {n} at offset {at}"
            )
        u = _unshuffle(raw, width, n).view(f"<u{width}").reshape(-1)
        return unzigzag(u)

    def deltas(self, count: int | None = None) -> np.ndarray:
        """Inverse of :meth:`BlockWriter.deltas`."""
        with np.errstate(over="ignore"):  # wrapped sums are out-of-table indices
            return np.cumsum(self.ints(count), dtype=np.int64)

    def floats(self, count: int | None = None) -> np.ndarray:
        at = self._pos
        _, n, raw = self._next(FLOAT)
        if count is not None and n != count:
            raise SectionError(
                f"section {self._name}: expected {count} floats, found {n} at offset {at}"
            )
        return np.frombuffer(raw, "<f8").copy()

    def next_is_ints(self) -> bool:
        """Whether the next array is an integer array (where a layout lets an
        array be either)."""
        if self._pos + _HEAD.size > len(self._data):
            return False
        return bool(_HEAD.unpack_from(self._data, self._pos)[0] == INT)

    def done(self) -> None:
        if self._pos != len(self._data):
            raise SectionError(
                f"section {self._name} has {len(self._data) - self._pos} extra bytes "
                f"at offset {self._pos}"
            )

    @property
    def remaining(self) -> int:
        """Bytes not read yet: an upper bound on the values any later array holds."""
        return len(self._data) - self._pos
