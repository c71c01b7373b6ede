"""The container layer: byte-exact round trips, and a specific error for each damage."""

import hashlib
import json
import struct
import zlib
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from nurbscomp import container, entropy
from nurbscomp.errors import (
    BadMagicError,
    ChecksumError,
    CorruptError,
    FormatError,
    LimitError,
    ReservedBitsError,
    TrailingDataError,
    TruncatedError,
    VersionError,
)
from nurbscomp.streams import varint

SECTIONS = [("META", b'{"a":1}'), ("SURF", bytes(range(256)) * 20), ("EMPT", b"")]


def test_round_trip_is_byte_exact() -> None:
    data = container.pack(SECTIONS, container.FLAG_LOSSLESS)
    c = container.unpack(data)
    assert [(s.tag, s.raw) for s in c.sections] == SECTIONS
    assert c.flags == container.FLAG_LOSSLESS
    assert (c.major, c.minor) == (container.MAJOR, container.MINOR)
    assert container.pack([(s.tag, s.raw) for s in c.sections], c.flags) == data


@pytest.mark.slow
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


def test_versions_read_and_refused() -> None:
    """A reader reads every 1.y (past 1.2 as 1.2) and 2.0; a newer 2.y and major 0
    (the drafts) are refused."""
    good = bytearray(container.pack(SECTIONS))

    def at(major: int, minor: int) -> bytes:
        data = bytearray(good)
        data[4], data[5] = major, minor
        data[12:16] = struct.pack("<I", zlib.crc32(bytes(data[:12])))
        return bytes(data)

    def of(*version: int) -> int:  # each version laid out as it lays out its directory
        c = container.unpack(container.pack(SECTIONS, version=version))
        assert [s.raw for s in c.sections] == [raw for _, raw in SECTIONS]
        return c.revision

    assert [of(1, m) for m in (0, 1, 2, 9)] == [0, 1, 2, 2]
    assert [of(2, m) for m in range(20)] == list(range(3, 23))
    assert of(2, 19) == container.REVISION == 22
    for major, minor in ((2, container.MINOR + 1), (0, 3)):
        with pytest.raises(VersionError, match=f"{major}.{minor} is not supported"):
            container.unpack(at(major, minor))


def test_checksum_error_names_offset() -> None:
    data = bytearray(container.pack(SECTIONS))
    data[-1] ^= 0xFF
    with pytest.raises(ChecksumError, match="offset"):
        container.unpack(bytes(data))


def test_trailing_bytes_are_refused() -> None:
    with pytest.raises(FormatError):
        container.unpack(container.pack(SECTIONS) + b"\0")


def test_inflated_length_is_refused_before_reading() -> None:
    data = bytearray(container.pack(SECTIONS, version=(2, 5)))
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
    data = raw + bytes(range(noise)) * 4  # something with repeats
    sizes = {}
    for c in entropy.Coder:
        out = entropy._compress(c, data)
        assert entropy.decompress(c, out, len(data)) == data
        sizes[c] = len(out)
    coder, out = entropy.compress(data)
    # no larger than any coder's default stream (the LZMA literal settings it
    # also tries can beat them all), and the smallest of what it tried
    assert len(out) <= min(sizes.values())
    tried = [
        len(entropy._compress(c, data, t)) for c, t in entropy._jobs(tuple(entropy.Coder), data)
    ]
    assert len(out) == min(tried)
    assert entropy.decompress(coder, out, len(data)) == data


def test_lzma_tunings_decode_with_the_default_settings() -> None:
    """The encoder's literal settings travel in the LZMA2 stream: one decoder reads them all."""
    import lzma

    data = bytes(range(256)) * 8 + b"nurbscomp" * 50
    for lc, lp, pb in entropy.LZMA_TUNINGS:
        f = {"id": lzma.FILTER_LZMA2, "preset": 6, "lc": lc, "lp": lp, "pb": pb}
        out = lzma.compress(data, format=lzma.FORMAT_RAW, filters=[f])
        assert entropy.decompress(entropy.Coder.LZMA, out, len(data)) == data


@pytest.mark.parametrize("coder", list(entropy.Coder)[1:], ids=lambda c: c.name)
def test_decompression_bomb_is_not_inflated(coder: entropy.Coder) -> None:
    """64 MiB of zeros declared as 1000 bytes: refused after at most 1001 bytes of output."""
    import lzma

    import brotli
    import zstandard

    zeros = bytes(64 << 20)
    bomb = {
        entropy.Coder.LZMA: lambda: lzma.compress(
            zeros, format=lzma.FORMAT_RAW, filters=[{"id": lzma.FILTER_LZMA2, "preset": 1}]
        ),
        entropy.Coder.ZSTD: lambda: zstandard.ZstdCompressor(level=1).compress(zeros),
        entropy.Coder.BROTLI: lambda: brotli.compress(zeros, quality=1),
        entropy.Coder.ZSTD_DICT: lambda: zstandard.ZstdCompressor(
            level=1, dict_data=entropy.dictionary()
        ).compress(zeros),
        entropy.Coder.ZSTD_DICT_11: lambda: zstandard.ZstdCompressor(
            level=1, dict_data=entropy.dictionary(5)
        ).compress(zeros),
        entropy.Coder.ZSTD_DICT_12: lambda: zstandard.ZstdCompressor(
            level=1, dict_data=entropy.dictionary(6)
        ).compress(zeros),
        entropy.Coder.ZSTD_DICT_13: lambda: zstandard.ZstdCompressor(
            level=1, dict_data=entropy.dictionary(7)
        ).compress(zeros),
        entropy.Coder.ZSTD_DICT_19: lambda: zstandard.ZstdCompressor(
            level=1, dict_data=entropy.dictionary(8)
        ).compress(zeros),
    }[coder]()
    assert len(bomb) < len(zeros) // 100
    with pytest.raises(CorruptError, match="1001 bytes, header says 1000"):
        entropy.decompress(coder, bomb, 1000)
    # a declared size above the reader's limit is refused before inflating
    sections = [("BOMB", zeros[:1000])]
    if coder < entropy.Coder.ZSTD_DICT_11:
        # (a 2.5 layout cannot hold coders 5 to 7)
        data = bytearray(container.pack(sections, coders=(coder,), version=(2, 5)))
        data[16 + 12 + 4 : 16 + 12 + 8] = struct.pack("<I", container.MAX_RAW + 1)
        data[16 + 4 : 16 + 8] = struct.pack("<I", container.MAX_RAW + 1)
        with pytest.raises(LimitError):
            container.unpack(_fix_crcs(bytes(data)))
    # from 2.6, by the directory's varint lengths: one entry at offset 16,
    # the escape code and the 4-byte tag, then the length (1000: two bytes)
    if coder < entropy.Coder.ZSTD_DICT_13:
        _bomb_in_2_12(sections, coder)
    # from 2.13: a count, the escape and the tag, then the length, at offset 7
    data = container.pack(sections, coders=(coder,))
    assert data[7:13] == b"\x01\xffBOMB" and data[13:15] == varint(1000)
    huge = data[:13] + varint(container.MAX_RAW + 1) + data[15:]
    with pytest.raises(LimitError, match="declares"):
        container.unpack(_fix_crcs(huge))


def _bomb_in_2_12(sections: list[tuple[str, bytes]], coder: int) -> None:
    data = container.pack(sections, coders=(coder,), version=(2, 12))
    assert data[16] == container.TAG_ESCAPE and data[21:23] == varint(1000)
    huge = data[:21] + varint(container.MAX_RAW + 1) + data[23:]
    with pytest.raises(LimitError, match="declares"):
        container.unpack(_fix_crcs(huge))


def _fix_crcs(data: bytes) -> bytes:
    from .golden.make_golden import fix_crcs

    return fix_crcs(data)


def test_duplicate_tags_are_refused() -> None:
    from .golden.make_golden import pack_raw

    with pytest.raises(ValueError):
        container.pack([("META", b"a"), ("META", b"b")])
    with pytest.raises(CorruptError, match="appears twice"):
        container.unpack(pack_raw([("META", b"a"), ("META", b"b")], 0))


def test_reserved_bits_and_trailing_bytes_have_their_own_errors() -> None:
    from .golden.make_golden import fix_crcs

    for version in ((2, 12), (container.MAJOR, container.MINOR)):
        data = bytearray(container.pack(SECTIONS, version=version))
        data[6] |= 0x80
        with pytest.raises(ReservedBitsError, match="offset 6"):
            container.unpack(fix_crcs(bytes(data)))
    with pytest.raises(TrailingDataError, match="offset"):
        container.unpack(container.pack(SECTIONS, version=(2, 5)) + b"xyz")
    # from 2.6 the payload runs to the end of the file: its CRC catches them
    with pytest.raises(ChecksumError, match="body checksum"):
        container.unpack(container.pack(SECTIONS, version=(2, 12)) + b"xyz")
    with pytest.raises(ChecksumError, match="checksum mismatch"):
        container.unpack(container.pack(SECTIONS) + b"xyz")


def test_large_bodies_try_fewer_streams() -> None:
    """Above FULL_SEARCH_MAX only the ranked LZMA finalists run at 9e, and brotli
    only up to BROTLI_MAX; the result still decodes and is the smallest tried."""
    rng = __import__("numpy").random.default_rng(5)
    body = rng.integers(0, 16, entropy.BROTLI_MAX + 1000, dtype="uint8").tobytes()
    jobs = entropy._jobs(tuple(entropy.Coder), body)
    coders = [c for c, _ in jobs]
    assert entropy.Coder.BROTLI not in coders
    assert coders.count(entropy.Coder.LZMA) == entropy.LZMA_FINALISTS
    mid = body[: entropy.FULL_SEARCH_MAX + 1]
    assert entropy.Coder.BROTLI in [c for c, _ in entropy._jobs(tuple(entropy.Coder), mid)]
    small = body[: entropy.FULL_SEARCH_MAX]
    n_lzma = [c for c, _ in entropy._jobs(tuple(entropy.Coder), small)].count(entropy.Coder.LZMA)
    assert n_lzma == 1 + len(entropy.LZMA_TUNINGS)
    coder, out = entropy.compress(mid)
    assert entropy.decompress(coder, out, len(mid)) == mid
    tried = [len(entropy._compress(c, mid, t)) for c, t in entropy._jobs(tuple(entropy.Coder), mid)]
    assert len(out) == min(tried)


def test_quick_search_on_large_bodies() -> None:
    """A quick search (lossless mode) on a body over QUICK_MAX ranks the LZMA
    settings on a sample and runs the best one only, at QUICK_PRESET; up to
    QUICK_MAX it is the thorough search.  Both decode."""
    rng = __import__("numpy").random.default_rng(6)
    body = rng.integers(0, 16, 4 * entropy.QUICK_MAX, dtype="uint8").tobytes()
    sample = entropy._sample(body)
    assert len(sample) == entropy.SAMPLE_PIECES * entropy.SAMPLE_PIECE
    assert sample.startswith(body[: entropy.SAMPLE_PIECE]) and sample.endswith(body[-100:])
    quick = entropy._jobs(tuple(entropy.Coder), body, thorough=False)
    assert [c for c, _ in quick] == [entropy.Coder.LZMA]
    assert entropy.Coder.ZSTD in [c for c, _ in entropy._jobs(tuple(entropy.Coder), body)]
    mid = body[: entropy.QUICK_MAX]
    assert entropy._jobs(tuple(entropy.Coder), mid, thorough=False) == entropy._jobs(
        tuple(entropy.Coder), mid
    )
    coder, out = entropy.compress(body, thorough=False)
    assert coder == entropy.Coder.LZMA and entropy.decompress(coder, out, len(body)) == body
    # the quick stream is the preset-6 stream of the top-ranked settings
    best = entropy._lzma_rank(sample)[0]
    assert out == entropy._compress(entropy.Coder.LZMA, body, best, entropy.QUICK_PRESET)
    assert out != entropy._compress(entropy.Coder.LZMA, body, best)
    assert (
        container.unpack(container.pack(SECTIONS, thorough=False)).sections
        == container.unpack(container.pack(SECTIONS)).sections
    )


# ------------------------------------------------- coder 4: zstd with the format's dictionary


@pytest.mark.parametrize("coder", sorted(entropy.DICTIONARIES))
def test_each_dictionary_is_the_format_s(coder: entropy.Coder) -> None:
    """Formats 2.4, 2.11, 2.12, 2.13 and 2.19 fix their dictionaries' bytes:
    a changed file is refused, never used (docs/format.md §1.3)."""
    path, sha, _ = entropy.DICTIONARIES[coder]
    raw = path.read_bytes()
    assert len(raw) == 65536 and raw[:4] == bytes.fromhex("37a430ec")
    assert hashlib.sha256(raw).hexdigest() == sha


def test_a_small_body_takes_the_dictionary_and_round_trips() -> None:
    body = json.dumps({"mode": "tolerance", "source_format": "STEP", "unit": "MM"}).encode()
    sections = [("META", body), ("LOCS", b"\x01\x01\x00\x00\x00\x00")]
    data = container.pack(sections)
    c = container.unpack(data)
    # smaller with a dictionary than with any other coder here
    assert c.coder in (entropy.Coder.ZSTD_DICT, entropy.Coder.ZSTD_DICT_11)
    assert [c.get(t) for t in c.tags()] == [s for _, s in sections]
    plain = container.pack(sections, coders=tuple(c for c in entropy.Coder if c < 4))
    assert len(data) < len(plain)
    for coder in entropy.Coder:
        stored = entropy._compress(coder, body)
        assert entropy.decompress(coder, stored, len(body)) == body


def test_the_dictionary_coder_only_from_2_4() -> None:
    """An older version's header is never written with coder 4, and a file
    of revision 0-6 that has it is refused."""
    sections = [("META", b'{"mode":"tolerance"}')]
    old = container.pack(sections, version=(2, 3))
    assert container.unpack(old).coder != entropy.Coder.ZSTD_DICT
    data = bytearray(container.pack(sections, version=(2, 5)))
    assert container.unpack(bytes(data)).coder == entropy.Coder.ZSTD_DICT
    data[5] = 3  # the same body in a 2.3 header
    data[12:16] = struct.pack("<I", zlib.crc32(bytes(data[:12])))
    with pytest.raises(CorruptError, match="unknown coder id 4"):
        container.unpack(bytes(data))


@pytest.mark.parametrize("coder", [4, 5, 6, 7])
def test_a_text_stream_never_takes_a_dictionary_coder(coder: int) -> None:
    from nurbscomp.text import coding

    stream = bytes([1, coder, 3, 3]) + b"abc"  # one stream, coder 4 or 5
    with pytest.raises(CorruptError, match=f"text stream coder {coder}"):
        coding.unpack(stream, 100)


# ------------------------------------------- coder 5 (2.11): zstd with 2.11's dictionary


def test_a_small_part_takes_the_2_11_dictionary() -> None:
    """A generated part's container (the golden bracket at 0.01 mm, written
    again): coder 5 is smaller than coder 4 on it, and what is written."""
    from . import fuzz

    golden = Path(__file__).resolve().parent / "golden" / "bracket.v2_11.tol0.01.nzc"
    m, meta = fuzz.decoded(golden.read_bytes())
    c = container.unpack(golden.read_bytes())
    body = b"".join(c.get(t) for t in c.tags())
    five = len(entropy._compress(entropy.Coder.ZSTD_DICT_11, body))
    four = len(entropy._compress(entropy.Coder.ZSTD_DICT, body))
    assert five < four
    assert c.coder == entropy.Coder.ZSTD_DICT_11 and c.stored_length == five
    assert m is not None and meta


def test_the_2_11_dictionary_coder_only_from_2_11() -> None:
    sections = [("META", b'{"mode":"tolerance"}')]
    for version in ((2, 5), (2, 10)):
        old = container.pack(sections, version=version)
        assert container.unpack(old).coder != entropy.Coder.ZSTD_DICT_11
    with pytest.raises(ValueError, match="no coder given"):
        container.pack(sections, coders=(entropy.Coder.ZSTD_DICT_11,), version=(2, 10))
    data = bytearray(
        container.pack(sections, coders=(entropy.Coder.ZSTD_DICT_11,), version=(2, 12))
    )
    assert container.unpack(bytes(data)).coder == entropy.Coder.ZSTD_DICT_11
    data[5] = 10  # the same body in a 2.10 header (2.6 layout: one CRC over the header)
    fixed = _fix_crcs(bytes(data))
    with pytest.raises(CorruptError, match="unknown coder id 5"):
        container.unpack(fixed)


# --------------------------------------------- format 2.6: compact directory and body header


def test_the_compact_layout_and_what_it_saves() -> None:
    """docs/format.md §1.2, §1.3 (2.6): one-byte codes for the format's tags,
    the escape and 4 bytes for others, varint lengths, a 9-byte body header."""
    sections = [("META", b"x" * 3), ("SURF", bytes(200)), ("ZZZZ", b""), ("TEXT", b"t")]
    data = container.pack(sections, coders=(entropy.Coder.STORED,), version=(2, 12))
    body = 16 + 2 + 3 + 6 + 2
    assert data[16:body] == bytes([0, 3, 2]) + varint(200) + b"\xffZZZZ\x00" + bytes([14, 1])
    assert len(data) == body + 9 + 204
    c = container.unpack(data)
    assert [(s.tag, s.raw) for s in c.sections] == sections
    assert c.file_bytes == len(data) and c.stored_length == 204
    old = container.pack(sections, coders=(entropy.Coder.STORED,), version=(2, 5))
    assert len(old) - len(data) == (12 * 4 + 16) - (body - 16 + 9)
    assert container.unpack(old).file_bytes == len(old)


@pytest.mark.parametrize(
    "edit, error, fragment",
    [
        (lambda d: d[:16] + b"\x20" + d[17:], CorruptError, "unknown section tag code 32"),
        (lambda d: d[:16] + b"\x01" + d[17:], CorruptError, "appears twice"),
        (lambda d: d[:17] + b"\xff" * 9 + d[18:], CorruptError, "longer than 9 bytes"),
        (lambda d: d[:18], TruncatedError, "directory truncated"),
        (lambda d: d[:22], TruncatedError, "body header truncated"),
    ],
    ids=["unknown code", "twice", "long varint", "cut directory", "cut body header"],
)
def test_a_damaged_compact_directory_is_refused(edit, error, fragment) -> None:
    from .golden.make_golden import fix_crcs

    data = container.pack(
        [("META", b"ab"), ("LOCS", b"c")], coders=(entropy.Coder.STORED,), version=(2, 12)
    )
    with pytest.raises(error, match=fragment):
        container.unpack(fix_crcs(edit(data)))


def test_the_decoded_body_crc_is_checked() -> None:
    """A 2.6 file's one CRC of the decoded sections (where 2.5 had one each)."""
    from .golden.make_golden import fix_crcs

    data = bytearray(container.pack(SECTIONS, coders=(entropy.Coder.STORED,), version=(2, 12)))
    data[-1] ^= 1  # the payload, then the body CRC made right again
    with pytest.raises(ChecksumError, match="decoded body checksum"):
        container.unpack(fix_crcs(bytes(data)))


# ------------------------------------------- coder 6 (2.12): zstd with 2.12's dictionary


@pytest.mark.parametrize("minor", [12, 13, 19])
def test_a_small_part_takes_its_format_s_dictionary(minor: int) -> None:
    """The golden bracket of 2.12 (2.13, 2.19) at 0.01 mm: coder 6 (7, 8) is
    smaller than every earlier dictionary coder on its body, and what was
    written."""
    coder = {12: entropy.Coder.ZSTD_DICT_12, 13: entropy.Coder.ZSTD_DICT_13}.get(
        minor, entropy.Coder.ZSTD_DICT_19
    )
    others = tuple(c for c in entropy.DICTIONARIES if c < coder)
    _takes_its_dictionary(f"bracket.v2_{minor}.tol0.01.nzc", coder, others)


def _takes_its_dictionary(
    name: str, coder: entropy.Coder, others: tuple[entropy.Coder, ...]
) -> None:
    """The golden file ``name``'s body: ``coder`` makes it smaller than each of
    ``others``, and is what was written."""
    golden = Path(__file__).resolve().parent / "golden" / name
    c = container.unpack(golden.read_bytes())
    body = b"".join(c.get(t) for t in c.tags())
    own = len(entropy._compress(coder, body))
    for other in others:
        assert own < len(entropy._compress(other, body))
    assert c.coder == coder and c.stored_length == own


def test_the_2_12_dictionary_coder_only_from_2_12() -> None:
    sections = [("META", b'{"mode":"tolerance"}')]
    with pytest.raises(ValueError, match="no coder given"):
        container.pack(sections, coders=(entropy.Coder.ZSTD_DICT_12,), version=(2, 11))
    data = bytearray(
        container.pack(sections, coders=(entropy.Coder.ZSTD_DICT_12,), version=(2, 12))
    )
    assert container.unpack(bytes(data)).coder == entropy.Coder.ZSTD_DICT_12
    data[5] = 11  # the same body in a 2.11 header
    with pytest.raises(CorruptError, match="unknown coder id 6"):
        container.unpack(_fix_crcs(bytes(data)))


# ------------------------------------------------- format 2.13: the short header


def test_the_short_header_and_what_it_saves() -> None:
    """docs/format.md §1.1–1.3 (2.13): magic, version, a flags byte; the
    table's tags in its order as a mask; varint lengths; the coder and one
    CRC-32 of every other byte."""
    sections = [("META", b"x" * 3), ("SURF", bytes(200)), ("VERT", b"v")]
    data = container.pack(sections, container.FLAG_LOSSLESS, coders=(entropy.Coder.STORED,))
    mask = (1 << 0) | (1 << 2) | (1 << 8)
    head = (
        container.MAGIC
        + bytes([2, container.MINOR, 1 | container.FLAG_MASK])
        + struct.pack("<H", mask)
    )
    head += bytes([3]) + varint(200) + bytes([1]) + bytes([0])
    assert data[: len(head)] == head
    crc = zlib.crc32(data[len(head) + 4 :], zlib.crc32(head))
    assert data[len(head) : len(head) + 4] == struct.pack("<I", crc)
    c = container.unpack(data)
    assert [(s.tag, s.raw) for s in c.sections] == sections
    assert c.flags == container.FLAG_LOSSLESS  # the layout bit is not the content's
    assert c.file_bytes == len(data) and c.overhead == len(head) + 4
    old = container.pack(
        sections, container.FLAG_LOSSLESS, (entropy.Coder.STORED,), version=(2, 12)
    )
    assert len(old) - len(data) == 11 + len(sections)
    # a tag outside the table, or the table's tags out of its order: a count and names
    for odd in ([("SURF", b"s"), ("META", b"m")], [("META", b"m"), ("ZZZZ", b"z")]):
        data = container.pack(odd, coders=(entropy.Coder.STORED,))
        assert data[6] == 0 and data[7] == 2
        assert [(s.tag, s.raw) for s in container.unpack(data).sections] == odd
    empty = container.pack([], coders=(entropy.Coder.STORED,))
    assert len(empty) == 14 and container.unpack(empty).sections == []


@pytest.mark.parametrize(
    "sections, edit, error, fragment",
    [
        ("mask", lambda d: d[:8] + bytes([d[8] | 0x80]) + d[9:], ReservedBitsError, "bit 15"),
        ("mask", lambda d: d[:6] + bytes([d[6] | 0x10]) + d[7:], ReservedBitsError, "offset 6"),
        ("mask", lambda d: d[:8], TruncatedError, "directory truncated"),
        ("mask", lambda d: d[:12], TruncatedError, "body header truncated"),
        ("mask", lambda d: d[:9] + b"\xff" * 9 + d[10:], CorruptError, "longer than 9 bytes"),
        ("names", lambda d: d[:8] + b"\x20" + d[9:], CorruptError, "unknown section tag code 32"),
        ("names", lambda d: d[:8] + d[9:10] + d[9:], CorruptError, "appears twice"),
        ("names", lambda d: d[:7] + b"\x7f" + d[8:], TruncatedError, "directory of 127"),
        ("names", lambda d: d[:9], TruncatedError, "truncated"),
    ],
    ids=["mask bit 15", "flag bit 4", "cut mask", "cut body header", "long varint", "code",
         "twice", "count", "cut names"],
)  # fmt: skip
def test_a_damaged_short_directory_is_refused(sections, edit, error, fragment) -> None:
    from .golden.make_golden import fix_crcs

    secs = {"mask": [("META", b"ab"), ("LOCS", b"c")], "names": [("LOCS", b"c"), ("META", b"ab")]}
    data = container.pack(secs[sections], coders=(entropy.Coder.STORED,))
    assert container.unpack(fix_crcs(data)).sections  # fix_crcs knows the layout
    with pytest.raises(error, match=fragment):
        container.unpack(fix_crcs(edit(data)))


def test_the_one_crc_covers_the_header() -> None:
    """2.13 has no header CRC of its own: a flip of the flags or of a length
    is caught by the one CRC, and so is a byte after the payload."""
    data = container.pack(SECTIONS, coders=(entropy.Coder.STORED,))
    for at in (6, 9, len(data) - 1):
        bad = bytearray(data)
        bad[at] ^= 1
        with pytest.raises(FormatError):
            container.unpack(bytes(bad))
    with pytest.raises(ChecksumError, match="checksum mismatch"):
        container.unpack(data[:6] + bytes([data[6] ^ 1]) + data[7:])


# ------------------------------------------- coder 7 (2.13): zstd with 2.13's dictionary


def test_the_2_13_dictionary_coder_only_from_2_13() -> None:
    sections = [("META", b'{"mode":"tolerance"}')]
    with pytest.raises(ValueError, match="no coder given"):
        container.pack(sections, coders=(entropy.Coder.ZSTD_DICT_13,), version=(2, 12))
    data = bytearray(container.pack(sections, coders=(entropy.Coder.ZSTD_DICT_13,)))
    assert container.unpack(bytes(data)).coder == entropy.Coder.ZSTD_DICT_13
    data[5] = 12  # the same body in a 2.12 header: the short layout is not 2.12's
    with pytest.raises(FormatError):
        container.unpack(_fix_crcs(bytes(data)))
    _refused_in((2, 12), entropy.Coder.ZSTD_DICT_12, entropy.Coder.ZSTD_DICT_13)


# ------------------------------------------- coder 8 (2.19): zstd with 2.19's dictionary


def test_the_2_19_dictionary_coder_only_from_2_19() -> None:
    sections = [("META", b'{"mode":"tolerance"}')]
    with pytest.raises(ValueError, match="no coder given"):
        container.pack(sections, coders=(entropy.Coder.ZSTD_DICT_19,), version=(2, 18))
    data = container.pack(sections, coders=(entropy.Coder.ZSTD_DICT_19,))
    assert container.unpack(data).coder == entropy.Coder.ZSTD_DICT_19
    _refused_in((2, 18), entropy.Coder.ZSTD_DICT_13, entropy.Coder.ZSTD_DICT_19)


def _refused_in(version: tuple[int, int], theirs: entropy.Coder, coder: entropy.Coder) -> None:
    """A file of ``version`` written with ``theirs``, its coder byte set to
    ``coder`` (a later format's): refused as an unknown coder."""
    sections = [("META", b'{"mode":"tolerance"}')]
    old = bytearray(container.pack(sections, coders=(theirs,), version=version))
    body = 5 if version >= (2, 13) else 9  # the body header: coder and CRC(s)
    body_at = len(old) - container.unpack(bytes(old)).stored_length - body
    assert old[body_at] == theirs
    old[body_at] = coder
    with pytest.raises(CorruptError, match=f"unknown coder id {int(coder)}"):
        container.unpack(_fix_crcs(bytes(old)))
