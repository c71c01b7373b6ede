"""§1 (header, directory, body) and §2.1 (arrays) of docs/format.md."""

from __future__ import annotations

import json
import lzma
import struct
import zlib
from pathlib import Path

import numpy as np

MAGIC = b"\x89NZC"
#: (major, minor) -> revision (§0)
REVISION = {
    (1, 0): 0,
    (1, 1): 1,
    (1, 2): 2,
    (2, 0): 3,
    (2, 1): 4,
    (2, 2): 5,
    (2, 3): 6,
    (2, 4): 7,
    (2, 5): 8,
    (2, 6): 9,
    (2, 7): 10,
    (2, 8): 11,
    (2, 9): 12,
    (2, 10): 13,
    (2, 11): 14,
    (2, 12): 15,
    (2, 13): 16,
    (2, 14): 17,
    (2, 15): 18,
    (2, 16): 19,
    (2, 17): 20,
    (2, 18): 21,
    (2, 19): 22,
}
#: §1.2 (2.6): the tags of the directory's one-byte codes
TAGS = "META LOCS SURF SNET CRV3 CNET CRV2 SHAP VERT EDGE FACE SIDE PROD FILE TEXT".split()
#: §2.12 (2.6): the binary META's key and string tables
META_KEYS = (
    "mode source_bytes source_format source_name step_pcurves tolerance_mm unit writer sha256 "
    "model reason decoded rows references depth poles bases step_bytes iges_bytes"
).split()
META_WORDS = (
    "tolerance lossless exact passthrough STEP IGES MM CM M KM UM INCH FT MI MIL UIN plain step "
    "iges"
).split()


#: §1.3 (2.4): the dictionary of coder 4, a file of the format
DICTIONARY = Path(__file__).resolve().parents[2] / "nurbscomp" / "data" / "nzc-2.4.dict"
#: §1.3 (2.11): the dictionary of coder 5
DICTIONARY_11 = DICTIONARY.with_name("nzc-2.11.dict")
DICTIONARY_12 = DICTIONARY.with_name("nzc-2.12.dict")
DICTIONARY_13 = DICTIONARY.with_name("nzc-2.13.dict")
DICTIONARY_19 = DICTIONARY.with_name("nzc-2.19.dict")


class ReadError(Exception):
    """Anything this reader refuses."""


def _inflate(coder: int, payload: bytes, raw_length: int, revision: int) -> bytes:
    if coder == 0:
        out = payload
    elif coder == 1:
        filt = [{"id": lzma.FILTER_LZMA2, "preset": 9 | lzma.PRESET_EXTREME}]
        out = lzma.LZMADecompressor(lzma.FORMAT_RAW, filters=filt).decompress(
            payload, max_length=raw_length + 1
        )
    elif coder == 2:
        import zstandard

        reader = zstandard.ZstdDecompressor().stream_reader(payload)
        out = reader.read(raw_length + 1)
    elif coder == 3:
        import brotli

        out = brotli.decompress(payload)
    elif (
        (coder == 4 and revision >= 7)
        or (coder == 5 and revision >= 14)
        or (coder == 6 and revision >= 15)
        or (coder == 7 and revision >= 16)
        or (coder == 8 and revision >= 22)
    ):
        import zstandard  # §1.3 (2.4, 2.11–2.13, 2.19): zstd with the format's dictionary

        path = {
            4: DICTIONARY,
            5: DICTIONARY_11,
            6: DICTIONARY_12,
            7: DICTIONARY_13,
            8: DICTIONARY_19,
        }[coder]
        d = zstandard.ZstdCompressionDict(path.read_bytes())
        reader = zstandard.ZstdDecompressor(dict_data=d).stream_reader(payload)
        out = reader.read(raw_length + 1)
    else:
        raise ReadError(f"unknown coder {coder}")
    if len(out) != raw_length:
        raise ReadError("body length")
    return out


def leb128(data: bytes, pos: int) -> tuple[int, int]:
    """§1.2: a varint, at most 9 bytes; the value and the position after it."""
    value = 0
    for i in range(9):
        if pos + i >= len(data):
            raise ReadError("varint cut")
        value |= (data[pos + i] & 127) << (7 * i)
        if data[pos + i] < 128:
            return value, pos + i + 1
    raise ReadError("varint of more than 9 bytes")


class BinaryMeta:
    """§2.12: META in binary."""

    def __init__(self, raw: bytes, revision: int) -> None:
        self.raw, self.pos, self.revision = raw, 1, revision

    def u8(self) -> int:
        if self.pos >= len(self.raw):
            raise ReadError("META cut")
        self.pos += 1
        return self.raw[self.pos - 1]

    def n(self) -> int:
        v, self.pos = leb128(self.raw, self.pos)
        return v

    def blob(self, k: int) -> bytes:
        if self.pos + k > len(self.raw):
            raise ReadError("META length")
        self.pos += k
        return self.raw[self.pos - k : self.pos]

    def string(self) -> str:
        return self.blob(self.n()).decode("utf-8")

    def obj(self, depth: int) -> dict:
        out = {}
        for _ in range(self.n()):
            code = self.u8()
            key = self.string() if code == 255 else META_KEYS[code]
            if key in out:
                raise ReadError("META key twice")
            kind = self.u8()
            if kind <= 2:
                value = (None, False, True)[kind]
            elif kind == 3:
                z = self.n()
                value = -(z + 1) // 2 if z % 2 else z // 2
            elif kind == 4:
                (value,) = struct.unpack("<d", self.blob(8))
            elif kind == 5:
                value = self.string()
            elif kind == 6:
                value = META_WORDS[self.u8()]
            elif kind == 7:
                value = self.blob(self.n()).hex()
            elif kind == 8 and depth == 0:
                value = self.obj(1)
            elif kind == 9 and self.revision >= 16:  # 2.13: m·10^e
                m, e = (-(z + 1) // 2 if z % 2 else z // 2 for z in (self.n(), self.n()))
                if abs(m) >= 2**53 or abs(e) > 22:
                    raise ReadError("META decimal")
                value = m * 10.0**e if e >= 0 else m / 10.0 ** (-e)
            else:
                raise ReadError(f"META value type {kind}")
            out[key] = value
        return out


def read_meta(raw: bytes, revision: int) -> dict:
    """§2 and §2.12: META as JSON, or from 2.6 in binary."""
    if revision >= 9 and raw[:1] == b"\x01":
        b = BinaryMeta(raw, revision)
        meta = b.obj(0)
        if b.pos != len(raw):
            raise ReadError("bytes after META")
        return meta
    return json.loads(raw.decode("utf-8"))


class Container:
    """The header's fields and the sections' bytes by tag (§1.1–1.3)."""

    def __init__(self, data: bytes) -> None:
        if len(data) < 6 or data[:4] != MAGIC:
            raise ReadError("bad magic")
        self.sections: dict[str, bytes] = {}
        self.order: list[str] = []
        if REVISION.get((data[4], data[5]), 0) >= 16:
            self._short(data)
            return
        if len(data) < 16:
            raise ReadError("header")
        self.major, self.minor, self.flags, nsec, reserved = struct.unpack_from("<BBHHH", data, 4)
        (crc,) = struct.unpack_from("<I", data, 12)
        if crc != zlib.crc32(data[:12]) or reserved:
            raise ReadError("header")
        if (self.major, self.minor) not in REVISION:
            raise ReadError(f"version {self.major}.{self.minor}")
        self.revision = REVISION[(self.major, self.minor)]
        if self.revision >= 9:
            self._compact(data, nsec)
            return
        pos = 16
        directory = []
        for _ in range(nsec):
            tag, length, scrc = struct.unpack_from("<4sII", data, pos)
            directory.append((tag.decode("ascii"), length, scrc))
            pos += 12
        coder, res, raw_length, stored_length, body_crc = struct.unpack_from("<B3sIII", data, pos)
        if res != b"\0\0\0":
            raise ReadError("reserved body bytes")
        payload = data[pos + 16 :]
        if len(payload) != stored_length:
            raise ReadError("payload length")
        crc = zlib.crc32(
            data[pos + 16 :], zlib.crc32(data[pos : pos + 12], zlib.crc32(data[16:pos]))
        )
        if crc != body_crc:
            raise ReadError("body crc")
        if raw_length != sum(d[1] for d in directory):
            raise ReadError("raw length")
        body = _inflate(coder, payload, raw_length, self.revision)
        at = 0
        for tag, length, scrc in directory:
            raw = body[at : at + length]
            at += length
            if zlib.crc32(raw) != scrc:
                raise ReadError(f"section {tag} crc")
            if tag in self.sections:
                raise ReadError(f"section {tag} twice")
            self.sections[tag] = raw
            self.order.append(tag)

    def _compact(self, data: bytes, nsec: int) -> None:
        """§1.2 and §1.3 from 2.6: codes and varints, one CRC of the decoded body."""
        pos = 16
        directory = []
        for _ in range(nsec):
            code = data[pos]
            pos += 1
            if code == 255:
                tag = data[pos : pos + 4].decode("ascii")
                pos += 4
            else:
                tag = TAGS[code]
            length, pos = leb128(data, pos)
            directory.append((tag, length))
        coder, raw_crc, body_crc = struct.unpack_from("<BII", data, pos)
        payload = data[pos + 9 :]
        if (
            zlib.crc32(payload, zlib.crc32(data[pos : pos + 5], zlib.crc32(data[16:pos])))
            != body_crc
        ):
            raise ReadError("body crc")
        body = _inflate(coder, payload, sum(n for _, n in directory), self.revision)
        if zlib.crc32(body) != raw_crc:
            raise ReadError("decoded body crc")
        at = 0
        for tag, length in directory:
            if tag in self.sections:
                raise ReadError(f"section {tag} twice")
            self.sections[tag] = body[at : at + length]
            self.order.append(tag)
            at += length

    def _short(self, data: bytes) -> None:
        """§1.1–1.3 from 2.13: a flags byte, a mask of TAGS (flag 8) or a count
        and codes, varint lengths, the coder, one CRC of all other bytes."""
        self.major, self.minor, flags = data[4], data[5], data[6]
        self.revision = REVISION[(self.major, self.minor)]
        self.flags = flags & ~8
        pos = 7
        if flags & 8:
            (mask,) = struct.unpack_from("<H", data, pos)
            pos += 2
            tags = [TAGS[k] for k in range(15) if mask & (1 << k)]
            if mask & 0x8000:
                raise ReadError("mask bit 15")
        else:
            count, pos = leb128(data, pos)
            tags = []
            for _ in range(count):
                if data[pos] == 255:
                    tags.append(data[pos + 1 : pos + 5].decode("ascii"))
                    pos += 5
                else:
                    tags.append(TAGS[data[pos]])
                    pos += 1
        lengths = []
        for _ in tags:
            n, pos = leb128(data, pos)
            lengths.append(n)
        coder = data[pos]
        (crc,) = struct.unpack_from("<I", data, pos + 1)
        payload = data[pos + 5 :]
        if zlib.crc32(payload, zlib.crc32(data[: pos + 1])) != crc:
            raise ReadError("crc")
        if self.flags & ~7:
            raise ReadError("reserved flags")
        body = _inflate(coder, payload, sum(lengths), self.revision)
        at = 0
        for tag, n in zip(tags, lengths):
            if tag in self.sections:
                raise ReadError(f"section {tag} twice")
            self.sections[tag] = body[at : at + n]
            self.order.append(tag)
            at += n

    @property
    def lossless(self) -> bool:
        return bool(self.flags & 1)

    @property
    def has_model(self) -> bool:
        return not self.flags & 6

    def meta(self) -> dict:
        return read_meta(self.sections["META"], self.revision)


class Arrays:
    """A section read as a sequence of arrays (§2.1)."""

    def __init__(self, raw: bytes, tag: str = "", pos: int = 0) -> None:
        self.raw, self.pos, self.tag = raw, pos, tag

    @property
    def remaining(self) -> int:
        return len(self.raw) - self.pos

    def _header(self) -> tuple[int, int, int]:
        if self.remaining < 6:
            raise ReadError(f"{self.tag}: array header at {self.pos}")
        kind, width, count = struct.unpack_from("<BBI", self.raw, self.pos)
        if width not in (1, 2, 4, 8) or kind not in (0, 1) or (kind == 1 and width != 8):
            raise ReadError(f"{self.tag}: bad array header at {self.pos}")
        if count * width > self.remaining - 6:
            raise ReadError(f"{self.tag}: array past the section at {self.pos}")
        return kind, width, count

    def ints(self) -> np.ndarray:
        kind, width, count = self._header()
        if kind != 0:
            raise ReadError(f"{self.tag}: integers expected at {self.pos}")
        start = self.pos + 6
        planes = np.frombuffer(self.raw, np.uint8, count * width, start).reshape(width, count)
        self.pos = start + count * width
        u = np.zeros(count, np.uint64)
        for b in range(width):
            u |= planes[b].astype(np.uint64) << np.uint64(8 * b)
        # zig-zag: 0, -1, 1, -2 ... -> 0, 1, 2, 3 ...
        half = (u >> np.uint64(1)).astype(np.int64)
        neg = (u & np.uint64(1)).astype(bool)
        return np.where(neg, -half - 1, half).astype(np.int64)

    def next_kind(self) -> str:
        """ "int" or "float": the kind of the next array (§2.1)."""
        return "int" if self._header()[0] == 0 else "float"

    def floats(self) -> np.ndarray:
        kind, width, count = self._header()
        if kind != 1:
            raise ReadError(f"{self.tag}: floats expected at {self.pos}")
        start = self.pos + 6
        self.pos = start + 8 * count
        return np.frombuffer(self.raw, "<f8", count, start).astype(float)

    def deltas(self) -> np.ndarray:
        """``D[n]``: entry k is the sum of the first k + 1 stored integers."""
        return np.cumsum(self.ints()).astype(np.int64)

    def end(self) -> None:
        if self.remaining:
            raise ReadError(f"{self.tag}: {self.remaining} bytes left over")


class Take:
    """Values taken one after another from the front of an array."""

    def __init__(self, values: np.ndarray, name: str = "") -> None:
        self.values, self.at, self.name = values, 0, name

    def __call__(self, k: int | None = None):
        if k is None:
            if self.at >= len(self.values):
                raise ReadError(f"{self.name} runs out")
            self.at += 1
            return self.values[self.at - 1].item()
        if self.at + k > len(self.values):
            raise ReadError(f"{self.name} runs out")
        self.at += k
        return self.values[self.at - k : self.at]

    def end(self) -> None:
        if self.at != len(self.values):
            raise ReadError(f"{self.name}: {len(self.values) - self.at} values left over")
