"""Byte-exact models of STEP and IGES text (issue 29).

``encode(data)`` gives a blob from which ``decode(blob, limit)`` returns
``data`` byte for byte.  The blob's first byte says how it was made:

* 0 plain: the whole file through :mod:`.coding` as one stream;
* 1 the STEP model (:mod:`.step`);
* 2 the IGES model (:mod:`.iges`).

The encoder tries the model that fits the text, decodes its own output to make
sure it gives the same bytes back, and keeps the smaller of the model and the
plain stream: raw LZMA2 at preset 9e, what ``xz -9e`` codes less its framing,
so a blob is never larger than ``xz -9e`` of the file.

Coding the plain stream costs what ``xz -9e`` costs, several times the model
on large files.  So on a file over twice the sample's size it is first
estimated from :data:`SAMPLE_PIECES` evenly spaced pieces of the file (a
smaller file is coded whole: the estimate would cost as much), and made in
full only if the model is not below :data:`SKIP_BELOW` of that estimate.
Pieces lose the history the whole file has, so the estimate is high: on the
corpus the whole file codes to 0.72–1.0 of it, so a model under 0.6 of the
estimate is under 0.83 of the plain stream even at the worst of those (the
corpus's models are at 0.5–0.77 of their plain streams).
Nothing here needs OpenCASCADE: this reads text.
"""

from __future__ import annotations

from ..entropy import Coder
from ..errors import CorruptError
from . import coding

PLAIN, STEP, IGES = 0, 1, 2


def _models() -> dict[int, object]:
    from . import iges, step  # noqa: F401  (imported here: a plain blob needs neither)

    return {STEP: step, IGES: iges}


def _plain(data: bytes) -> bytes:
    """Method 0: one raw LZMA2 stream at preset 9e (``coding.quick_lzma``)."""
    return bytes([PLAIN]) + coding.pack_coded([(Coder.LZMA, data, coding.quick_lzma(data))])


#: The plain stream is estimated on this many pieces of a file ...
SAMPLE_PIECES = 8
#: ... of this many bytes each (a file up to twice their size is coded whole).
SAMPLE_PIECE = 32 * 1024
#: A model below this fraction of the plain stream's estimate is kept without
#: coding the plain stream in full (module docstring).
SKIP_BELOW = 0.6


def _plain_estimate(data: bytes) -> tuple[float, bytes | None]:
    """The plain stream's size, estimated, and the plain blob itself where the
    file is small enough to be coded whole."""
    n, k = len(data), SAMPLE_PIECES * SAMPLE_PIECE
    if n <= 2 * k:
        blob = _plain(data)
        return len(blob), blob
    last = SAMPLE_PIECES - 1
    starts = [i * (n - SAMPLE_PIECE) // last for i in range(SAMPLE_PIECES)]
    sample = b"".join(data[a : a + SAMPLE_PIECE] for a in starts)
    return len(coding.quick_lzma(sample)) * n / len(sample), None


def encode(data: bytes) -> bytes:
    """The smallest blob that gives ``data`` back (module docstring)."""
    estimate, plain = _plain_estimate(data)
    blobs = sorted(_model_blobs(data), key=len)
    if plain is None and not (blobs and len(blobs[0]) <= SKIP_BELOW * estimate):
        plain = _plain(data)
    return min([*blobs, *([plain] if plain is not None else [])], key=len)


def _model_blobs(data: bytes) -> list[bytes]:
    """The blobs of the models that fit ``data`` and give it back."""
    out = []
    for method, model in _models().items():
        payload = model.encode(data)  # type: ignore[attr-defined]
        if payload is None:
            continue
        if model.decode(payload, len(data)) != data:  # type: ignore[attr-defined]
            continue  # never a wrong byte: the plain stream is kept
        out.append(bytes([method]) + payload)
    return out


def decode(blob: bytes, limit: int) -> bytes:
    """The bytes ``blob`` was made from; at most ``limit`` of them.

    Raises
    ------
    FormatError
        A blob :func:`encode` does not write, or one that inflates past ``limit``.
    """
    if not blob:
        raise CorruptError("empty text model")
    method = blob[0]
    if method == PLAIN:
        return coding.unpack(blob[1:], limit, count=1)[0]
    model = _models().get(method)
    if model is None:
        raise CorruptError(f"unknown text model {method}")
    out = model.decode(blob[1:], limit)  # type: ignore[attr-defined]
    assert isinstance(out, bytes)
    return out
