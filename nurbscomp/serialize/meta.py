"""`META` (§2): the JSON header of a container, read with bounds on its size,
its strings and its numbers."""

from __future__ import annotations

import json
from typing import Any, cast

from ..errors import LimitError, SectionError
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


def read_meta(raw: bytes) -> dict[str, Any]:
    """The META section's JSON object, its fields checked.

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
    try:
        meta = json.loads(raw.decode("utf-8"), parse_int=_meta_int, parse_constant=_meta_constant)
    except (UnicodeDecodeError, json.JSONDecodeError, RecursionError):
        raise SectionError("META section is not valid JSON") from None
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
    return meta


def tolerance(meta: dict[str, Any]) -> float:
    """The tolerance (mm) a container's META gives, 0.0 if none (lossless)."""
    tol = meta.get("tolerance_mm")
    return float(cast(float, tol)) if _number(tol) else 0.0
