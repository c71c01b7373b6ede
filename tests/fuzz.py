"""Mutations of valid containers, and the long fuzzing run of ``make fuzz``.

The mutations are shared with ``tests/test_fuzz.py``.  Two families:

* **raw**: the container's bytes are damaged as they are (truncation, bit
  flips, random bytes, inflated length fields, trailing or missing bytes);
  most are caught by a CRC, and some also have their CRCs recomputed so that
  the length checks behind them are reached;
* **sections**: the container is unpacked, its decoded sections are damaged
  (bytes, array headers, integers and floats inside the arrays, section
  order, duplicates, drops, renames, swaps between samples, META's JSON, the
  lossless flag, a newer minor version), and it is
  packed again with valid CRCs, so the section decoders
  (``serialize.sections_to_model``) and the shape builder see it.

The property (:func:`check`): decoding, building (and in the long run,
writing STEP) either succeed or raise a ``FormatError`` subclass; anything
else is a failure, and so is a case that takes longer than the time limit.

Run ``python -m tests.fuzz --cases 10000`` (what ``make fuzz`` does): the cases
run in worker processes, so that a crash or a hang in OCCT is reported as a
failure of its case instead of ending the run.  The exit status is 1 when a
case failed.
"""

from __future__ import annotations

import argparse
import json
import random
import signal
import struct
import subprocess
import sys
import tempfile
import time
import traceback
import zlib
from pathlib import Path

from nurbscomp import container, entropy, pipeline
from nurbscomp.errors import FormatError, UndiagnosedError

from .golden.make_golden import pack_raw

ROOT = Path(__file__).resolve().parent.parent
SAMPLES = ROOT / "samples"

#: (sample, options) the seed containers are made from.
SEEDS = [
    ("loft.step", {"lossless": True}),
    ("loft.step", {"tol": 0.01}),
    ("teapot.step", {"tol": 0.01}),
    ("bracket.step", {"lossless": True}),
    ("blob.step", {"tol": 0.01}),
]

_HEADER = 16
_ENTRY = 12
_ARRAY_HEAD = struct.Struct("<BBI")


def make_seeds(folder: Path) -> list[bytes]:
    """Compress the seed samples into ``folder``; return the containers' bytes."""
    out = []
    for name, opts in SEEDS:
        dst = folder / f"{name}.{'lossless' if opts.get('lossless') else 'tol'}.nzc"
        if not dst.exists():
            pipeline.compress_file(SAMPLES / name, dst, force=True, **opts)  # type: ignore[arg-type]
        out.append(dst.read_bytes())
    # format 1.1's parts (SIDE, copied curves): the golden surface models
    golden = Path(__file__).resolve().parent / "golden"
    out += [p.read_bytes() for p in sorted(golden.glob("*.faces.*.nzc"))]
    # format 1.2's PROD (assembly tree, names, colours, layers): the golden assemblies
    out += [p.read_bytes() for p in sorted(golden.glob("assembly.*.nzc"))]
    return out


# ---------------------------------------------------------------- raw mutations


def fix_crcs(data: bytes) -> bytes:
    """Recompute the header and body CRCs, where the layout allows it."""
    b = bytearray(data)
    if len(b) < _HEADER:
        return data
    b[12:16] = struct.pack("<I", zlib.crc32(bytes(b[:12])))
    nsec = struct.unpack_from("<H", b, 8)[0]
    body = _HEADER + nsec * _ENTRY
    if body + 16 > len(b):
        return bytes(b)
    crc = zlib.crc32(bytes(b[body : body + 12]), zlib.crc32(bytes(b[_HEADER:body])))
    b[body + 12 : body + 16] = struct.pack("<I", zlib.crc32(bytes(b[body + 16 :]), crc))
    return bytes(b)


def _length_fields(data: bytes) -> list[tuple[int, str]]:
    """Offsets and formats of every declared length or count in the outer layout."""
    fields = [(8, "<H")]  # nsections
    nsec = struct.unpack_from("<H", data, 8)[0]
    for i in range(nsec):
        fields.append((_HEADER + i * _ENTRY + 4, "<I"))  # a section's raw length
    body = _HEADER + nsec * _ENTRY
    fields += [(body + 4, "<I"), (body + 8, "<I")]  # raw and stored length
    return [(o, f) for o, f in fields if o + struct.calcsize(f) <= len(data)]


def _big(rng: random.Random, fmt: str) -> int:
    top = (1 << (8 * struct.calcsize(fmt))) - 1
    return min(top, rng.choice([top, top // 2 + 1, rng.randrange(top + 1), 1 << 24, 0, 1]))


def mutate_raw(data: bytes, rng: random.Random) -> bytes:
    """One random damage to the container bytes as they are."""
    b = bytearray(data)
    kind = rng.randrange(8)
    if kind == 0:  # truncation
        return bytes(b[: rng.randrange(len(b))])
    if kind == 1:  # bit flips
        for _ in range(rng.randint(1, 4)):
            b[rng.randrange(len(b))] ^= 1 << rng.randrange(8)
        return bytes(b)
    if kind == 2:  # a run of random bytes
        at = rng.randrange(len(b))
        n = rng.randint(1, 16)
        b[at : at + n] = rng.randbytes(n)
        return bytes(b)
    if kind == 3:  # trailing bytes
        return bytes(b) + rng.randbytes(rng.randint(1, 8))
    if kind == 4:  # bytes cut out of the middle
        at = rng.randrange(len(b))
        del b[at : at + rng.randint(1, 8)]
        return bytes(b)
    if kind == 5:  # random bytes with the magic
        return container.MAGIC + rng.randbytes(rng.randint(0, 64))
    # an inflated (or shrunk) length field, CRCs kept (6) or recomputed (7)
    off, fmt = rng.choice(_length_fields(data))
    struct.pack_into(fmt, b, off, _big(rng, fmt))
    return fix_crcs(bytes(b)) if kind == 7 else bytes(b)


# ---------------------------------------------------------------- section mutations


def array_headers(raw: bytes) -> list[tuple[int, int, int, int]]:
    """(offset, kind, width, count) of the arrays of a section, as far as they parse."""
    out, pos = [], 0
    while pos + _ARRAY_HEAD.size <= len(raw):
        k, w, n = _ARRAY_HEAD.unpack_from(raw, pos)
        end = pos + _ARRAY_HEAD.size + w * n
        if k not in (0, 1) or w not in (1, 2, 4, 8) or end > len(raw):
            break
        out.append((pos, k, w, n))
        pos = end
    return out


_FLOATS = [float("nan"), float("inf"), -float("inf"), 0.0, -0.0, 1e308, -1e308, 5e-324, 1.0]


def _mutate_array(raw: bytes, rng: random.Random) -> bytes:
    """Damage one array of a section: its header's count, or one of its values."""
    heads = array_headers(raw)
    if not heads:
        return raw
    b = bytearray(raw)
    pos, k, w, n = rng.choice(heads)
    what = rng.randrange(4)
    if what == 0 or n == 0:  # the count: inflated, shrunk, or random
        struct.pack_into("<I", b, pos + 2, _big(rng, "<I") if rng.random() < 0.5 else n + 1)
        return bytes(b)
    if what == 1:  # the width
        b[pos + 1] = rng.choice([1, 2, 4, 8, 0, 3, 255])
        return bytes(b)
    i = rng.randrange(n)
    data_at = pos + _ARRAY_HEAD.size
    if k == 1:  # a float value
        struct.pack_into("<d", b, data_at + 8 * i, rng.choice(_FLOATS))
        return bytes(b)
    # an integer value: each byte plane of value i (planes are split)
    value = rng.choice(
        [0, 1, 2, 3, (1 << (8 * w)) - 1, (1 << (8 * w)) - 2, rng.randrange(1 << 8 * w)]
    )
    for plane in range(w):
        b[data_at + plane * n + i] = (value >> (8 * plane)) & 0xFF
    return bytes(b)


def _mutate_bytes(raw: bytes, rng: random.Random) -> bytes:
    b = bytearray(raw)
    kind = rng.randrange(5)
    if kind == 0 and b:
        for _ in range(rng.randint(1, 4)):
            b[rng.randrange(len(b))] ^= 1 << rng.randrange(8)
    elif kind == 1 and b:
        at = rng.randrange(len(b))
        n = rng.randint(1, 8)
        b[at : at + n] = rng.randbytes(n)
    elif kind == 2:
        return bytes(b[: rng.randrange(len(b) + 1)])
    elif kind == 3:
        at = rng.randrange(len(b) + 1)
        b[at:at] = rng.randbytes(rng.randint(1, 16))
    else:
        return rng.randbytes(rng.randint(0, 64))
    return bytes(b)


def _mutate_meta(raw: bytes, rng: random.Random) -> bytes:
    meta = json.loads(raw)
    key = rng.choice([*meta, "unit", "tolerance_mm", "mode"])
    meta[key] = rng.choice(
        [None, 0, -1, 1e308, float("nan"), "x", "INCH", "lossless", "tolerance", [], {}, 1e-300]
    )
    return json.dumps(meta).encode()


def mutate_sections(data: bytes, rng: random.Random, others: list[bytes]) -> bytes:
    """Unpack, damage the decoded sections, pack again (every CRC valid)."""
    c = container.unpack(data)
    secs = [(s.tag, s.raw) for s in c.sections]
    dup = False
    for _ in range(rng.choice([1, 1, 1, 2, 3])):
        kind = rng.randrange(11)
        i = rng.randrange(len(secs))
        tag, raw = secs[i]
        if kind <= 3:
            secs[i] = (tag, _mutate_array(raw, rng))
        elif kind == 4:
            secs[i] = (tag, _mutate_bytes(raw, rng))
        elif kind == 5:  # another sample's section of the same tag
            other = container.unpack(rng.choice(others))
            if tag in other.tags():
                secs[i] = (tag, other.get(tag))
        elif kind == 6:
            rng.shuffle(secs)
        elif kind == 7 and len(secs) > 1:
            del secs[i]
        elif kind == 10:  # a section twice (``container.pack`` would refuse it)
            secs.insert(rng.randrange(len(secs) + 1), secs[i])
            dup = True
        elif kind == 8:  # a section under another (possibly unknown) tag
            secs[i] = (rng.choice(["ZZZZ", "\x00\x00\x00\x00", *(t for t, _ in secs)]), raw)
            if len({t for t, _ in secs}) != len(secs):
                secs[i] = (tag, raw)
        else:
            j = [t for t, _ in secs].index("META") if any(t == "META" for t, _ in secs) else i
            try:
                secs[j] = ("META", _mutate_meta(secs[j][1], rng))
            except ValueError:
                pass
    flags = c.flags if rng.random() < 0.9 else c.flags ^ container.FLAG_LOSSLESS
    if dup:
        out = pack_raw(secs, flags)
    else:
        # one coder, mostly the fast ones: packing with all four is slow
        coder = rng.choice([*[entropy.Coder.STORED] * 3, *entropy.Coder])
        out = container.pack(secs, flags, (coder,))
    if rng.random() < 0.05:  # a newer minor version of this major
        b = bytearray(out)
        b[5] = rng.randint(container.MINOR + 1, 255)
        out = fix_crcs(bytes(b))
    return out


def mutate(seeds: list[bytes], rng: random.Random) -> bytes:
    """One fuzz case: a seed container damaged raw, or through its sections."""
    data = rng.choice(seeds)
    if rng.random() < 0.35:
        return mutate_raw(data, rng)
    return mutate_sections(data, rng, seeds)


# ---------------------------------------------------------------- the property


class Hang(BaseException):
    """A case ran past its time limit (``BaseException``: no ``except Exception`` eats it)."""


def _alarm(signum: int, frame: object) -> None:
    raise Hang


def check(data: bytes, seconds: float = 20.0, write: bool = False) -> str:
    """Decode and build ``data``: ``"ok"`` or the FormatError's class name.

    With ``write``, a shape that builds is also written to STEP (in a temporary
    folder), as ``nurbscomp decompress`` does.

    Raises
    ------
    Hang
        The case took longer than ``seconds`` (checked between Python bytecodes:
        a hang inside one OCCT call is caught by the worker's timeout instead).
    Exception
        Anything but a ``FormatError``, or an ``UndiagnosedError`` (the
        decoder's last-resort wrapper): the property is broken.
    """
    old = signal.signal(signal.SIGALRM, _alarm)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        m, meta = pipeline.decode(container.unpack(data))
        shape = pipeline.build(m)
        if write:
            with tempfile.TemporaryDirectory() as d:
                pipeline.write(shape, Path(d) / "out.step", "STEP", m.unit, meta, m.product)
        return "ok"
    except UndiagnosedError:
        raise  # a FormatError, but one that no specific check caught: a failure
    except FormatError as e:
        return type(e).__name__
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)


# ---------------------------------------------------------------- the long run


def _worker(seed: int, first: int, count: int, folder: Path) -> None:
    """Run cases ``first`` … ``first + count - 1``; one line per case on stdout."""
    seeds = make_seeds(folder)
    for case in range(first, first + count):
        print(f"start {case}", flush=True)
        try:
            data = mutate(seeds, random.Random(f"{seed}:{case}"))
        except Exception as e:  # a bug of the fuzzer itself: reported, not hidden
            print(f"done {case} FAIL fuzzer {type(e).__name__}: {e}", flush=True)
            continue
        try:
            result = check(data, write=True)
        except Hang:
            result = "FAIL hang"
        except Exception as e:  # the property is broken: report, go on
            tb = traceback.format_exc().strip().splitlines()
            result = f"FAIL {type(e).__name__}: {e} | {' / '.join(tb[-3:])}"
        print(f"done {case} {result}", flush=True)


def run(cases: int, seed: int, jobs: int, timeout: float, chunk: int = 500) -> int:
    """Fuzz ``cases`` cases in ``jobs`` worker processes; print a summary; 1 if any failed."""
    t0 = time.time()
    results: dict[int, str] = {}
    with tempfile.TemporaryDirectory() as d:
        folder = Path(d)
        make_seeds(folder)
        todo = [(a, min(chunk, cases - a)) for a in range(0, cases, chunk)]
        running: list[tuple[subprocess.Popen[str], int, int]] = []
        while todo or running:
            while todo and len(running) < jobs:
                first, n = todo.pop(0)
                cmd = [sys.executable, "-m", "tests.fuzz", "--worker"]
                cmd += [str(seed), str(first), str(n), str(folder)]
                p = subprocess.Popen(cmd, cwd=ROOT, stdout=subprocess.PIPE, text=True)
                running.append((p, first, n))
            p, first, n = running.pop(0)
            last = _collect(p, results, timeout)
            end = first + n
            if last is not None and last + 1 < end:  # died or hung in case `last`
                todo.insert(0, (last + 1, end - last - 1))
            done = len(results)
            print(f"{done} cases, {time.time() - t0:.0f} s", file=sys.stderr, flush=True)
    fails = {k: v for k, v in sorted(results.items()) if v.startswith("FAIL")}
    kinds: dict[str, int] = {}
    for v in results.values():
        kinds[v.split(" ")[0] if not v.startswith("FAIL") else "FAIL"] = (
            kinds.get(v.split(" ")[0] if not v.startswith("FAIL") else "FAIL", 0) + 1
        )
    print(f"fuzz: {len(results)} cases, seed {seed}, {time.time() - t0:.0f} s")
    print("outcomes: " + ", ".join(f"{k} {v}" for k, v in sorted(kinds.items())))
    print(f"failures: {len(fails)}")
    for k, v in fails.items():
        print(f"  case {k}: {v}")
    return 1 if fails else 0


def _collect(p: subprocess.Popen[str], results: dict[int, str], timeout: float) -> int | None:
    """Read a worker's lines; on a hang or crash, record its case as failed and
    return it (the caller resumes after it)."""
    assert p.stdout is not None
    current = None
    deadline = [time.time() + timeout]

    def on_alarm(signum: int, frame: object) -> None:
        raise Hang

    old = signal.signal(signal.SIGALRM, on_alarm)
    try:
        signal.setitimer(signal.ITIMER_REAL, timeout)
        for line in p.stdout:
            word, case, *rest = line.rstrip("\n").split(" ", 2)
            if word == "start":
                current = int(case)
                deadline[0] = time.time() + timeout
                signal.setitimer(signal.ITIMER_REAL, timeout)
            elif word == "done":
                results[int(case)] = rest[0] if rest else ""
                current = None
        p.wait()
    except Hang:
        p.kill()
        p.wait()
        if current is not None:
            results[current] = f"FAIL timeout after {timeout:g} s"
        return current
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)
    if current is not None:  # the worker died inside a case
        results[current] = f"FAIL worker died (exit {p.returncode})"
        return current
    return None


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--cases", type=int, default=10000)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--timeout", type=float, default=60.0, help="seconds per case")
    ap.add_argument("--worker", nargs=4, help=argparse.SUPPRESS)
    a = ap.parse_args()
    if a.worker:
        seed, first, count, folder = a.worker
        _worker(int(seed), int(first), int(count), Path(folder))
        return
    sys.exit(run(a.cases, a.seed, a.jobs, a.timeout))


if __name__ == "__main__":
    main()
