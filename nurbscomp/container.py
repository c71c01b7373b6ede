"""The ``.nzc`` byte layout: header, section directory, one compressed body.

See docs/format.md for the specification; this module is its reference
implementation.  All fields are little-endian.

::

    header     magic "\\x89NZC" | major u8 | minor u8 | flags u16 | nsections u16
               | reserved u16 (0) | crc32 u32 of the 12 bytes before it
    directory  nsections x (tag 4s | raw_length u32 | crc32 u32 of the section's bytes)
    body       coder u8 | reserved 3 bytes (0) | raw_length u32 | stored_length u32
               | crc32 u32 of the directory, the 12 body-header bytes and the payload
               | payload: the sections' bytes, concatenated, then compressed

and from format 2.6 (what every container pays, some 140 bytes less)::

    directory  nsections x (tag code u8 [| tag 4s after code 255] | raw_length varint)
    body       coder u8 | crc32 u32 of the decoded body
               | crc32 u32 of the directory, the 5 body-header bytes and the payload
               | payload: to the end of the file

and from format 2.13 (some 24 bytes less again: one CRC, no reserved fields,
the usual sections named by a mask)::

    header     magic "\\x89NZC" | major u8 | minor u8 | flags u8
    directory  (flag bit 3) mask u16, a bit per TAGS entry present, in TAGS order
               | (otherwise) nsections varint | 2.6's entries (tag code [| tag 4s])
               | raw_length varint per section, in body order
    body       coder u8 | crc32 u32 of every byte before it and the payload
               | payload: to the end of the file

The sections are compressed together, not one by one: B-rep data repeats
across tables (a vertex is the end pole of its curves, which are boundary
poles of their surfaces) and one LZ window sees those repeats.  Measured on
the corpus, this is 13% smaller than compressing each section alone.
"""

from __future__ import annotations

import struct
import zlib
from dataclasses import dataclass

from . import entropy
from .errors import (
    BadMagicError,
    ChecksumError,
    CorruptError,
    LimitError,
    ReservedBitsError,
    TrailingDataError,
    TruncatedError,
    VersionError,
)
from .formats import CONTAINER_MAGIC
from .streams import read_varint, varint

MAGIC = CONTAINER_MAGIC  # b"\x89NZC", formats' (it tells a container apart from CAD)
#: The version this writer writes (docs/format.md §0).  Format 1.x is frozen:
#: 1.0, 1.1 and 1.2 decode forever, and no 1.3 will be written.
MAJOR = 2
MINOR = 19
#: Every version this reader reads, oldest first.  A file's *revision* is its
#: index here (:attr:`Container.revision`); the sections' readers branch on it.
VERSIONS = (
    (1, 0),
    (1, 1),
    (1, 2),
    (2, 0),
    (2, 1),
    (2, 2),
    (2, 3),
    (2, 4),
    (2, 5),
    (2, 6),
    (2, 7),
    (2, 8),
    (2, 9),
    (2, 10),
    (2, 11),
    (2, 12),
    (2, 13),
    (2, 14),
    (2, 15),
    (2, 16),
    (2, 17),
    (2, 18),
    (2, 19),
)
#: The revision this writer writes.
REVISION = VERSIONS.index((MAJOR, MINOR))
FLAG_LOSSLESS = 1
#: Format 1.2: the container holds a STEP/IGES file verbatim (``passthrough``).
FLAG_PASSTHROUGH = 2
#: Format 2.0: the container holds a STEP/IGES file byte for byte through the
#: text model (``nurbscomp.text``; docs/format.md §1.5).
FLAG_EXACT = 4
#: The flag bits a file of each revision may set (a bit is reserved in the
#: revisions before the one that defines it).
_KNOWN_FLAGS = (
    FLAG_LOSSLESS,
    FLAG_LOSSLESS,
    FLAG_LOSSLESS | FLAG_PASSTHROUGH,
    FLAG_LOSSLESS | FLAG_PASSTHROUGH | FLAG_EXACT,
    FLAG_LOSSLESS | FLAG_PASSTHROUGH | FLAG_EXACT,
    FLAG_LOSSLESS | FLAG_PASSTHROUGH | FLAG_EXACT,
    FLAG_LOSSLESS | FLAG_PASSTHROUGH | FLAG_EXACT,
    FLAG_LOSSLESS | FLAG_PASSTHROUGH | FLAG_EXACT,
    FLAG_LOSSLESS | FLAG_PASSTHROUGH | FLAG_EXACT,
    FLAG_LOSSLESS | FLAG_PASSTHROUGH | FLAG_EXACT,
    FLAG_LOSSLESS | FLAG_PASSTHROUGH | FLAG_EXACT,
    FLAG_LOSSLESS | FLAG_PASSTHROUGH | FLAG_EXACT,
    FLAG_LOSSLESS | FLAG_PASSTHROUGH | FLAG_EXACT,
    FLAG_LOSSLESS | FLAG_PASSTHROUGH | FLAG_EXACT,
    FLAG_LOSSLESS | FLAG_PASSTHROUGH | FLAG_EXACT,
    FLAG_LOSSLESS | FLAG_PASSTHROUGH | FLAG_EXACT,
    FLAG_LOSSLESS | FLAG_PASSTHROUGH | FLAG_EXACT,
    FLAG_LOSSLESS | FLAG_PASSTHROUGH | FLAG_EXACT,
    FLAG_LOSSLESS | FLAG_PASSTHROUGH | FLAG_EXACT,
    FLAG_LOSSLESS | FLAG_PASSTHROUGH | FLAG_EXACT,
    FLAG_LOSSLESS | FLAG_PASSTHROUGH | FLAG_EXACT,
    FLAG_LOSSLESS | FLAG_PASSTHROUGH | FLAG_EXACT,
    FLAG_LOSSLESS | FLAG_PASSTHROUGH | FLAG_EXACT,
)
#: Format 2.6: the first revision with the compact directory and body header.
COMPACT = VERSIONS.index((2, 6))
#: Format 2.13: the first revision with the short header (docs/format.md §1.1).
SHORT = VERSIONS.index((2, 13))
#: Format 2.18: kind-2 vertices' references may be coded as differences
#: (docs/format.md §2.6, ``serialize.vertices``).
TWIN_DELTAS = VERSIONS.index((2, 18))
#: Format 2.19: ``SHAP`` mode 2, the walk that leaves out what the model's
#: properties imply (docs/format.md §2.5.1, ``topocode``).
SHAP_IMPLIED = VERSIONS.index((2, 19))
#: Format 2.13: flag bit 3, the directory is a mask of :data:`TAGS` (a
#: property of the layout, not of the content: :attr:`Container.flags` never
#: holds it).
FLAG_MASK = 8
#: Format 2.13: the mask's bit 15 is reserved.
_MASK_BITS = (1 << 15) - 1
#: The first version of each coder that a format defines after 2.0.
CODER_SINCE = {int(c): since for c, (_, _, since) in entropy.DICTIONARIES.items()}
#: Format 2.6: the tags a directory entry names by a one-byte code (its index);
#: code :data:`TAG_ESCAPE` is followed by the tag's 4 ASCII bytes.
TAGS = (
    "META", "LOCS", "SURF", "SNET", "CRV3", "CNET", "CRV2", "SHAP",
    "VERT", "EDGE", "FACE", "SIDE", "PROD", "FILE", "TEXT",
)  # fmt: skip
TAG_ESCAPE = 255
_HEADER = struct.Struct("<4sBBHHH")
_ENTRY = struct.Struct("<4sII")
_BODY = struct.Struct("<B3sII")
#: Format 2.6's body header: coder, CRC-32 of the decoded body (then the body CRC).
_BODY6 = struct.Struct("<BI")
_CRC = struct.Struct("<I")
_MASK = struct.Struct("<H")
#: Largest body (all sections, decoded) a reader will inflate: a
#: decompression-bomb guard, checked before anything is inflated.
MAX_RAW = 1 << 28


@dataclass(frozen=True)
class Section:
    """One section: its tag and its (decoded) bytes."""

    tag: str
    raw: bytes


@dataclass(frozen=True)
class Container:
    major: int
    minor: int
    flags: int
    coder: int
    stored_length: int
    sections: list[Section]
    #: bytes before the payload: header, directory and body header
    overhead: int = 0

    def get(self, tag: str) -> bytes:
        """The bytes of the section ``tag`` (:func:`unpack` refuses duplicate tags).

        Raises
        ------
        CorruptError
            No section has this tag.
        """
        for s in self.sections:
            if s.tag == tag:
                return s.raw
        raise CorruptError(f"missing section {tag}")

    def tags(self) -> list[str]:
        return [s.tag for s in self.sections]

    @property
    def revision(self) -> int:
        """The file's version as an index into :data:`VERSIONS` (a 1.x file
        newer than 1.2, which no writer makes, reads as 1.2)."""
        return revision(self.major, self.minor)

    @property
    def file_bytes(self) -> int:
        """Size of the container's bytes (header, directory, body)."""
        return self.overhead + self.stored_length


def revision(major: int, minor: int) -> int:
    """The index into :data:`VERSIONS` of format ``major.minor`` (1.y past 1.2 as 1.2)."""
    if major == 1:
        return min(minor, 2)
    return VERSIONS.index((major, minor))


def pack(
    sections: list[tuple[str, bytes]],
    flags: int = 0,
    coders: tuple[entropy.Coder, ...] = tuple(entropy.Coder),
    thorough: bool = True,
    version: tuple[int, int] = (MAJOR, MINOR),
) -> bytes:
    """Build container bytes from ``(tag, raw payload)`` pairs.

    The body is compressed with each of ``coders`` and the smallest kept (tests
    pass one coder to pack fast); ``thorough=False`` searches less on a large
    body (``entropy.compress``).  ``version`` is what the header says: a
    writer says its own; tests re-pack older files' sections with theirs.
    """
    if len({tag for tag, _ in sections}) != len(sections):
        raise ValueError("section tags must be distinct")
    for tag, _ in sections:
        if len(tag.encode("ascii")) != 4:
            raise ValueError(f"section tag must be 4 ASCII bytes: {tag!r}")
    body = b"".join(raw for _, raw in sections)
    # a dictionary is its format's: a version before it has no such coder
    coders = tuple(c for c in coders if version >= CODER_SINCE.get(c, (0, 0)))
    if not coders:
        raise ValueError(f"no coder given is format {version[0]}.{version[1]}'s")
    coder, stored = entropy.compress(body, coders, thorough)
    return frame(sections, flags, version, coder, stored)


def _name(tag: str) -> bytes:
    """A tag as 2.6's directory names it: its code, or the escape and the tag."""
    code = TAGS.index(tag) if tag in TAGS else TAG_ESCAPE
    return bytes([code]) + (tag.encode("latin-1") if code == TAG_ESCAPE else b"")


def _entry(tag: str, size: int) -> bytes:
    """A 2.6 directory entry: the tag's name, its length."""
    return _name(tag) + varint(size)


def frame(
    sections: list[tuple[str, bytes]],
    flags: int,
    version: tuple[int, int],
    coder: int,
    stored: bytes,
) -> bytes:
    """The container bytes of ``sections`` whose concatenation ``coder``
    compressed into ``stored``, laid out as ``version`` lays them out (no
    check of the tags: tests frame damaged directories with it).

    From 2.13 (docs/format.md §1.1–1.3): a mask of :data:`TAGS` where the
    sections are tags of the table in its order (every container this writer
    makes), else a count and the tags' names; then the lengths, the coder and
    one CRC-32 of all bytes but its own."""
    if revision(*version) >= SHORT:
        codes = [TAGS.index(t) if t in TAGS else -1 for t, _ in sections]
        if all(c >= 0 for c in codes) and all(a < b for a, b in zip(codes, codes[1:])):
            mask = _MASK.pack(sum(1 << c for c in codes))
            head = bytes([*MAGIC, *version, flags | FLAG_MASK]) + mask
        else:
            names = b"".join(_name(tag) for tag, _ in sections)
            head = bytes([*MAGIC, *version, flags]) + varint(len(sections)) + names
        head += b"".join(varint(len(raw)) for _, raw in sections) + bytes([coder])
        return head + _CRC.pack(zlib.crc32(stored, zlib.crc32(head))) + stored
    head = _HEADER.pack(MAGIC, *version, flags, len(sections), 0)
    head += _CRC.pack(zlib.crc32(head))
    if revision(*version) >= COMPACT:
        d = b"".join(_entry(tag, len(raw)) for tag, raw in sections)
        crc_raw = 0
        for _, raw in sections:
            crc_raw = zlib.crc32(raw, crc_raw)
        bh = _BODY6.pack(coder, crc_raw)
    else:
        d = b"".join(
            _ENTRY.pack(tag.encode("latin-1"), len(raw), zlib.crc32(raw)) for tag, raw in sections
        )
        bh = _BODY.pack(coder, b"\0\0\0", sum(len(raw) for _, raw in sections), len(stored))
    crc = zlib.crc32(stored, zlib.crc32(bh, zlib.crc32(d)))
    return b"".join([head, d, bh, _CRC.pack(crc), stored])


#: Bytes of a file's start that :func:`header_flags` needs (any version).
HEAD_BYTES = _HEADER.size + _CRC.size


def header_flags(head: bytes) -> int | None:
    """The content flags a container's first :data:`HEAD_BYTES` bytes (or
    fewer, for a short file) declare, None where they are not a header this
    reader knows: the header CRC is checked before 2.13, which has none (the
    file's one CRC is checked by :func:`unpack`)."""
    if len(head) < 7 or head[:4] != MAGIC:
        return None
    major, minor = head[4], head[5]
    if major != 1 and (major, minor) not in VERSIONS:
        return None
    if revision(major, minor) >= SHORT:
        return head[6] & ~FLAG_MASK
    if (
        len(head) < HEAD_BYTES
        or zlib.crc32(head[: _HEADER.size]) != _CRC.unpack_from(head, _HEADER.size)[0]
    ):
        return None
    return int(_HEADER.unpack_from(head)[3])


def unpack(data: bytes) -> Container:
    """Parse and check container bytes; decompress the body and split it into sections.

    Every declared length is checked against the bytes that remain (or against
    ``MAX_RAW``) before anything is read or inflated.  Any minor version of
    ``MAJOR`` is accepted here; what a section holds is checked by
    :mod:`nurbscomp.serialize`.

    Raises
    ------
    FormatError
        A subclass naming what is wrong, with the byte offset.
    """
    if len(data) < 4 or data[:4] != MAGIC:
        raise BadMagicError("not a .nzc container (bad magic at offset 0)")
    if len(data) < 6:
        raise TruncatedError(f"header truncated at offset {len(data)}")
    major, minor = data[4], data[5]
    if major != 1 and (major, minor) not in VERSIONS:
        raise VersionError(
            f"format version {major}.{minor} is not supported (this reads 1.x and "
            f"{MAJOR}.0 to {MAJOR}.{MINOR}) at offset 4"
        )
    rev = revision(major, minor)
    if rev >= SHORT:
        return _unpack_short(data, major, minor)
    if len(data) < _HEADER.size + 4:
        raise TruncatedError(f"header truncated at offset {len(data)}")
    magic, major, minor, flags, nsec, reserved = _HEADER.unpack_from(data, 0)
    (crc,) = _CRC.unpack_from(data, _HEADER.size)
    if crc != zlib.crc32(data[: _HEADER.size]):
        raise ChecksumError("header checksum mismatch at offset 12")
    known = _KNOWN_FLAGS[rev]
    if flags & ~known:
        raise ReservedBitsError(f"reserved flag bits 0x{flags & ~known:04x} set at offset 6")
    if reserved:
        raise ReservedBitsError("reserved header field is not zero at offset 10")
    pos = _HEADER.size + 4
    if rev >= COMPACT:
        return _unpack_compact(data, major, minor, flags, nsec)
    dir_end = pos + nsec * _ENTRY.size
    body_at = dir_end
    if body_at + _BODY.size + 4 > len(data):
        raise TruncatedError(f"directory or body header truncated at offset {len(data)}")
    coder, res, raw_len, stored_len = _BODY.unpack_from(data, body_at)
    (crc,) = _CRC.unpack_from(data, body_at + _BODY.size)
    start = body_at + _BODY.size + 4
    if stored_len > len(data) - start:
        raise TruncatedError(
            f"body at offset {start} declares {stored_len} bytes, {len(data) - start} remain"
        )
    if start + stored_len != len(data):
        raise TrailingDataError(
            f"{len(data) - start - stored_len} unexpected bytes at offset {start + stored_len}"
        )
    stored = data[start:]
    d = data[pos:dir_end]
    if crc != zlib.crc32(stored, zlib.crc32(data[body_at : body_at + _BODY.size], zlib.crc32(d))):
        raise ChecksumError(
            f"body checksum mismatch (directory at offset {pos}, body at {body_at})"
        )
    if res != b"\0\0\0":
        raise ReservedBitsError(f"reserved body bytes are set at offset {body_at + 1}")
    if raw_len > MAX_RAW:
        raise LimitError(
            f"body at offset {body_at} declares {raw_len} bytes, more than the {MAX_RAW} "
            "a reader inflates"
        )
    entries = [_ENTRY.unpack_from(data, pos + i * _ENTRY.size) for i in range(nsec)]
    if sum(e[1] for e in entries) != raw_len:
        raise CorruptError(f"section lengths do not add up to the body length at offset {body_at}")
    tags: list[str] = []
    for i, (tb, _, _) in enumerate(entries):
        at = pos + i * _ENTRY.size
        try:
            tag = tb.decode("ascii")
        except UnicodeDecodeError:
            raise CorruptError(f"bad section tag at offset {at}") from None
        if tag in tags:
            raise CorruptError(f"section {tag} appears twice (entry at offset {at})")
        tags.append(tag)
    _check_coder(coder, major, minor)
    body = entropy.decompress(coder, stored, raw_len)
    sections = []
    at = 0
    for i, ((_, n, scrc), tag) in enumerate(zip(entries, tags)):
        raw = body[at : at + n]
        at += n
        if zlib.crc32(raw) != scrc:
            raise ChecksumError(
                f"section {tag} checksum mismatch (entry at offset {pos + i * _ENTRY.size})"
            )
        sections.append(Section(tag, raw))
    return Container(major, minor, flags, coder, stored_len, sections, start)


def _check_coder(coder: int, major: int, minor: int) -> None:
    """Refuse a dictionary coder in a file older than the version defining it."""
    since = CODER_SINCE.get(coder)
    if since is not None and revision(major, minor) < VERSIONS.index(since):
        raise CorruptError(f"unknown coder id {coder} in a {major}.{minor} file")


def _unpack_compact(data: bytes, major: int, minor: int, flags: int, nsec: int) -> Container:
    """:func:`unpack` of a 2.6 file from its directory on (docs/format.md §1.2, §1.3)."""
    pos = at = _HEADER.size + 4
    entries: list[tuple[str, int]] = []
    seen: set[str] = set()
    raw_len = 0
    for _ in range(nsec):
        entry = at
        tag, at = _tag_at(data, at)
        n, at = read_varint(data, at)
        if tag in seen:
            raise CorruptError(f"section {tag} appears twice (entry at offset {entry})")
        seen.add(tag)
        entries.append((tag, n))
        raw_len += n
    body_at = at
    start = body_at + _BODY6.size + 4
    if start > len(data):
        raise TruncatedError(f"directory or body header truncated at offset {len(data)}")
    coder, raw_crc = _BODY6.unpack_from(data, body_at)
    (crc,) = _CRC.unpack_from(data, body_at + _BODY6.size)
    stored = data[start:]
    head = data[body_at : body_at + _BODY6.size]
    if crc != zlib.crc32(stored, zlib.crc32(head, zlib.crc32(data[pos:body_at]))):
        raise ChecksumError(
            f"body checksum mismatch (directory at offset {pos}, body at {body_at})"
        )
    body = _inflate(coder, stored, raw_len, (major, minor), pos)
    if zlib.crc32(body) != raw_crc:
        raise ChecksumError(f"decoded body checksum mismatch (body at offset {body_at})")
    return Container(major, minor, flags, coder, len(stored), _split(body, entries), start)


def _inflate(coder: int, stored: bytes, raw_len: int, version: tuple[int, int], at: int) -> bytes:
    """The decoded body of a 2.6 or later file whose directory, at offset
    ``at``, declares ``raw_len`` bytes: the limit and the coder checked first."""
    if raw_len > MAX_RAW:
        raise LimitError(
            f"directory at offset {at} declares {raw_len} bytes, more than the {MAX_RAW} "
            "a reader inflates"
        )
    _check_coder(coder, *version)
    return entropy.decompress(coder, stored, raw_len)


def _split(body: bytes, entries: list[tuple[str, int]]) -> list[Section]:
    """The sections of ``entries`` (tag, length), in order, cut from ``body``."""
    sections, k = [], 0
    for tag, n in entries:
        sections.append(Section(tag, body[k : k + n]))
        k += n
    return sections


def _tag_at(data: bytes, at: int) -> tuple[str, int]:
    """The tag 2.6's directory names at ``at`` (a code, or the escape and 4
    ASCII bytes), and the offset after it."""
    if at >= len(data):
        raise TruncatedError(f"directory truncated at offset {len(data)}")
    code = data[at]
    if code == TAG_ESCAPE:
        if at + 5 > len(data):
            raise TruncatedError(f"directory truncated at offset {len(data)}")
        try:
            return data[at + 1 : at + 5].decode("ascii"), at + 5
        except UnicodeDecodeError:
            raise CorruptError(f"bad section tag at offset {at + 1}") from None
    if code < len(TAGS):
        return TAGS[code], at + 1
    raise CorruptError(f"unknown section tag code {code} at offset {at}")


def _unpack_short(data: bytes, major: int, minor: int) -> Container:
    """:func:`unpack` of a 2.13 file from its flags on (docs/format.md §1.1–1.3)."""
    if len(data) < 7:
        raise TruncatedError(f"header truncated at offset {len(data)}")
    flags, at = data[6], 7
    tags: list[str] = []
    if flags & FLAG_MASK:
        if at + _MASK.size > len(data):
            raise TruncatedError(f"directory truncated at offset {len(data)}")
        (mask,) = _MASK.unpack_from(data, at)
        at += _MASK.size
        tags = [t for k, t in enumerate(TAGS) if mask >> k & 1]
    else:
        mask = 0
        nsec, at = read_varint(data, at)
        if nsec > len(data) - at:  # a name is a byte at least
            raise TruncatedError(f"directory of {nsec} sections truncated at offset {len(data)}")
        for _ in range(nsec):
            entry = at
            tag, at = _tag_at(data, at)
            if tag in tags:
                raise CorruptError(f"section {tag} appears twice (entry at offset {entry})")
            tags.append(tag)
    lengths = []
    for _ in tags:
        n, at = read_varint(data, at)
        lengths.append(n)
    start = at + 1 + _CRC.size
    if start > len(data):
        raise TruncatedError(f"directory or body header truncated at offset {len(data)}")
    coder = data[at]
    (crc,) = _CRC.unpack_from(data, at + 1)
    stored = data[start:]
    if crc != zlib.crc32(stored, zlib.crc32(data[: at + 1])):
        raise ChecksumError(f"checksum mismatch (body header at offset {at})")
    known = _KNOWN_FLAGS[revision(major, minor)] | FLAG_MASK
    if flags & ~known:
        raise ReservedBitsError(f"reserved flag bits 0x{flags & ~known:02x} set at offset 6")
    if mask & ~_MASK_BITS:
        raise ReservedBitsError("reserved directory bit 15 set at offset 7")
    body = _inflate(coder, stored, sum(lengths), (major, minor), 7)
    sections = _split(body, list(zip(tags, lengths)))
    return Container(major, minor, flags & ~FLAG_MASK, coder, len(stored), sections, start)
