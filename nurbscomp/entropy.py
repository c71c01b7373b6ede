"""The entropy stage: bytes <-> compressed bytes, choosing the best coder per body.

A container's body is compressed by several coders and the smallest result is
kept; its id goes into the body header.  Measured on the corpus
(docs/benchmarks.md), raw LZMA2 wins on most containers and brotli on a few
small ones, so both stay, and zstd costs next to nothing.  Format 2.4 adds
zstd with a dictionary the format fixes (:data:`DICT_PATH`), for small
bodies: on 130 generated parts it won on 123 containers, 19% smaller in all
(they are of the kinds the dictionary was trained on; on 105 of kinds it
was not, 6%); on the corpus, only on its smallest container.

Trying every stream at full strength cost more than OCCT's whole STEP read on
the larger files (NIST_MBE_PMI_2 at 0.01 mm: 2.8 s of CPU for nine LZMA 9e
streams, brotli 11 and zstd 19), so the choice is made cheaply first:

* the LZMA literal settings are ranked by a fast LZMA pass (preset 2) and only
  the best :data:`LZMA_FINALISTS` are run at preset 9e;
* brotli 11, the slowest coder (1.5 µs a byte), is tried on bodies up to
  :data:`BROTLI_MAX` bytes only.  In format 2.13 it won on 20 of 940
  containers of generated parts, all of bodies under 56 kB, and lost by
  1.3–9 % on every corpus body over 40 kB at 0.001, 0.01 and 0.1 mm (it had
  been tried up to 256 kB: 0.28 s and 0.37 s a pack on NIST_MBE_PMI_2 and
  trj7, packed more than once while the validity stage weighs its choices).

On the corpus's 22 containers (lossless and 0.01 mm) the stage took 7.5 s
instead of 30.7 s (wall, two threads, a loaded machine); 17 came out the same
size, and the total grew by 1,199 bytes (0.09%), 31 of them at 0.01 mm.

A *quick* search (``thorough=False``, what ``--lossless`` asks for) does less
on bodies over :data:`QUICK_MAX`: the LZMA settings are ranked on a sample of
the body (:func:`_sample`), only the best one is run, at preset
:data:`QUICK_PRESET` rather than 9e, and zstd and brotli are not tried.  A
lossless body is mostly exact doubles, where the coders differ least, and
lossless is the mode meant to be fast.  On the corpus's 11 lossless
containers, ranking on samples took the stage from 4.4 s to 1.6 s (wall, one
process) for 3 bytes more in all; one finalist at preset 6 instead of two at
9e then took its CPU time from 1.78 s to 0.96 s for 1,315 bytes more in all
(0.12%).  On these bodies preset 6 codes as small as 9e (one finalist each:
1,058,108 against 1,058,304 bytes) in two thirds of the time; the second
finalist is what the bytes paid for.
"""

from __future__ import annotations

import functools
import hashlib
import lzma
import os
import threading
from concurrent.futures import ThreadPoolExecutor
from enum import IntEnum
from pathlib import Path

import brotli
import zstandard

from .errors import CorruptError


class Coder(IntEnum):
    """Coder ids stored in section headers.  Never renumber."""

    STORED = 0
    LZMA = 1  # raw LZMA2 stream (no .xz container), preset 9e, any literal settings
    ZSTD = 2  # zstd frame, level 19
    BROTLI = 3  # brotli, quality 11
    ZSTD_DICT = 4  # (format 2.4) zstd frame, level 19, with the format's dictionary
    ZSTD_DICT_11 = 5  # (format 2.11) zstd frame, level 19, with format 2.11's dictionary
    ZSTD_DICT_12 = 6  # (format 2.12) zstd frame, level 19, with format 2.12's dictionary
    ZSTD_DICT_13 = 7  # (format 2.13) zstd frame, level 19, with format 2.13's dictionary
    ZSTD_DICT_19 = 8  # (format 2.19) zstd frame, level 19, with format 2.19's dictionary


#: Format 2.4's zstd dictionary (coder 4, docs/format.md §1.3): 64 KiB that
#: zstd's trainer took from the bodies of containers of generated parts
#: (``benchmarks/train_dictionary.py``).  What containers share (META's keys,
#: array headers, common values) then costs a small body next to nothing: on
#: 105 generated files of kinds it was not trained on, 6% less in all.
DICT_PATH = Path(__file__).resolve().parent / "data" / "nzc-2.4.dict"
DICT_SHA256 = "30e3c3d0ad34adc918eaee5b4d660937e579efe9615552e845b2faa883dec582"
#: Format 2.11's zstd dictionary (coder 5): made the same way from the
#: containers of 2.11 (``EDGE`` by prediction changed what small containers
#: share; with coder 4, 39 of 77 generated parts came out up to 16 bytes
#: larger than in 2.10).  On 44 generated parts of the stress corpus that it
#: was not made from, 3.3 % smaller than with coder 4.
DICT_11_PATH = Path(__file__).resolve().parent / "data" / "nzc-2.11.dict"
DICT_11_SHA256 = "e1097dd6ba27c2344260f99380c18549178eeac37663c7cc7dc22b89636b583f"
#: Format 2.12's zstd dictionary (coder 6): made the same way from the
#: containers of 2.12 (its knot forms and multiplicities changed what small
#: containers share; with coder 5, generated parts the 2.11 dictionary was
#: made from came out up to 216 bytes larger than in 2.11).
DICT_12_PATH = Path(__file__).resolve().parent / "data" / "nzc-2.12.dict"
DICT_12_SHA256 = "0eeb1e99cb3c0ddc555df2f3c7e0b4e756dd482b5deed095f8a40e1b7b6ee6c6"
#: Format 2.13's zstd dictionary (coder 7): made the same way from the
#: containers of 2.13 at 0.01 and at 0.1 mm (coder 6's, made at 0.01 mm only,
#: held 0.01 mm's containers: 37 of 77 generated parts came out larger at
#: 0.1 mm than at 0.01 mm).
DICT_13_PATH = Path(__file__).resolve().parent / "data" / "nzc-2.13.dict"
DICT_13_SHA256 = "307e36e2a324d629761fae2420806785d273294625a8c1532274f103aedbc708"
#: Format 2.19's zstd dictionary (coder 8): made the same way as coder 7's,
#: at 0.01 and 0.1 mm, from the containers of 2.19 (``SHAP`` mode 2 changed
#: what small containers share: with coder 7, a one-face part's container
#: grew 281 -> 302 bytes, its shorter stream no longer one the dictionary
#: held).
DICT_19_PATH = Path(__file__).resolve().parent / "data" / "nzc-2.19.dict"
DICT_19_SHA256 = "e307da4ab7b6a2afea66ae6ab72c2cf9af6c08cc0abed82c7ced5234e869cac0"
#: Largest body the dictionary coders are tried on: past it the dictionary's share
#: is small (on the corpus coder 4 won on one container, of a 38 kB body).
DICT_MAX = 128 * 1024


#: The dictionary coders: per coder, its dictionary's file, SHA-256 and the
#: format version that defines it (``container`` refuses it in older files).
DICTIONARIES = {
    Coder.ZSTD_DICT: (DICT_PATH, DICT_SHA256, (2, 4)),
    Coder.ZSTD_DICT_11: (DICT_11_PATH, DICT_11_SHA256, (2, 11)),
    Coder.ZSTD_DICT_12: (DICT_12_PATH, DICT_12_SHA256, (2, 12)),
    Coder.ZSTD_DICT_13: (DICT_13_PATH, DICT_13_SHA256, (2, 13)),
    Coder.ZSTD_DICT_19: (DICT_19_PATH, DICT_19_SHA256, (2, 19)),
}


@functools.cache
def dictionary(coder: int = Coder.ZSTD_DICT) -> zstandard.ZstdCompressionDict:
    """The dictionary of coder 4 (format 2.4's), 5 (2.11's), 6 (2.12's) or 7 (2.13's),
    checked against its SHA-256."""
    path, sha, (major, minor) = DICTIONARIES[Coder(coder)]
    raw = path.read_bytes()
    if hashlib.sha256(raw).hexdigest() != sha:
        raise RuntimeError(
            f"{path} is not format {major}.{minor}'s dictionary (reinstall nurbscomp)"
        )
    return zstandard.ZstdCompressionDict(raw, dict_type=zstandard.DICT_TYPE_FULLDICT)


#: Largest zstd window a reader accepts (level 19 uses 8 MiB at most).
_ZSTD_MAX_WINDOW = 1 << 25
_PRESET = 9 | lzma.PRESET_EXTREME
_LZMA_FILTERS = [{"id": lzma.FILTER_LZMA2, "preset": _PRESET}]
#: Literal-context settings (lc, lp, pb) the LZMA encoder tries besides the
#: default (3, 0, 2), keeping the smallest stream.  An LZMA2 stream carries its
#: settings in its chunk headers, so the decoder needs nothing more.  Binary
#: tables like fewer literal context bits: 0.2-2% smaller than the default on
#: the corpus; each of these won on some corpus container (lossless or 0.01 mm).
#: The last three (more literal context, no position bits) won on 2.13's
#: boxed_sphere and ec_turbine (-21 and -121 bytes at 0.01 mm) and on two
#: IGES files by a few bytes.
LZMA_TUNINGS = (
    (0, 0, 0),
    (0, 0, 2),
    (0, 0, 3),
    (1, 0, 0),
    (1, 0, 2),
    (0, 2, 2),
    (0, 3, 2),
    (1, 3, 2),
    (2, 0, 0),
    (3, 0, 0),
    (4, 0, 0),
)


def lzma_size(raw: bytes, strong: bool = False) -> int:
    """Bytes of ``raw`` as one raw LZMA2 stream, LZMA2's default preset (or,
    ``strong``, 9e with a 1 MiB dictionary): what the writer and the encoder
    weigh one array's alternatives by (weights rounded or not, on a grid or
    as floats; knots rounded or not)."""
    preset, cap = (_PRESET, 1 << 20) if strong else (6, _PRESET_DICT[6])
    f = {"id": lzma.FILTER_LZMA2, "preset": preset, "dict_size": dict_size(raw, cap)}
    return len(lzma.compress(raw, format=lzma.FORMAT_RAW, filters=[f]))


#: The dictionaries of the presets used here (xz's table): 8 MiB for 6,
#: 64 MiB for 9 and 9e.
_PRESET_DICT = {6: 1 << 23, _PRESET: 1 << 26}


def dict_size(raw: bytes, cap: int = _PRESET_DICT[_PRESET]) -> int:
    """An LZMA dictionary no larger than ``raw`` needs, and no larger than
    ``cap`` (the dictionary of the preset it replaces: 9e's 64 MiB by
    default).  The stream is the same, byte for byte, as with the preset's
    own (no match reaches further back than the input; checked on 683
    bodies, the corpus containers' among them), but a 64 MiB dictionary
    costs some 50 ms a call to set up, an 8 MiB one (preset 6) some 2 to
    10 ms: more than compressing a small part's arrays takes."""
    return min(cap, max(1 << 16, 1 << max(len(raw) - 1, 1).bit_length()))


def xz_size(raw: bytes, preset: int = 6) -> int:
    """``len(lzma.compress(raw, preset=preset))`` (.xz; preset 6 or 9e), with
    :func:`dict_size`'s dictionary: the same length (an .xz header says its
    dictionary in one byte either way)."""
    size = dict_size(raw, _PRESET_DICT[preset])
    f = {"id": lzma.FILTER_LZMA2, "preset": preset, "dict_size": size}
    return len(lzma.compress(raw, filters=[f]))


def lzma_raw(raw: bytes, tuning: tuple[int, int, int] | None, preset: int = _PRESET) -> bytes:
    """One raw LZMA2 stream (``preset``, 9e by default), with the default literal
    settings or ``tuning``.  Any preset decodes with :data:`_LZMA_FILTERS`: its
    dictionary is no larger than 9e's."""
    f = {"id": lzma.FILTER_LZMA2, "preset": preset, "dict_size": dict_size(raw)}
    if tuning is None:
        return lzma.compress(raw, format=lzma.FORMAT_RAW, filters=[f])
    lc, lp, pb = tuning
    f.update(lc=lc, lp=lp, pb=pb)
    return lzma.compress(raw, format=lzma.FORMAT_RAW, filters=[f])


#: LZMA literal settings run at full strength, after the fast ranking.
LZMA_FINALISTS = 2
#: Largest body brotli is tried on.
BROTLI_MAX = 64 * 1024
#: Largest body each coder with a limit is tried on (in a search with more than one).
_LARGEST = {Coder.BROTLI: BROTLI_MAX, **{c: DICT_MAX for c in DICTIONARIES}}
#: Bodies up to this size get every stream at full strength (cheap there).
FULL_SEARCH_MAX = 16 * 1024
#: A quick search treats bodies up to this size as a thorough one does.
QUICK_MAX = 64 * 1024
#: The LZMA preset of a quick search's one finalist.
QUICK_PRESET = 6
#: A quick search ranks the LZMA settings on this many pieces of the body ...
SAMPLE_PIECES = 4
#: ... of this many bytes each, evenly spaced (8 kB: the ranking took 0.32 s
#: of the stage's 0.96 s on the corpus's lossless bodies with 16 kB pieces,
#: 0.16 s with these, and chose streams 108 bytes smaller in all).
SAMPLE_PIECE = 8 * 1024


def _sample(raw: bytes) -> bytes:
    """:data:`SAMPLE_PIECES` evenly spaced pieces of ``raw``, joined, the first
    at its start and the last at its end (all of ``raw`` when it is no longer
    than they are)."""
    n, k = len(raw), SAMPLE_PIECES * SAMPLE_PIECE
    if n <= k:
        return raw
    last = SAMPLE_PIECES - 1
    starts = [i * (n - SAMPLE_PIECE) // last for i in range(SAMPLE_PIECES)]
    return b"".join(raw[a : a + SAMPLE_PIECE] for a in starts)


def _lzma_rank(raw: bytes) -> list[tuple[int, int, int] | None]:
    """LZMA literal settings, best first by a fast pass (preset 2) over ``raw``."""
    sizes = []
    for i, t in enumerate((None, *LZMA_TUNINGS)):
        f: dict[str, int] = {"id": lzma.FILTER_LZMA2, "preset": 2}
        if t is not None:
            f.update(lc=t[0], lp=t[1], pb=t[2])
        sizes.append((len(lzma.compress(raw, format=lzma.FORMAT_RAW, filters=[f])), i, t))
    return [t for _, _, t in sorted(sizes, key=lambda x: (x[0], x[1]))]


def _quick(raw: bytes, thorough: bool) -> bool:
    """Whether ``raw`` gets the quick search (module docstring)."""
    return not thorough and len(raw) > QUICK_MAX


def _jobs(
    coders: tuple[Coder, ...], raw: bytes, thorough: bool = True
) -> list[tuple[Coder, tuple[int, int, int] | None]]:
    """The streams tried on ``raw``: LZMA's finalists (every setting for a
    small body), zstd, and brotli on bodies up to :data:`BROTLI_MAX`; a quick
    search on a body over :data:`QUICK_MAX` ranks on a sample and tries one
    LZMA stream only (module docstring)."""
    full = len(raw) <= FULL_SEARCH_MAX
    quick = _quick(raw, thorough)
    out: list[tuple[Coder, tuple[int, int, int] | None]] = []
    for c in coders:
        if c == Coder.LZMA:
            if full:
                tunings = [None, *LZMA_TUNINGS]
            elif quick:
                tunings = _lzma_rank(_sample(raw))[:1]
            else:
                tunings = _lzma_rank(raw)[:LZMA_FINALISTS]
            out += [(c, t) for t in tunings]
        elif len(coders) == 1 or (not quick and len(raw) <= _LARGEST.get(c, len(raw))):
            out.append((c, None))
    return out


#: zstd compressors not in use, by coder (a compressor serves one thread at
#: a time; the entropy stage's threads are new at every call).
_ZSTD_FREE: dict[Coder, list[zstandard.ZstdCompressor]] = {}
_ZSTD_LOCK = threading.Lock()


def _zstd(coder: Coder, raw: bytes) -> bytes:
    """``raw`` through zstd level 19 (coder 2), or with the format's
    dictionary (coders 4 to 7), with a compressor made once and reused: a new
    one per call loaded its dictionary every time (3.9 ms a call against
    1.2 ms reused), for the same frames (checked on 358 bodies, every
    coder)."""
    with _ZSTD_LOCK:
        free = _ZSTD_FREE.setdefault(coder, [])
        z = free.pop() if free else None
    if z is None:
        if coder == Coder.ZSTD:
            z = zstandard.ZstdCompressor(level=19, write_content_size=False)
        else:
            z = zstandard.ZstdCompressor(
                level=19,
                dict_data=dictionary(coder),
                write_content_size=False,
                write_dict_id=False,
            )
    try:
        return z.compress(raw)
    finally:
        with _ZSTD_LOCK:
            free.append(z)


def _compress(
    coder: Coder, raw: bytes, tuning: tuple[int, int, int] | None = None, preset: int = _PRESET
) -> bytes:
    """One coder's stream of ``raw`` (LZMA with the literal settings ``tuning``
    at ``preset``)."""
    if coder == Coder.STORED:
        return raw
    if coder == Coder.LZMA:
        return lzma_raw(raw, tuning, preset)
    if coder == Coder.ZSTD or coder in DICTIONARIES:
        return _zstd(coder, raw)
    return brotli.compress(raw, quality=11)


def compress(
    raw: bytes, coders: tuple[Coder, ...] = tuple(Coder), thorough: bool = True
) -> tuple[Coder, bytes]:
    """Compress ``raw`` with each of ``coders`` (module docstring: which streams,
    and what a search that is not ``thorough`` leaves out) and keep the
    smallest (ties go to the lower id, then the earlier stream).

    The streams are made in a thread pool (the coders release the GIL), one
    thread per core.
    """
    jobs = _jobs(coders, raw, thorough)
    preset = QUICK_PRESET if _quick(raw, thorough) else _PRESET
    workers = max(1, min(len(jobs), os.cpu_count() or 1))
    if workers == 1 or len(raw) < 4096:
        outs = [_compress(c, raw, t, preset) for c, t in jobs]
    else:
        with ThreadPoolExecutor(workers) as pool:  # the slowest (brotli) first
            outs = list(pool.map(lambda j: _compress(j[0], raw, j[1], preset), jobs[::-1]))[::-1]
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
            d = lzma.LZMADecompressor(format=lzma.FORMAT_RAW, filters=_lzma_decoder(limit))
            out = d.decompress(data, max_length=limit)
        elif coder == Coder.ZSTD:
            out = _zstd_bounded(data, limit)
        elif coder in DICTIONARIES:
            out = _zstd_bounded(data, limit, dictionary(coder))
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


#: The dictionary of preset 9, the largest any writer's LZMA stream uses.
_LZMA_DICT = 1 << 26


def _lzma_decoder(limit: int) -> list[dict[str, int]]:
    """Filters that decode any LZMA stream of at most ``limit`` bytes: the
    preset-9e filter with a dictionary no larger than the output (no match
    reaches further back than the bytes decoded, so the output and the
    errors are the same as with preset 9's 64 MiB, which costs a tenth of a
    millisecond and more to set up; the text models' streams are many and small)."""
    return [{**_LZMA_FILTERS[0], "dict_size": min(max(limit, 4096), _LZMA_DICT)}]


def _zstd_bounded(
    data: bytes, limit: int, dict_data: zstandard.ZstdCompressionDict | None = None
) -> bytes:
    """At most ``limit`` bytes of a zstd frame (the frame's own size field is not trusted)."""
    dctx = zstandard.ZstdDecompressor(dict_data=dict_data, max_window_size=_ZSTD_MAX_WINDOW)
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
