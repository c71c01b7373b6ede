"""The container layer: byte-exact round trips, and a specific error for each damage."""

import struct
import zlib

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from nurbscomp import container
from nurbscomp.errors import (
    BadMagicError,
    ChecksumError,
    FormatError,
    TruncatedError,
    VersionError,
)

SECTIONS = [("META", b'{"a":1}'), ("SURF", bytes(range(256)) * 20), ("EMPT", b"")]


def test_round_trip_is_byte_exact() -> None:
    data = container.pack(SECTIONS, container.FLAG_LOSSLESS)
    c = container.unpack(data)
    assert [(s.tag, s.raw) for s in c.sections] == SECTIONS
    assert c.flags == container.FLAG_LOSSLESS
    assert (c.major, c.minor) == (container.MAJOR, container.MINOR)
    assert container.pack([(s.tag, s.raw) for s in c.sections], c.flags) == data


@given(
    st.lists(
        st.tuples(st.text("ABCDEFGHIJ", min_size=4, max_size=4), st.binary(max_size=300)),
        max_size=5,
        unique_by=lambda s: s[0],
    )
)
@settings(max_examples=50, deadline=None)
def test_round_trip_any_sections(sections: list[tuple[str, bytes]]) -> None:
    c = container.unpack(container.pack(sections))
    assert [(s.tag, s.raw) for s in c.sections] == sections


def test_bad_magic() -> None:
    with pytest.raises(BadMagicError):
        container.unpack(b"ISO-10303-21;")


def test_every_truncation_is_refused() -> None:
    data = container.pack(SECTIONS)
    for cut in range(len(data)):
        with pytest.raises(FormatError):
            container.unpack(data[:cut])


def test_every_bit_flip_is_caught() -> None:
    data = container.pack(SECTIONS)
    for i in range(len(data)):
        for bit in (0, 3, 7):
            bad = bytearray(data)
            bad[i] ^= 1 << bit
            with pytest.raises(FormatError):
                container.unpack(bytes(bad))


def test_unknown_major_version() -> None:
    data = bytearray(container.pack(SECTIONS))
    data[4] = container.MAJOR + 1
    data[12:16] = struct.pack("<I", zlib.crc32(bytes(data[:12])))
    with pytest.raises(VersionError):
        container.unpack(bytes(data))


def test_checksum_error_names_offset() -> None:
    data = bytearray(container.pack(SECTIONS))
    data[-1] ^= 0xFF
    with pytest.raises(ChecksumError, match="offset"):
        container.unpack(bytes(data))


def test_trailing_bytes_are_refused() -> None:
    with pytest.raises(FormatError):
        container.unpack(container.pack(SECTIONS) + b"\0")


def test_inflated_length_is_refused_before_reading() -> None:
    data = bytearray(container.pack(SECTIONS))
    # body header follows the 16-byte header and the directory (12 bytes an entry)
    at = 16 + 12 * len(SECTIONS)
    data[at + 8 : at + 12] = struct.pack("<I", 2**31)
    with pytest.raises(TruncatedError):
        container.unpack(bytes(data))


@given(st.binary(max_size=200))
@settings(max_examples=200, deadline=None)
def test_random_bytes_never_crash(noise: bytes) -> None:
    for data in (noise, container.MAGIC + noise):
        with pytest.raises(FormatError):
            container.unpack(data)
