"""The STEP text model (issue 29): ISO 10303-21 text split into streams.

The text is cut by one regular expression (:data:`TOKEN`) into *values* and the
literal text between them.  Five kinds of value are taken out:

* entity ids (``#12`` before ``=``),
* references (any other ``#12``),
* numbers (``-1.5E-03``, ``15.``, ``7``: their text, exactly as written),
* strings (``'it''s'``, quotes included, any bytes inside),
* the bytes ``0x00``-``0x05`` wherever they stand outside a string (they are
  the placeholders, so a literal one is taken out as a value of its own).

What is left is the *skeleton*: the text with each value replaced by a
one-byte placeholder of its kind (``0x01`` ... ``0x05``).  It keeps the entity
names, punctuation, enumerations, comments and the layout (spaces and line
breaks) exactly, and repeats itself from entity to entity, which LZMA codes in
a few bits an entity.

Numbers and references are sorted into *contexts* read off the skeleton
(:func:`contexts`): the entity name (the last word before a ``(`` that
precedes the value) and the value's rank among values of its kind since that
name, capped at :data:`SLOTS` - 1.  ``CARTESIAN_POINT('',(x,y,z))`` puts x, y
and z in three contexts.  Each context with enough values has a stream of its
own; the others share stream 0 of their kind.  The decoder reads the same
contexts off the skeleton, so they are not stored.

* a number stream holds the numbers' texts joined by ``,``;
* a reference stream holds integers joined by ``,``, each the reference minus
  the id of the entity it stands in (mode 0) or minus the previous reference
  of the same stream (mode 1); the encoder keeps the smaller mode per stream;
* the id stream holds each id minus the previous id minus 1 (``0`` for
  ``#1, #2, #3``).

Before the numbers go to their streams, repeats are taken out by *group*: the
numbers that follow one entity id (:func:`_groups`), of a *kind* made of the
entity name of the group's first number and the group's count.  A group whose
number texts equal those of an earlier group of its kind is a copy, coded as
how many groups of its kind back the nearest such group stands (a vertex's
``CARTESIAN_POINT`` that repeats a pole: one small integer instead of three
long matches); only new groups' numbers reach the number streams.  On the
corpus this took 2.6% off the STEP payloads.

The skeleton is stored as its distinct *statements* (cut after each ``;``),
their lengths and one index per statement (:func:`_statements`, version 3).
Every stream goes through :func:`nurbscomp.text.coding.pack`.  The payload
ends with nothing: the first stream (the header) holds the output's length
and CRC-32, checked on decode, so a damaged payload raises a ``FormatError``
instead of giving wrong bytes.  The layout is written out in
docs/text-model.md, section "STEP".

Decoding is bulk work: placeholders are found with numpy, the contexts with one
``re.finditer`` over the entity names, and the values are laid out as
:mod:`.columns` (one buffer and offsets: ids and references printed with numpy,
number streams cut at their commas) and joined with the skeleton's pieces by
one gather; nothing loops over values or characters in Python.

Number streams may also be coded as numbers (:mod:`.numbers`, version 4):
their values predicted from the previous ones, kept where that packs smaller
than the text.
"""

from __future__ import annotations

import operator
import re
import warnings
import zlib

import numpy as np

from ..entropy import Coder
from ..errors import CorruptError, FormatError, LimitError
from . import coding, columns, numbers

#: Payload version (the header's first varint): 3 stores the skeleton as
#: statements (:func:`_statements`); 2, the skeleton whole, is still read.
VERSION = 4
_VERSIONS = (2, 3, 4)
#: Number streams of at least this many bytes of text are also tried as
#: numbers (:mod:`.numbers`, version 4), where a zlib estimate puts them under
#: :data:`NUMERIC_GATE` of the text (:func:`_worth_trying`); the smaller coding
#: is kept.  Below, the trial costs more time than it saves bytes: on the
#: corpus, streams under 16 kB saved 9-36 bytes each, and on a 60 kB file
#: written by OCCT the trial (two more LZMA2 calls, about 2 ms each) took the
#: encode from 0.85x to 1.2x the time of ``xz -9e`` for 3 bytes.
NUMERIC_QUICK = 16 * 1024
NUMERIC_GATE = 0.72
#: Placeholder bytes of the skeleton.
ID, REF, NUM, STR, RAW = 1, 2, 3, 4, 5
#: Ranks per entity name that get a context of their own (the last collects the rest).
SLOTS = 3
#: A context gets a stream of its own from this many values; fewer share stream 0
#: (on the corpus 1,000 gave 1.6% fewer bytes than 48: small streams code worse apart).
MIN_STREAM = 1000

#: The tokenizer: one group per kind of value, in :data:`ID` ... :data:`RAW` order.
#: Ids and references are at most 18 digits without a leading zero (they fit an
#: int64 and print back the same); anything else stays literal.
#: (The leading look-ahead only skips, fast, the positions where no value starts.)
TOKEN = re.compile(
    rb"(?=[#0-9+\-'\x00-\x05])"
    rb"(?:(#(?:0|[1-9][0-9]{0,17})(?![0-9])(?=[ \t\r\n]*+=))"
    rb"|(#(?:0|[1-9][0-9]{0,17})(?![0-9]))"
    rb"|((?<![A-Za-z0-9_.#])[+-]?[0-9]++(?:\.[0-9]*+)?(?:[eE][+-]?[0-9]++)?)"
    rb"|('(?:[^']++|'')*+')"
    rb"|([\x00-\x05]))"
)
_GROUPS = 5
#: Brotli is tried on small streams adding up to 1/BROTLI_SHARE of the text
#: (``coding.brotli_set``): on every small stream it doubled the encode time of
#: a 60 kB file (past xz -9e's), for 8% fewer bytes; with 1/8, 1.1x the time
#: for 2%; on the corpus files it made 0.1% of the difference.
BROTLI_SHARE = 8
#: An entity name in the skeleton: a word followed by ``(``.
NAME = re.compile(rb"(?<![A-Za-z0-9_])[A-Za-z_][A-Za-z0-9_]*+(?=[ \t\r\n]*+\()")
#: :data:`NAME` with the name captured, to cut the skeleton at its names.
_NAME_SPLIT = re.compile(rb"(?<![A-Za-z0-9_])([A-Za-z_][A-Za-z0-9_]*+)(?=[ \t\r\n]*+\()")
#: Where the skeleton is cut into *statements* (version 3): after each ``;``.
_STATEMENT = re.compile(rb"(?<=;)")
_PH = [b"", b"\x01", b"\x02", b"\x03", b"\x04", b"\x05"]


def names(skel: bytes) -> tuple[np.ndarray, np.ndarray]:
    """Where each entity name of ``skel`` starts, and its number: distinct names
    numbered 1, 2, ... in order of first appearance."""
    parts = _NAME_SPLIT.split(skel)  # text, name, text, name, ..., text
    ends = np.cumsum(np.fromiter(map(len, parts), dtype=np.int64, count=len(parts)))
    seen: dict[bytes, int] = {}
    codes = [seen.setdefault(m, len(seen) + 1) for m in parts[1::2]]
    return ends[0:-1:2].copy(), np.asarray([0, *codes], dtype=np.int64)


def contexts(
    skel: bytes, kind: int, named: tuple[np.ndarray, np.ndarray], pos: np.ndarray | None = None
) -> np.ndarray:
    """The context of each placeholder ``kind`` of ``skel``, in order.

    A context is ``name * SLOTS + slot``: ``name`` numbers the distinct entity
    names of the skeleton in order of first appearance (0 before any name,
    ``k + 1`` for the k-th), ``slot`` is the value's rank among the values of
    ``kind`` since the last name, capped at ``SLOTS - 1``.  ``named`` is
    :func:`names` of ``skel``; ``pos``, where known, the placeholders' positions.
    """
    if pos is None:
        pos = np.flatnonzero(np.frombuffer(skel, dtype=np.uint8) == kind)
    if not len(pos):
        return np.zeros(0, dtype=np.int64)
    st, cd = named
    seg = np.searchsorted(st, pos, side="right")  # 0: before any name
    name = cd[seg]
    k = np.arange(len(pos), dtype=np.int64)
    first = np.r_[0, np.flatnonzero(np.diff(seg)) + 1]
    rank = k - np.repeat(first, np.diff(np.r_[first, len(pos)]))
    return name * SLOTS + np.minimum(rank, SLOTS - 1)


def _streams_of(ctx: np.ndarray) -> tuple[np.ndarray, list[tuple[int, int]]]:
    """Stream number per value and the map ``[(context, stream)]`` of the contexts
    that have a stream of their own (streams 1, 2, ... in context order)."""
    if not len(ctx):
        return np.zeros(0, dtype=np.int64), []
    keys, counts = np.unique(ctx, return_counts=True)
    own = [int(k) for k, c in zip(keys, counts) if c >= MIN_STREAM]
    cmap = [(k, i + 1) for i, k in enumerate(own)]
    return _apply_map(ctx, cmap), cmap


def _apply_map(ctx: np.ndarray, cmap: list[tuple[int, int]]) -> np.ndarray:
    """Stream number per value of ``ctx`` under ``cmap`` (unmapped: 0)."""
    if not cmap or not len(ctx):
        return np.zeros(len(ctx), dtype=np.int64)
    keys = np.asarray([k for k, _ in cmap], dtype=np.int64)
    vals = np.asarray([s for _, s in cmap], dtype=np.int64)
    order = np.argsort(keys)
    keys, vals = keys[order], vals[order]
    i = np.minimum(np.searchsorted(keys, ctx), len(keys) - 1)
    return np.where(keys[i] == ctx, vals[i], 0)


def _owners(skel: bytes, kind: int, ids: np.ndarray) -> np.ndarray:
    """For each placeholder ``kind``, the id of the last entity id before it (0: none)."""
    arr = np.frombuffer(skel, dtype=np.uint8)
    idpos = np.flatnonzero(arr == ID)
    pos = np.flatnonzero(arr == kind)
    j = np.searchsorted(idpos, pos, side="right")
    return np.r_[np.int64(0), ids][j]


def _groups(skel: bytes) -> tuple[np.ndarray, np.ndarray]:
    """The numbers of ``skel`` cut into *groups*, the runs of numbers with the
    same last entity id before them: each group's first number and its count."""
    arr = np.frombuffer(skel, dtype=np.uint8)
    idpos = np.flatnonzero(arr == ID)
    pos = np.flatnonzero(arr == NUM)
    return _runs(np.searchsorted(idpos, pos, side="right"))


def _runs(owner: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`_groups` from the number of entity ids before each number."""
    if not len(owner):
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    start = np.r_[0, np.flatnonzero(np.diff(owner)) + 1].astype(np.int64)
    return start, np.diff(np.r_[start, len(owner)]).astype(np.int64)


def _kinds(
    ctx: np.ndarray, start: np.ndarray, count: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each group's *kind* (its first number's entity name and its count,
    as one integer), the groups sorted by kind (stable), and each group's
    rank among the groups of its kind."""
    kind = (ctx[start] // SLOTS) * (1 << 32) + np.minimum(count, (1 << 32) - 1)
    order = np.argsort(kind, kind="stable")
    sk = kind[order]
    first = np.r_[0, np.flatnonzero(np.diff(sk)) + 1]
    rank = np.empty(len(kind), dtype=np.int64)
    rank[order] = np.arange(len(kind)) - np.repeat(first, np.diff(np.r_[first, len(kind)]))
    return kind, order, rank


def _copies(nums: list[bytes], start: np.ndarray, kind: np.ndarray, rank: np.ndarray) -> list[int]:
    """For each group, 0 when its numbers are new, else how many groups of its
    kind back the nearest earlier group of its kind with the same number texts
    stands."""
    last: dict[tuple[object, ...], int] = {}
    out: list[int] = []
    ends = np.r_[start[1:], len(nums)].tolist() if len(start) else []
    for a, e, k, r in zip(start.tolist(), ends, kind.tolist(), rank.tolist()):
        key = (k, *nums[a:e])
        prev = last.get(key)
        out.append(0 if prev is None else r - prev)
        last[key] = r
    return out


def _sources(copy: np.ndarray, order: np.ndarray, rank: np.ndarray) -> np.ndarray:
    """Each group's source group: itself when new, else (transitively) the
    new group it copies.

    Raises
    ------
    CorruptError
        A negative copy, or one that reaches before the first group of its kind.
    """
    g = np.arange(len(copy), dtype=np.int64)
    if len(g) and (copy.min() < 0 or np.any(copy > rank)):
        raise CorruptError("STEP model: bad number group copy")
    pos = np.empty(len(g), dtype=np.int64)
    pos[order] = g
    src = order[pos - copy] if len(g) else g
    for _ in range(64):  # pointer jumping: chains halve each round
        nxt = src[src]
        if np.array_equal(nxt, src):
            return src
        src = nxt
    raise CorruptError("STEP model: number group copies do not resolve")


def _ints(values: list[int]) -> bytes:
    return b",".join(b"%d" % v for v in values)


def _read_ints(raw: bytes, n: int, what: str) -> np.ndarray:
    if n == 0:
        if raw:
            raise CorruptError(f"STEP model: {what} stream should be empty")
        return np.zeros(0, dtype=np.int64)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        try:  # numpy's parser, ten times Python's int(); checked below
            fast = np.fromstring(raw, dtype=np.int64, sep=",")
        except (ValueError, DeprecationWarning):
            fast = None
    # a short or saturated parse goes the strict way (which says what is wrong)
    if fast is not None and len(fast) == n and not np.any((fast >= 1 << 62) | (fast <= -(1 << 62))):
        return fast
    parts = raw.split(b",")
    if len(parts) != n:
        raise CorruptError(f"STEP model: {len(parts)} {what}, the skeleton has {n}")
    try:
        return np.array([int(p) for p in parts], dtype=np.int64)
    except (ValueError, OverflowError):
        raise CorruptError(f"STEP model: a {what} value is not an int64") from None


_ENTITY = re.compile(rb"#[0-9]++[ \t\r\n]*+=")


def _looks_like_step(data: bytes) -> bool:
    """The ISO 10303-21 magic in the first 4 kB, or an entity instance ``#12=``
    in the first 64 kB (a piece of a file, a damaged head)."""
    return b"ISO-10303-21" in data[:4096] or _ENTITY.search(data, 0, 65536) is not None


def encode(data: bytes) -> bytes | None:
    """The payload of ``data``, or None when it is not STEP text (module docstring)."""
    if not _looks_like_step(data):
        return None
    parts = TOKEN.split(data)
    step = _GROUPS + 1
    lits = parts[0::step]
    groups = [parts[k::step] for k in range(1, step)]
    n = len(lits) - 1
    kinds = [
        ID
        if a is not None
        else REF
        if b is not None
        else NUM
        if c is not None
        else STR
        if d is not None
        else RAW
        for a, b, c, d in zip(*groups[:4])
    ]
    skel_parts: list[bytes] = [b""] * (2 * n + 1)
    skel_parts[0::2] = lits
    skel_parts[1::2] = [_PH[k] for k in kinds]
    skel = b"".join(skel_parts)
    ids_t = [v for v in groups[0] if v is not None]
    refs_t = [v for v in groups[1] if v is not None]
    nums_t = [v for v in groups[2] if v is not None]
    strs_t = [v for v in groups[3] if v is not None]
    raws_t = [v for v in groups[4] if v is not None]

    ids = np.asarray([int(t[1:]) for t in ids_t], dtype=np.int64)
    id_deltas = np.diff(np.r_[np.int64(0), ids]) - 1

    # references, by context, each stream in the smaller of its two modes
    table, index = _units(skel)
    named = _unit_names(table, index)
    refs = np.asarray([int(t[1:]) for t in refs_t], dtype=np.int64)
    r_stream, r_map = _streams_of(contexts(skel, REF, named))
    owner = _owners(skel, REF, ids)
    ref_streams: list[bytes] = []
    modes: list[int] = []
    for s in range(len(r_map) + 1):
        sel = r_stream == s
        own = refs[sel] - owner[sel]
        chain = np.diff(np.r_[np.int64(0), refs[sel]])
        a, b = coding.int_stream(own), coding.int_stream(chain)
        if _cost(b) < _cost(a):
            modes.append(1)
            ref_streams.append(b)
        else:
            modes.append(0)
            ref_streams.append(a)

    # numbers: groups that repeat an earlier group are copies of it; the
    # others' numbers by context
    g_start, g_count = _groups(skel)
    n_ctx = contexts(skel, NUM, named)
    kind, _, rank = _kinds(n_ctx, g_start, g_count)
    copy = _copies(nums_t, g_start, kind, rank)
    fresh = np.repeat(np.asarray(copy, dtype=np.int64) == 0, g_count)
    n_stream, n_map = _streams_of(n_ctx[fresh])
    num_streams: list[list[bytes]] = [[] for _ in range(len(n_map) + 1)]
    for s, t in zip(n_stream.tolist(), (t for t, f in zip(nums_t, fresh.tolist()) if f)):
        num_streams[s].append(t)

    texts = [b",".join(x) for x in num_streams]
    alts: dict[int, tuple[bytes, bytes]] = {}
    for s, items in enumerate(num_streams):
        pair = numbers.encode(items) if len(texts[s]) >= NUMERIC_QUICK else None
        if pair is not None and _worth_trying(texts[s], pair):
            alts[s] = pair
    body = [
        *_statements(table, index),
        coding.int_stream(id_deltas),
        coding.int_stream(np.asarray([len(t) for t in strs_t], dtype=np.int64)),
        b"".join(strs_t),
        b"".join(raws_t),
        coding.int_stream(np.asarray(copy, dtype=np.int64)),
        *ref_streams,
        *texts,
    ]
    first = len(body) - len(texts)
    extra = [x for s in sorted(alts) for x in alts[s]]
    coded = coding.code(
        body + extra,
        # less one call: the header's share of the budget (it is coded apart)
        brotli_budget=len(data) // BROTLI_SHARE - coding.BROTLI_CALL,
        binary=frozenset(range(len(body), len(body) + len(extra))),
    )
    alt_coded = dict(zip(sorted(alts), zip(coded[len(body) :: 2], coded[len(body) + 1 :: 2])))
    num_modes: list[int] = []
    residuals: list[tuple[Coder, bytes, bytes]] = []
    for s in range(len(texts)):
        alt = alt_coded.get(s)
        if alt is not None and _stored(alt[0]) + _stored(alt[1]) < _stored(coded[first + s]):
            num_modes.append(1)
            coded[first + s] = alt[0]
            residuals.append(alt[1])
        else:
            num_modes.append(0)

    head = [VERSION, len(data), zlib.crc32(data), len(r_map), len(n_map)]
    head += modes
    for cmap in (r_map, n_map):
        for k, s in cmap:
            head += [k, s]
    head += num_modes
    header = b"".join(coding.varint(v) for v in head)
    head_coded = coding.code([header], (Coder.LZMA,), binary=frozenset({0}))
    return coding.pack_coded(head_coded + coded[: len(body)] + residuals)


def _worth_trying(text: bytes, pair: tuple[bytes, bytes]) -> bool:
    """Whether a number stream's coding as numbers is worth coding with LZMA
    next to its text: only where zlib level 1 makes it at most
    :data:`NUMERIC_GATE` of the text's (LZMA codes the text's repeats better
    than zlib does: on the corpus every stream that came out smaller as
    numbers was under 0.70 by this estimate, and the LZMA trials of the
    others were a third of the encode time)."""
    quick = sum(len(zlib.compress(x, 1)) for x in pair)
    return quick < NUMERIC_GATE * len(zlib.compress(text, 1))


def _stored(c: tuple[object, bytes, bytes]) -> int:
    """The bytes a coded stream takes in :func:`coding.pack_coded`'s layout,
    less its two length varints (the smaller of payload and raw)."""
    return min(len(c[1]), len(c[2]))


def _units(skel: bytes) -> tuple[list[bytes], np.ndarray]:
    """The skeleton's distinct *statements* (the pieces it is cut into after
    each ``;``) in order of first appearance, and each statement's index in
    that list."""
    seen: dict[bytes, int] = {}
    index = [seen.setdefault(u, len(seen)) for u in _STATEMENT.split(skel)]
    return list(seen), np.asarray(index, dtype=np.int64)


def _statements(table: list[bytes], index: np.ndarray) -> list[bytes]:
    """The skeleton as three streams (version 3): its distinct statements
    (:func:`_units`), their lengths, and each statement's index, as unsigned
    integers of 1, 2 or 4 bytes (the fewest that hold the number of distinct
    statements), little-endian, one byte plane after another.  A few hundred
    distinct statements make up a skeleton of tens of thousands: LZMA2 codes
    the three in a tenth of the time it takes on the skeleton, and smaller
    (19% on the corpus)."""
    width = _index_width(len(table))
    planes = index.astype(f"<u{width}").view(np.uint8).reshape(-1, width).T
    return [b"".join(table), _ints([len(u) for u in table]), planes.tobytes()]


#: Bytes of a word (:data:`NAME`), of a word's first byte, and the blanks
#: between a name and its ``(``.
_WORD = np.zeros(256, bool)
_WORD[list(b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789_")] = True
_FIRST = _WORD.copy()
_FIRST[list(b"0123456789")] = False
_BLANK = np.zeros(256, bool)
_BLANK[list(b" \t\r\n")] = True


def _name_spans(text: bytes) -> tuple[np.ndarray, np.ndarray]:
    """Where each match of :data:`NAME` in ``text`` starts and ends, with
    numpy: the maximal runs of word bytes that start with a letter or ``_``
    and that blanks and a ``(`` follow (a tenth of the time of the regular
    expression's scan)."""
    a = np.frombuffer(text, np.uint8)
    word = _WORD[a]
    edge = np.flatnonzero(np.diff(word, prepend=False, append=False))
    start, end = edge[0::2], edge[1::2]  # runs [start, end) of word bytes
    rest = np.flatnonzero(~_BLANK[a])  # where a run's blanks stop
    k = np.searchsorted(rest, end)
    paren = np.zeros(len(end), bool)
    has = k < len(rest)
    paren[has] = a[rest[k[has]]] == ord("(")
    keep = paren & _FIRST[a[start]]
    return start[keep], end[keep]


def _unit_names(table: list[bytes], index: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`names` of the skeleton the statements make, found in each
    distinct statement once (a name never crosses a statement: each ends
    with ``;``)."""
    lens = np.fromiter(map(len, table), dtype=np.int64, count=len(table))
    # one pass over the statements joined (a name's look-behind sees the
    # previous statement's closing ";", as it would see nothing alone)
    seen: dict[bytes, int] = {}
    joined = b"".join(table)
    at_all, name_end = _name_spans(joined)
    local = np.asarray(
        [
            seen.setdefault(joined[a:e], len(seen))
            for a, e in zip(at_all.tolist(), name_end.tolist())
        ],
        dtype=np.int64,
    )
    unit_start = np.cumsum(lens) - lens
    owner = np.searchsorted(unit_start + lens, at_all, side="right")
    count = np.bincount(owner, minlength=len(table)).astype(np.int64)
    pos = at_all - unit_start[owner]
    if not len(index) or not len(pos):
        return np.zeros(0, dtype=np.int64), np.zeros(1, dtype=np.int64)
    first = np.cumsum(count) - count
    k = count[index]
    total = int(k.sum())
    at = np.repeat(np.cumsum(lens[index]) - lens[index], k)
    within = np.arange(total, dtype=np.int64) - np.repeat(np.cumsum(k) - k, k)
    src = np.repeat(first[index], k) + within
    starts = pos[src] + at
    lid = local[src]
    # number the names in order of first appearance in the skeleton: the
    # order they are found in the table when its statements are too, each
    # used and in order of first use (as _units makes it)
    seq = np.maximum.accumulate(index)
    if index[0] == 0 and seq[-1] == len(table) - 1 and (index[1:] <= seq[:-1] + 1).all():
        return starts, np.r_[np.int64(0), lid + 1]
    uniq, first_at = np.unique(lid, return_index=True)
    rank = np.empty(len(seen), dtype=np.int64)
    rank[uniq[np.argsort(first_at)]] = np.arange(1, len(uniq) + 1)
    return starts, np.r_[np.int64(0), rank[lid]]


def _index_width(n: int) -> int:
    """Bytes per statement index for ``n`` distinct statements."""
    return 1 if n <= 1 << 8 else 2 if n <= 1 << 16 else 4


def _skeleton(
    units: bytes, lens_raw: bytes, index_raw: bytes, size: int
) -> tuple[list[bytes], np.ndarray]:
    """Invert :func:`_statements`: the table and index of :func:`_units`.  A
    skeleton longer than ``size`` (the text's length: every value stands for
    one byte or more) is refused before it is made."""
    if not lens_raw:
        raise CorruptError("STEP model: no statements")
    lens = _read_ints(lens_raw, lens_raw.count(b",") + 1, "statement lengths")
    if lens.min() < 0 or int(lens.sum()) != len(units):
        raise CorruptError("STEP model: statement lengths do not add up")
    width = _index_width(len(lens))
    if len(index_raw) % width:
        raise CorruptError("STEP model: statement index has the wrong size")
    planes = np.frombuffer(index_raw, np.uint8).reshape(width, -1)
    index = np.ascontiguousarray(planes.T).view(f"<u{width}").ravel().astype(np.int64)
    if len(index) and int(index.max()) >= len(lens):
        raise CorruptError("STEP model: a statement index past the dictionary")
    if int(lens[index].sum()) > size:
        raise CorruptError("STEP model: skeleton longer than the text")
    ends = np.cumsum(lens).tolist()
    table = [units[a:b] for a, b in zip([0, *ends[:-1]], ends)]
    return table, index


def _cost(stream: bytes) -> int:
    """A quick size estimate of a stream (zlib, level 6), to choose a mode."""
    return len(zlib.compress(stream, 6))


def decode(payload: bytes, limit: int) -> bytes:
    """The STEP text ``payload`` was made from; at most ``limit`` bytes.

    Raises
    ------
    CorruptError, TruncatedError, LimitError
        A payload :func:`encode` does not write, or one that decodes past ``limit``.
    """
    try:
        return _decode(payload, limit)
    except FormatError:
        raise
    except (ValueError, IndexError, OverflowError, MemoryError) as e:
        raise CorruptError(f"STEP model does not decode ({type(e).__name__})") from None


def _decode(payload: bytes, limit: int) -> bytes:
    # every stream is at most twice the text (a number's separator, a
    # placeholder): the streams' total is held to that
    streams = coding.unpack(payload, 2 * limit + 4096)
    if len(streams) < 9:
        raise CorruptError(f"STEP model: {len(streams)} streams")
    header = streams[0]
    pos = 0

    def next_int() -> int:
        nonlocal pos
        v, pos = coding.read_varint(header, pos)
        return v

    version = next_int()
    if version not in _VERSIONS:
        raise CorruptError("STEP model: unknown version")
    size, crc, nr, nn = next_int(), next_int(), next_int(), next_int()
    if size > limit:
        raise LimitError(f"STEP model decodes to {size} bytes, more than {limit}")
    if version >= 3:  # the skeleton as statements: three streams for one
        if len(streams) < 11:
            raise CorruptError(f"STEP model: {len(streams)} streams")
        table, index = _skeleton(streams[1], streams[2], streams[3], size)
        streams = [streams[0], b"".join(_pick(table, index)), *streams[4:]]
    else:
        table, index = _units(streams[1])
    modes = [next_int() for _ in range(nr + 1)]
    if any(m > 1 for m in modes):
        raise CorruptError("STEP model: unknown reference mode")
    r_map = [(next_int(), next_int()) for _ in range(nr)]
    n_map = [(next_int(), next_int()) for _ in range(nn)]
    num_modes = [next_int() for _ in range(nn + 1)] if version >= 4 else [0] * (nn + 1)
    if any(m > 1 for m in num_modes):
        raise CorruptError("STEP model: unknown number mode")
    if len(streams) != 9 + nr + nn + sum(num_modes):
        want = 9 + nr + nn + sum(num_modes)
        raise CorruptError(f"STEP model: {len(streams)} streams, header says {want}")
    if pos != len(header):
        raise CorruptError("STEP model: bytes after the header")
    for cmap, count in ((r_map, nr), (n_map, nn)):
        if sorted(s for _, s in cmap) != list(range(1, count + 1)):
            raise CorruptError("STEP model: bad context map")
    skel, id_raw, slen_raw, str_raw, raw_raw, copy_raw = streams[1:7]
    ref_raw = streams[7 : 8 + nr]
    num_raw = streams[8 + nr : 9 + nr + nn]
    res_raw = iter(streams[9 + nr + nn :])

    arr = np.frombuffer(skel, dtype=np.uint8)
    holes = np.flatnonzero((arr >= ID) & (arr <= RAW))
    kinds = arr[holes]
    counts = np.bincount(kinds, minlength=RAW + 1)
    is_kind = [kinds == k for k in range(RAW + 1)]
    ids_before = np.cumsum(is_kind[ID])  # entity ids up to each placeholder
    n = int(len(kinds))
    if len(skel) - n > size:
        raise CorruptError("STEP model: skeleton longer than the text")

    # ids
    read = coding.read_int_stream if version >= 3 else _read_ints
    ids = np.cumsum(read(id_raw, int(counts[ID]), "ids") + 1)
    id_t = columns.ints(ids, b"#")

    # references
    named = _unit_names(table, index)
    r_ctx = contexts(skel, REF, named, holes[is_kind[REF]])
    r_stream = _apply_map(r_ctx, r_map)
    owner = np.r_[np.int64(0), ids][ids_before[is_kind[REF]]]
    refs = np.zeros(len(r_ctx), dtype=np.int64)
    for s in range(nr + 1):
        sel = r_stream == s
        d = read(ref_raw[s], int(sel.sum()), "references")
        refs[sel] = (owner[sel] + d) if modes[s] == 0 else np.cumsum(d)
    ref_t = columns.ints(refs, b"#")

    # numbers: the new groups' from the streams, the copies' from their source
    g_start, g_count = _runs(ids_before[is_kind[NUM]])
    n_ctx = contexts(skel, NUM, named, holes[is_kind[NUM]])
    _, g_order, g_rank = _kinds(n_ctx, g_start, g_count)
    copy = read(copy_raw, len(g_start), "number groups")
    src = _sources(copy, g_order, g_rank)
    fresh = np.repeat(copy == 0, g_count)
    n_stream = _apply_map(n_ctx[fresh], n_map)
    per = np.bincount(n_stream, minlength=nn + 1) if len(n_stream) else np.zeros(nn + 1, int)
    pieces = columns.concat(
        [
            numbers.decode_column(num_raw[s], next(res_raw), int(per[s]))
            if num_modes[s]
            else columns.split(num_raw[s], int(per[s]), "numbers")
            for s in range(nn + 1)
        ]
    )
    # stream numbers: sorted stably as 16-bit integers (a radix sort) where they fit
    order = np.argsort(n_stream.astype(np.uint16) if nn < 1 << 16 else n_stream, kind="stable")
    inv = np.empty_like(order)
    inv[order] = np.arange(len(order))
    # number k of group g is number k of group src[g]; fresh numbers are
    # numbered in text order among the fresh ones
    fresh_rank = np.cumsum(fresh) - 1
    within = np.arange(len(fresh), dtype=np.int64) - np.repeat(g_start, g_count)
    source = np.repeat(g_start[src], g_count) + within
    num_t = columns.take(pieces, inv[fresh_rank[source]] if len(source) else source)

    # strings and raw bytes
    slen = read(slen_raw, int(counts[STR]), "string lengths")
    if len(slen) and (slen.min() < 2 or int(slen.sum()) != len(str_raw)):
        raise CorruptError("STEP model: string lengths do not add up")
    str_t = columns.Column(str_raw, np.cumsum(slen) - slen, slen)
    if len(raw_raw) != counts[RAW]:
        raise CorruptError("STEP model: raw bytes do not match the skeleton")
    raw_t = columns.Column(raw_raw, np.arange(len(raw_raw)), np.ones(len(raw_raw), np.int64))

    # every placeholder's value, in skeleton order
    allv = columns.concat([id_t, ref_t, num_t, str_t, raw_t])
    place = np.empty(n, dtype=np.int64)
    offset = 0
    for k in range(ID, RAW + 1):
        sel = is_kind[k]
        place[sel] = np.arange(offset, offset + int(counts[k]))
        offset += int(counts[k])
    total = len(skel) - n + int(allv.size[place].sum())
    if total != size:
        raise CorruptError(f"STEP model decodes to {total} bytes, header says {size}")
    out = columns.fill(skel, holes, columns.take(allv, place)).tobytes()
    if zlib.crc32(out) != crc:
        raise CorruptError("STEP model: CRC-32 of the text does not match")
    return out


def _pick(items: list[bytes], index: np.ndarray) -> list[bytes]:
    """``[items[i] for i in index]``, in bulk."""
    if len(index) == 0:
        return []
    if len(index) == 1:
        return [items[int(index[0])]]
    return list(operator.itemgetter(*index.tolist())(items))
