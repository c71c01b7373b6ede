"""`META` (§2): the header of a container, as JSON or (format 2.6, §2.12) in
binary, read with bounds on its size, its strings and its numbers."""

from __future__ import annotations

import decimal
import json
import math
import struct
from typing import Any, cast

from .. import container
from ..errors import CorruptError, LimitError, SectionError
from ..streams import read_varint, varint
from ..units import UNITS_MM
from .limits import MAX_COORD


def _number(x: Any) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool)


#: Largest META section a reader parses, in bytes (a writer's is ~200).
MAX_META_BYTES = 1 << 16
#: Longest string in META, in characters (``source_name`` is a file name).
MAX_META_TEXT = 1024
#: Most digits of an integer in META (``int()`` of a longer one is refused by
#: Python, and ``source_bytes`` fits 2^53 anyway).
MAX_META_DIGITS = 20
#: Largest ``source_bytes`` (exactly representable as a double).
MAX_SOURCE_BYTES = 2**53


def _meta_int(digits: str) -> int:
    if len(digits.lstrip("-")) > MAX_META_DIGITS:
        raise SectionError(f"META: an integer of {len(digits)} digits is too long")
    return int(digits)


def _meta_constant(name: str) -> float:
    raise SectionError(f"META: {name} is not a number")


def _bad_text(s: str) -> bool:
    """A control character (C0, DEL, C1) or a lone surrogate in ``s``."""
    return any(c < " " or "\x7f" <= c <= "\x9f" or "\ud800" <= c <= "\udfff" for c in s)


def meta_text(s: str) -> str:
    """``s`` as META may hold it: control characters and lone surrogates (a
    file name's undecodable bytes) become U+FFFD, and it is cut to ``MAX_META_TEXT``."""
    s = s[:MAX_META_TEXT]
    return "".join("\ufffd" if _bad_text(c) else c for c in s) if _bad_text(s) else s


#: §2.12: the keys a binary META names by a one-byte code (its index).
KEYS = (
    "mode", "source_bytes", "source_format", "source_name", "step_pcurves", "tolerance_mm",
    "unit", "writer", "sha256", "model", "reason", "decoded", "rows", "references", "depth",
    "poles", "bases", "step_bytes", "iges_bytes",
)  # fmt: skip
#: §2.12: the strings a binary META value names by a one-byte code.
WORDS = (
    "tolerance", "lossless", "exact", "passthrough", "STEP", "IGES", "MM", "CM", "M", "KM",
    "UM", "INCH", "FT", "MI", "MIL", "UIN", "plain", "step", "iges",
)  # fmt: skip
#: §2.12: the first byte of a binary META (a JSON one starts with ``{``).
BINARY = 1
_KEY_ESCAPE = 255
_NULL, _FALSE, _TRUE, _INT, _FLOAT, _STR, _WORD, _HEX, _OBJECT, _DECIMAL = range(10)
_F64 = struct.Struct("<d")
#: Largest magnitude of a binary META integer (a zig-zag varint of 9 bytes).
_INT_LIMIT = 1 << 62


#: §2.12 (2.13): a decimal number m·10^e has |m| < 2^53 and |e| <= 22, where
#: m and 10^|e| are binary64 numbers exactly and one product or quotient of
#: them is the correctly rounded value.
_DEC_MANTISSA = 1 << 53
_DEC_EXPONENT = 22


def _zigzag(v: int) -> bytes:
    return varint(2 * v if v >= 0 else -2 * v - 1)


def from_decimal(m: int, e: int) -> float:
    """m·10^e as §2.12 (2.13) reads it: one binary64 product or quotient,
    correctly rounded (m and 10^|e| are exact)."""
    return float(m) * float(10**e) if e >= 0 else float(m) / float(10**-e)


def _decimal(x: float) -> tuple[int, int] | None:
    """(m, e) whose :func:`from_decimal` is ``x`` bit for bit, m with the
    fewest digits (Python's shortest repr), or None (-0.0, a number that
    needs more digits or a larger exponent)."""
    if not math.isfinite(x) or math.copysign(1.0, x) < 0 and x == 0:
        return None
    t = decimal.Decimal(repr(x)).normalize().as_tuple()
    m = int("".join(map(str, t.digits))) * (-1 if t.sign else 1)
    e = int(t.exponent)
    if abs(m) >= _DEC_MANTISSA or abs(e) > _DEC_EXPONENT:
        return None
    y = from_decimal(m, e)
    return (m, e) if _F64.pack(y) == _F64.pack(x) else None


def _hex(s: str) -> bool:
    return bool(s) and len(s) % 2 == 0 and all(c in "0123456789abcdef" for c in s)


def _text(s: str) -> bytes | None:
    """A String of §2.12 (None for text UTF-8 cannot hold: a lone surrogate)."""
    try:
        b = s.encode("utf-8")
    except UnicodeEncodeError:
        return None
    return varint(len(b)) + b


def _value(v: Any, top: bool, decimals: bool) -> bytes | None:
    """One value in binary (§2.12), None where the binary form has none; with
    ``decimals`` (2.13), a number a short decimal gives bit for bit as one."""
    if v is None:
        return bytes([_NULL])
    if isinstance(v, bool):
        return bytes([_TRUE if v else _FALSE])
    if isinstance(v, int):
        if abs(v) >= _INT_LIMIT:
            return None
        return bytes([_INT]) + _zigzag(v)
    if isinstance(v, float):
        d = _decimal(v) if decimals else None
        short = b"" if d is None else _zigzag(d[0]) + _zigzag(d[1])
        if 0 < len(short) <= _F64.size:  # else the binary64 is no longer
            return bytes([_DECIMAL]) + short
        return bytes([_FLOAT]) + _F64.pack(v) if math.isfinite(v) else None
    if isinstance(v, str):
        if v in WORDS:
            return bytes([_WORD, WORDS.index(v)])
        if _hex(v):
            return bytes([_HEX]) + varint(len(v) // 2) + bytes.fromhex(v)
        t = _text(v)
        return None if t is None else bytes([_STR]) + t
    if isinstance(v, dict) and top:
        inner = _object(v, False, decimals)
        return None if inner is None else bytes([_OBJECT]) + inner
    return None


def _object(d: dict[str, Any], top: bool, decimals: bool) -> bytes | None:
    parts = [varint(len(d))]
    for k in sorted(d):
        if not isinstance(k, str):
            return None
        v = _value(d[k], top, decimals)
        key = bytes([KEYS.index(k)]) if k in KEYS else _text(k)
        if v is None or key is None:
            return None
        parts += [key if k in KEYS else bytes([_KEY_ESCAPE]) + key, v]
    return b"".join(parts)


def write_meta(meta: dict[str, Any], revision: int = container.REVISION) -> bytes:
    """The META section of ``meta``: binary (§2.12) from format 2.6 wherever
    every value has a binary form, else JSON with sorted keys."""
    if revision >= container.COMPACT:
        body = _object(meta, True, revision >= container.SHORT)
        if body is not None:
            return bytes([BINARY]) + body
    return json.dumps(meta, sort_keys=True, separators=(",", ":")).encode()


class _Binary:
    """Reads a binary META (§2.12); every fault a ``SectionError``."""

    def __init__(self, raw: bytes, revision: int) -> None:
        self.raw, self.pos, self.revision = raw, 1, revision

    def byte(self) -> int:
        if self.pos >= len(self.raw):
            raise SectionError("META: binary object runs past the section")
        self.pos += 1
        return self.raw[self.pos - 1]

    def count(self) -> int:
        try:
            n, self.pos = read_varint(self.raw, self.pos)
        except CorruptError:  # a TruncatedError too
            raise SectionError(f"META: bad varint at offset {self.pos}") from None
        return n

    def take(self, n: int) -> bytes:
        if n > len(self.raw) - self.pos:
            raise SectionError("META: a length past the section's end")
        self.pos += n
        return self.raw[self.pos - n : self.pos]

    def signed(self) -> int:
        """A zig-zag varint: z even is z/2, z odd is -(z+1)/2."""
        z = self.count()
        return z >> 1 if not z & 1 else -((z + 1) >> 1)

    def text(self) -> str:
        try:
            return self.take(self.count()).decode("utf-8")
        except UnicodeDecodeError:
            raise SectionError("META: text that is not UTF-8") from None

    def value(self, top: bool) -> Any:
        t = self.byte()
        if t in (_NULL, _FALSE, _TRUE):
            return (None, False, True)[t]
        if t == _INT:
            return self.signed()
        if t == _DECIMAL and self.revision >= container.SHORT:
            m, e = self.signed(), self.signed()
            if abs(m) >= _DEC_MANTISSA or abs(e) > _DEC_EXPONENT:
                raise SectionError("META: a decimal number out of range")
            return from_decimal(m, e)
        if t == _FLOAT:
            (x,) = _F64.unpack(self.take(8))
            if not math.isfinite(x):
                raise SectionError("META: a number that is not finite")
            return x
        if t == _STR:
            return self.text()
        if t == _WORD:
            w = self.byte()
            if w >= len(WORDS):
                raise SectionError(f"META: string code {w} past the table")
            return WORDS[w]
        if t == _HEX:
            return self.take(self.count()).hex()
        if t == _OBJECT and top:
            return self.object(False)
        raise SectionError(f"META: unknown value type {t}" + ("" if top else " in an object"))

    def object(self, top: bool) -> dict[str, Any]:
        n = self.count()
        if n > len(self.raw) - self.pos:  # two bytes an entry at least
            raise SectionError("META: more entries than the section holds")
        out: dict[str, Any] = {}
        for _ in range(n):
            k = self.byte()
            if k == _KEY_ESCAPE:
                key = self.text()
            elif k < len(KEYS):
                key = KEYS[k]
            else:
                raise SectionError(f"META: key code {k} past the table")
            if key in out:
                raise SectionError(f"META: key {key[:20]!r} twice")
            out[key] = self.value(top)
        return out


def parse_meta(raw: bytes, revision: int = container.REVISION) -> Any:
    """META's object, JSON or (from format 2.6) binary, before its fields are
    checked (:func:`read_meta` checks a B-rep container's, ``passthrough`` a
    verbatim one's).

    Raises
    ------
    SectionError
        Neither valid JSON nor, in a file of format 2.6 or later, a valid binary object.
    """
    if revision >= container.COMPACT and raw[:1] not in (b"{", bytes([BINARY])):
        raise SectionError("META section is neither a JSON object nor binary")
    if revision >= container.COMPACT and raw[:1] == bytes([BINARY]):
        b = _Binary(raw, revision)
        meta = b.object(True)
        if b.pos != len(raw):
            raise SectionError("META: bytes after the binary object")
        return meta
    try:
        return json.loads(raw.decode("utf-8"), parse_int=_meta_int, parse_constant=_meta_constant)
    except (UnicodeDecodeError, json.JSONDecodeError, RecursionError):
        raise SectionError("META section is not valid JSON") from None


def read_meta(raw: bytes, revision: int = container.REVISION) -> dict[str, Any]:
    """The META section's object (JSON, or binary in a file of ``revision``
    from format 2.6), its fields checked.

    Raises
    ------
    LimitError
        The section is larger than ``MAX_META_BYTES``.
    SectionError
        Not a JSON object, or a field of the wrong type or value: integers of
        more than ``MAX_META_DIGITS`` digits, NaN or infinities, strings longer
        than ``MAX_META_TEXT`` or holding control characters or lone surrogates.
    """
    if len(raw) > MAX_META_BYTES:
        raise LimitError(f"META: {len(raw)} bytes, more than the {MAX_META_BYTES} a reader parses")
    meta = parse_meta(raw, revision)
    if not isinstance(meta, dict):
        raise SectionError("META section is not a JSON object")
    for key in ("unit", "source_format", "mode", "source_name", "writer"):
        v = meta.get(key, "")
        if not isinstance(v, str) and not (key == "mode" and v is None):
            raise SectionError(f"META: {key} is not a string")
        if isinstance(v, str) and (len(v) > MAX_META_TEXT or _bad_text(v)):
            raise SectionError(
                f"META: {key} is longer than {MAX_META_TEXT} characters or holds control "
                "characters or lone surrogates"
            )
    unit = meta.get("unit", "MM")
    if unit not in UNITS_MM:
        raise SectionError(f"META: unknown unit {unit[:20]!r}")
    mode, tol = meta.get("mode"), meta.get("tolerance_mm")
    if mode not in ("lossless", "tolerance"):
        raise SectionError(f"META: unknown mode {str(mode)[:20]!r}")
    if mode == "tolerance" and not (_number(tol) and 0 < cast(float, tol) < MAX_COORD):
        raise SectionError("META: tolerance_mm is not a positive number")
    if mode == "lossless" and tol is not None:
        raise SectionError("META: a lossless container has a tolerance")
    size = meta.get("source_bytes", 0)
    if not (_number(size) and 0 <= size <= MAX_SOURCE_BYTES):
        raise SectionError(f"META: source_bytes is not a number from 0 to {MAX_SOURCE_BYTES}")
    if not isinstance(meta.get("step_pcurves", True), bool):
        raise SectionError("META: step_pcurves is not true or false")
    u = meta.get("uncertainty")
    if u is not None and not (_number(u) and 0 < cast(float, u) < MAX_COORD):
        raise SectionError("META: uncertainty is not a positive number")
    return meta


def tolerance(meta: dict[str, Any]) -> float:
    """The tolerance (mm) a container's META gives, 0.0 if none (lossless)."""
    tol = meta.get("tolerance_mm")
    return float(cast(float, tol)) if _number(tol) else 0.0
