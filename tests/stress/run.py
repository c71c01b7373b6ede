"""The stress run (issue 10): compress and decode every generated file, and check it.

``python -m tests.stress.run [--tols 0.001,0.01,0.1] [--only SUBSTRING]
[--limit N] [--seed S] [--jobs 1] [--out DIR]`` (what ``make stress`` runs)
writes the corpus of :mod:`tests.stress.shapes` as STEP, IGES BRep and IGES
faces (:mod:`tests.stress.files`), and for each file and tolerance runs
``pipeline.compress_file`` and ``pipeline.decode_file``.  The decoded shape is
checked against OCCT's own read of the source file (``occ.read_cad``) and
OCCT's own STEP round trip of it (``occ.step_round_trip``):

``crash``
    compress or decode raised anything but a ``NurbscompError``;
``error``
    they raised a ``NurbscompError`` although OCCT reads the file;
``counts``
    topology counts (``occ.counts``) differ from the source's;
``deviation``
    points sampled inside each source face (``occ.deviation``) are further
    than tol (+ 1e-9) from the decoded face of the same index;
``invalid``
    the decoded shape fails BRepCheck where the source passes, or its
    decompressed STEP file read back fails where OCCT's own STEP round trip of the source
    passes (a source that is invalid as OCCT reads it may come back as it
    is: nurbscomp keeps the B-rep it was given);
``step``
    the decompressed STEP file (``pipeline.decompress_file``) read back keeps
    less than OCCT's own STEP round trip of the source keeps
    (``validity.step_keeps`` on the topology counts: each between the
    source's and that round trip's; and no more free edges, sewn at 1e-7, than the source or
    that round trip), or OCCT's reader does not finish on it where it does on
    the source's;
``free_edges``
    more free edges than the source: edges left free when the faces are
    sewn at 1e-7 (``ShapeAnalysis_FreeBounds(shape, 1e-7, False, False)``,
    ``occ.free_edges_sewn``; ``occ.free_edges`` counts without sewing, per shell);
``measure``
    a check itself raised on the decoded shape.

``crash`` in a worker (``--jobs`` > 1 runs each file in its own process)
also covers a process that dies or exceeds ``--timeout``.  A file that OCCT
cannot read passes if compress fails with a ``NurbscompError`` too.  One
line per (file, tol), then a table of failures per kind and format; the exit
status is 1 when anything failed.

``--limit N`` takes the first N files with the shapes taken round-robin over
the categories, so a small run still covers every category.  Without it the
assemblies and blended parts of :mod:`tests.stress.assemblies` (written by
OCCT's XDE writer) are checked too.
"""

from __future__ import annotations

import argparse
import json
import math
import subprocess
import sys
import tempfile
import time
import traceback
from collections import Counter
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from nurbscomp import occ, pipeline
from nurbscomp.encode.validity import step_keeps, step_time_limit
from nurbscomp.errors import NurbscompError

from . import assemblies, files, shapes

ROOT = Path(__file__).resolve().parents[2]
KINDS = (
    "generate",
    "crash",
    "error",
    "counts",
    "deviation",
    "invalid",
    "step",
    "free_edges",
    "measure",
)
#: Slack on the deviation check (float noise of the sampling).
SLACK = 1e-9
#: Sewing tolerance of the free-edge count (the issue's definition).
SEWING_TOL = 1e-7


@dataclass
class Result:
    """The checks of one (file, tol)."""

    file: str
    tol: float
    failures: list[tuple[str, str]] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    seconds: float = 0.0

    @property
    def ok(self) -> bool:
        return not self.failures

    def fail(self, kind: str, detail: str) -> None:
        assert kind in KINDS, kind
        self.failures.append((kind, detail))

    def line(self) -> str:
        head = (
            f"{'PASS' if self.ok else 'FAIL'}  {self.file}  tol={self.tol:g}  {self.seconds:.1f}s"
        )
        parts = [f"{k}: {d}" for k, d in self.failures] + [f"({n})" for n in self.notes]
        return head + ("  " + "; ".join(parts) if parts else "")


def free_edges(shape: Any, tol: float = SEWING_TOL) -> int:
    """Edges left free when the faces of ``shape`` are sewn at ``tol``."""
    return occ.free_edges_sewn(shape, tol)


def _where(e: BaseException) -> str:
    """The innermost frame of an exception's traceback, as file:line."""
    tb = traceback.extract_tb(e.__traceback__)
    if not tb:
        return ""
    f = tb[-1]
    return f" at {Path(f.filename).name}:{f.lineno}"


def _one_line(e: BaseException) -> str:
    msg = " ".join(str(e).split())
    return f"{type(e).__name__}: {msg[:300]}"


@dataclass
class Reference:
    """What the source file gives OCCT: shape, counts, free edges, floor validity."""

    shape: Any
    unit: str
    counts: dict[str, int]
    free: int
    valid: bool
    floor_valid: bool
    notes: list[str]
    #: OCCT's own STEP round trip's counts (None: it failed or looped)
    floor_counts: dict[str, int] | None = None
    #: ... and its free edges (sewn at 1e-7)
    floor_free: int = 0
    #: seconds a STEP round trip may take (``validity.step_time_limit``)
    limit: float | None = None


def reference(path: Path) -> Reference:
    """OCCT's read of ``path`` and its own STEP round trip (raises if
    unreadable): written as ``decompress`` writes the source, through OCCT's
    XDE writer with the source's product data (written plainly, a compound
    part's solids each get an uncertainty of their own, and read back
    otherwise)."""
    cad = occ.read_cad(path, product=True)
    notes = []
    limit = step_time_limit(occ.shape_to_model(cad.shape)[0])
    floor_counts: dict[str, int] | None = None
    floor_free = 0
    try:
        floor_valid, floor_counts, floor_free = step_trip(
            cad.shape, cad.unit, limit, product=cad.product
        )
    except occ.ReaderTimeout as e:  # OCCT's reader loops on its own round trip
        floor_valid = False
        notes.append(f"no STEP round trip: {e}")
    except Exception as e:  # OCCT's own round trip fails: no validity to keep
        floor_valid = False
        notes.append(f"OCCT's STEP round trip fails: {_one_line(e)}")
    if not floor_valid and not notes:
        notes.append("OCCT's STEP round trip is invalid")
    valid = occ.is_valid(cad.shape)
    if not valid:
        notes.append("the source is invalid as OCCT reads it")
    counts, free = occ.counts(cad.shape), free_edges(cad.shape)
    return Reference(
        cad.shape,
        cad.unit,
        counts,
        free,
        valid,
        floor_valid,
        notes,
        floor_counts,
        floor_free,
        limit,
    )


def step_trip(
    shape: Any,
    unit: str,
    limit: float | None,
    written: Path | None = None,
    product: Any = None,
) -> tuple[bool, dict[str, int], int]:
    """BRepCheck's verdict, the topology counts and the free edges of ``shape`` written to STEP
    (or of the STEP file ``written``, as ``decompress`` wrote it) and read
    back by OCCT, in a child process given ``limit`` seconds
    (``occ.RoundTrip``; raises ``occ.ReaderTimeout`` past them)."""
    with tempfile.TemporaryDirectory() as d:
        if written is None:
            make = lambda: occ.step_round_trip(shape, unit, product, Path(d))  # noqa: E731
        else:
            make = lambda: occ.read_cad(written, own=True).shape  # noqa: E731
        with occ.RoundTrip(make, 0, limit) as back:
            return bool(back.ask(occ.is_valid)), back.ask(occ.counts), back.ask(free_edges)


def check_one(path: Path, tol: float, ref: Reference, work: Path) -> Result:
    """Compress ``path`` at ``tol``, decode it, and run the checks against ``ref``."""
    r = Result(path.name, tol, notes=list(ref.notes))
    t0 = time.perf_counter()
    dst = work / f"{path.name}.{tol:g}.nzc"
    step = work / f"{path.name}.{tol:g}.step"  # as decompress writes it (XDE, product data)
    try:
        stage = "compress"
        pipeline.compress_file(path, dst, tol=tol, force=True)
        stage = "decode"
        shape, _, _ = pipeline.decode_file(dst)
        stage = "decompress"
        pipeline.decompress_file(dst, step, force=True)
    except NurbscompError as e:
        r.fail("error", f"{stage}: {_one_line(e)}")
    except Exception as e:
        r.fail("crash", f"{stage}: {_one_line(e)}{_where(e)}")
    else:
        compare(r, ref, shape, tol, step)
    finally:
        dst.unlink(missing_ok=True)
        step.unlink(missing_ok=True)
    r.seconds = time.perf_counter() - t0
    return r


def compare(r: Result, ref: Reference, shape: Any, tol: float, written: Path | None = None) -> None:
    """Checks 2-5 of a decoded ``shape`` (and ``written``, its decompressed
    STEP file, if given; else ``shape`` written plainly) against the source's
    ``ref``, into ``r``."""
    try:
        got = occ.counts(shape)
        if got != ref.counts:
            diff = {k: f"{ref.counts[k]}->{got[k]}" for k in got if got[k] != ref.counts[k]}
            r.fail("counts", ", ".join(f"{k} {v}" for k, v in diff.items()))
        if got["faces"] == ref.counts["faces"]:
            dev = occ.deviation(ref.shape, shape, tol=tol)
            if len(dev) and dev.max() > tol + SLACK:
                bad = int((dev > tol + SLACK).sum())
                r.fail(
                    "deviation",
                    f"{dev.max():.3g} mm > tol on face {int(dev.argmax())}"
                    f" ({bad} of {len(dev)} faces over)",
                )
        if ref.valid and not occ.is_valid(shape):
            r.fail("invalid", f"faces {sorted(occ.faulty_faces(shape))[:8]} fail BRepCheck")
        elif ref.floor_counts is not None:
            step_check(r, ref, shape, written)
        fe = free_edges(shape)
        if fe > ref.free:
            r.fail("free_edges", f"{ref.free}->{fe}")
    except Exception as e:
        r.fail("measure", f"{_one_line(e)}{_where(e)}")


def step_check(r: Result, ref: Reference, shape: Any, written: Path | None) -> None:
    """The ``invalid`` and ``step`` checks of the decoded shape's STEP re-read."""
    assert ref.floor_counts is not None
    try:
        valid, back, free = step_trip(shape, ref.unit, ref.limit, written)
    except occ.ReaderTimeout as e:
        r.fail("step", f"its STEP file read back: {e}, unlike the source's")
        return
    if ref.floor_valid and not valid:
        r.fail("invalid", "its STEP file read back fails BRepCheck")
    if not step_keeps(ref.counts, ref.floor_counts, back):
        ours = ", ".join(f"{k} {ref.counts[k]}->{v}" for k, v in back.items() if v != ref.counts[k])
        occts = ", ".join(f"{k} {v}" for k, v in ref.floor_counts.items() if v != ref.counts[k])
        r.fail("step", f"its STEP file read back: {ours} (OCCT's own: {occts or 'as read'})")
    if free > max(ref.free, ref.floor_free):
        r.fail(
            "step",
            f"its STEP file read back: {free} free edges"
            f" (the source {ref.free}, OCCT's own round trip {ref.floor_free})",
        )


def check_file(path: Path, tols: Sequence[float], work: Path) -> list[Result]:
    """Every tolerance of one file."""
    path = Path(path)
    try:
        ref = reference(path)
    except Exception as e:  # OCCT cannot read it: nurbscomp must refuse it cleanly
        out = []
        for tol in tols:
            r = Result(path.name, tol, notes=[f"OCCT cannot read it: {_one_line(e)}"])
            dst = work / f"{path.name}.{tol:g}.nzc"
            try:
                pipeline.compress_file(path, dst, tol=tol, force=True)
                r.notes.append("compressed anyway")
            except NurbscompError:
                pass
            except Exception as e2:
                r.fail("crash", f"compress: {_one_line(e2)}{_where(e2)}")
            finally:
                dst.unlink(missing_ok=True)
            out.append(r)
        return out
    return [check_one(path, tol, ref, work) for tol in tols]


def _format_of(name: str) -> str:
    for fmt, suffix in files.FORMATS:
        if name.endswith(suffix):
            return fmt
    return "?"


def summary(results: Sequence[Result]) -> str:
    """A table of failing (file, tol) per kind and format."""
    fmts = [f for f, _ in files.FORMATS]
    table: dict[str, Counter[str]] = {k: Counter() for k in KINDS}
    for r in results:
        for kind in {k for k, _ in r.failures}:
            table[kind][_format_of(r.file)] += 1
    width = max(len(k) for k in KINDS)
    lines = [f"{'kind':{width}s} " + " ".join(f"{f:>6s}" for f in fmts) + f" {'total':>6s}"]
    for kind in KINDS:
        row = table[kind]
        lines.append(
            f"{kind:{width}s} "
            + " ".join(f"{row[f]:6d}" for f in fmts)
            + f" {sum(row.values()):6d}"
        )
    failed = sum(not r.ok for r in results)
    lines.append(f"{len(results)} checks (file x tol), {failed} failed")
    return "\n".join(lines)


def _run_worker(path: Path, tols: Sequence[float], work: Path, timeout: float) -> list[Result]:
    """One file in its own process: a crash or a hang is that file's failure."""
    cmd = [
        sys.executable,
        "-m",
        "tests.stress.run",
        "--one",
        str(path),
        "--tols",
        ",".join(repr(t) for t in tols),
        "--work",
        str(work),
    ]
    try:
        p = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return [Result(path.name, t, [("crash", f"no answer in {timeout:g} s")]) for t in tols]
    if p.returncode != 0 or not p.stdout.strip():
        why = f"worker exited with {p.returncode}: {' '.join(p.stderr.split()[-20:])}"
        return [Result(path.name, t, [("crash", why)]) for t in tols]
    rows = json.loads(p.stdout.strip().splitlines()[-1])
    return [
        Result(x["file"], x["tol"], [tuple(f) for f in x["failures"]], x["notes"], x["seconds"])
        for x in rows
    ]


def _parse_tols(s: str) -> list[float]:
    tols = [float(x) for x in s.split(",") if x.strip()]
    if not tols or any(not (math.isfinite(t) and t > 0) for t in tols):
        raise argparse.ArgumentTypeError(f"bad tolerances {s!r}")
    return tols


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        prog="python -m tests.stress.run", description=__doc__.split("\n")[0]
    )
    ap.add_argument("--tols", type=_parse_tols, default=[0.001, 0.01, 0.1])
    ap.add_argument("--only", default="", help="only shapes whose name contains this")
    ap.add_argument("--limit", type=int, default=0, help="at most N files (0: all)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--jobs", type=int, default=1, help="worker processes (default 1: in process)")
    ap.add_argument("--out", help="keep the files here (default: a temporary folder)")
    ap.add_argument("--timeout", type=float, default=900.0, help="per file, with --jobs > 1")
    ap.add_argument("--one", help=argparse.SUPPRESS)  # worker: one file, JSON out
    ap.add_argument("--work", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)

    if args.one:
        rs = check_file(Path(args.one), args.tols, Path(args.work))
        print(json.dumps([asdict(r) for r in rs]))
        return 0

    with tempfile.TemporaryDirectory(prefix="stress-") as tmp:
        out = Path(args.out) if args.out else Path(tmp)
        work = Path(tmp) / "nzc"
        work.mkdir(parents=True, exist_ok=True)
        t0 = time.perf_counter()
        items = shapes.interleaved([e for e in shapes.entries(args.seed) if args.only in e.name])
        if args.limit:
            items = items[: -(-args.limit // len(files.FORMATS))]
        errors: list[tuple[str, str]] = []
        paths = files.write_all(out, items, errors=errors)
        if args.limit:
            paths = paths[: args.limit]
        elif any(args.only in name for name, _ in assemblies.CASES):
            paths += assemblies.write_all(out, errors)  # XDE assemblies, blended parts
        print(
            f"{len(paths)} files from {len(items)} shapes in {out if args.out else 'a temp folder'}"
            f" ({time.perf_counter() - t0:.1f} s); tols {', '.join(f'{t:g}' for t in args.tols)}",
            flush=True,
        )
        results = [Result(name, math.nan, [("generate", msg)]) for name, msg in errors]
        for r in results:
            print(r.line(), flush=True)
        if args.jobs > 1:
            with ThreadPoolExecutor(args.jobs) as pool:
                futures = [
                    pool.submit(_run_worker, p, args.tols, work, args.timeout) for p in paths
                ]
                for fut in futures:
                    for r in fut.result():
                        print(r.line(), flush=True)
                        results.append(r)
        else:
            for p in paths:
                for r in check_file(p, args.tols, work):
                    print(r.line(), flush=True)
                    results.append(r)
        print()
        print(summary(results))
        print(f"{time.perf_counter() - t0:.0f} s")
    return 0 if all(r.ok for r in results) else 1


if __name__ == "__main__":
    raise SystemExit(main())
