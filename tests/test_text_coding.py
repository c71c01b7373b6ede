"""The text models' stream layer (nurbscomp.text.coding): varints in bulk."""

from __future__ import annotations

import random

import pytest

from nurbscomp.errors import CorruptError, TruncatedError
from nurbscomp.text import coding


def _one_by_one(data: bytes, pos: int, n: int) -> tuple[list[int], int]:
    out = []
    for _ in range(n):
        v, pos = coding.read_varint(data, pos)
        out.append(v)
    return out, pos


def test_read_varints_reads_what_varint_writes():
    vals = [0, 1, 127, 128, 300, 2**20, 2**56 - 1, 2**56, 2**62, 2**63 - 1]
    data = b"\x07" + b"".join(coding.varint(v) for v in vals) + b"tail"
    got, pos = coding.read_varints(data, 1, len(vals))
    assert got.tolist() == vals and data[pos:] == b"tail"
    assert coding.read_varints(data, 3, 0)[0].tolist() == []
    assert coding.read_varints(data, 3, 0)[1] == 3


def test_read_varints_raises_as_read_varint():
    with pytest.raises(TruncatedError):
        coding.read_varints(b"\x01\x81", 0, 2)  # ends inside the second
    with pytest.raises(TruncatedError):
        coding.read_varints(b"\x01\x02", 0, 3)  # ends before the third
    with pytest.raises(TruncatedError):
        coding.read_varints(b"\x01", 1, 1)
    with pytest.raises(CorruptError):
        coding.read_varints(b"\x01" + b"\x80" * 9 + b"\x01", 0, 2)  # 10 bytes
    with pytest.raises(CorruptError):
        coding.read_varints(b"\x80" * 40, 0, 2)  # runs on past 9 bytes
    with pytest.raises(CorruptError):
        coding.read_varints(b"\x80" * 9 + b"\x00\x05", 0, 2)  # the first is too long


def test_read_varints_matches_read_varint_on_damaged_streams():
    rng = random.Random(5)
    for _ in range(3000):
        vals = [rng.randrange(2 ** rng.randrange(1, 64)) for _ in range(rng.randrange(6))]
        data = bytearray(b"".join(coding.varint(v) for v in vals))
        for _ in range(rng.randrange(3) if data else 0):
            data[rng.randrange(len(data))] = rng.choice([0x00, 0x7F, 0x80, 0xFF])
        if rng.random() < 0.3:
            data = data[: rng.randrange(len(data) + 1)]
        if rng.random() < 0.2:
            data += b"\x80" * rng.randrange(12)
        pos, n = rng.randrange(min(3, len(data) + 1)), rng.randrange(8)
        try:
            want: tuple[object, ...] = _one_by_one(bytes(data), pos, n)
        except (TruncatedError, CorruptError) as e:
            want = (type(e), str(e))
        try:
            v, end = coding.read_varints(bytes(data), pos, n)
            got: tuple[object, ...] = (v.tolist(), end)
        except (TruncatedError, CorruptError) as e:
            got = (type(e), str(e))
        assert got == want


def test_inflate_is_entropy_decompress():
    """An LZMA stream inflated with a dictionary of its own size (what
    entropy.decompress does) gives what preset 9's 64 MiB dictionary gives
    (bytes, or CorruptError), damaged or not."""
    import lzma

    from nurbscomp.entropy import Coder, decompress

    def preset9(coder: int, data: bytes, n: int) -> bytes:
        filters = [{"id": lzma.FILTER_LZMA2, "preset": 9 | lzma.PRESET_EXTREME}]
        try:
            d = lzma.LZMADecompressor(format=lzma.FORMAT_RAW, filters=filters)
            out = d.decompress(data, max_length=n + 1)
        except (lzma.LZMAError, EOFError):
            raise CorruptError("does not decode") from None
        if len(out) != n:
            raise CorruptError("length")
        return out

    rng = random.Random(8)
    raws = [b"", b"a", bytes(range(256)) * 40, rng.randbytes(3000), b"ab" * 5000]
    for _ in range(400):
        raw = rng.choice(raws)
        blob = bytearray(coding.quick_lzma(raw) if raw else coding._lzma(b"x", 0, 0, 0))
        for _ in range(rng.randrange(3)):
            blob[rng.randrange(len(blob))] = rng.randrange(256)
        if rng.random() < 0.2:
            blob = blob[: rng.randrange(len(blob) + 1)]
        n = len(raw) + rng.choice([0, 0, 0, -1, 1, 100])
        outcome = []
        for f in (preset9, decompress):
            try:
                outcome.append(f(Coder.LZMA, bytes(blob), max(n, 0)))
            except CorruptError as e:
                outcome.append(type(e))
        assert outcome[0] == outcome[1]
