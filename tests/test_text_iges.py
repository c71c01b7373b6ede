"""The IGES text model (issue 29): byte-exact, smaller than xz, robust."""

from __future__ import annotations

import hashlib
import lzma
import random

import numpy as np
import pytest

from nurbscomp.errors import FormatError
from nurbscomp.text import coding, iges

from .conftest import corpus_files

IGES = [p for p in corpus_files() if p.suffix.lower() in (".igs", ".iges")]


def _xz(data: bytes) -> int:
    return len(lzma.compress(data, preset=9 | lzma.PRESET_EXTREME))


def _roundtrip(data: bytes) -> bytes | None:
    """The payload, after checking that it decodes to ``data`` exactly
    (the inner encoder, so that a bug raises here rather than becoming None)."""
    payload = iges._encode(data)
    if payload is not None:
        back = iges.decode(payload, len(data))
        assert hashlib.sha256(back).digest() == hashlib.sha256(data).digest()
    return payload


def _small_iges() -> bytes:
    """A small IGES file written here, with a custom delimiter, Hollerith
    strings, D exponents and a wrapped record."""
    g = "1H|,1H;,5HHELLO,10Hdemo.iges,32,38,6,308,15,2HMM,1,1.0D0;"
    p = [
        ("110", "110|1.0D0|-2.5E+01|0.125|3.|4.|5.5D-3;"),
        (
            "126",
            "126|1|1|0|0|1|0|0.|0.|1.|1.|1.|1.|0.123456|1.5|2.25|3.75|4.5|-6.125|0.|1.|0.|0.|1.;",
        ),
    ]
    lines = ["A test file".ljust(72) + "S0000001", g.ljust(72) + "G0000001"]
    plines: list[tuple[str, int]] = []
    for k, (_, text) in enumerate(p):
        de = 2 * k + 1
        while text:
            cut = text[:64]
            if len(text) > 64:
                cut = cut[: cut.rfind("|") + 1]
            plines.append((cut, de))
            text = text[len(cut) :]
    first = 1
    for k, (t, _) in enumerate(p):
        n = sum(1 for _, de in plines if de == 2 * k + 1)
        lines.append(
            f"{t:>8}{first:>8}{0:>8}{0:>8}{0:>8}{0:>8}{0:>8}{0:>8}00000000D{2 * k + 1:07d}"
        )
        lines.append(f"{t:>8}{0:>8}{0:>8}{n:>8}{0:>8}{'':>8}{'':>8}{'':>8}{0:>8}D{2 * k + 2:07d}")
        first += n
    for i, (t, de) in enumerate(plines):
        lines.append(f"{t:<64} {de:07d}P{i + 1:07d}")
    lines.append(f"S{1:07d}G{1:07d}D{2 * len(p):07d}P{len(plines):07d}".ljust(72) + "T0000001")
    return ("\n".join(lines) + "\n").encode()


@pytest.mark.slow
@pytest.mark.parametrize("path", IGES, ids=lambda p: p.name)
def test_corpus_byte_exact_and_smaller_than_xz(path):
    data = path.read_bytes()
    payload = _roundtrip(data)
    assert payload is not None
    assert 1.2 * len(payload) <= _xz(data), (len(payload), _xz(data))


@pytest.mark.slow
@pytest.mark.corpus
def test_corpus_total_ratio():
    total = sum(len(p.read_bytes()) and _xz(p.read_bytes()) for p in IGES)
    model = 0
    for p in IGES:
        payload = iges.encode(p.read_bytes())
        assert payload is not None
        model += len(payload)
    assert 1.6 * model <= total, (model, total)


def test_small_file_variants():
    base = _small_iges()
    variants = {
        "lf": base,
        "crlf": base.replace(b"\n", b"\r\n"),
        "no final newline": base[:-1],
        "trailing garbage": base + b"\x00\xff garbage\n\n",
        "short line": base.replace(b"A test file", b"A test file\nshort", 1),
        "spaces as seq": base.replace(b"S0000001", b"S      1"),
    }
    for name, data in variants.items():
        assert _roundtrip(data) is not None, name


def test_not_iges_gives_none():
    assert iges.encode(b"") is None
    assert iges.encode(b"ISO-10303-21;\nHEADER;\nENDSEC;\n") is None
    assert iges.encode(bytes(range(256)) * 10) is None


def _mutate(data: bytes, rng: random.Random) -> bytes:
    lines = data.split(b"\n")
    kind = rng.randrange(9)
    if kind == 0:  # bit flips
        b = bytearray(data)
        for _ in range(rng.randint(1, 8)):
            i = rng.randrange(len(b))
            b[i] ^= 1 << rng.randrange(8)
        return bytes(b)
    if kind == 1:
        return data[: rng.randrange(len(data))]
    if kind == 2:
        del lines[rng.randrange(len(lines))]
    elif kind == 3:
        i = rng.randrange(len(lines))
        lines.insert(i, lines[i])
    elif kind == 4:
        i = rng.randrange(len(data))
        return data[:i] + rng.randbytes(rng.randint(1, 200)) + data[i:]
    elif kind == 5:  # a huge number
        i = rng.randrange(len(lines))
        lines[i] = lines[i][:10] + b"9" * rng.randint(20, 3000) + b".5E+99999," + lines[i][10:]
    elif kind == 6:  # non-ASCII
        i = rng.randrange(len(lines))
        lines[i] = lines[i].replace(b",", "\u00e9".encode(), 1)
    elif kind == 7:  # wrong sequence number or back pointer
        i = rng.randrange(len(lines))
        if len(lines[i]) >= 80:
            lines[i] = lines[i][:66] + b"%06d" % rng.randrange(10**6) + lines[i][72:]
    else:  # a bad pointer in a D entry
        i = rng.randrange(len(lines))
        if len(lines[i]) >= 16:
            lines[i] = lines[i][:8] + b"%8d" % rng.randrange(-(10**6), 10**7) + lines[i][16:]
    return b"\n".join(lines)


@pytest.mark.slow
def test_mutations_byte_exact_or_none():
    rng = random.Random(29)
    sources = [_small_iges()] + [p.read_bytes()[:20000] for p in IGES]
    if IGES:
        sources.append(IGES[0].read_bytes()[:3000] + IGES[0].read_bytes()[-4000:])
    modelled = 0
    for _ in range(300):
        data = _mutate(rng.choice(sources), rng)
        for _ in range(rng.randrange(3)):
            data = _mutate(data, rng) if data else data
        if _roundtrip(data) is not None:
            modelled += 1
    assert modelled > 150  # most mutated files are still modelled, not given up


def test_damaged_payloads_raise_format_errors():
    data = _small_iges()
    payload = iges.encode(data)
    assert payload is not None
    rng = random.Random(7)
    for _ in range(300):
        b = bytearray(payload)
        kind = rng.randrange(3)
        if kind == 0:
            for _ in range(rng.randint(1, 4)):
                b[rng.randrange(len(b))] = rng.randrange(256)
        elif kind == 1:
            del b[rng.randrange(len(b)) :]
        else:
            b[rng.randrange(len(b))] ^= 1 << rng.randrange(8)
        try:
            out = iges.decode(bytes(b), len(data))
        except FormatError:
            continue
        assert len(out) <= len(data)


def test_damaged_streams_raise_format_errors():
    """Payloads whose streams decode but say wrong things (coder intact)."""
    data = _small_iges()
    streams = coding.unpack(iges.encode(data) or b"", 10**6)
    rng = random.Random(11)
    for _ in range(300):
        s = [bytearray(x) for x in streams]
        k = rng.randrange(len(s))
        if s[k] and rng.random() < 0.7:
            s[k][rng.randrange(len(s[k]))] = rng.randrange(256)
        else:
            s[k] += rng.randbytes(rng.randint(1, 9))
        try:
            out = iges.decode(coding.pack([bytes(x) for x in s], quick=True), len(data))
        except FormatError:
            continue
        assert len(out) <= len(data)


def test_limit_is_enforced():
    data = _small_iges()
    payload = iges.encode(data)
    assert payload is not None
    with pytest.raises(FormatError):
        iges.decode(payload, len(data) // 2)


@pytest.mark.parametrize("path", [p for p in IGES if "sunglasses" in p.name], ids=lambda p: p.name)
def test_second_differences_and_version_1(path):
    """Version 2 codes some surface pole lanes as second differences (lane flag
    2: the sunglasses lens's smooth nets); a version 1 payload, whose flags are
    0 or 1 only, still decodes, and flag 2 under version 1 is refused."""
    data = path.read_bytes()
    streams = coding.unpack(_roundtrip(data), 4 * len(data))
    assert streams[0][0] == 2 and b"\x02" in streams[6]
    v1 = coding.pack([b"\x01" + streams[0][1:], *streams[1:]])
    with pytest.raises(FormatError):
        iges.decode(v1, len(data))
    small = _small_iges()
    s = coding.unpack(_roundtrip(small), 4 * len(small))
    assert b"\x02" not in s[6]
    old = coding.pack([b"\x01" + s[0][1:], *s[1:]])
    assert iges.decode(old, len(small)) == small


def _tails_one_by_one(
    zero: bool, exc: dict[int, bytes], nrec: int
) -> tuple[list[bytes], list[int]]:
    """The record tails and DE numbers, record by record (what iges._tails computes)."""
    cur, tails, des = 1, [], []
    for r in range(nrec):
        t = exc.get(r)
        if t is None:
            t = (b" %07d" if zero else b" %7d") % cur
            if len(t) > 8:
                t = b" " + t[-7:]
        s = t.strip()
        val = int(s) if s.isdigit() and len(s) < 12 else cur
        tails.append(t)
        des.append(val)
        cur = val + 2
    return tails, des


def test_tails_match_the_record_by_record_rule():
    """Back pointers predicted as the previous + 2 (wrapping past 7 digits),
    with exceptions of digits, blanks and other bytes."""
    rng = random.Random(3)
    choices = [
        b" 9999997",
        b"99999999",
        b"   12345",
        b"        ",
        b" 12 34  ",
        b"  abc  1",
        b" 0000001",
    ]
    for _ in range(200):
        nrec = rng.randrange(0, 40)
        at = sorted(rng.sample(range(nrec), rng.randrange(min(nrec, 6) + 1)))
        exc = {r: rng.choice(choices) for r in at}
        zero = rng.random() < 0.5
        rows, des = iges._tails(zero, np.asarray(at, np.int64), b"".join(exc[r] for r in at), nrec)
        want_t, want_d = _tails_one_by_one(zero, exc, nrec)
        assert [bytes(r) for r in rows] == want_t and des.tolist() == want_d


def test_record_types_match_split_and_strip():
    recs = [b"128,1,2", b"  110 ,3", b"", b"12345678901,2", b"   ", b" " * 30 + b"406,1", b"7"]
    recs.append(b"\t 99 \x0b;x")
    ptext = b"\n".join(recs)
    lens = np.asarray([len(r) for r in recs], np.int64)
    end = np.cumsum(lens + 1) - 1
    got = iges._record_types(ptext, ord(","), end - lens, end)
    for row, r in zip(got, recs):
        head = r.split(b",", 1)[0].strip()
        assert bytes(row) == (b"%8s" % head if len(head) <= 8 else b" " * 8)


def _lines_one_by_one(mode, bounds, rlen, rcount, exc):
    """P line starts and lengths, line by line (what iges._lines computes)."""
    ends = np.cumsum(rlen + 1) - 1
    starts, lens, li = [], [], 0
    bl = bounds.tolist()
    for r in range(len(rlen)):
        pr, er = int(ends[r] - rlen[r]), int(ends[r])
        for _ in range(int(rcount[r])):
            w = int(exc[li]) if exc[li] >= 0 else iges._layout1(mode, bl, pr, er)
            if w < 0 or w > iges.P_WIDTH or pr + w > er:
                raise FormatError("does not fit")
            starts.append(pr)
            lens.append(w)
            pr += w
            li += 1
        if pr != er:
            raise FormatError("does not cover")
    return starts, lens


def test_lines_match_the_line_by_line_layout():
    """Records of every length (long ones go by pointer doubling), parameters
    longer than a line, layout exceptions and wrong line counts."""
    rng = random.Random(4)
    for _ in range(300):
        recs = []
        for _ in range(rng.randrange(1, 40)):
            n = rng.choice([rng.randrange(80), rng.randrange(600), rng.randrange(3000)])
            dense = rng.random() * 0.3
            recs.append(
                bytes(
                    rng.choice(b",;") if rng.random() < dense else rng.choice(b"0123456789.E-")
                    for _ in range(n)
                )
            )
        ptext = b"\n".join(recs)
        mode = rng.randrange(2)
        bounds = iges._bounds(ptext, ord(","), ord(";"))
        rlen = np.array([len(r) for r in recs], np.int64)
        ends = np.cumsum(rlen + 1) - 1
        rcount = []
        bl = bounds.tolist()
        for r in range(len(recs)):
            s, e, c = int(ends[r] - rlen[r]), int(ends[r]), 0
            while (w := iges._layout1(mode, bl, s, e)) >= 0:
                s, c = s + w, c + 1
            rcount.append(max(c, 1))
        rc = np.array(rcount, np.int64)
        if rng.random() < 0.3:
            i = rng.randrange(len(rc))
            rc[i] = max(1, rc[i] + rng.choice([-1, 1, 2]))
        exc = np.full(int(rc.sum()), -1, np.int64)
        for _ in range(rng.randrange(4) if rng.random() < 0.4 else 0):
            exc[rng.randrange(len(exc))] = rng.randrange(70)
        try:
            want = _lines_one_by_one(mode, bounds, rlen, rc, exc)
        except FormatError:
            with pytest.raises(FormatError):
                iges._lines(mode, bounds, rlen, rc, exc)
            continue
        starts, lens = iges._lines(mode, bounds, rlen, rc, exc)
        assert (starts.tolist(), lens.tolist()) == want


def test_parameter_text_with_the_slot_byte():
    """A ``#`` in the parameter text (the placeholder is then another byte):
    the digits go only into the numbers' slots."""
    data = _small_iges().replace(b"110|1.0D0|", b"110|3HA#B|")
    assert b"3HA#B" in data
    assert _roundtrip(data) is not None
