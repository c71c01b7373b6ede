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


@given(st.binary(max_size=3000), st.integers(0, 255))
@settings(max_examples=4, deadline=None)
def test_every_coder_round_trips(raw: bytes, noise: int) -> None:
    from nurbscomp import entropy

    data = raw + bytes(range(noise)) * 4  # something with repeats
    sizes = {}
    for c in entropy.Coder:
        out = entropy._compress(c, data)
        assert entropy.decompress(c, out, len(data)) == data
        sizes[c] = len(out)
    coder, out = entropy.compress(data)
    assert len(out) == min(sizes.values())


def test_tuned_lzma_settings_are_checked() -> None:
    from nurbscomp import entropy
    from nurbscomp.errors import CorruptError

    data = bytes(range(256)) * 8
    out = entropy._compress(entropy.Coder.LZMA_TUNED, data)
    lc, lp, pb = entropy._props(out[0])
    assert (lc, lp, pb) in entropy._TUNINGS
    for bad in (bytes([(0 * 5 + 3) * 9 + 3]), bytes([225]), b""):  # lc+lp > 4, pb > 4, nothing
        with pytest.raises(CorruptError):
            entropy.decompress(entropy.Coder.LZMA_TUNED, bad + out[1:], len(data))
