"""Numbers coded as numbers in the STEP text model (nurbscomp.text.numbers)."""

from __future__ import annotations

import hashlib
import lzma
import random
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from nurbscomp import text
from nurbscomp.errors import CorruptError
from nurbscomp.text import coding, numbers

TRICKY = [
    b"0.",
    b"-0.",
    b"+0.",
    b"-0.0",
    b"15.",
    b"1.50000000000000E+01",
    b"1.5E1",
    b"1.5e-007",
    b"007.10",
    b"7",
    b"-7",
    b"+7",
    b"0.5000000000000009992",
    b"1.E-0",
    b"2.E+000",
    b"3E5",
    b"-1.0E-300",
    b"9.99999999999999E+307",
    b"123456789012345678",
    b"0.000000000000000001",
    b"61.70512107362",
    b"5.932870935608E-14",
    b"62.",
    b"59.5",
    b"-4.",
    b"1.",
    b"10.",
    b"100.",
]


def _round(texts: list[bytes]) -> list[bytes]:
    pair = numbers.encode(texts)
    assert pair is not None
    return numbers.decode(*pair, len(texts))


def test_tricky_texts_come_back_as_written():
    texts = TRICKY * 3
    assert _round(texts) == texts
    rng = random.Random(5)
    for _ in range(20):
        sample = rng.choices(TRICKY, k=rng.randint(1, 80))
        assert _round(sample) == sample


def test_what_it_does_not_code():
    """Texts past its limits are refused (the stream stays text), never coded wrong."""
    for bad in (b"1" * 41, b"9" * 20, b"1.E1000", b"1.E0000000001", b"abc", b"1..2", b"", b".5"):
        assert numbers.encode([b"1.", bad]) is None
    assert numbers.encode([]) is None
    # 2**63 - 1 is the largest value it codes
    assert _round([b"9223372036854775807", b"-9223372036854775807", b"0.5"]) == [
        b"9223372036854775807",
        b"-9223372036854775807",
        b"0.5",
    ]
    assert numbers.encode([b"9223372036854775808"]) is None


_SIGN = st.sampled_from([b"", b"+", b"-"])
_DIGITS = st.text("0123456789", min_size=1, max_size=19).map(str.encode)
_FRAC = st.one_of(st.none(), st.text("0123456789", max_size=19).map(str.encode))
_EXP = st.one_of(
    st.none(),
    st.tuples(
        st.sampled_from([b"E", b"e"]),
        st.sampled_from([b"", b"+", b"-"]),
        st.integers(0, 400),
        st.integers(1, 4),
    ),
)


@st.composite
def _number(draw: st.DrawFn) -> bytes:
    t = draw(_SIGN) + draw(_DIGITS)
    frac = draw(_FRAC)
    if frac is not None:
        t += b"." + frac
    e = draw(_EXP)
    if e is not None:
        letter, sign, mag, width = e
        t += letter + sign + b"%0*d" % (width, mag)
    return t


@settings(max_examples=300, deadline=None)
@given(st.lists(_number(), min_size=1, max_size=60))
def test_any_number_texts_come_back_or_stay_text(texts: list[bytes]):
    pair = numbers.encode(texts)
    if pair is None:  # only past the documented limits
        assert any(
            int(t.lstrip(b"+-").split(b"e")[0].split(b"E")[0].replace(b".", b"") or b"0")
            >= numbers.M_LIMIT
            for t in texts
        )
        return
    assert numbers.decode(*pair, len(texts)) == texts


def _smooth(n: int, seed: int) -> list[bytes]:
    """A pole row's coordinates as a CAD writer prints them: a smooth curve,
    13 significant digits, trailing zeros dropped."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 1.0, n)
    x = 40.0 + 25.0 * np.sin(3.0 * t + rng.uniform()) + 3.0 * t**2
    return [(b"%.13G" % v).rstrip(b"0") if b"." in b"%.13G" % v else b"%.13G." % v for v in x]


def test_a_smooth_row_codes_smaller_than_its_text():
    """Second differences of a smooth row are small: coded as numbers it takes
    well under its text through LZMA (the predictor pays)."""
    texts = _smooth(4000, 1)
    assert _round(texts) == texts
    fmt, res = numbers.encode(texts)  # type: ignore[misc]
    as_text = len(lzma.compress(b",".join(texts), preset=9))
    as_numbers = len(lzma.compress(fmt, preset=9)) + len(lzma.compress(res, preset=9))
    assert as_numbers < 0.8 * as_text
    assert fmt[0] == 2  # second differences
    r = coding.read_int_stream(res, len(texts), "residuals")
    assert np.abs(r[2:]).max() < np.abs(r[:2]).max() / 1000


def test_exceptions_finer_than_the_grid():
    """Numbers finer than the stream's grid (noise near zero among coordinates
    of 12 decimals) come back exactly, predicted from the last regular one."""
    texts = _smooth(300, 2)
    rng = random.Random(3)
    for k in range(0, 300, 7):
        texts[k] = b"%.12E" % (rng.uniform(-1, 1) * 1e-14)
    texts[5] = b"1234567890123456.5"  # too long for the grid
    assert _round(texts) == texts


def test_damaged_streams_raise_format_errors():
    """Flipped bytes and truncations of either stream raise CorruptError (or
    decode to other texts, which the STEP model's CRC refuses), nothing else."""
    texts = _smooth(200, 4) + TRICKY
    fmt, res = numbers.encode(texts)  # type: ignore[misc]
    rng = random.Random(9)
    for _ in range(400):
        f, r = bytearray(fmt), bytearray(res)
        target = f if rng.random() < 0.5 else r
        if rng.random() < 0.2:
            del target[rng.randrange(len(target)) :]
        else:
            for _ in range(rng.randint(1, 3)):
                target[rng.randrange(len(target))] = rng.randrange(256)
        try:
            out = numbers.decode(bytes(f), bytes(r), len(texts))
        except CorruptError:
            continue
        assert len(out) == len(texts)
    with pytest.raises(CorruptError):
        numbers.decode(fmt, res, len(texts) + 1)


#: A STEP model payload of version 4 written on 2026-12-03 by ``text.encode``
#: of ``tests.fuzz_text._smooth_points(1050)`` (1,050 poles; x, y and z coded as
#: numbers): the text it must give back, forever.
GOLDEN = Path(__file__).resolve().parent / "golden" / "text" / "poles.step.v4.blob"
GOLDEN_SHA256 = "94c221e059d0c07c37e17052a9ca30af3b429af35b6df6439f6b6401f3832502"


def test_a_version_4_payload_still_decodes():
    blob = GOLDEN.read_bytes()
    assert blob[0] == text.STEP
    streams = coding.unpack(blob[1:], 10**6)
    head, pos = [], 0
    while pos < len(streams[0]):
        v, pos = coding.read_varint(streams[0], pos)
        head.append(v)
    assert head[0] == 4 and head[-3:] == [1, 1, 1]  # x, y, z as numbers
    out = text.decode(blob, 79524)
    assert hashlib.sha256(out).hexdigest() == GOLDEN_SHA256
