"""The entropy stage: bytes <-> compressed bytes, choosing the best coder per block.

Each section of a container is compressed on its own by every coder below, and
the smallest result is kept; its id goes into the section header.  Measured on
the corpus (docs/benchmarks.md), raw LZMA2 wins on most geometry sections and
zstd or brotli on a few small ones, so all three stay.  LZMA with fewer literal
context bits (``LZMA_TUNED``, its settings in a first byte) wins on most
tolerance-mode containers by 0.2-2%.
"""

from __future__ import annotations

import lzma
from enum import IntEnum

import brotli
import zstandard

from .errors import CorruptError


class Coder(IntEnum):
    """Coder ids stored in section headers.  Never renumber."""

    STORED = 0
    LZMA = 1  # raw LZMA2 stream (no .xz container), preset 9e
    ZSTD = 2  # zstd frame, level 19
    BROTLI = 3  # brotli, quality 11
    LZMA_TUNED = 4  # one byte (pb·5 + lp)·9 + lc, then raw LZMA2, preset 9e with those


_LZMA_FILTERS = [{"id": lzma.FILTER_LZMA2, "preset": 9 | lzma.PRESET_EXTREME}]
#: (lc, lp, pb) settings LZMA_TUNED tries besides LZMA's (3, 0, 2).  Literal
#: context bits matter on binary tables: on the corpus, (0, 3, 2) or (1, 0, 2)
#: are up to 2% smaller than the default.
_TUNINGS = ((0, 0, 0), (0, 0, 2), (0, 0, 3), (1, 0, 0), (1, 0, 2), (0, 2, 2), (0, 3, 2), (1, 3, 2))


def _lzma_filters(lc: int, lp: int, pb: int, size: int = 1 << 26) -> list[dict[str, int]]:
    """LZMA2 filters, preset 9e with these literal settings; a dictionary of
    ``size`` bytes (the encoder needs no more than its input: less memory to
    clear; the decoder keeps preset 9e's 64 MiB, which reads any of them)."""
    return [
        {
            "id": lzma.FILTER_LZMA2,
            "preset": 9 | lzma.PRESET_EXTREME,
            "lc": lc,
            "lp": lp,
            "pb": pb,
            "dict_size": size,
        }
    ]


def _props(byte: int) -> tuple[int, int, int]:
    """(lc, lp, pb) of an LZMA properties byte; CorruptError outside LZMA2's range."""
    lc, rest = byte % 9, byte // 9
    lp, pb = rest % 5, rest // 5
    if pb > 4 or lc + lp > 4:
        raise CorruptError(f"bad LZMA properties byte {byte}")
    return lc, lp, pb


def _compress(coder: Coder, raw: bytes) -> bytes:
    if coder == Coder.STORED:
        return raw
    if coder == Coder.LZMA:
        return lzma.compress(raw, format=lzma.FORMAT_RAW, filters=_LZMA_FILTERS)
    if coder == Coder.ZSTD:
        return zstandard.ZstdCompressor(level=19, write_content_size=False).compress(raw)
    if coder == Coder.LZMA_TUNED:
        size = min(1 << 26, max(1 << 16, 1 << max(len(raw) - 1, 1).bit_length()))
        outs = [
            bytes([(pb * 5 + lp) * 9 + lc])
            + lzma.compress(raw, format=lzma.FORMAT_RAW, filters=_lzma_filters(lc, lp, pb, size))
            for lc, lp, pb in _TUNINGS
        ]
        return min(outs, key=len)
    return brotli.compress(raw, quality=11)


def compress(raw: bytes, coders: tuple[Coder, ...] = tuple(Coder)) -> tuple[Coder, bytes]:
    """Compress ``raw`` with each coder and keep the smallest (ties go to the lower id)."""
    best = min(((len(out := _compress(c, raw)), c, out) for c in coders), key=lambda t: t[:2])
    return best[1], best[2]


def decompress(coder: int, data: bytes, raw_length: int) -> bytes:
    """Invert :func:`compress`, producing at most ``raw_length`` bytes.

    Raises
    ------
    CorruptError
        Unknown coder, undecodable data, or a length other than ``raw_length``.
    """
    try:
        if coder == Coder.STORED:
            out = data
        elif coder == Coder.LZMA:
            d = lzma.LZMADecompressor(format=lzma.FORMAT_RAW, filters=_LZMA_FILTERS)
            out = d.decompress(data, max_length=raw_length + 1)
        elif coder == Coder.ZSTD:
            dz = zstandard.ZstdDecompressor().decompressobj()
            out = dz.decompress(data)
        elif coder == Coder.BROTLI:
            out = brotli.decompress(data)
        elif coder == Coder.LZMA_TUNED:
            if not data:
                raise CorruptError("LZMA properties byte missing")
            d = lzma.LZMADecompressor(
                format=lzma.FORMAT_RAW, filters=_lzma_filters(*_props(data[0]))
            )
            out = d.decompress(data[1:], max_length=raw_length + 1)
        else:
            raise CorruptError(f"unknown coder id {coder}")
    except CorruptError:
        raise
    except (lzma.LZMAError, zstandard.ZstdError, brotli.error, EOFError) as e:
        raise CorruptError(f"compressed data does not decode ({e})") from None
    if len(out) != raw_length:
        raise CorruptError(f"section decodes to {len(out)} bytes, header says {raw_length}")
    return out
