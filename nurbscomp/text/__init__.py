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

Coding the plain stream costs what ``xz -9e`` costs, more than the model.
So it is made only where the model might lose to it: the file is first coded
with LZMA2 preset 1 (a tenth of 9e's time), and a model no larger than
:data:`PLAIN_FLOOR` of that is kept without the plain stream.  On the corpus
``xz -9e`` codes a file to 0.73-0.83 of preset 1, so a model under 0.7 of
preset 1 is below ``xz -9e`` of the file there; the corpus's models are at
0.40-0.63 of it.  This is a measured bound, not a proved one: a file that 9e
codes to less than 0.7 of preset 1 and whose model lands between the two
would keep a model larger than ``xz -9e`` of it (by at most that margin).
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


#: A model at most this fraction of the file's LZMA2 preset 1 size is kept
#: without coding the plain stream (module docstring).
PLAIN_FLOOR = 0.7


def encode(data: bytes) -> bytes:
    """The smallest blob that gives ``data`` back (module docstring)."""
    blobs = sorted(_model_blobs(data), key=len)
    if blobs and len(blobs[0]) <= PLAIN_FLOOR * len(coding.fast_lzma(data)):
        return blobs[0]
    return min([*blobs, _plain(data)], key=len)


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
