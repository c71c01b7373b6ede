"""Streams of a text model, each through the entropy stage that suits it.

A text model (issue 29) splits a file into byte streams (ids, references,
digits, layout, ...).  :func:`pack` compresses each stream on its own with the
smallest of the coders :mod:`nurbscomp.entropy` offers and joins them;
:func:`unpack` inverts it, inflating no more than a caller's limit.

Each stream is coded on its own (:func:`_smallest`): raw LZMA2 at preset 9e
with a dictionary no larger than the stream (so a 200-byte stream does not pay
for clearing 64 MiB of match finder), with no literal context bits
(``lc=lp=pb=0``: best on the digit and integer streams of the STEP model) and,
for streams up to :data:`DEFAULT_MAX` (4 kB: above, the second trial cost a
fifth of the encode time for 25 bytes on the corpus), also with the default
settings; brotli 11 only for streams up to :data:`BROTLI_MAX`, and within a
caller's budget (:func:`brotli_set`).  The streams are coded in a pool
of threads (the coders release the GIL).  On the corpus STEP files this made
the model's coding 3.6x faster than ``entropy.compress`` on every stream
(which tries nine LZMA settings, zstd and brotli) for 0.4% more bytes.

Layout (little-endian, docs/format.md §1.5)::

    nstreams  varint
    per stream: coder u8 | raw_length varint | stored_length varint | payload
"""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor

import brotli
import numpy as np

from ..entropy import DICTIONARIES, Coder, decompress, lzma_raw
from ..errors import CorruptError, LimitError, TruncatedError
from ..streams import read_varint, varint


def read_varints(data: bytes | memoryview, pos: int, n: int) -> tuple[np.ndarray, int]:
    """The ``n`` LEB128 integers from ``pos`` (as int64) and the position
    after them: :func:`read_varint` ``n`` times, in one numpy pass over at
    most ``9 n`` bytes.

    Raises
    ------
    TruncatedError
        ``data`` ends inside an integer (or before the ``n``-th).
    CorruptError
        An integer longer than 9 bytes.
    """
    if n <= 0:
        return np.zeros(0, np.int64), pos
    if pos >= len(data):
        raise TruncatedError(f"varint at offset {pos} runs past the end")
    window = np.frombuffer(data, np.uint8, count=min(9 * n, len(data) - pos), offset=pos)
    ends = np.flatnonzero(window < 0x80)[:n]  # the last byte of each integer
    lens = np.diff(ends, prepend=-1)
    if len(lens) and int(lens.max()) > 9:
        k = int(np.argmax(lens > 9))
        at = pos + int(ends[k] - lens[k]) + 1
        raise CorruptError(f"varint at offset {at} is longer than 9 bytes")
    if len(ends) < n:  # the next integer has no last byte in the window
        at = int(ends[-1]) + 1 if len(ends) else 0
        if len(window) - at >= 9:
            raise CorruptError(f"varint at offset {pos + at} is longer than 9 bytes")
        raise TruncatedError(f"varint at offset {pos + at} runs past the end")
    used = int(ends[-1]) + 1
    body = window[:used]
    first = ends - lens + 1
    shift = (np.arange(used) - np.repeat(first, lens)) * 7
    terms = (body & 0x7F).astype(np.uint64) << shift.astype(np.uint64)
    return np.add.reduceat(terms, first).astype(np.int64), pos + used


#: LZMA literal settings (lc, lp, pb) a quick :func:`pack` tries: text, then bytes.
QUICK_TUNINGS = ((3, 0, 2), (0, 0, 0))
#: Streams up to this size are also tried with LZMA's default literal settings.
DEFAULT_MAX = 4 * 1024
#: Streams up to this size are also tried with brotli 11 (slow: ~3 µs a byte).
BROTLI_MAX = 8 * 1024
#: What one brotli call costs, in bytes of a stream coded (:func:`brotli_set`).
BROTLI_CALL = 1024


def _lzma(raw: bytes, lc: int, lp: int, pb: int) -> bytes:
    """Raw LZMA2 at preset 9e with these literal settings and a dictionary no
    larger than ``raw`` needs (``entropy.lzma_raw``: a 64 MiB one costs more to
    set up than a small stream takes to code); :func:`entropy.decompress`
    reads it as any ``Coder.LZMA`` stream: LZMA2 carries its settings in its
    chunks."""
    return lzma_raw(raw, (lc, lp, pb))


def quick_lzma(raw: bytes) -> bytes:
    """:func:`_lzma`, the smaller of :data:`QUICK_TUNINGS` (on a stream over
    32 kB, the one its first 4 kB suggest: text or bytes)."""
    tunings: tuple[tuple[int, int, int], ...] = QUICK_TUNINGS
    if len(raw) > 1 << 15:
        head = raw[:4096]
        text = sum(head.count(bytes([c])) for c in range(32, 127)) > 0.9 * len(head)
        tunings = tunings[:1] if text else tunings[1:]
    return min((_lzma(raw, *t) for t in tunings), key=len)


def fast_lzma(raw: bytes) -> bytes:
    """Raw LZMA2 at preset 1 (text literal settings): a quick upper estimate
    of what preset 9e makes of ``raw``."""
    return lzma_raw(raw, (3, 0, 2), preset=1)


def _smallest(raw: bytes, coders: tuple[Coder, ...], brotli_too: bool) -> tuple[Coder, bytes]:
    """The smallest coding of ``raw`` among the candidates of the module
    docstring that ``coders`` allows (stored when nothing is smaller);
    brotli only where ``brotli_too``."""
    best: tuple[Coder, bytes] = (Coder.STORED, raw)
    cands: list[tuple[Coder, bytes]] = []
    if raw and Coder.LZMA in coders:
        cands.append((Coder.LZMA, _lzma(raw, 0, 0, 0)))
        if len(raw) <= DEFAULT_MAX:
            cands.append((Coder.LZMA, _lzma(raw, 3, 0, 2)))
    if raw and Coder.BROTLI in coders and brotli_too:
        cands.append((Coder.BROTLI, brotli.compress(raw, quality=11)))
    for c in cands:
        if len(c[1]) < len(best[1]):
            best = c
    return best


def brotli_set(streams: list[bytes], budget: int | None) -> set[int]:
    """The streams brotli is tried on: those up to :data:`BROTLI_MAX` bytes,
    and with a ``budget``, only the shortest of them while their lengths and
    :data:`BROTLI_CALL` a stream add up to no more than it (brotli 11 costs
    about a microsecond a byte and a millisecond a call: on a small file it
    would cost more than ``xz -9e`` of the whole file)."""
    small = sorted((len(s), i) for i, s in enumerate(streams) if 0 < len(s) <= BROTLI_MAX)
    if budget is None:
        return {i for _, i in small}
    out, total = set(), 0
    for n, i in small:
        total += n + BROTLI_CALL
        if total > budget:
            break
        out.add(i)
    return out


def pack(
    streams: list[bytes],
    coders: tuple[Coder, ...] = tuple(Coder),
    quick: bool = False,
    brotli_budget: int | None = None,
) -> bytes:
    """``streams`` compressed one by one, each with the smallest of ``coders``
    (of the candidates the module docstring names); ``quick``: each with
    :func:`quick_lzma` only (a model's many small streams).  Brotli is tried
    on the streams :func:`brotli_set` picks with ``brotli_budget`` (none in a
    quick pack)."""
    return pack_coded(code(streams, coders, quick, brotli_budget))


def code(
    streams: list[bytes],
    coders: tuple[Coder, ...] = tuple(Coder),
    quick: bool = False,
    brotli_budget: int | None = None,
    binary: frozenset[int] = frozenset(),
) -> list[tuple[Coder, bytes, bytes]]:
    """What :func:`pack` lays out: (coder, raw, payload) per stream, coded
    in a pool of threads when there is enough to code.  The streams numbered
    in ``binary`` get one trial only, LZMA2 with no literal context bits
    (byte planes of integers: a trial costs a millisecond even on a small
    stream)."""
    trial = (
        set()
        if quick
        else brotli_set([b"" if i in binary else s for i, s in enumerate(streams)], brotli_budget)
    )

    def one(i: int) -> tuple[Coder, bytes]:
        s = streams[i]
        if i in binary and s:
            return (Coder.LZMA, _lzma(s, 0, 0, 0))
        if quick and s:
            return (Coder.LZMA, quick_lzma(s))
        return _smallest(s, coders, i in trial)

    workers = min(os.cpu_count() or 1, 2)
    big = sum(len(s) for s in streams) > 64 * 1024 and len(streams) > 1 and workers > 1
    if big:
        with ThreadPoolExecutor(workers) as pool:  # the largest first
            order = sorted(range(len(streams)), key=lambda i: -len(streams[i]))
            done = dict(zip(order, pool.map(one, order)))
        coded = [done[i] for i in range(len(streams))]
    else:
        coded = [one(i) for i in range(len(streams))]
    return [(c, s, p) for s, (c, p) in zip(streams, coded)]


def pack_coded(coded: list[tuple[Coder, bytes, bytes]]) -> bytes:
    """The layout of :func:`pack` for streams already coded: (coder, raw,
    payload) each; a payload no shorter than its raw bytes is stored instead."""
    out = [varint(len(coded))]
    for coder, s, payload in coded:
        if len(payload) >= len(s):
            coder, payload = Coder.STORED, s
        out += [bytes([coder]), varint(len(s)), varint(len(payload)), payload]
    return b"".join(out)


def unpack(data: bytes, limit: int, count: int | None = None) -> list[bytes]:
    """Invert :func:`pack`; the streams' raw lengths together are at most ``limit``.

    ``count``, when given, is the number of streams the caller expects.

    Raises
    ------
    LimitError
        The declared raw lengths add up to more than ``limit``.
    CorruptError, TruncatedError
        Anything else that is not what :func:`pack` writes.
    """
    view = memoryview(data)
    n, pos = read_varint(view, 0)
    if count is not None and n != count:
        raise CorruptError(f"{n} text streams, expected {count}")
    if n > 4096:
        raise CorruptError(f"{n} text streams")
    out: list[bytes] = []
    total = 0
    for _ in range(n):
        if pos >= len(view):
            raise TruncatedError(f"text stream header at offset {pos} runs past the end")
        coder = view[pos]
        raw_len, pos = read_varint(view, pos + 1)
        stored, pos = read_varint(view, pos)
        total += raw_len
        if total > limit:
            raise LimitError(f"text streams inflate to more than {limit} bytes")
        if pos + stored > len(view):
            raise TruncatedError(f"text stream at offset {pos} runs past the end")
        if coder in DICTIONARIES:  # a container's coder, not a text stream's
            raise CorruptError(f"text stream coder {coder} at offset {pos}")
        out.append(decompress(coder, bytes(view[pos : pos + stored]), raw_len))
        pos += stored
    if pos != len(view):
        raise CorruptError(f"{len(view) - pos} bytes after the last text stream")
    return out


def int_stream(values: np.ndarray) -> bytes:
    """Integers as a stream of version 3: nothing for none; else one byte
    ``w`` (1, 2, 4 or 8), then each value zigzag-mapped (``2v`` for ``v`` ≥ 0,
    ``-2v - 1`` below) as a ``w``-byte little-endian integer, one byte plane
    after another (every value's lowest byte first).  On the corpus this
    codes the reference, copy, id and length streams 9% smaller than decimal
    text."""
    if not len(values):
        return b""
    z = (values.astype(np.int64) << 1) ^ (values.astype(np.int64) >> 63)
    top = int(z.astype(np.uint64).max())
    w = 1 if top < 1 << 8 else 2 if top < 1 << 16 else 4 if top < 1 << 32 else 8
    planes = z.astype(f"<u{w}").view(np.uint8).reshape(-1, w).T
    return bytes([w]) + planes.tobytes()


def read_int_stream(raw: bytes, n: int, what: str) -> np.ndarray:
    """Invert :func:`int_stream` of ``n`` values."""
    if n == 0:
        if raw:
            raise CorruptError(f"{what} stream should be empty")
        return np.zeros(0, dtype=np.int64)
    w = raw[0] if raw else 0
    if w not in (1, 2, 4, 8) or len(raw) != 1 + w * n:
        raise CorruptError(f"{what} stream does not hold {n} values")
    planes = np.frombuffer(raw, np.uint8, offset=1).reshape(w, n)
    z = np.ascontiguousarray(planes.T).view(f"<u{w}").ravel().astype(np.uint64)
    return ((z >> np.uint64(1)).astype(np.int64)) ^ -((z & np.uint64(1)).astype(np.int64))
