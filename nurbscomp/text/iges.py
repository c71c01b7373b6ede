"""The IGES text model (issue 29): fixed 80-column records, byte for byte.

``encode(data)`` returns the model's payload, or None where the text is not
IGES it can model; ``decode(payload, limit)`` inverts it.  docs/text-model.md (IGES)
describes the model and its figures.

The file is cut at ``\\n`` into pieces.  A piece that is an 80-column record
(81 with the ``\\r`` of a CRLF file) with a section letter S, G, D, P or T in
column 73 is a *record*; any other piece (a short line, garbage, the
compressed or binary forms) is stored as it is in the raw stream, so every
byte comes back whatever the file holds.  Of a record:

* columns 73-80 (letter and sequence number) are recomputed: the letters as
  runs, the numbers as 1, 2, ... within each run, written zero-padded or
  right-aligned as the file does; a field that differs is an exception;
* S, G and T columns 1-72 are kept as text (trailing blanks dropped);
* D entries (line pairs, nine 8-column fields a line): the entity type is
  predicted from its parameter record's first parameter, the parameter
  pointer and line count from the P section, the second type field from the
  first, and every other field from the previous entry of the same type; a
  mask says which fields differ from their prediction and those are stored;
* P lines are grouped into parameter records by their columns 65-72 (the
  pointer back to the D entry, predicted as the previous record's + 2).  A
  record's text is its lines' columns 1-64 without trailing blanks, joined;
  the line breaks are predicted by the writer's policy (fill to 64 columns
  breaking after a delimiter, or one parameter a line) with exceptions;
* the parameter text of all records becomes a skeleton (integers as written,
  each real a placeholder byte), a dictionary of number formats (sign, digit
  places, point, exponent: ``-#.######E-003``), the formats' ids and the
  digits, so a number comes back exactly as written (``1.0D0``,
  ``0.5000000000000009992``), never through a float; the poles of B-spline
  surfaces (128) are coded as integer differences from a parallelogram
  prediction where that pays.

Decoding is whole-array work (numpy masks, scatters and joins), no loop per
character; the P layout takes one Python step a line.
"""

from __future__ import annotations

import re
from bisect import bisect_right

import numpy as np

from ..errors import CorruptError, FormatError, LimitError, TruncatedError
from . import coding, columns

#: Payload version: 2 adds the second-difference pole predictor (lane flag 2);
#: 1 is still read.
VERSION = 2
_VERSIONS = (1, 2)
#: Columns of parameter data on a P line.
P_WIDTH = 64
#: D fields predicted from elsewhere: type, parameter pointer, type again, line count.
_COMPUTED = (0, 1, 9, 12)
_DEFAULT_FIELD = b"       0"
_LETTERS = b"SGDPT"
_N_STREAMS = 12


def encode(data: bytes) -> bytes | None:
    """The model's payload for ``data``, or None when it is not IGES this models."""
    try:
        return _encode(data)
    except (ValueError, IndexError, KeyError, OverflowError, RecursionError, MemoryError):
        return None  # never a crash: the plain stream is kept


def decode(payload: bytes, limit: int) -> bytes:
    """The bytes :func:`encode` made ``payload`` from, at most ``limit`` of them.

    Raises
    ------
    FormatError
        CorruptError, TruncatedError or LimitError for a payload that is
        damaged or inflates past ``limit``.
    """
    try:
        return _decode(payload, limit)
    except FormatError:
        raise
    except (ValueError, IndexError, KeyError, OverflowError, TypeError) as e:
        raise CorruptError(f"IGES text model does not decode ({type(e).__name__})") from None


# ---------------------------------------------------------------- helpers


def _fmt(zero: bool, width: int, values: list[int]) -> bytes:
    """``values`` as fixed-width fields, zero-padded or right-aligned, joined.
    A value too wide for the field is cut to its last ``width`` characters
    (it is then an exception)."""
    f = b"%0*d" if zero else b"%*d"
    return b"".join([(f % (width, v))[-width:] for v in values])


def _fmt_rows(zero: bool, width: int, values: np.ndarray) -> np.ndarray:
    """:func:`_fmt` of values >= 0 as an (n, width) array of bytes."""
    v = values.astype(np.int64)
    if len(v) and v.min() < 0:
        return np.frombuffer(_fmt(zero, width, v.tolist()), np.uint8).reshape(len(v), width)
    # a column at a time from the right, dividing by ten (numpy divides by a
    # constant fast; its % and a division by an array of powers are slow)
    out = np.empty((len(v), width), np.uint8)
    q = v.astype(np.uint64)
    ten = np.uint64(10)
    for k in range(width - 1, -1, -1):
        q10 = q // ten
        out[:, k] = (q - q10 * ten).astype(np.uint8) + np.uint8(48)
        if not zero and k < width - 1:
            out[q == 0, k] = 32  # right-aligned: blank left of the number
        q = q10
    return out


def _delims(gtext: bytes) -> tuple[int, int]:
    """The parameter and record delimiters the global section declares
    (``,`` and ``;`` by default, or ``1Hx`` for another)."""
    pd, rd = ord(","), ord(";")
    g = gtext
    if g[:2] == b"1H" and len(g) > 3:
        pd = g[2]
        g = g[3:]
    else:
        g = g[1:] if g[:1] == b"," else b""
    if g[:1] == bytes([pd]):
        g = g[1:]
        if g[:2] == b"1H" and len(g) > 2:
            rd = g[2]
    if pd in b"0123456789 \n" or rd in b"0123456789 \n" or pd == rd:
        return ord(","), ord(";")
    return pd, rd


def _rows(blob: bytes, width: int, n: int) -> np.ndarray:
    if len(blob) != width * n:
        raise CorruptError("IGES model: a fixed-width table has the wrong size")
    return np.frombuffer(blob, np.uint8).reshape(n, width)


def _layout(mode: int, bounds: np.ndarray, s: np.ndarray, e: np.ndarray) -> np.ndarray:
    """The predicted length of a P line starting at each ``s`` in a record
    ending at ``e`` (-1 where ``s`` is at or past ``e``): mode 0, fill to
    P_WIDTH breaking after the last delimiter that fits; mode 1, one parameter
    a line.  ``bounds``: the positions just after each delimiter, ascending."""
    if mode == 0:
        i = np.searchsorted(bounds, s + P_WIDTH, side="right") - 1
        b = np.where(i >= 0, bounds[np.maximum(i, 0)] if len(bounds) else -1, -1)
        n = np.where(b > s, b - s, P_WIDTH)
        n = np.where(e - s <= P_WIDTH, e - s, n)
    else:
        i = np.searchsorted(bounds, s, side="right")
        b = bounds[np.minimum(i, len(bounds) - 1)] if len(bounds) else e
        b = np.where(i < len(bounds), b, e)
        n = np.minimum(np.minimum(b, e), s + P_WIDTH) - s
    return np.where(s < e, n, -1)


def _layout1(mode: int, bounds: list[int], s: int, e: int) -> int:
    """:func:`_layout` of one line."""
    if s >= e:
        return -1
    if mode == 0:
        if e - s <= P_WIDTH:
            return e - s
        i = bisect_right(bounds, s + P_WIDTH) - 1
        b = bounds[i] if i >= 0 else -1
        return b - s if b > s else P_WIDTH
    i = bisect_right(bounds, s)
    b = bounds[i] if i < len(bounds) else e
    return min(b, e, s + P_WIDTH) - s


#: Records laid out together below this many: then the rest line by line.
FEW_RECORDS = 24


def _bounds(ptext: bytes, pd: int, rd: int) -> np.ndarray:
    """The positions just after each delimiter of ``ptext``."""
    a = np.frombuffer(ptext, np.uint8)
    return np.flatnonzero((a == pd) | (a == rd)) + 1


def _lines(
    mode: int,
    bounds: np.ndarray,
    rlen: np.ndarray,
    rcount: np.ndarray,
    exc: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """Where each P line starts in the joined record text and its length: the
    records (of ``rlen`` bytes and ``rcount`` lines, joined by one byte each)
    laid out by :func:`_layout` but where ``exc`` (one per line, -1 for none)
    gives the length.  All records advance a line at a time together.

    Raises
    ------
    CorruptError
        A line that does not fit its record, or lines that do not cover it.
    """
    nrec = len(rlen)
    npl = int(rcount.sum())
    rpos = np.cumsum(rlen + 1) - (rlen + 1)
    ends = rpos + rlen
    base = np.cumsum(rcount) - rcount
    order = np.argsort(-rcount, kind="stable")
    desc = rcount[order]
    starts = np.empty(npl, np.int64)
    lens = np.empty(npl, np.int64)
    pos = rpos.copy()
    bnd: list[int] | None = None
    for j in range(int(desc[0]) if nrec else 0):
        act = order[: int(np.searchsorted(-desc, -j, side="left"))]
        if len(act) < FEW_RECORDS:  # a few long records left: each on its own
            # those with a layout exception to come line by line, the others
            # by pointer doubling
            xl = np.flatnonzero(exc >= 0)
            xr = np.searchsorted(base, xl, side="right") - 1
            late = np.isin(act, xr[xl - base[xr] >= j])
            slow = act[late].tolist()
            quick = act[~late]
            if len(quick):
                got = _chain(mode, bounds, pos[quick], ends[quick], rcount[quick] - j)
                if got is None:
                    slow = act.tolist()
                else:
                    left = rcount[quick] - j
                    at = np.repeat(base[quick] + j - (np.cumsum(left) - left), left)
                    at += np.arange(len(at))
                    starts[at], lens[at] = got
                    pos[quick] = ends[quick]
            bnd = bounds.tolist() if slow else []
            for r in slow:
                pr, er, lr = int(pos[r]), int(ends[r]), int(base[r])
                for li in range(lr + j, lr + int(rcount[r])):
                    w = int(exc[li])
                    w = w if w >= 0 else _layout1(mode, bnd, pr, er)
                    if w < 0 or w > P_WIDTH or pr + w > er:
                        raise CorruptError("IGES model: P line layout does not fit its record")
                    starts[li] = pr
                    lens[li] = w
                    pr += w
                pos[r] = pr
            break
        p, e = pos[act], ends[act]
        li = base[act] + j
        n = _layout(mode, bounds, p, e)
        x = exc[li]
        n = np.where(x >= 0, x, n)
        if ((n < 0) | (n > P_WIDTH) | (p + n > e)).any():
            raise CorruptError("IGES model: P line layout does not fit its record")
        starts[li] = p
        lens[li] = n
        pos[act] = p + n
    if (pos != ends).any():
        raise CorruptError("IGES model: P lines do not cover their record")
    return starts, lens


#: Rounds of :func:`_chain` that add the positions lines break at inside a
#: parameter (no delimiter fits) before it gives up: then line by line.
CHAIN_ROUNDS = 4


def _merge(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The distinct values of two ascending arrays, ascending (``b`` the
    shorter: ``np.unique`` sorts, ten times the time of this)."""
    out = np.insert(a, np.searchsorted(a, b), b)
    return out[np.r_[True, out[1:] != out[:-1]]] if len(out) else out


def _chain(
    mode: int, bounds: np.ndarray, first: np.ndarray, end: np.ndarray, count: np.ndarray
) -> tuple[np.ndarray, np.ndarray] | None:
    """Where each line of some records starts and its length, the records
    (disjoint, from ``first`` to ``end``, ``count`` lines each) laid out by
    :func:`_layout` alone, by pointer doubling: a line's start follows from
    the previous one's, so the starts lines can have (the records' first
    positions and the bounds in them; a position past a parameter cut at
    P_WIDTH is added) are each given the next, and the k-th line's start
    found in log2(k) steps.  None when lines cut parameters more than
    :data:`CHAIN_ROUNDS` rounds find.

    Raises
    ------
    CorruptError
        A line that does not fit its record, or lines that do not cover it.
    """
    order = np.argsort(first)
    lo, hi = first[order], end[order]
    k = np.searchsorted(hi, bounds, side="left")
    inside = k < len(hi)
    inside[inside] &= bounds[inside] > lo[k[inside]]
    nodes = _merge(bounds[inside], lo)
    for _ in range(CHAIN_ROUNDS):
        e = hi[np.searchsorted(hi, nodes, side="left")]
        step = _layout(mode, bounds, nodes, e)
        ok = (step >= 0) & (step <= P_WIDTH) & (nodes + step <= e)
        nxt = nodes + step
        to = nxt[ok]
        where = np.searchsorted(nodes, to)
        new = to[nodes[np.minimum(where, len(nodes) - 1)] != to]
        if not len(new):
            break
        nodes = _merge(nodes, np.sort(new))
    else:
        return None
    sink = len(nodes)
    jump = np.full(sink + 1, sink, np.int64)  # the sink: where a line does not fit
    jump[:-1][ok] = where
    # the start of line t of each record, t = 0 ... count (the last: where it ends)
    t = np.arange(int(count.sum()) + len(count)) - np.repeat(
        np.cumsum(count + 1) - count - 1, count + 1
    )
    at = np.repeat(np.searchsorted(nodes, first), count + 1)
    for bit in range(int(count.max()).bit_length()):
        at = np.where(t >> bit & 1, jump[at], at)
        jump = jump[jump]
    last = np.cumsum(count + 1) - 1
    line = np.ones(len(at), bool)
    line[last] = False
    if (at[line] == sink).any() or not ok[at[line]].all():
        raise CorruptError("IGES model: P line layout does not fit its record")
    if (at[last] == sink).any() or (nodes[np.minimum(at[last], sink - 1)] != end).any():
        raise CorruptError("IGES model: P lines do not cover their record")
    at = at[line]
    return nodes[at], step[at]


class _Varints:
    """Reads LEB128 integers one after another from one stream."""

    def __init__(self, data: bytes) -> None:
        self.data, self.pos = data, 0

    def __call__(self) -> int:
        v, self.pos = coding.read_varint(self.data, self.pos)
        return v

    def many(self, n: int) -> np.ndarray:
        """The next ``n`` integers (one numpy pass: ``coding.read_varints``)."""
        if n > len(self.data) - self.pos:
            raise TruncatedError("IGES model: fewer integers than declared")
        v, self.pos = coding.read_varints(self.data, self.pos, n)
        return v

    def gaps(self, n: int, bound: int, what: str) -> np.ndarray:
        """``n`` increasing indices below ``bound``, stored as gaps.

        Raises
        ------
        CorruptError
            An index at or past ``bound`` (``what`` says which).
        """
        g = self.many(n)
        if n and int(g.max()) >= bound:  # checked first: the sum stays in an int64
            raise CorruptError(f"IGES model: {what}")
        at = np.cumsum(g + 1) - 1
        if n and int(at[-1]) >= bound:
            raise CorruptError(f"IGES model: {what}")
        return at


def _gaps(idx: list[int]) -> list[int]:
    out, prev = [], -1
    for i in idx:
        out.append(i - prev - 1)
        prev = i
    return out


# ---------------------------------------------------------------- encode


def _encode(data: bytes) -> bytes | None:
    pieces = data.split(b"\n")
    crlf = 2 * sum(1 for p in pieces if p[-1:] == b"\r") > len(pieces)
    reclen = 81 if crlf else 80
    letters_ok = set(_LETTERS)
    is_rec = [
        len(p) == reclen and p[72] in letters_ok and (not crlf or p[80] == 13) for p in pieces
    ]
    raw_idx = [i for i, r in enumerate(is_rec) if not r]
    recs = [p[:80] for p, r in zip(pieces, is_rec) if r]
    m = len(recs)
    if m == 0:
        return None
    M = np.frombuffer(b"".join(recs), np.uint8).reshape(m, 80)
    letters = M[:, 72]
    if not ((letters == ord("D")).any() or (letters == ord("P")).any()):
        return None

    # letter runs and sequence numbers
    change = np.flatnonzero(letters[1:] != letters[:-1]) + 1
    starts = np.concatenate(([0], change))
    counts = np.diff(np.concatenate((starts, [m])))
    run_id = np.repeat(np.arange(len(starts)), counts)
    seqno = np.arange(m) - starts[run_id] + 1
    seq_actual = M[:, 73:80]
    best: tuple[int, bool, np.ndarray] | None = None
    for zero in (True, False):
        pred = _fmt_rows(zero, 7, seqno)
        bad = np.flatnonzero((pred != seq_actual).any(axis=1))
        if best is None or len(bad) < best[0]:
            best = (len(bad), zero, bad)
    assert best is not None
    _, seq_zero, seq_bad = best

    # S, G, T text; D pairs; P lines
    is_d = letters == ord("D")
    is_p = letters == ord("P")
    d_idx = np.flatnonzero(is_d)
    nd = len(d_idx) // 2
    text_mask = ~(is_d | is_p)
    if len(d_idx) % 2:
        text_mask[d_idx[-1]] = True
        d_idx = d_idx[:-1]
    text_rows = [bytes(r).rstrip(b" ") for r in M[text_mask, :72]]
    gtext = b"".join(bytes(r) for r in M[letters == ord("G"), :72])
    pd, rd = _delims(gtext)

    # P records
    P = M[is_p]
    npl = len(P)
    tails = P[:, 64:72]
    if npl:
        rstart = np.concatenate(([0], np.flatnonzero((tails[1:] != tails[:-1]).any(axis=1)) + 1))
    else:
        rstart = np.zeros(0, np.int64)
    rcount = np.diff(np.concatenate((rstart, [npl]))).tolist()
    rstart_l = rstart.tolist()
    rtails = [bytes(tails[s]) for s in rstart_l]
    content = P[:, :64].tobytes()
    lines = [content[64 * i : 64 * i + 64].rstrip(b" ") for i in range(npl)]
    lens = [len(x) for x in lines]
    # record DE numbers: predicted as the previous + 2
    best_tail: tuple[int, bool, list[int], list[int]] | None = None
    for zero in (True, False):
        cur, exc, des = 1, [], []
        for r, t in enumerate(rtails):
            if t != b" " + _fmt(zero, 7, [cur]):
                exc.append(r)
            s = t.strip()
            val = int(s) if s.isdigit() and len(s) < 12 else cur
            des.append(val)
            cur = val + 2
        if best_tail is None or len(exc) < best_tail[0]:
            best_tail = (len(exc), zero, exc, des)
    assert best_tail is not None
    _, tail_zero, tail_exc, rdes = best_tail
    rtexts = []
    k = 0
    for c in rcount:
        rtexts.append(b"".join(lines[k : k + c]))
        k += c
    ptext = b"\n".join(rtexts)

    # layout of P lines: the policy with fewest exceptions
    bounds = _bounds(ptext, pd, rd)
    lens_a = np.asarray(lens, np.int64)
    rcount_a = np.asarray(rcount, np.int64)
    rec = np.repeat(np.arange(len(rcount_a)), rcount_a)
    rlen = np.asarray([len(t) for t in rtexts], np.int64)
    line_pos = np.cumsum(lens_a) - lens_a + rec  # one joining byte per record before
    line_end = (np.cumsum(rlen + 1) - 1)[rec] if len(rec) else line_pos
    best_lay: tuple[int, np.ndarray] | None = None
    for mode in (0, 1):
        bad = np.flatnonzero(_layout(mode, bounds, line_pos, line_end) != lens_a)
        if best_lay is None or len(bad) < len(best_lay[1]):
            best_lay = (mode, bad)
    assert best_lay is not None
    lay_mode = best_lay[0]
    lay_i = best_lay[1].tolist()
    lay_l = lens_a[best_lay[1]].tolist()

    # D entries
    D = M[d_idx, :72].reshape(nd, 18, 8)
    rend = np.cumsum(rlen + 1) - 1
    types = _record_types(ptext, pd, rend - rlen, rend)
    erec = _entry_records(np.asarray(rdes, np.int64), nd)
    pred_c = _d_predicted(erec, np.asarray(rstart_l, np.int64), rcount_a, types)
    dmask, dvals = _d_encode(D, pred_c)

    # skeleton and digits
    ph = _placeholder(ptext)
    if ph is None:
        return None
    numbers = _numbers_encode(ptext, pd, rd, ph)

    header = [
        VERSION,
        crlf | seq_zero << 1 | tail_zero << 2 | lay_mode << 3,
        ph,
        pd,
        rd,
        len(pieces),
        len(raw_idx),
        len(starts),
        *[v for s, c in zip(starts.tolist(), counts.tolist()) for v in (int(letters[s]), c)],
        len(seq_bad),
        len(text_rows),
        len(rcount),
        len(tail_exc),
        len(lay_i),
        nd,
    ]
    ints = (
        _gaps(raw_idx) + _gaps(seq_bad.tolist()) + _gaps(tail_exc) + _gaps(lay_i) + lay_l + rcount
    )
    exc_bytes = b"".join(bytes(seq_actual[i]) for i in seq_bad) + b"".join(
        rtails[r] for r in tail_exc
    )
    streams = [
        b"".join(coding.varint(v) for v in header),
        b"\n".join(pieces[i] for i in raw_idx),
        b"".join(coding.varint(v) for v in ints) + exc_bytes,
        b"\n".join(text_rows),
        dmask,
        dvals,
        *numbers,
    ]
    return coding.pack(streams, quick=True)


#: The bytes ``bytes.strip()`` takes off (ASCII whitespace).
_WHITE = np.zeros(256, bool)
_WHITE[list(b" \t\n\r\x0b\x0c")] = True
#: Record heads up to this long (to the first delimiter) are read as arrays.
_HEAD_SPAN = 16


def _record_types(ptext: bytes, pd: int, rbeg: np.ndarray, rend: np.ndarray) -> np.ndarray:
    """Each record's first parameter as a D field: ``ptext[rbeg:rend]`` up
    to its first ``pd``, stripped, right-aligned in 8 columns; blanks where
    it is longer.  An (n, 8) array; one gather of a short window a record,
    Python's ``strip`` only on heads longer than :data:`_HEAD_SPAN`."""
    n = len(rbeg)
    out = np.full((n, 8), 32, np.uint8)
    if not n:
        return out
    a = np.frombuffer(ptext, np.uint8)
    if not len(a):
        return out
    # each record's first bytes, one past the longest head read here
    cols = np.arange(_HEAD_SPAN + 1)
    win = a[np.minimum(rbeg[:, None] + cols, len(a) - 1)]
    sep = (win == pd) & (cols < (rend - rbeg)[:, None])
    span = np.where(sep.any(axis=1), np.argmax(sep, axis=1), rend - rbeg)  # to the first pd
    short = span <= _HEAD_SPAN
    keep = (cols < span[:, None]) & ~_WHITE[win]
    some = keep.any(axis=1)
    lo = np.argmax(keep, axis=1)
    hi = _HEAD_SPAN + 1 - np.argmax(keep[:, ::-1], axis=1)
    size = np.where(some, hi - lo, 0)
    fits = short & (size <= 8)
    for c in range(8):
        at = np.flatnonzero(fits & (c >= 8 - size))
        out[at, c] = win[at, (lo + c - 8 + size)[at]]
    for r in np.flatnonzero(~short).tolist():
        b, e = int(rbeg[r]), int(rend[r])
        cut = ptext.find(bytes([pd]), b, e)
        head = ptext[b : e if cut < 0 else cut].strip()
        if len(head) <= 8:
            out[r] = np.frombuffer(b"%8s" % head, np.uint8)
    return out


def _entry_records(des: np.ndarray, nd: int) -> np.ndarray:
    """For each of ``nd`` D entries, the first record whose back pointer
    (``des``) is its DE number ``2 k + 1``; -1 where none is."""
    rec = np.full(nd, -1, np.int64)
    odd = np.flatnonzero((des & 1 == 1) & (des >= 0) & (des < 2 * nd))
    k, first = np.unique(des[odd] >> 1, return_index=True)
    rec[k] = odd[first]
    return rec


def _d_predicted(
    rec: np.ndarray, rstart: np.ndarray, rcount: np.ndarray, types: np.ndarray
) -> np.ndarray:
    """The computed D fields (type, pointer, type, line count) of each entry,
    predicted from its parameter record ``rec`` (:func:`_entry_records`);
    blanks where there is none.  ``types``: :func:`_record_types`."""
    out = np.full((len(rec), 4, 8), 32, np.uint8)
    has = np.flatnonzero(rec >= 0)
    r = rec[has]
    out[has, 0] = out[has, 2] = types[r]
    out[has, 1] = _fmt_rows(False, 8, rstart[r] + 1)
    out[has, 3] = _fmt_rows(False, 8, rcount[r])
    return out


def _d_prev_same_type(key: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Order stable by type, and whether each position in it starts a type."""
    order = np.argsort(key, kind="stable")
    ks = key[order]
    first = np.ones(len(key), bool)
    first[1:] = ks[1:] != ks[:-1]
    return order, first


def _d_encode(D: np.ndarray, pred_c: np.ndarray) -> tuple[bytes, bytes]:
    nd = len(D)
    pred = np.empty_like(D)
    pred[:, list(_COMPUTED)] = pred_c
    pred[:, 9] = D[:, 0]  # the second type field repeats the first
    key = np.ascontiguousarray(D[:, 0]).view(np.uint64).ravel()
    order, first = _d_prev_same_type(key)
    other = [j for j in range(18) if j not in _COMPUTED]
    Ds = D[order]
    ps = np.empty((nd, len(other), 8), np.uint8)
    if nd:
        ps[1:] = Ds[:-1][:, other]
        ps[first] = np.frombuffer(_DEFAULT_FIELD, np.uint8)
    pred[order[:, None], np.array(other)[None, :]] = ps
    mask = (pred != D).any(axis=2)  # (nd, 18)
    vals = b"".join(D[mask[:, j], j].tobytes() for j in range(18))
    return np.packbits(mask, axis=None).tobytes(), vals


def _placeholder(ptext: bytes) -> int | None:
    used = np.bincount(np.frombuffer(ptext, np.uint8), minlength=256)
    for c in b"#~!`|@$%^&*_?<>{}[]\\":
        if not used[c]:
            return c
    free = np.flatnonzero(used == 0)
    return int(free[0]) if len(free) else None


#: Reals with fewer digits than this (``0.``, ``1.``) are kept whole in their format.
SHORT = 2
#: Longest mantissa (in digits) a pole lane predicts: differences stay in int64.
LANE_DIGITS = 17
#: Second differences are taken where their estimated cost is below this
#: share of the first's (bearing's nets lose to LZMA's matches otherwise).
D2_GAIN = 0.9
_SLOT = ord("#")  # a digit's place in a number format
_TO_SLOT = bytes.maketrans(b"0123456789", b"##########")


def _number_pattern(pd: int, rd: int) -> re.Pattern[bytes]:
    cls = re.escape(bytes([pd, rd])) + rb" \n"
    return re.compile(
        rb"(?<![^" + cls + rb"])([-+]?)(\d+\.?\d*|\.\d+)"
        rb"(?:([EeDd])([-+]?\d+))?(?=[" + cls + rb"]|$)"
    )


def _template_info(fmts: list[bytes]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per format: digit slots, quantum exponent (``None`` -> a large sentinel) and sign."""
    nd, q, neg = [], [], []
    for f in fmts:
        n = f.count(b"#")
        body, _, ex = f.partition(b"E") if b"E" in f else f.partition(b"D")
        if not ex:
            body, _, ex = f.partition(b"e") if b"e" in f else f.partition(b"d")
        frac = body.partition(b".")[2]
        if not ex:
            e = 0
        elif ex.lstrip(b"+-").isdigit() and len(ex) < 12:
            e = int(ex)
        else:
            e = 10**9
        nd.append(n)
        q.append(e - len(frac) if n else 10**9)
        neg.append(f[:1] == b"-")
    return np.array(nd, np.int64), np.array(q, np.int64), np.array(neg, bool)


def _pole_lanes(skel: bytes, pd: int, ph: int) -> list[tuple[int, int, int]]:
    """B-spline surface poles in the skeleton (its records joined by ``\\n``):
    (first real, rows, columns) of each surface (128) whose poles are all
    reals; the decoder finds the same from the skeleton alone.  The records
    are counted with numpy, and only those that start ``128`` and a
    delimiter are split (bearing.iges: 213 of 2,932)."""
    arr = np.frombuffer(skel, np.uint8)
    rec_start = np.r_[np.int64(0), np.flatnonzero(arr == 10) + 1]
    rec_len = np.r_[rec_start[1:] - 1, np.int64(len(arr))] - rec_start
    # the number of reals before each record
    base = np.asarray(np.searchsorted(np.flatnonzero(arr == ph), rec_start))
    cand = np.flatnonzero(rec_len >= 4)  # records that start "128" and a delimiter
    for j, c in enumerate(b"128" + bytes([pd])):
        cand = cand[arr[rec_start[cand] + j] == c]
    out = []
    sep = bytes([pd])
    hole = bytes([ph])
    for k in cand.tolist():
        a = int(rec_start[k])
        p = skel[a : a + int(rec_len[k])].split(sep)
        try:
            k1, k2, m1, m2 = (int(x) for x in p[1:5])
        except ValueError:
            continue
        rows, cols = k2 + 1, k1 + 1
        off = 10 + (k1 + m1 + 2) + (k2 + m2 + 2) + rows * cols
        n = 3 * rows * cols
        if min(rows, cols) >= 1 and off + n < len(p) and p[off : off + n].count(hole) == n:
            out.append((int(base[k]) + sep.join(p[:off]).count(hole), rows, cols))
    return out


def _lane_table(
    lanes: list[tuple[int, int, int]], nd: np.ndarray, q: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The real indices of the pole lanes (entity and coordinate) that are
    predicted: all their reals have digit slots, and at the lane's finest
    quantum none has more than LANE_DIGITS digits.  One flat index array and,
    per lane kept, its offset in it, its rows and columns (the lane's
    indices are ``flat[off : off + rows * cols]``, row by row).  All lanes at
    once: one flat index array, reduced per lane."""
    if not lanes:
        empty = np.zeros(0, np.int64)
        return empty, empty, empty, empty
    first_e, rows_e, cols_e = (np.asarray(x, dtype=np.int64) for x in zip(*lanes))
    size = np.repeat(rows_e * cols_e, 3)
    start = np.repeat(first_e, 3) + np.tile(np.arange(3), len(lanes))
    off = np.cumsum(size) - size
    t = np.arange(int(size.sum()), dtype=np.int64) - np.repeat(off, size)
    flat = np.repeat(start, size) + 3 * t
    ok = np.minimum.reduceat((nd >= SHORT)[flat], off)
    qf = q[flat]
    qmin = np.minimum.reduceat(qf, off)
    widest = np.maximum.reduceat(nd[flat] + qf - np.repeat(qmin, size), off)
    keep = np.flatnonzero(ok & (widest <= LANE_DIGITS))
    return flat, off[keep], np.repeat(rows_e, 3)[keep], np.repeat(cols_e, 3)[keep]


def _lane_sel(lanes: list[tuple[int, int, int]], nd: np.ndarray, q: np.ndarray) -> list[np.ndarray]:
    """The real indices of each pole lane that is predicted (:func:`_lane_table`),
    as a (rows, columns) array each."""
    flat, off, rows, cols = _lane_table(lanes, nd, q)
    return [
        flat[o : o + r * c].reshape(r, c)
        for o, r, c in zip(off.tolist(), rows.tolist(), cols.tolist())
    ]


def _diff(a: np.ndarray) -> np.ndarray:
    """Differences along both axes (zeros before the first): the poles of a
    surface less their parallelogram prediction; a curve's, second differences."""
    if a.shape[0] == 1:
        a = a[0]
        return np.diff(np.diff(a, prepend=0), prepend=0)[None, :]
    return np.diff(np.diff(a, axis=0, prepend=0), axis=1, prepend=0)


def _diff2(a: np.ndarray) -> np.ndarray:
    """Second differences along both axes of a surface's poles (zeros before
    the first): the residual of a prediction that follows the net's
    curvature, not only its slope (version 2, lane flag 2; at most 16 times
    the poles, within int64 at LANE_DIGITS)."""
    d = np.diff(np.diff(a, axis=0, prepend=0), axis=0, prepend=0)
    return np.diff(np.diff(d, axis=1, prepend=0), axis=1, prepend=0)


def _undiff2(d: np.ndarray) -> np.ndarray:
    return np.cumsum(np.cumsum(np.cumsum(np.cumsum(d, axis=0), axis=0), axis=1), axis=1)


def _undiff(d: np.ndarray) -> np.ndarray:
    if d.shape[0] == 1:
        return np.cumsum(np.cumsum(d[0]))[None, :]
    return np.cumsum(np.cumsum(d, axis=0), axis=1)


def _numbers_encode(ptext: bytes, pd: int, rd: int, ph: int) -> list[bytes]:
    """Skeleton, format dictionary, format ids, digits and pole residuals of
    the parameter text (module docstring)."""
    spans, fmts_of, digs = [], [], []
    fmt_id: dict[bytes, int] = {}
    for mt in _number_pattern(pd, rd).finditer(ptext):
        sign, body, el, ex = mt.groups()
        if el is None and b"." not in body:
            continue  # an integer: stays in the skeleton
        d = body.replace(b".", b"")
        if len(d) < SHORT:
            f = mt.group()
            d = b""
        else:
            f = sign + body.translate(_TO_SLOT) + (el or b"") + (ex or b"")
        spans.append(mt.span())
        fmts_of.append(fmt_id.setdefault(f, len(fmt_id)))
        digs.append(d)
    if len(fmt_id) > 0xFFFF:
        raise ValueError("too many number formats")
    parts, at = [], 0
    hole = bytes([ph])
    for a, b in spans:
        parts.append(ptext[at:a])
        parts.append(hole)
        at = b
    parts.append(ptext[at:])
    skel = b"".join(parts)
    fmts = list(fmt_id)
    ids = np.array(fmts_of, np.uint16)
    nd_f, q_f, _ = _template_info(fmts)
    nd, q = nd_f[ids], q_f[ids]
    sel = _lane_sel(_pole_lanes(skel, pd, ph), nd, q)
    _, _, neg_f = _template_info(fmts)
    neg = neg_f[ids]
    predicted = np.zeros(len(digs), bool)
    res = []
    flags = bytearray()
    for ix in sel:
        m = np.array([int(digs[i]) for i in ix.flat.__array__().tolist()], np.int64)
        m = np.where(neg[ix], -m.reshape(ix.shape), m.reshape(ix.shape))
        m = m * np.int64(10) ** (q[ix] - q[ix].min())  # at the lane's finest quantum
        best, flag = 3.3 * float(nd[ix].sum()), 0  # the digits' cost, in bits
        res_d = np.zeros(0, np.int64)
        for fl, pred, gain in ((1, _diff, 1.0), (2, _diff2, D2_GAIN)):
            if fl == 2 and min(ix.shape) < 3:
                continue
            dd = pred(m).ravel()
            bits = float(np.log2(2.0 * np.abs(dd.astype(np.float64)) + 2.0).sum()) + 2.0 * dd.size
            if bits < gain * best:
                best, flag, res_d = bits, fl, dd
        flags.append(flag)
        if flag:
            predicted[ix] = True
            res.append(res_d)
    r = np.concatenate(res) if res else np.zeros(0, np.int64)
    z = ((r << 1) ^ (r >> 63)).astype(np.uint64)  # zigzag
    digits = b"".join(d for d, p in zip(digs, predicted.tolist()) if not p)
    return [
        bytes(flags),
        skel,
        b"\n".join(fmts),
        ids.view(np.uint8).reshape(-1, 2).T.tobytes(),
        digits,
        z.view(np.uint8).reshape(-1, 8).T.tobytes(),
    ]


def _numbers_decode(streams: list[bytes], pd: int, ph: int, version: int) -> bytes:
    flags, skel, fdict, fids, digits, zres = streams
    if len(fids) % 2 or len(zres) % 8:
        raise CorruptError("IGES model: number streams have the wrong size")
    n = len(fids) // 2
    holes_at = np.flatnonzero(np.frombuffer(skel, np.uint8) == ph)
    if len(holes_at) != n:
        raise CorruptError("IGES model: number count does not match the skeleton")
    if not n:
        return skel
    fmts = fdict.split(b"\n")
    ids = np.frombuffer(fids, np.uint8).reshape(2, n).T.copy().view(np.uint16).ravel()
    if int(ids.max()) >= len(fmts):
        raise CorruptError("IGES model: a number format past the dictionary")
    nd_f, q_f, neg_f = _template_info(fmts)
    nd, q = nd_f[ids], q_f[ids]
    flat, off, rows, cols = _lane_table(_pole_lanes(skel, pd, ph), nd, q)
    how = np.frombuffer(flags, np.uint8)
    if len(how) != len(off) or (len(how) and int(how.max()) > (2 if version >= 2 else 1)):
        raise CorruptError("IGES model: pole lane flags do not match")
    use = np.flatnonzero(how)
    how, off, rows, cols = how[use], off[use], rows[use], cols[use]
    z = np.frombuffer(zres, np.uint8).reshape(8, -1).T.copy().view(np.uint64).ravel()
    r = ((z >> np.uint64(1)).astype(np.int64)) ^ -((z & np.uint64(1)).astype(np.int64))
    slots = int(nd.sum())
    sizes = rows * cols
    if int(sizes.sum()) != len(r):
        raise CorruptError("IGES model: pole residuals do not match the poles")
    if np.any((how == 2) & (np.minimum(rows, cols) < 3)):
        raise CorruptError("IGES model: second differences on a short lane")
    at = np.cumsum(sizes) - sizes
    # lanes of one shape (and predictor) together
    order = np.lexsort((cols, rows, how))
    cut = np.flatnonzero(np.diff(how[order]) | np.diff(rows[order]) | np.diff(cols[order])) + 1
    pidx, pm = [], []
    for ks in np.split(order, cut) if len(order) else []:
        f, nr, nc = int(how[ks[0]]), int(rows[ks[0]]), int(cols[ks[0]])
        span = np.arange(nr * nc)
        ix = flat[off[ks][:, None] + span].reshape(len(ks), nr, nc)
        d = r[at[ks][:, None] + span].reshape(len(ks), nr, nc)
        if f == 2:
            big = np.cumsum(np.cumsum(np.cumsum(np.cumsum(d, 1), 1), 2), 2)
        elif nr == 1:
            big = np.cumsum(np.cumsum(d, 2), 2)
        else:
            big = np.cumsum(np.cumsum(d, 1), 2)
        qx = q[ix]
        scale = np.int64(10) ** (qx - qx.min(axis=(1, 2), keepdims=True))
        if (big % scale).any():
            raise CorruptError("IGES model: a pole is finer than its format")
        pidx.append(ix.ravel())
        pm.append((big // scale).ravel())
    out = np.empty(slots, np.uint8)
    predicted = np.zeros(n, bool)
    if pidx:
        pi = np.concatenate(pidx)
        predicted[pi] = True
    pslot = np.repeat(predicted, nd)
    if int((~pslot).sum()) != len(digits):
        raise CorruptError("IGES model: digit count does not match the formats")
    out[~pslot] = np.frombuffer(digits, np.uint8)
    if pidx:
        m = np.concatenate(pm)  # the lanes are disjoint: in any order
        neg = neg_f[ids[pi]]
        if ((m > 0) & neg).any() or ((m < 0) & ~neg).any():
            raise CorruptError("IGES model: a pole's sign does not match its format")
        a = np.abs(m).astype(np.uint64)
        w = nd[pi]
        if (a >= columns.POW10[w]).any():
            raise CorruptError("IGES model: a pole has more digits than its format")
        columns.put_digits(out, (np.cumsum(nd) - nd)[pi], a, w)
    # the skeleton's pieces between the holes and the numbers' formats,
    # interleaved in one gather; then the digits into the formats' slots
    flen = np.fromiter(map(len, fmts), np.int64, len(fmts))
    words = columns.Column(b"".join(fmts), (np.cumsum(flen) - flen)[ids], flen[ids])
    text = columns.fill(skel, holes_at, words)
    slot = text == _SLOT
    if skel.count(_SLOT) != (n if ph == _SLOT else 0):  # a literal slot byte: numbers' only
        inside = np.zeros(len(text) + 1, np.int8)
        num_end = holes_at + np.cumsum(words.size - 1) + 1  # where each number ends
        inside[num_end - words.size] += 1
        inside[num_end] -= 1
        slot &= np.cumsum(inside[:-1], dtype=np.int8) > 0
    if int(slot.sum()) != slots:
        raise CorruptError("IGES model: digit slots do not match")
    text[slot] = out
    return text.tobytes()


# ---------------------------------------------------------------- decode


def _decode(payload: bytes, limit: int) -> bytes:
    streams = coding.unpack(payload, 2 * limit + 4096, count=_N_STREAMS)
    hdr_s, raw_s, ints_s, text_s, dmask_s, dvals_s = streams[:6]
    h = _Varints(hdr_s)
    version = h()
    if version not in _VERSIONS:
        raise CorruptError("IGES model: unknown version")
    flags = h()
    if flags >> 4:
        raise CorruptError("IGES model: reserved flags set")
    crlf, seq_zero, tail_zero, lay_mode = (bool(flags >> i & 1) for i in range(4))
    ph, pd, rd = h(), h(), h()
    if max(ph, pd, rd) > 255:
        raise CorruptError("IGES model: a delimiter is not a byte")
    npieces, nraw, nruns = h(), h(), h()
    if npieces > limit + 1 or nraw > npieces or nruns > npieces:
        raise LimitError("IGES model: more lines than the limit allows")
    runs = [(h(), h()) for _ in range(nruns)]
    m = sum(c for _, c in runs)
    if m + nraw != npieces or any(c < 1 or x not in _LETTERS for x, c in runs):
        raise CorruptError("IGES model: line counts do not add up")
    nseq, ntext, nrec, ntail, nlay, nd = (h() for _ in range(6))
    if h.pos != len(hdr_s):
        raise CorruptError("IGES model: bytes after the header")
    if (
        m * (81 if crlf else 80) + len(raw_s) - max(nraw - 1, 0) + npieces - 1 > limit
        or max(nseq, ntext) > m
        or max(ntail, nrec, nlay) > m
        or 2 * nd > m
    ):
        raise LimitError("IGES model: output past the limit")

    letters = np.repeat(
        np.frombuffer(bytes(x for x, _ in runs), np.uint8), np.array([c for _, c in runs])
    )
    is_d = letters == ord("D")
    is_p = letters == ord("P")
    npl = int(is_p.sum())

    iv = _Varints(ints_s)
    raw_idx = iv.gaps(nraw, npieces, "an exception past the last line")
    seq_bad = iv.gaps(nseq, m, "an exception past the last line")
    tail_exc = iv.gaps(ntail, nrec, "a back pointer exception past the last record")
    lay_i = iv.gaps(nlay, npl, "a layout exception past the last P line")
    lay_l = iv.many(nlay)
    rcount = iv.many(nrec)
    eb = ints_s[iv.pos :]
    if len(eb) != 7 * nseq + 8 * ntail:
        raise CorruptError("IGES model: exception bytes do not add up")

    eol = b"\r\n" if crlf else b"\n"
    W = np.empty((m, 80 + len(eol)), np.uint8)  # the records and their line ends
    W[:, 80:] = np.frombuffer(eol, np.uint8)
    M = W[:, :80]
    M[:, 72] = letters
    counts = [c for _, c in runs]
    cnt = np.asarray(counts, dtype=np.int64)
    seqno = np.arange(m, dtype=np.int64) - np.repeat(np.cumsum(cnt) - cnt, cnt) + 1
    M[:, 73:80] = _fmt_rows(seq_zero, 7, seqno)
    if nseq:
        M[seq_bad, 73:80] = _rows(eb[: 7 * nseq], 7, nseq)
    d_idx = np.flatnonzero(is_d)
    text_mask = ~(is_d | is_p)
    if len(d_idx) % 2:
        text_mask[d_idx[-1]] = True
        d_idx = d_idx[:-1]
    if len(d_idx) != 2 * nd:
        raise CorruptError("IGES model: D entry count does not match")

    # text rows
    rows = text_s.split(b"\n") if ntext else []
    if len(rows) != ntext or ntext != int(text_mask.sum()) or any(len(r) > 72 for r in rows):
        raise CorruptError("IGES model: text rows do not match")
    if ntext:
        M[text_mask, :72] = _rows(b"".join(r.ljust(72) for r in rows), 72, ntext)

    # parameter text: records joined by newlines
    ptext = _numbers_decode(streams[6:], pd, ph, version)
    pbuf = np.frombuffer(ptext, np.uint8)
    if nrec:
        nl = np.flatnonzero(pbuf == 10)
        if len(nl) + 1 != nrec:
            raise CorruptError("IGES model: parameter records do not match")
        rend = np.r_[nl, np.int64(len(ptext))]
        rbeg = np.r_[np.int64(0), nl + 1]
        if int(rcount.min()) < 1 or int(rcount.max()) > npl or int(rcount.sum()) != npl:
            raise CorruptError("IGES model: parameter records do not match")
    elif npl:
        raise CorruptError("IGES model: parameter records do not match")
    else:
        rbeg = rend = np.zeros(0, np.int64)

    # record tails (back pointers)
    rtails, rdes = _tails(tail_zero, tail_exc, eb[7 * nseq :], nrec)

    # P lines: their lengths by the layout policy, then one scatter
    exc = np.full(npl, -1, np.int64)
    if nlay:
        exc[lay_i] = lay_l
    lens = _lines(lay_mode, _bounds(ptext, pd, rd), rend - rbeg, rcount, exc)[1]
    if npl:
        # the lines cover the records in order: their bytes are the text's
        # but its newlines, laid out left-aligned in 64 columns
        p_rows = np.flatnonzero(is_p)
        together = int(p_rows[-1]) - int(p_rows[0]) + 1 == npl
        P = W[int(p_rows[0]) : int(p_rows[0]) + npl] if together else np.empty((npl, 72), np.uint8)
        body = P[:, :P_WIDTH]
        body[...] = 32
        body[np.arange(P_WIDTH) < lens[:, None]] = pbuf[pbuf != 10]
        P[:, 64:72] = np.repeat(rtails, rcount, axis=0)
        if not together:
            M[is_p, :72] = P[:, :72]

    # D entries
    if nd:
        rstart = np.cumsum(rcount) - rcount
        types = _record_types(ptext, pd, rbeg, rend)
        pred_c = _d_predicted(_entry_records(rdes, nd), rstart, rcount, types)
        D = _d_decode(nd, pred_c, dmask_s, dvals_s)
        M[d_idx, :72] = D.reshape(2 * nd, 72)
    elif dmask_s or dvals_s:
        raise CorruptError("IGES model: D data without D entries")

    # assemble: every piece followed by a newline, the last one's dropped
    raws = raw_s.split(b"\n") if nraw else []
    if len(raws) != nraw:
        raise CorruptError("IGES model: raw line count does not match")
    if not nraw and m:
        out = W.reshape(-1)[:-1].tobytes()
        if len(out) > limit:
            raise LimitError(f"IGES model inflates past {limit} bytes")
        return out
    blob = W.tobytes()
    w = W.shape[1]
    chunks: list[bytes] = []
    k = prev = 0
    for i, raw in zip(raw_idx.tolist(), raws):
        take = i - prev
        chunks += [blob[w * k : w * (k + take)], raw, b"\n"]
        k += take
        prev = i + 1
    chunks.append(blob[w * k :])
    out = b"".join(chunks)[:-1]
    if len(out) > limit:
        raise LimitError(f"IGES model inflates past {limit} bytes")
    return out


#: Back pointers wrap at this (7 columns of digits).
_WRAP = 10**7


def _tails(
    zero: bool, exc_at: np.ndarray, exc_bytes: bytes, nrec: int
) -> tuple[np.ndarray, np.ndarray]:
    """The P records' tails (columns 65-72, an (n, 8) array) and the DE
    numbers they point back to.  Each record's is predicted as the previous
    one's + 2 (1 for the first), written zero-padded or right-aligned (its
    last 7 digits when longer), but at the exceptions ``exc_at``, whose
    tails are ``exc_bytes`` (8 each) and whose DE numbers are their digits
    (the prediction when they are not digits).

    Between two exceptions the numbers go up by 2 modulo :data:`_WRAP`, so
    only the exceptions are visited one by one (for the number after each)."""
    cur = 1  # the prediction for the next record
    at = exc_at.tolist()
    base = [cur]  # the prediction at the start of each run (after each exception)
    vals = []
    prev = 0
    for k, x in enumerate(at):
        if x > prev:  # the run before: cur, then (cur + 2 j) % _WRAP + 2
            cur = (cur + 2 * (x - prev - 1)) % _WRAP + 2
        s = exc_bytes[8 * k : 8 * k + 8].strip()
        v = int(s) if s.isdigit() and len(s) < 12 else cur
        vals.append(v)
        cur = v + 2
        base.append(cur)
        prev = x + 1
    run = np.searchsorted(exc_at, np.arange(nrec), side="right")
    run_start = np.r_[np.int64(0), exc_at + 1]
    j = np.arange(nrec) - run_start[run]
    b = np.asarray(base, np.int64)[run]
    des = (b + 2 * j) % _WRAP
    pred = np.where(j == 0, b, (b + 2 * (j - 1)) % _WRAP + 2)
    rows = np.full((nrec, 8), 32, np.uint8)
    rows[:, 1:] = _fmt_rows(True, 7, pred % _WRAP)
    if not zero:  # right-aligned where the number fits, its last digits where not
        p = np.int64(10) ** np.arange(6, 0, -1, dtype=np.int64)
        rows[:, 1:7][(pred[:, None] < p)] = 32
    if len(at):
        des[exc_at] = vals
        rows[exc_at] = _rows(exc_bytes, 8, len(at))
    return rows, des


def _d_decode(nd: int, pred_c: np.ndarray, dmask_s: bytes, dvals_s: bytes) -> np.ndarray:
    """The D entries, (nd, 18, 8): the fields the mask marks from the values
    stream (column by column), the others predicted: the computed ones
    (``pred_c``), the second type from the first, the rest from the previous
    entry of the same type.  Each 8-column field is handled as one uint64,
    all columns at once."""
    nbits = nd * 18
    if len(dmask_s) != (nbits + 7) // 8:
        raise CorruptError("IGES model: D mask has the wrong size")
    mask = np.unpackbits(np.frombuffer(dmask_s, np.uint8))[:nbits].reshape(nd, 18).astype(bool)
    per = mask.sum(axis=0)
    if 8 * int(per.sum()) != len(dvals_s):
        raise CorruptError("IGES model: D values do not match the mask")
    D = np.empty((nd, 18), np.uint64)
    vals = np.frombuffer(dvals_s, np.uint64)
    offs = np.concatenate(([0], np.cumsum(per))).tolist()
    pred = np.ascontiguousarray(pred_c).view(np.uint64).reshape(nd, 4)
    # the type first: computed or explicit
    for j, col in ((0, 0), (1, 1), (12, 3)):
        D[:, j] = pred[:, col]
        D[mask[:, j], j] = vals[offs[j] : offs[j + 1]]
    D[:, 9] = D[:, 0]
    D[mask[:, 9], 9] = vals[offs[9] : offs[10]]
    order, first = _d_prev_same_type(D[:, 0].copy())
    other = [j for j in range(18) if j not in _COMPUTED]
    # in type order, per field: explicit, or the previous entry's of the type
    given = mask[:, other].T  # (fields, nd)
    full = np.full((len(other), nd), np.frombuffer(_DEFAULT_FIELD, np.uint64)[0])
    full[given] = np.concatenate([vals[offs[j] : offs[j + 1]] for j in other])
    src = np.where(given[:, order] | first, np.arange(nd), 0)
    np.maximum.accumulate(src, axis=1, out=src)
    picked = np.take_along_axis(full[:, order], src, axis=1)
    back = np.empty((nd, len(other)), np.uint64)
    back[order] = picked.T
    D[:, other] = back
    return D.view(np.uint8).reshape(nd, 18, 8)
