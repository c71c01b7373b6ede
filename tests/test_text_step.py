"""The STEP text model (issue 29): byte-exact round trips, streams, damage, a short fuzz."""

from __future__ import annotations

import hashlib
import lzma
import random

import numpy as np
import pytest

from nurbscomp import text
from nurbscomp.errors import CorruptError, FormatError, LimitError
from nurbscomp.text import coding, numbers, step

from .conftest import corpus_files
from .fuzz_text import SNIPPETS, case, check, seeds


def _round(data: bytes) -> bytes:
    payload = step.encode(data)
    assert payload is not None
    return step.decode(payload, len(data))


@pytest.mark.parametrize("k", range(len(SNIPPETS)))
def test_snippets_byte_exact(k):
    data = SNIPPETS[k]
    assert _round(data) == data
    assert text.decode(text.encode(data), len(data)) == data


@pytest.mark.parametrize(
    "data",
    [
        b"ISO-10303-21;",
        b"ISO-10303-21;\nDATA;\n#1=A();",  # no trailing line break
        b"ISO-10303-21;\nDATA;\n#1=A('unterminated);\n#2=B(#1);\n",
        b"ISO-10303-21;\nDATA;\n#5=(A()B()C());\n#3=X(LENGTH_MEASURE(1.),.T.,$,*);\n",
        b"ISO-10303-21;\nDATA;\n#9=A(#007,#0,#99999999999999999999,#-1,1.2.3,.5,1E,e5);\n",
        b"ISO-10303-21;\nDATA;\n#1=A('a\x00b\x01''c',\x02\x03\x04\x05,\xff\xfe);\n",
        b"ISO-10303-21;\nDATA;\n#1=A(" + b"(" * 100000 + b")" * 100000 + b");\n",
        b"ISO-10303-21;\nDATA;\n#1=A(" + b"9" * 5000 + b".E+999999);\n",
        b"ISO-10303-21;\r\nDATA;\r\n#1=A(1.0,\r\n  2.0);\r\n#3=B(12\n34,'x\r\ny');\r\n",
    ],
)
def test_edge_cases_byte_exact(data):
    assert _round(data) == data


def test_numbers_keep_their_text():
    """``1.50000000000000E+01`` and ``15.`` both come back as written, and 19
    significant digits are kept (a double would lose them)."""
    nums = [b"1.50000000000000E+01", b"15.", b"0.5000000000000009992", b"-0.", b"+1.e-3", b"007"]
    data = b"ISO-10303-21;\nDATA;\n" + b"".join(
        b"#%d=CARTESIAN_POINT('',(%s,%s,%s));\n" % (i + 1, n, n, n) for i, n in enumerate(nums * 20)
    )
    assert _round(data) == data


def _header(streams: list[bytes]) -> dict[str, list[int]]:
    """The varints of a version 4 payload's header, by field."""
    vals, pos = [], 0
    while pos < len(streams[0]):
        v, pos = coding.read_varint(streams[0], pos)
        vals.append(v)
    nr, nn = vals[3], vals[4]
    at = 5 + (nr + 1) + 2 * nr + 2 * nn
    return {"version": vals[:1], "num_modes": vals[at : at + nn + 1], "counts": [nr, nn]}


def _number_streams(streams: list[bytes], counts: list[int]) -> list[list[bytes]]:
    """The number texts of each number stream of a version 4 payload, whether
    it was coded as text or as numbers; ``counts``: numbers per stream."""
    head = _header(streams)
    nr, nn = head["counts"]
    first = 10 + nr
    residuals = iter(streams[first + nn + 1 :])
    out = []
    for s, mode in enumerate(head["num_modes"]):
        raw = streams[first + s]
        out.append(numbers.decode(raw, next(residuals), counts[s]) if mode else raw.split(b","))
    return out


def test_context_streams():
    """Coordinates of CARTESIAN_POINT go to three streams of their own (x, y, z)
    once each context has step.MIN_STREAM values, so the streams hold the
    numbers in file order; x, on a line, is coded as numbers (second
    differences all zero)."""
    n = 3000  # x's text over step.NUMERIC_QUICK, so that it is tried as numbers
    rows = [(i * 0.5, -i * 1.25, 7.0) for i in range(n)]
    data = b"ISO-10303-21;\nDATA;\n" + b"".join(
        b"#%d=CARTESIAN_POINT('',(" % (i + 10) + b",".join(repr(v).encode() for v in r) + b"));\n"
        for i, r in enumerate(rows)
    )
    payload = step.encode(data)
    assert payload is not None
    streams = coding.unpack(payload, 10 * len(data))
    head = _header(streams)
    assert head["version"] == [step.VERSION] and head["counts"] == [0, 3]
    got = _number_streams(streams, [2, n, n, n])  # stream 0: 10303 and -21 of the magic
    for k in range(3):
        assert got[k + 1] == [repr(r[k]).encode() for r in rows]
    assert head["num_modes"][1] == 1
    ids = coding.read_int_stream(streams[4], n, "ids")
    assert ids.tolist() == [9] + [0] * (n - 1)  # ids: #10, then +1 each
    assert streams[4] == bytes([1, 18]) + bytes(n - 1)  # one byte each, zigzag


def test_group_copies():
    """A CARTESIAN_POINT whose numbers repeat an earlier point's is a copy
    (stream 8: how many points back), with its numbers out of the number
    streams; a DIRECTION with the same numbers is of another kind and new; a
    copy that reaches too far back or forward is refused."""
    pts = [b"(1.5,2.,3.)", b"(4.,5.,6.)", b"(1.5,2.,3.)", b"(4.,5.,6.)", b"(4.,5.,6.)"]
    data = b"ISO-10303-21;\nDATA;\n" + b"".join(
        b"#%d=CARTESIAN_POINT('',%s);\n" % (i + 1, p) for i, p in enumerate(pts)
    )
    data += b"#9=DIRECTION('',(1.5,2.,3.));\n#10=A('x',7);\n#11=A('y',7);\n"
    assert _round(data) == data
    streams = coding.unpack(step.encode(data), 10 * len(data))
    copies = coding.read_int_stream(streams[8], 9, "copies").tolist()
    assert copies == [0, 0, 0, 2, 2, 1, 0, 0, 1]  # the first: 10303 and -21 of the magic
    assert b"4.,4." not in b"".join(streams[9:])
    ok = coding.int_stream(np.array(copies))
    assert ok == streams[8]
    bad_copies = (
        coding.int_stream(np.array([0, 0, 0, 3, 2, 1, 0, 0, 1])),
        coding.int_stream(np.array([0, 0, 0, 2, 2, 1, 0, 0, -1])),
        coding.int_stream(np.array([0, 0, 0, 2, 2, 1, 0, 0])),
        bytes([3]) + ok[1:],
        ok + b"\x00",
    )
    for bad in bad_copies:
        with pytest.raises(CorruptError):
            step.decode(coding.pack([*streams[:8], bad, *streams[9:]]), len(data))


def test_damaged_payload_raises():
    data = SNIPPETS[0] * 3
    payload = step.encode(data)
    assert payload is not None
    rng = random.Random(3)
    for _ in range(200):
        b = bytearray(payload)
        b[rng.randrange(len(b))] ^= 1 << rng.randrange(8)
        try:
            out = step.decode(bytes(b), len(data))
        except FormatError:
            continue
        assert out == data
    for cut in range(0, len(payload), max(1, len(payload) // 50)):
        with pytest.raises(FormatError):
            step.decode(payload[:cut], len(data))


def test_limit():
    data = SNIPPETS[1]
    payload = step.encode(data)
    with pytest.raises(LimitError):
        step.decode(payload, len(data) - 1)


def test_crc_is_checked():
    """A payload whose streams decode but give other text fails on its CRC."""
    data = SNIPPETS[2]
    streams = coding.unpack(step.encode(data), 10 * len(data))
    skel = streams[1].replace(b"PRODUCT_CONTEXT", b"PRODUCT_CONTEXX")
    with pytest.raises(CorruptError):
        step.decode(coding.pack([streams[0], skel, *streams[2:]]), len(data))


def test_not_step():
    assert step.encode(b"hello world") is None


def test_cadquery_exports(tmp_path):
    """STEP written by OCCT through cadquery: a part, and an assembly with colours."""
    cq = pytest.importorskip("cadquery")
    part = cq.Workplane().box(10, 20, 5).faces(">Z").hole(3).edges("|Z").fillet(1)
    cq.exporters.export(part, str(tmp_path / "part.step"))
    asm = cq.Assembly()
    asm.add(part, name="a", color=cq.Color("red"))
    asm.add(
        cq.Workplane().sphere(4),
        name="b",
        color=cq.Color(0, 0, 1, 0.5),
        loc=cq.Location((20, 0, 0)),
    )
    asm.save(str(tmp_path / "asm.step"))
    for p in (tmp_path / "part.step", tmp_path / "asm.step"):
        data = p.read_bytes()
        payload = step.encode(data)
        assert payload is not None
        assert step.decode(payload, len(data)) == data
        assert len(payload) < len(lzma.compress(data, preset=9 | lzma.PRESET_EXTREME))


@pytest.mark.slow
@pytest.mark.parametrize(
    "path",
    [p for p in corpus_files() if p.suffix.lower() in (".step", ".stp")],
    ids=lambda p: p.name,
)
def test_corpus_byte_exact_and_smaller(path):
    """Each corpus STEP file: SHA-256 equal, and at least 1.2x smaller than xz -9e."""
    data = path.read_bytes()
    payload = step.encode(data)
    assert payload is not None
    back = step.decode(payload, len(data))
    assert hashlib.sha256(back).digest() == hashlib.sha256(data).digest()
    xz = len(lzma.compress(data, preset=9 | lzma.PRESET_EXTREME))
    assert len(payload) * 1.2 <= xz, (len(payload), xz)


@pytest.mark.slow
def test_short_fuzz():
    """A few hundred mutated sources (tests/fuzz_text.py), in this process."""
    pool = seeds()
    fails = []
    for k in range(200):
        src, rng = case(7, k, pool)
        result = check(src, rng, seconds=30.0)
        if result.startswith("FAIL"):
            fails.append((k, result))
    assert not fails


def test_statements():
    """Version 3 stores the skeleton as its distinct statements (stream 1, cut
    after each ``;``), their lengths (2) and one index per statement (3); an
    index past the dictionary, or one that would make the skeleton longer
    than the text, is refused."""
    data = b"ISO-10303-21;\nDATA;\n" + b"".join(
        b"#%d=CARTESIAN_POINT('',(%d.,2.,3.));\n" % (i + 1, i) for i in range(300)
    )
    assert _round(data) == data
    streams = coding.unpack(step.encode(data), 10 * len(data))
    # "ISO-#-#;", "\nDATA;", "\n#=CARTESIAN_POINT(...);" and the last "\n"
    assert streams[1].count(b"CARTESIAN_POINT") == 1
    assert streams[2] == b"8,6,30,1"
    assert streams[3] == b"\x00\x01" + b"\x02" * 300 + b"\x03"
    for bad in (bytes([250]) * len(streams[3]), bytes([1]) * (50 * len(streams[3]))):
        with pytest.raises(CorruptError):
            step.decode(coding.pack([*streams[:3], bad, *streams[4:]]), len(data))


def test_versions_2_and_3_still_decode():
    """A version 3 payload (no number modes: every number stream is text) and
    a version 2 payload (the skeleton as one stream, integers as decimal
    text) decode as before."""
    data = SNIPPETS[0] * 3
    streams = coding.unpack(step.encode(data), 10 * len(data))
    head, pos = streams[0], 0
    fields = []
    for _ in range(5):  # version, size, crc, nr, nn
        v, pos = coding.read_varint(head, pos)
        fields.append(v)
    assert fields[0] == 4
    nr, nn = fields[3], fields[4]
    assert head.endswith(bytes(nn + 1))  # a small file: every number stream is text
    head = head[: -(nn + 1)]
    v3 = [coding.varint(3) + head[1:], *streams[1:]]
    assert step.decode(coding.pack(v3), len(data)) == data

    def text(raw: bytes) -> bytes:
        n = (len(raw) - 1) // raw[0] if raw else 0
        return b",".join(b"%d" % v for v in coding.read_int_stream(raw, n, "x").tolist())

    v2 = [*streams]
    for i in [4, 5, 8, *range(9, 10 + nr)]:
        v2[i] = text(streams[i])
    table, index = step._skeleton(*streams[1:4], len(data))
    skel = b"".join(table[i] for i in index.tolist())
    assert b"CARTESIAN_POINT" in skel and skel.count(b";") > 3
    old = [coding.varint(2) + head[1:], skel, *v2[4:]]
    assert step.decode(coding.pack(old), len(data)) == data


def test_int_streams():
    """Version 3 integer streams: a width byte and zigzag byte planes, the
    narrowest width that holds them; empty for no values."""
    for vals in ([0], [1, -1, 2, -2], [300, -5], [2**40, -(2**40)], [2**62, -(2**62)]):
        raw = coding.int_stream(np.array(vals, dtype=np.int64))
        assert coding.read_int_stream(raw, len(vals), "x").tolist() == vals
    assert coding.int_stream(np.array([1, -1, 127])) == bytes([1, 2, 1, 254])
    assert coding.int_stream(np.array([128]))[0] == 2
    assert coding.int_stream(np.zeros(0, dtype=np.int64)) == b""
    with pytest.raises(CorruptError):
        coding.read_int_stream(b"\x01\x00", 2, "x")
    with pytest.raises(CorruptError):
        coding.read_int_stream(b"", 1, "x")


def test_name_spans_match_the_name_expression():
    """step._name_spans finds what NAME's regular expression finds."""
    rng = random.Random(9)
    alpha = b"aZ_09 (\t\r\n);,#'\x01\x80xy"
    cases = [b"", b"A(", b"9A(", b"_x (", b"AB\n\t (x", b"AB C(", b"(A)(", b"\x80A("]
    cases += [bytes(rng.choice(alpha) for _ in range(rng.randrange(40))) for _ in range(3000)]
    for t in cases:
        a, e = step._name_spans(t)
        assert list(zip(a.tolist(), e.tolist())) == [m.span() for m in step.NAME.finditer(t)]


def test_unit_names_match_names_of_the_skeleton():
    """_unit_names (statements in order of first use, or not) gives what
    names() finds in the whole skeleton."""
    data = (
        b"ISO-10303-21;\nDATA;\n#1=CARTESIAN_POINT('',(0.,1.,2.));\n#2=DIRECTION('',(1.,0.,0.));\n"
        b"#3=CARTESIAN_POINT('',(3.,1.,2.));\n#4=AXIS2_PLACEMENT_3D('',#1,#2,$);\nENDSEC;\n"
    )
    table, index = step._units(step.TOKEN.sub(b"\x03", data))
    skel = b"".join(table[i] for i in index.tolist())
    rng = random.Random(2)
    for shuffle in (False, True, True):
        perm = list(range(len(table)))
        if shuffle:
            rng.shuffle(perm)
        t2 = [table[i] for i in perm]
        i2 = np.argsort(perm)[index]
        got, want = step._unit_names(t2, i2), step.names(skel)
        assert np.array_equal(got[0], want[0]) and np.array_equal(got[1], want[1])
