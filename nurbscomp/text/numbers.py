"""Decimal numbers coded as numbers, byte-exact (issue 29, "numbers coded as numbers").

A stream of number texts (``61.70512107362``, ``62.``, ``5.9E-14``) is cut
into a *format* and a *value* per number, so that the text comes back exactly
as written:

* the format: the sign as written, the count of digits before the point, the
  point, the count of digits after it, the exponent's letter, sign, width and
  magnitude;
* the value: the integer ``M`` the digits make, signed.  The number is
  ``M * 10**s``, where the *scale* ``s`` is the exponent less the count of
  digits after the point, which the format gives.

The values are predicted from the numbers before them in the stream, the way
a pole's coordinate follows its neighbour's, and only the residuals are
stored.  To make the prediction exact integer arithmetic, the numbers are
put on one fixed-point grid of the stream, ``10**S``: a number whose scale is
at least ``S`` and that has at most :data:`DIGITS` digits on that grid is
*regular*, and is ``W = M * 10**(s - S)`` there exactly.  The regular numbers,
in order, are coded as differences (``pred`` 1: ``W[k] - W[k-1]``) or second
differences (``pred`` 2: ``W[k] - 2 W[k-1] + W[k-2]``), with ``W = 0`` before
the first; the decoder gets them back with one or two cumulative sums.  Every
other number (finer than the grid, or too long for it) is an *exception*: its
``M`` less the value of the last regular number before it, rounded to the
exception's own scale (see :func:`_exception_prediction`).  Which numbers are
regular follows from the formats alone, so the decoder knows it before it
reads a residual.  Nothing loops over the numbers in Python: the encoder
parses a stream with one regular expression and numpy, and the decoder
prints it place by place into one buffer (a :class:`.columns.Column`).

Streams (each through :func:`nurbscomp.text.coding.pack` on its own):

``format``::

    pred u8 (1 or 2) | S zigzag varint
    4 byte planes of n bytes each: sign, nint, frac, ecode
    exponent magnitudes: coding.int_stream, one per number whose ecode > 0

``residuals``: ``coding.int_stream`` of the n residuals, in text order.

The byte fields (one per number):

* ``sign`` 0: as the value says (``-`` when ``M < 0``, none otherwise);
  1: ``+`` (``M`` ≥ 0); 2: ``-`` before a zero (``-0.``);
* ``nint``: digits before the point, 1 ... :data:`MAX_DIGITS`;
* ``frac``: 0 no point; else 1 + the digits after the point (the digits
  before and after add up to at most :data:`MAX_DIGITS`);
* ``ecode``: 0 no exponent; else ``1 + lower + 2 * esign + 6 * (width - 1)``
  where ``lower`` is 1 for ``e`` and 0 for ``E``, ``esign`` is 0 none, 1
  ``+``, 2 ``-``, and ``width`` (1 ... :data:`MAX_WIDTH`) the exponent's
  digits as written, leading zeros included.

The layout is in docs/text-model.md ("Numbers as numbers").
"""

from __future__ import annotations

import re

import numpy as np

from ..errors import CorruptError
from . import coding, columns

#: Digits of a regular number on the stream's grid: ``|W| < 10**18 < 2**60``,
#: so second differences stay within an int64.
DIGITS = 18
#: Digits a number may have before and after its point together.
MAX_DIGITS = 40
#: Digits an exponent may have as written.
MAX_WIDTH = 9
#: Exponent magnitudes above this are not coded as numbers.
MAX_EXPONENT = 400
#: ``|M|`` below this: an int64 (residuals are taken modulo 2**64).
M_LIMIT = 1 << 63
#: Grid candidates tried per stream: its most common scales.
CANDIDATES = 3

_ONE = rb"[+-]?[0-9]++(?:\.[0-9]*+)?(?:[eE][+-]?[0-9]++)?"
#: A stream of numbers joined by ``,`` (the STEP tokenizer's number grammar).
_ALL = re.compile(_ONE + rb"(?:," + _ONE + rb")*+")
_POW = np.array([10**k for k in range(DIGITS + 1)], dtype=np.int64)


#: Powers of ten as doubles, ``10.0**k`` for ``|k|`` ≤ :data:`_SPAN`: the
#: doubles nearest to the decimal powers (CPython parses them correctly
#: rounded on every platform, so encoder and decoder agree to the bit).
_SPAN = 2 * (MAX_EXPONENT + MAX_DIGITS)
_POW10 = np.array([float(f"1e{k}") for k in range(-_SPAN, _SPAN + 1)])


def _pow10(k: np.ndarray) -> np.ndarray:
    """``10.0**k`` elementwise, from :data:`_POW10` (clipped to its span)."""
    return _POW10[np.clip(k, -_SPAN, _SPAN) + _SPAN]


class _Fields:
    """The per-number fields of a stream (module docstring) as arrays."""

    def __init__(
        self,
        sign: np.ndarray,
        nint: np.ndarray,
        frac: np.ndarray,
        ecode: np.ndarray,
        emag: np.ndarray,
    ) -> None:
        self.sign, self.nint, self.frac, self.ecode, self.emag = sign, nint, frac, ecode, emag
        esign = np.where(ecode > 0, ((ecode - 1) // 2) % 3, 0)
        self.digits = nint + np.maximum(frac - 1, 0)
        self.scale = np.where(esign == 2, -emag, emag) - np.maximum(frac - 1, 0)


def _parse(texts: list[bytes]) -> tuple[_Fields, np.ndarray] | None:
    """The fields and signed values of ``texts``; None if one of them is not
    a number this module codes.  One regular expression checks the grammar
    of all of them at once; the fields are then read with numpy, character
    classes and positions, with no loop over the numbers."""
    joined = b",".join(texts)
    if not texts or _ALL.fullmatch(joined) is None:
        return None
    n = len(texts)
    buf = np.frombuffer(joined, np.uint8)
    size = np.fromiter(map(len, texts), np.int64, n)
    start = np.cumsum(size + 1) - size - 1
    end = start + size
    signed = (buf[start] == ord("+")) | (buf[start] == ord("-"))
    body = start + signed
    # the first point and the exponent letter of each number (its end if none)
    letter = end.copy()
    e_at = np.flatnonzero((buf == ord("e")) | (buf == ord("E")))
    letter[np.searchsorted(end, e_at)] = e_at
    dot = letter.copy()
    d_at = np.flatnonzero(buf == ord("."))
    dot[np.searchsorted(end, d_at)] = d_at
    point = dot < letter
    nint = dot - body
    nfrac = np.where(point, letter - dot - 1, 0)
    ndig = nint + nfrac
    if np.any(ndig > MAX_DIGITS):
        return None
    mant = _digits_value(buf, body, letter, np.where(point, dot, -1), ndig)
    if mant is None:
        return None
    # the exponent: letter, optional sign, digits
    has_e = letter < end
    e_sign = np.zeros(n, np.int64)
    after = np.minimum(letter + 1, len(buf) - 1)
    e_sign[has_e] = np.where(
        buf[after[has_e]] == ord("+"), 1, np.where(buf[after[has_e]] == ord("-"), 2, 0)
    )
    e_body = letter + 1 + (e_sign > 0)
    width = np.where(has_e, end - e_body, 0)
    if np.any(width > MAX_WIDTH):
        return None
    emag = _digits_value(buf, e_body, np.where(has_e, end, e_body), np.full(n, -1), width)
    if emag is None or np.any(emag > MAX_EXPONENT):
        return None
    lower = buf[np.minimum(letter, len(buf) - 1)] == ord("e")
    ecode = np.where(has_e, 1 + lower + 2 * e_sign + 6 * (width - 1), 0)
    minus = signed & (buf[start] == ord("-"))
    sign = np.where(signed & ~minus, 1, np.where(minus & (mant == 0), 2, 0))
    mant = np.where(minus, -mant, mant)
    frac = np.where(point, nfrac + 1, 0)
    return _Fields(sign, nint, frac, ecode, emag), mant


def _digits_value(
    buf: np.ndarray, first: np.ndarray, stop: np.ndarray, skip: np.ndarray, count: np.ndarray
) -> np.ndarray | None:
    """The integer each run of decimal digits ``buf[first:stop]`` makes
    (leaving out the byte at ``skip``, the point, where it is ≥ 0); ``count``
    digits each, at least one where ``stop > first``; None where a value is
    ``M_LIMIT`` or more."""
    n = len(first)
    out = np.zeros(n, np.uint64)
    has = count > 0
    if not np.any(has):
        return out.astype(np.int64)
    span = stop - first
    who = np.repeat(np.arange(n), span)
    at = np.repeat(first, span) + (np.arange(len(who)) - np.repeat(np.cumsum(span) - span, span))
    keep = at != skip[who]
    who, at = who[keep], at[keep]
    # place: how many digits of the run follow this one
    place = (
        np.repeat(count, count)
        - 1
        - (np.arange(len(who)) - np.repeat(np.cumsum(count) - count, count))
    )
    digit = (buf[at] - ord("0")).astype(np.uint64)
    if np.any(digit[place >= 19]):
        return None
    term = digit * columns.POW10[np.minimum(place, 19)] * (place < 19)
    heads = (np.cumsum(count) - count)[has]
    out[has] = np.add.reduceat(term, heads)
    if np.any(out >= np.uint64(M_LIMIT)):
        return None
    return out.astype(np.int64)


def _regular(f: _Fields, grid: int) -> np.ndarray:
    """Which numbers are regular on the grid ``10**grid`` (module docstring)."""
    return (f.scale >= grid) & (f.digits + f.scale - grid <= DIGITS)


def _differences(w: np.ndarray, pred: int) -> np.ndarray:
    """The regular numbers' residuals: first or second differences, zeros before."""
    d = np.diff(np.r_[np.int64(0), w])
    return d if pred == 1 else np.diff(np.r_[np.int64(0), d])


def _exception_prediction(f: _Fields, reg: np.ndarray, w: np.ndarray, grid: int) -> np.ndarray:
    """Each number's prediction from the last regular number before it (0
    when none): its grid value ``W`` times ``10**(grid - s)`` in doubles,
    rounded half to even, 0 where that is ``2**62`` or more."""
    last = np.cumsum(reg) - 1  # index into w of the last regular number at or before each
    prev = np.where(last >= 0, w[np.maximum(last, 0)] if len(w) else 0, 0)
    with np.errstate(all="ignore"):
        x = prev.astype(np.float64) * _pow10(grid - f.scale)
        ok = np.abs(x) < float(M_LIMIT)
        return np.where(ok, np.rint(np.where(ok, x, 0.0)), 0.0).astype(np.int64)


def _residuals(f: _Fields, mant: np.ndarray, grid: int, pred: int) -> np.ndarray:
    reg = _regular(f, grid)
    w = mant[reg] * _POW[f.scale[reg] - grid]
    out = np.empty(len(mant), np.int64)
    out[reg] = _differences(w, pred)
    exc = ~reg
    out[exc] = mant[exc] - _exception_prediction(f, reg, w, grid)[exc]
    return out


def _format_stream(f: _Fields, pred: int, grid: int) -> bytes:
    planes = np.stack([f.sign, f.nint, f.frac, f.ecode]).astype(np.uint8)
    z = (grid << 1) ^ (grid >> 63)
    return (
        bytes([pred]) + coding.varint(z) + planes.tobytes() + coding.int_stream(f.emag[f.ecode > 0])
    )


def encode(texts: list[bytes]) -> tuple[bytes, bytes] | None:
    """The format and residual streams of ``texts`` (module docstring), with
    the grid and predictor of the smallest :func:`_cost`; None when a text is
    not a number this module codes (it then stays text)."""
    parsed = _parse(texts)
    if parsed is None:
        return None
    f, mant = parsed
    scales, counts = np.unique(f.scale, return_counts=True)
    grids = scales[np.argsort(-counts, kind="stable")][:CANDIDATES].tolist()
    best: tuple[float, int, int, np.ndarray] | None = None
    for grid in grids:
        for pred in (1, 2):
            r = _residuals(f, mant, grid, pred)
            cost = _cost(r)
            if best is None or cost < best[0]:
                best = (cost, grid, pred, r)
    assert best is not None
    _, grid, pred, r = best
    return _format_stream(f, pred, grid), coding.int_stream(r)


def _cost(r: np.ndarray) -> float:
    """An estimate of the bits residuals ``r`` take: the sum of their bit
    lengths (a tenth of the time of a zlib trial, and it picked the same
    grid and predictor on the corpus's large streams)."""
    with np.errstate(all="ignore"):
        return float(np.log2(np.abs(r.astype(np.float64)) + 1.0).sum())


def _read_format(raw: bytes, n: int) -> tuple[_Fields, int, int]:
    if len(raw) < 2 or raw[0] not in (1, 2):
        raise CorruptError("number stream: bad predictor")
    pred = raw[0]
    z, pos = coding.read_varint(raw, 1)
    grid = (z >> 1) ^ -(z & 1)
    if pos + 4 * n > len(raw):
        raise CorruptError("number stream: formats run past the end")
    planes = np.frombuffer(raw, np.uint8, count=4 * n, offset=pos).reshape(4, n).astype(np.int64)
    sign, nint, frac, ecode = planes
    has_e = ecode > 0
    emag = np.zeros(n, np.int64)
    emag[has_e] = coding.read_int_stream(raw[pos + 4 * n :], int(has_e.sum()), "exponents")
    width = (ecode - 1) // 6 + 1
    if (
        np.any(sign > 2)
        or np.any(nint < 1)
        or np.any(ecode > 6 * MAX_WIDTH)
        or np.any(nint + np.maximum(frac - 1, 0) > MAX_DIGITS)
        or np.any((emag < 0) | (emag > MAX_EXPONENT))
        or np.any(has_e & (emag >= 10 ** np.minimum(width, 9)))
    ):
        raise CorruptError("number stream: a format out of range")
    if abs(grid) > _SPAN:
        raise CorruptError("number stream: grid out of range")
    return _Fields(sign, nint, frac, ecode, emag), pred, grid


def decode(fmt: bytes, res: bytes, n: int) -> list[bytes]:
    """The ``n`` number texts of :func:`encode`'s two streams (raises as
    :func:`decode_column`)."""
    return decode_column(fmt, res, n).items()


def decode_column(fmt: bytes, res: bytes, n: int) -> columns.Column:
    """The ``n`` number texts of :func:`encode`'s two streams, as a column.

    Raises
    ------
    CorruptError
        Streams :func:`encode` does not write.
    """
    f, pred, grid = _read_format(fmt, n)
    r = coding.read_int_stream(res, n, "residuals")
    reg = _regular(f, grid)
    w = np.cumsum(r[reg])
    if pred == 2:
        w = np.cumsum(w)
    mant = np.empty(n, np.int64)
    step = _POW[np.where(reg, f.scale - grid, 0)][reg]
    if np.any(np.abs(w) >= _POW[DIGITS]) or np.any(w % step):
        raise CorruptError("number stream: a value off its grid")
    mant[reg] = w // step
    exc = ~reg
    mant[exc] = r[exc] + _exception_prediction(f, reg, w, grid)[exc]
    return _print(f, mant)


def _print(f: _Fields, mant: np.ndarray) -> columns.Column:
    """The texts of values ``mant`` with formats ``f``, laid out in one byte
    buffer with numpy (sign, digits, point, exponent) and cut into numbers."""
    if (
        np.any(mant == np.iinfo(np.int64).min)
        or np.any((f.sign == 2) & (mant != 0))
        or np.any((f.sign == 1) & (mant < 0))
    ):
        raise CorruptError("number stream: a value does not fit its format")
    n = len(mant)
    v = np.abs(mant).astype(np.uint64)
    ndig = f.digits
    if np.any(v >= columns.POW10[np.minimum(ndig, 19)]):
        raise CorruptError("number stream: a value longer than its format")
    signed = (f.sign > 0) | (mant < 0)
    point = f.frac > 0
    # exponent tails: one text per distinct (ecode, magnitude)
    # (np.unique sorts: a tenth of the time with a count over the few keys)
    key = f.ecode * (MAX_EXPONENT + 1) + f.emag  # < 55 * 401: checked by _read_format
    seen = np.bincount(key) > 0
    keys = np.flatnonzero(seen)
    tail_of = (np.cumsum(seen) - 1)[key]
    tails = [_tail(int(k) // (MAX_EXPONENT + 1), int(k) % (MAX_EXPONENT + 1)) for k in keys]
    tail_len = np.fromiter(map(len, tails), np.int64, len(tails))[tail_of]
    size = signed + ndig + point + tail_len
    end = np.cumsum(size)
    start = end - size
    buf = np.empty(int(end[-1]) if n else 0, np.uint8)
    buf[start[signed]] = np.where(
        mant[signed] < 0, ord("-"), np.where(f.sign[signed] == 1, ord("+"), ord("-"))
    )
    first = start + signed
    columns.put_digits(buf, first, v, ndig, np.where(point, f.nint, -1))
    buf[(first + f.nint)[point]] = ord(".")
    # tails, by position within the tail
    width = max(map(len, tails))
    table = np.frombuffer(b"".join(t.ljust(width) for t in tails), np.uint8).reshape(
        len(tails), width
    )
    for j in range(width):
        has = tail_len > j
        buf[(end - tail_len + j)[has]] = table[tail_of[has], j]
    return columns.Column(buf.tobytes(), start, size)


def _tail(ecode: int, magnitude: int) -> bytes:
    """The exponent text of ``ecode`` (module docstring) and ``magnitude``."""
    if not ecode:
        return b""
    letter = b"e" if (ecode - 1) % 2 else b"E"
    return (
        letter
        + (b"", b"+", b"-")[(ecode - 1) // 2 % 3]
        + b"%0*d" % ((ecode - 1) // 6 + 1, magnitude)
    )
