"""Mutated STEP and IGES sources through the byte-exact text models (issue 29).

Seeds: hand-written STEP snippets of the awkward parts of ISO 10303-21
(:data:`SNIPPETS`: complex entities, comments, ``''`` escapes, ``\\X2\\``
strings, typed parameters, CRLF, no line breaks, binary bytes) and pieces of
the corpus's STEP and IGES files (:func:`seeds`: the first and a middle
:data:`PIECE` bytes of each, so that a case stays fast).

Each case mutates one seed (:func:`mutate`: byte flips, truncations,
unbalanced parentheses, binary garbage, 10^5 nested lists, huge numbers and
ids, non-ASCII, deleted ``;``, line breaks changed or added mid-token,
placeholder bytes; IGES seeds get the generic byte mutations) and checks
(:func:`check`):

* ``nurbscomp.text.decode(nurbscomp.text.encode(src), len(src)) == src``;
* when the STEP model took the source, its payload damaged (bit flips, a
  run of random bytes, truncation, bytes cut or appended) either decodes to
  ``src`` exactly or raises a ``FormatError``; and the damaged blob through
  ``nurbscomp.text.decode`` raises nothing but a ``FormatError``.

Anything else (another exception, a wrong byte, a case over its time limit,
a worker that dies) is a failure.  ``python -m tests.fuzz_text --cases 10000
--seed 1`` runs the cases in worker processes with a per-case timeout (the
pattern of tests/fuzz.py) and exits 1 when a case failed; ``make fuzz-text``
runs it.
"""

from __future__ import annotations

import argparse
import random
import resource
import signal
import sys
import traceback
from pathlib import Path

from .supervisor import supervise

ROOT = Path(__file__).resolve().parent.parent
CORPUS = ROOT.parent / "shared" / "corpus"
#: Bytes of each corpus piece a seed is made of.
PIECE = 12 * 1024

SNIPPETS: list[bytes] = [
    b"ISO-10303-21;\nHEADER;\n/* a comment ; with ( parens */\n"
    b"FILE_DESCRIPTION(('it''s a ''quoted'' one'),'2;1');\n"
    b"FILE_NAME('x\\X2\\00E400F6\\X0\\y','2020-01-01T00:00:00',(''),(''),'','','');\n"
    b"FILE_SCHEMA(('AP242_MANAGED_MODEL_BASED_3D_ENGINEERING_MIM_LF { 1 0 10303 442 1 1 4 }'));\n"
    b"ENDSEC;\nDATA;\n"
    b"#5=(GEOMETRIC_REPRESENTATION_CONTEXT(3)GLOBAL_UNCERTAINTY_ASSIGNED_CONTEXT((#7))"
    b"GLOBAL_UNIT_ASSIGNED_CONTEXT((#8,#9,#10))REPRESENTATION_CONTEXT('',''));\n"
    b"#7=UNCERTAINTY_MEASURE_WITH_UNIT(LENGTH_MEASURE(1.E-07),#8,'distance_accuracy_value','');\n"
    b"#8=(LENGTH_UNIT()NAMED_UNIT(*)SI_UNIT(.MILLI.,.METRE.));\n"
    b"#9=(NAMED_UNIT(*)PLANE_ANGLE_UNIT()SI_UNIT($,.RADIAN.));\n"
    b"#10=(NAMED_UNIT(*)SI_UNIT($,.STERADIAN.)SOLID_ANGLE_UNIT());\n"
    b"#30=CARTESIAN_POINT('',(1.50000000000000E+01,15.,-0.5000000000000009992));\n"
    b"#20=CARTESIAN_POINT('',(0.,-0.,1.E0));\n#21=DIRECTION('',(+1.,0.0000000000000000000,-1.e-3));\n"
    b"#1000=ORIENTED_EDGE('',*,*,#30,.T.);\n#999=VERTEX_POINT('',#20);\nENDSEC;\nEND-ISO-10303-21;\n",
    b"ISO-10303-21;\r\nHEADER;\r\nFILE_DESCRIPTION((''),'2;1');\r\nENDSEC;\r\nDATA;\r\n"
    b"#1 = CARTESIAN_POINT ( 'NONE',  ( -1.500000000000000200, 0.6250000000000000000, "
    b"1.000000000000000000 ) ) ;\r\n#2 = DIRECTION ( 'NONE',  ( 1.000000000000000000, "
    b"0.0000000000000000000, 0.0000000000000000000 ) ) ;\r\n"
    b"#3 = EDGE_CURVE ( 'NONE', #1, #2, #4, .T. ) ;\r\nENDSEC;\r\nEND-ISO-10303-21;\r\n",
    b"ISO-10303-21;HEADER;FILE_DESCRIPTION((''),'1');ENDSEC;DATA;#1=PRODUCT('a','b','',(#2));"
    b"#2=PRODUCT_CONTEXT('',#3,'mechanical');#3=APPLICATION_CONTEXT('x');ENDSEC;END-ISO-10303-21;",
    b"ISO-10303-21;\nDATA;\n#12 = B_SPLINE_CURVE_WITH_KNOTS('',3,(#13,#14,#15,\n    #16),.UNSPEC"
    b"IFIED.,.F.,.F.,(4,4),(0.,1.),.UNSPECIFIED.);\n#13 = CARTESIAN_POINT('',(127.07438913572,"
    b"23.727096331371,\n    -0.168013787254));\n#14 = CARTESIAN_POINT('',(127.1406811386,23.7\n"
    b"69194186299,-0.336010914536));\n#15=CARTESIAN_POINT('Author N\name',(1.,2.,3.));\n"
    b"#16=CARTESIAN_POINT('\x00\x01\x02\x05\xff\xfe',(1.,2.,3.));\x00\x03\x04 \xc3\xa9\n"
    b"#0017=DIRECTION('',(1.,0.,0.));#18=CURVE_STYLE('',#19,POSITIVE_LENGTH_MEASURE(0.1),#20);\n"
    b"ENDSEC;\nEND-ISO-10303-21;\n",
]


def _smooth_points(n: int = 1300) -> bytes:
    """A STEP file of ``n`` poles along a smooth curve, 13 significant digits,
    with noise-sized numbers near zero among them: each coordinate gets a
    stream of its own (``step.MIN_STREAM``) of more than ``step.NUMERIC_QUICK``
    bytes, coded as numbers
    (``text.numbers``), so mutations reach that decoder."""
    import math

    rows = []
    for i in range(n):
        t = i / n
        xyz = (
            40 + 25 * math.sin(3 * t),
            -7.5 + 12 * t * t,
            1e-14 * math.cos(40 * t) if i % 9 else 0,
        )
        rows.append(
            b"#%d=CARTESIAN_POINT('',(%s));\n" % (i + 1, b",".join(b"%.13G" % v for v in xyz))
        )
    return b"ISO-10303-21;\nDATA;\n" + b"".join(rows) + b"ENDSEC;\nEND-ISO-10303-21;\n"


def seeds() -> list[tuple[str, bytes]]:
    """(format, bytes) of every seed: the snippets, a file of smooth poles
    and the corpus pieces."""
    out = [("STEP", s) for s in SNIPPETS] + [("STEP", _smooth_points())]
    if CORPUS.is_dir():
        for p in sorted(CORPUS.iterdir()):
            suffix = p.suffix.lower()
            if suffix not in (".step", ".stp", ".igs", ".iges"):
                continue
            data = p.read_bytes()
            fmt = "STEP" if suffix in (".step", ".stp") else "IGES"
            mid = len(data) // 2
            out += [(fmt, data[:PIECE]), (fmt, data[mid : mid + PIECE])]
    return out


# ---------------------------------------------------------------- mutations


def _generic(b: bytearray, rng: random.Random) -> None:
    """One generic byte mutation of ``b``, in place."""
    n = len(b)
    kind = rng.randrange(7)
    if kind == 0 and n:  # bit flips
        for _ in range(rng.randint(1, 8)):
            b[rng.randrange(n)] ^= 1 << rng.randrange(8)
    elif kind == 1 and n:  # truncation
        del b[rng.randrange(n) :]
    elif kind == 2:  # a run of binary garbage
        at = rng.randint(0, n)
        b[at:at] = rng.randbytes(rng.randint(1, 64))
    elif kind == 3 and n:  # bytes cut out
        at = rng.randrange(n)
        del b[at : at + rng.randint(1, 64)]
    elif kind == 4 and n:  # a piece duplicated elsewhere
        a = rng.randrange(n)
        piece = b[a : a + rng.randint(1, 200)]
        at = rng.randint(0, n)
        b[at:at] = piece
    elif kind == 5:  # non-ASCII text
        at = rng.randint(0, n)
        b[at:at] = rng.choice(["é", "日本語", "\ufeff", "\u2028", "Ω≈ç"]).encode(
            rng.choice(["utf-8", "utf-16-le"])
        )
    elif n:  # random bytes overwritten
        at = rng.randrange(n)
        k = rng.randint(1, 16)
        b[at : at + k] = rng.randbytes(k)


def _insert(b: bytearray, rng: random.Random, piece: bytes) -> None:
    at = rng.randint(0, len(b))
    b[at:at] = piece


def _step(b: bytearray, rng: random.Random) -> None:
    """One STEP-aware mutation of ``b``, in place."""
    kind = rng.randrange(14)
    n = len(b)
    if kind == 0:  # unbalanced parentheses
        for _ in range(rng.randint(1, 5)):
            _insert(b, rng, rng.choice([b"(", b")", b"((", b"))"]))
    elif kind == 1:  # deep nesting
        depth = rng.choice([100, 1000, 10**5])
        _insert(b, rng, b"#77=X(" + b"(" * depth + b"1." + b")" * depth + b");\n")
    elif kind == 2:  # huge numbers
        digits = "".join(rng.choice("0123456789") for _ in range(rng.choice([19, 25, 400, 5000])))
        _insert(
            b,
            rng,
            rng.choice([b"", b"-", b"+"])
            + digits.encode()
            + rng.choice([b"", b".", b".5", b"E+99999", b"e-0007", b".E"]),
        )
    elif kind == 3:  # huge or odd ids and references
        _insert(
            b,
            rng,
            rng.choice([b"#", b"#0", b"#007", b"#" + b"9" * 30, b"#-1", b"#18446744073709551616"])
            + rng.choice([b"=", b" = ", b",", b")", b""]),
        )
    elif kind == 4:  # deleted ';'
        semis = [i for i in range(n) if b[i] == 0x3B]
        for i in sorted(rng.sample(semis, min(len(semis), rng.randint(1, 5))), reverse=True):
            del b[i]
    elif kind == 5:  # line breaks: CRLF, none, or split mid-token
        choice = rng.randrange(3)
        if choice == 0:
            b[:] = bytes(b).replace(b"\r\n", b"\n").replace(b"\n", b"\r\n")
        elif choice == 1:
            b[:] = bytes(b).replace(b"\n", b"")
        else:
            for _ in range(rng.randint(1, 20)):
                _insert(b, rng, rng.choice([b"\n", b"\r\n", b"\n    ", b"\r"]))
    elif kind == 6:  # placeholder bytes and NULs
        for _ in range(rng.randint(1, 10)):
            _insert(b, rng, bytes([rng.randrange(8)]))
    elif kind == 7:  # quotes: unterminated strings, escapes
        _insert(b, rng, rng.choice([b"'", b"''", b"'''", b"'\\X2\\00E4\\X0\\'", b"'a''b"]))
    elif kind == 8:  # comments, closed or not
        _insert(b, rng, rng.choice([b"/* x */", b"/*", b"*/", b"/* ; ( ' */"]))
    elif kind == 9:  # numbers reformatted
        _insert(
            b,
            rng,
            rng.choice(
                [b"1.", b"-0.", b"0.0000000000000000000", b".5", b"1.5.3", b"1E5", b"00012"]
            ),
        )
    elif kind == 10:  # a long run of one entity
        _insert(
            b,
            rng,
            b"".join(
                b"#%d=CARTESIAN_POINT('',(%d.,%d.5,-%d.E-3));\n" % (i, i, i, i)
                for i in range(rng.randint(1, 3000))
            ),
        )
    elif kind == 11:  # lines shuffled
        lines = bytes(b).split(b"\n")
        rng.shuffle(lines)
        b[:] = b"\n".join(lines)
    elif kind == 12:  # enumerations, $ and *
        _insert(b, rng, rng.choice([b".T.", b".F.", b"$", b"*", b".UNSPECIFIED.", b".", b".."]))
    else:
        _generic(b, rng)


def mutate(fmt: str, data: bytes, rng: random.Random) -> bytes:
    """One to three mutations of ``data`` (STEP-aware ones for STEP seeds)."""
    b = bytearray(data)
    for _ in range(rng.choice([1, 1, 2, 3])):
        if fmt == "STEP" and rng.random() < 0.75:
            _step(b, rng)
        else:
            _generic(b, rng)
    return bytes(b)


def damage(payload: bytes, rng: random.Random) -> bytes:
    """A damaged copy of an encoded payload."""
    b = bytearray(payload)
    if not b:
        return b"\x00"
    kind = rng.randrange(5)
    if kind == 0:
        for _ in range(rng.randint(1, 4)):
            b[rng.randrange(len(b))] ^= 1 << rng.randrange(8)
    elif kind == 1:
        del b[rng.randrange(len(b)) :]
    elif kind == 2:
        at = rng.randrange(len(b))
        k = rng.randint(1, 16)
        b[at : at + k] = rng.randbytes(k)
    elif kind == 3:
        at = rng.randrange(len(b))
        del b[at : at + rng.randint(1, 8)]
    else:
        b += rng.randbytes(rng.randint(1, 8))
    return bytes(b)


# ---------------------------------------------------------------- the property


class Hang(BaseException):
    """A case ran past its time limit (``BaseException``: no ``except Exception`` eats it)."""


def _alarm(signum: int, frame: object) -> None:
    raise Hang


def check(src: bytes, rng: random.Random, seconds: float = 20.0) -> str:
    """The round trip of ``src`` and the damaged payloads (module docstring):
    ``"ok"`` plus which model was used, or ``"FAIL ..."``."""
    from nurbscomp import text
    from nurbscomp.errors import FormatError
    from nurbscomp.text import step

    old = signal.signal(signal.SIGALRM, _alarm)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        blob = text.encode(src)
        back = text.decode(blob, len(src))
        if back != src:
            return f"FAIL not byte-exact (model {blob[0]}, {len(src)} bytes)"
        used = {0: "plain", 1: "step", 2: "iges"}.get(blob[0], "?")
        payload = step.encode(src)
        if payload is not None:
            for _ in range(3):
                bad = damage(payload, rng)
                try:
                    out = step.decode(bad, len(src))
                except FormatError:
                    continue
                if out != src:
                    return "FAIL damaged payload decoded to other bytes"
        for _ in range(2):
            bad = damage(blob, rng)
            try:
                text.decode(bad, len(src))
            except FormatError:
                pass
        return f"ok {used}"
    except Hang:
        return f"FAIL hang (over {seconds:g} s)"
    except MemoryError:
        return "FAIL out of memory"
    except Exception as e:
        tb = traceback.format_exc().strip().splitlines()
        return f"FAIL {type(e).__name__}: {e} | {' / '.join(tb[-3:])}"
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)


def case(seed: int, k: int, pool: list[tuple[str, bytes]]) -> tuple[bytes, random.Random]:
    """The source of case ``k`` of run ``seed``, and the case's random generator."""
    rng = random.Random(f"text:{seed}:{k}")
    fmt, data = rng.choice(pool)
    return mutate(fmt, data, rng), rng


# ---------------------------------------------------------------- the long run


def _worker(seed: int, first: int, count: int, mb: int) -> None:
    """Run cases ``first`` ... ``first + count - 1``; one line per case on stdout."""
    pool = seeds()
    if mb > 0:
        resource.setrlimit(resource.RLIMIT_AS, (mb << 20, mb << 20))
    for k in range(first, first + count):
        print(f"start {k}", flush=True)
        src, rng = case(seed, k, pool)
        print(f"done {k} {check(src, rng)}", flush=True)


def run(cases: int, seed: int, jobs: int, timeout: float, mb: int, chunk: int = 250) -> int:
    """Fuzz ``cases`` cases in ``jobs`` workers; print a summary; 1 if any failed."""

    def command(first: int, n: int) -> list[str]:
        return [sys.executable, "-m", "tests.fuzz_text", "--worker"] + [
            str(x) for x in (seed, first, n, mb)
        ]

    return supervise(cases, jobs, timeout, chunk, command, "fuzz (text)", seed, whole=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--cases", type=int, default=10000)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--timeout", type=float, default=60.0, help="seconds per case")
    ap.add_argument("--memory-mb", type=int, default=2048, help="address space of a worker")
    ap.add_argument("--worker", nargs=4, help=argparse.SUPPRESS)
    a = ap.parse_args()
    if a.worker:
        seed, first, count, mb = (int(x) for x in a.worker)
        _worker(seed, first, count, mb)
        return
    sys.exit(run(a.cases, a.seed, a.jobs, a.timeout, a.memory_mb))


if __name__ == "__main__":
    main()
