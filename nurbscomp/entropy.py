"""The entropy stage: bytes <-> compressed bytes, choosing the best coder per block.

Each section of a container is compressed on its own by every coder below, and
the smallest result is kept; its id goes into the section header.  Measured on
the corpus (docs/benchmarks.md), raw LZMA2 wins on most geometry sections and
zstd or brotli on a few small ones, so all three stay.
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
    LZMA = 1  # raw LZMA2 stream (no .xz container), preset 9e, any literal settings
    ZSTD = 2  # zstd frame, level 19
    BROTLI = 3  # brotli, quality 11


#: Largest zstd window a reader accepts (level 19 uses 8 MiB at most).
_ZSTD_MAX_WINDOW = 1 << 25
_LZMA_FILTERS = [{"id": lzma.FILTER_LZMA2, "preset": 9 | lzma.PRESET_EXTREME}]
#: Literal-context settings (lc, lp, pb) the LZMA encoder tries besides the
#: default (3, 0, 2), keeping the smallest stream.  An LZMA2 stream carries its
#: settings in its chunk headers, so the decoder needs nothing more.  Binary
#: tables like fewer literal context bits: on the corpus's tolerance-mode
#: containers, 0.2-2% smaller.
LZMA_TUNINGS = (
    (0, 0, 0),
    (0, 0, 2),
    (0, 0, 3),
    (1, 0, 0),
    (1, 0, 2),
    (0, 2, 2),
    (0, 3, 2),
    (1, 3, 2),
)


def _lzma(raw: bytes) -> bytes:
    """The smallest raw LZMA2 stream of ``raw`` over the default and ``LZMA_TUNINGS``."""
    outs = [lzma.compress(raw, format=lzma.FORMAT_RAW, filters=_LZMA_FILTERS)]
    # the encoder needs no dictionary larger than its input (less memory to clear)
    size = min(1 << 26, max(1 << 16, 1 << max(len(raw) - 1, 1).bit_length()))
    for lc, lp, pb in LZMA_TUNINGS:
        f = {"id": lzma.FILTER_LZMA2, "preset": 9 | lzma.PRESET_EXTREME, "dict_size": size}
        f.update(lc=lc, lp=lp, pb=pb)
        outs.append(lzma.compress(raw, format=lzma.FORMAT_RAW, filters=[f]))
    return min(outs, key=len)


def _compress(coder: Coder, raw: bytes) -> bytes:
    if coder == Coder.STORED:
        return raw
    if coder == Coder.LZMA:
        return _lzma(raw)
    if coder == Coder.ZSTD:
        return zstandard.ZstdCompressor(level=19, write_content_size=False).compress(raw)
    return brotli.compress(raw, quality=11)


def compress(raw: bytes, coders: tuple[Coder, ...] = tuple(Coder)) -> tuple[Coder, bytes]:
    """Compress ``raw`` with each coder and keep the smallest (ties go to the lower id)."""
    best = min(((len(out := _compress(c, raw)), c, out) for c in coders), key=lambda t: t[:2])
    return best[1], best[2]


def decompress(coder: int, data: bytes, raw_length: int) -> bytes:
    """Invert :func:`compress`, producing at most ``raw_length`` bytes.

    Every coder is run with a bounded output (a decompression bomb cannot
    inflate past the declared length): LZMA with ``max_length``, zstd through
    a stream reader read in bounded pieces, brotli with ``output_buffer_limit``.
    One byte more than ``raw_length`` is asked for, so that data that would
    inflate further is refused rather than cut.

    Raises
    ------
    CorruptError
        Unknown coder, undecodable data, or a length other than ``raw_length``.
    """
    limit = raw_length + 1
    try:
        if coder == Coder.STORED:
            out = data
        elif coder == Coder.LZMA:
            d = lzma.LZMADecompressor(format=lzma.FORMAT_RAW, filters=_LZMA_FILTERS)
            out = d.decompress(data, max_length=limit)
        elif coder == Coder.ZSTD:
            out = _zstd_bounded(data, limit)
        elif coder == Coder.BROTLI:
            out = _brotli_bounded(data, limit)
        else:
            raise CorruptError(f"unknown coder id {coder}")
    except CorruptError:
        raise
    except (lzma.LZMAError, zstandard.ZstdError, brotli.error, EOFError) as e:
        raise CorruptError(f"compressed data does not decode ({e})") from None
    if len(out) != raw_length:
        raise CorruptError(f"body decodes to {len(out)} bytes, header says {raw_length}")
    return out


def _zstd_bounded(data: bytes, limit: int) -> bytes:
    """At most ``limit`` bytes of a zstd frame (the frame's own size field is not trusted)."""
    dctx = zstandard.ZstdDecompressor(max_window_size=_ZSTD_MAX_WINDOW)
    reader = dctx.stream_reader(data, read_across_frames=False)
    parts, got = [], 0
    while got < limit:
        chunk = reader.read(min(limit - got, 1 << 20))
        if not chunk:
            break
        parts.append(chunk)
        got += len(chunk)
    return b"".join(parts)


def _brotli_bounded(data: bytes, limit: int) -> bytes:
    """At most ``limit`` bytes of a brotli stream; an unfinished stream is an error."""
    d = brotli.Decompressor()
    out = d.process(data, output_buffer_limit=limit)
    if len(out) < limit and not d.is_finished():
        raise CorruptError("compressed data ends early")
    return out[:limit]
