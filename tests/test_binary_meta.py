"""`META` in binary (format 2.6, docs/format.md §2.12): the same object as the
JSON, in fewer bytes, and a ``SectionError`` for every damage."""

import json
import math
import struct

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from nurbscomp import container, serialize
from nurbscomp.errors import SectionError
from nurbscomp.serialize.meta import KEYS, WORDS

TOLERANCE = {
    "mode": "tolerance",
    "tolerance_mm": 0.01,
    "source_name": "bracket.step",
    "source_bytes": 225626,
    "source_format": "STEP",
    "unit": "INCH",
    "step_pcurves": False,
    "decoded": {"rows": 3_000_000, "poles": 12},
    "writer": "nurbscomp 0.1.0",
}
EXACT = {
    "mode": "exact",
    "source_format": "IGES",
    "source_name": "lens é.igs",
    "source_bytes": 0,
    "sha256": "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855",
    "model": "iges",
    "writer": "nurbscomp 0.1.0",
    "reason": "holds no B-rep",
}


@pytest.mark.parametrize("meta", [TOLERANCE, EXACT], ids=["tolerance", "exact"])
def test_binary_meta_is_the_same_object_in_fewer_bytes(meta: dict) -> None:
    raw = serialize.write_meta(meta)
    assert raw[0] == 1
    back = serialize.parse_meta(raw)
    assert back == meta
    assert [type(back[k]) for k in sorted(meta)] == [type(meta[k]) for k in sorted(meta)]
    as_json = serialize.write_meta(meta, revision=8)
    assert json.loads(as_json) == meta
    assert len(raw) < 0.45 * len(as_json)


def test_what_has_no_binary_form_is_written_as_json() -> None:
    for odd in ([1, 2], 2**62, "x\ud800", float("nan"), {"a": {"b": 1}}):
        raw = serialize.write_meta({**TOLERANCE, "extra": odd})
        assert raw[:1] == b"{"
    assert serialize.write_meta({**TOLERANCE, "extra": 2**62 - 1})[:1] == b"\x01"


def test_binary_meta_is_refused_before_2_6() -> None:
    raw = serialize.write_meta(TOLERANCE, container.SHORT - 1)
    assert serialize.read_meta(raw, container.COMPACT) == TOLERANCE
    with pytest.raises(SectionError, match="not valid JSON"):
        serialize.read_meta(raw, container.COMPACT - 1)


def _entry(key: int, value: bytes) -> bytes:
    return b"\x01\x01" + bytes([key]) + value


@pytest.mark.parametrize(
    "raw, fragment",
    [
        (_entry(len(KEYS), b"\x00"), "key code"),
        (_entry(0, b"\x0a"), "unknown value type 10"),
        (_entry(5, b"\x09\x02\x2e"), "decimal number out of range"),
        (_entry(5, b"\x09" + b"\x80" * 7 + b"\x20\x00"), "decimal number out of range"),
        (_entry(0, bytes([6, len(WORDS)])), "string code"),
        (b"\x01\x02\x00\x00\x00\x00", "twice"),
        (_entry(11, b"\x08\x01\x0c\x08\x00"), "in an object"),
        (_entry(5, b"\x04" + struct.pack("<d", math.inf)), "not finite"),
        (_entry(3, b"\x05\x02\xff\xfe"), "not UTF-8"),
        (_entry(3, b"\x05\x09ab"), "past the section"),
        (_entry(0, b"\x00") + b"\x00", "bytes after"),
        (b"\x01\x05\x00", "more entries"),
        (_entry(1, b"\x03" + b"\xff" * 9), "bad varint"),
        (b"\x02{}", "neither"),
        (b" {}", "neither"),
    ],
)
def test_a_damaged_binary_meta_is_a_section_error(raw: bytes, fragment: str) -> None:
    with pytest.raises(SectionError, match=fragment):
        serialize.parse_meta(raw)


_SCALARS = (
    st.none()
    | st.booleans()
    | st.integers(-(2**62) + 1, 2**62 - 1)
    | st.floats(allow_nan=False, allow_infinity=False)
    | st.text(max_size=20)
    | st.sampled_from(WORDS)
)


@settings(max_examples=200, deadline=None)
@given(
    st.dictionaries(
        st.text(max_size=8) | st.sampled_from(KEYS),
        _SCALARS | st.dictionaries(st.text(max_size=4), _SCALARS, max_size=3),
        max_size=8,
    )
)
def test_any_object_of_scalars_round_trips(meta: dict) -> None:
    raw = serialize.write_meta(meta)
    back = serialize.parse_meta(raw)
    assert json.dumps(back, sort_keys=True) == json.dumps(meta, sort_keys=True)


def test_the_2_6_golden_files_hold_binary_meta() -> None:
    from pathlib import Path

    golden = Path(__file__).resolve().parent / "golden"
    files = sorted(golden.glob("*.v2_6.*.nzc"))
    assert len(files) == 4
    for p in files:
        c = container.unpack(p.read_bytes())
        assert (c.major, c.minor) == (2, 6) and c.get("META")[0] == 1
        assert serialize.parse_meta(c.get("META"), c.revision)["writer"].startswith("nurbscomp ")


# ------------------------------------------------ format 2.13: decimal numbers


def test_a_short_decimal_is_written_as_one() -> None:
    """§2.12 (2.13): 0.01 as (1, -2) in 3 bytes instead of 9; a number whose
    decimal is no shorter than its binary64 (1/3), -0.0 and 1e30 keep type 4."""
    raw = serialize.write_meta({"tolerance_mm": 0.01})
    assert raw == bytes([1, 1, KEYS.index("tolerance_mm"), 9, 2, 3])
    assert serialize.parse_meta(raw) == {"tolerance_mm": 0.01}
    for x in (1 / 3, -0.0, 1e30):
        raw = serialize.write_meta({"tolerance_mm": x})
        assert raw[3] == 4 and struct.unpack("<d", raw[4:]) == (x,)
    assert serialize.write_meta({"tolerance_mm": 0.01}, container.SHORT - 1)[3] == 4


def test_a_decimal_is_refused_before_2_13() -> None:
    raw = serialize.write_meta({"tolerance_mm": 0.1})
    with pytest.raises(SectionError, match="unknown value type 9"):
        serialize.parse_meta(raw, container.SHORT - 1)


@settings(max_examples=500, deadline=None)
@given(st.floats(allow_nan=False, allow_infinity=False) | st.sampled_from([1e-3, 0.05, 2.5e-5]))
def test_every_number_comes_back_bit_for_bit(x: float) -> None:
    raw = serialize.write_meta({"tolerance_mm": x})
    (back,) = serialize.parse_meta(raw).values()
    assert isinstance(back, float) and struct.pack("<d", back) == struct.pack("<d", x)
