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
reads a residual, and nothing loops over the numbers in Python but the
parsing of the encoder and the printing of the decoder.

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
import zlib

import numpy as np

from ..errors import CorruptError
from . import coding

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

_NUM = re.compile(rb"([+-]?)([0-9]+)(?:(\.)([0-9]*))?(?:([eE])([+-]?)([0-9]+))?\Z")
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
        self.exponent = np.where(esign == 2, -emag, emag)
        self.digits = nint + np.maximum(frac - 1, 0)
        self.scale = self.exponent - np.maximum(frac - 1, 0)


def _parse(texts: list[bytes]) -> tuple[_Fields, np.ndarray] | None:
    """The fields and signed values of ``texts``; None if one of them is not
    a number this module codes."""
    n = len(texts)
    sign = np.zeros(n, np.int64)
    nint = np.zeros(n, np.int64)
    frac = np.zeros(n, np.int64)
    ecode = np.zeros(n, np.int64)
    emag = np.zeros(n, np.int64)
    mant: list[int] = []
    for i, t in enumerate(texts):
        m = _NUM.match(t)
        if m is None:
            return None
        sg, ip, pt, fp, e, es, ed = m.groups()
        digits = ip + fp if pt else ip
        if len(digits) > MAX_DIGITS:
            return None
        v = int(digits)
        if v >= M_LIMIT:
            return None
        if sg == b"-":
            if v:
                v = -v
            else:
                sign[i] = 2
        elif sg == b"+":
            sign[i] = 1
        mant.append(v)
        nint[i] = len(ip)
        frac[i] = len(fp) + 1 if pt else 0
        if e:
            if len(ed) > MAX_WIDTH or int(ed) > MAX_EXPONENT:
                return None
            ecode[i] = 1 + (e == b"e") + 2 * (b"+-".find(es) + 1 if es else 0) + 6 * (len(ed) - 1)
            emag[i] = int(ed)
    return _Fields(sign, nint, frac, ecode, emag), np.asarray(mant, dtype=np.int64)


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
    the grid and predictor whose residuals zlib codes smallest; None when a
    text is not a number this module codes (it then stays text)."""
    parsed = _parse(texts)
    if parsed is None or not texts:
        return None
    f, mant = parsed
    scales, counts = np.unique(f.scale, return_counts=True)
    grids = scales[np.argsort(-counts, kind="stable")][:CANDIDATES].tolist()
    best: tuple[int, int, int, np.ndarray] | None = None
    for grid in grids:
        for pred in (1, 2):
            r = _residuals(f, mant, grid, pred)
            cost = len(zlib.compress(coding.int_stream(r), 6))
            if best is None or cost < best[0]:
                best = (cost, grid, pred, r)
    assert best is not None
    _, grid, pred, r = best
    return _format_stream(f, pred, grid), coding.int_stream(r)


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
    """The ``n`` number texts of :func:`encode`'s two streams.

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


def _print(f: _Fields, mant: np.ndarray) -> list[bytes]:
    """The texts of values ``mant`` with formats ``f``."""
    if (
        np.any(mant == np.iinfo(np.int64).min)
        or np.any((f.sign == 2) & (mant != 0))
        or np.any((f.sign == 1) & (mant < 0))
    ):
        raise CorruptError("number stream: a value does not fit its format")
    signs = np.where(f.sign == 1, 1, np.where((f.sign == 2) | (mant < 0), 2, 0))
    esign = np.where(f.ecode > 0, ((f.ecode - 1) // 2) % 3, 0)
    tails: dict[tuple[int, int], bytes] = {}
    out = []
    for s, v, ni, fr, ec, em, es in zip(
        signs.tolist(),
        np.abs(mant).tolist(),
        f.nint.tolist(),
        f.frac.tolist(),
        f.ecode.tolist(),
        f.emag.tolist(),
        esign.tolist(),
    ):
        width = ni + fr - 1 if fr else ni
        d = b"%0*d" % (width, v)
        if len(d) != width:
            raise CorruptError("number stream: a value longer than its format")
        if fr:
            d = d[:ni] + b"." + d[ni:]
        if ec:
            key = (ec, em)
            tail = tails.get(key)
            if tail is None:
                letter = b"e" if (ec - 1) % 2 else b"E"
                tail = tails[key] = (
                    letter + (b"", b"+", b"-")[es] + b"%0*d" % ((ec - 1) // 6 + 1, em)
                )
            d += tail
        out.append((b"", b"+", b"-")[s] + d)
    return out
