"""The entropy stage: bytes <-> compressed bytes, choosing the best coder per block.

Each section of a container is compressed on its own by every coder below, and
the smallest result is kept; its id goes into the section header.  Measured on
the corpus (docs/benchmarks.md), raw LZMA2 wins on most geometry sections and
zstd or brotli on a few small ones, so all three stay.
"""

from __future__ import annotations

import lzma
import os
from concurrent.futures import ThreadPoolExecutor
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
#: tables like fewer literal context bits: 0.2-2% smaller than the default on
#: the corpus; each of these won on some corpus container (lossless or 0.01 mm).
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


def _lzma_raw(raw: bytes, tuning: tuple[int, int, int] | None) -> bytes:
    """One raw LZMA2 stream (preset 9e), with the default literal settings or ``tuning``."""
    if tuning is None:
        return lzma.compress(raw, format=lzma.FORMAT_RAW, filters=_LZMA_FILTERS)
    # the encoder needs no dictionary larger than its input (less memory to clear)
    size = min(1 << 26, max(1 << 16, 1 << max(len(raw) - 1, 1).bit_length()))
    lc, lp, pb = tuning
    f = {"id": lzma.FILTER_LZMA2, "preset": 9 | lzma.PRESET_EXTREME, "dict_size": size}
    f.update(lc=lc, lp=lp, pb=pb)
    return lzma.compress(raw, format=lzma.FORMAT_RAW, filters=[f])


def _jobs(coder: Coder) -> list[tuple[Coder, tuple[int, int, int] | None]]:
    """The streams tried for one coder: LZMA's one per literal setting."""
    if coder == Coder.LZMA:
        return [(coder, None), *((coder, t) for t in LZMA_TUNINGS)]
    return [(coder, None)]


def _compress(coder: Coder, raw: bytes, tuning: tuple[int, int, int] | None = None) -> bytes:
    """One coder's stream of ``raw`` (LZMA with the literal settings ``tuning``)."""
    if coder == Coder.STORED:
        return raw
    if coder == Coder.LZMA:
        return _lzma_raw(raw, tuning)
    if coder == Coder.ZSTD:
        return zstandard.ZstdCompressor(level=19, write_content_size=False).compress(raw)
    return brotli.compress(raw, quality=11)


def compress(raw: bytes, coders: tuple[Coder, ...] = tuple(Coder)) -> tuple[Coder, bytes]:
    """Compress ``raw`` with each coder and keep the smallest (ties go to the lower id).

    The streams are made in a thread pool (the coders release the GIL), one
    thread per core: on two cores this halves the stage's wall time.
    """
    jobs = [j for c in coders for j in _jobs(c)]
    workers = max(1, min(len(jobs), os.cpu_count() or 1))
    if workers == 1 or len(raw) < 4096:
        outs = [_compress(c, raw, t) for c, t in jobs]
    else:
        with ThreadPoolExecutor(workers) as pool:  # the slowest (brotli) first
            outs = list(pool.map(lambda j: _compress(j[0], raw, j[1]), jobs[::-1]))[::-1]
    best = min(range(len(jobs)), key=lambda i: (len(outs[i]), jobs[i][0], i))
    return jobs[best][0], outs[best]


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
