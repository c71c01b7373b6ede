"""Extreme inputs for the stress run (issue 27): far from the origin, thin
walls, huge nets, many instances, extreme tolerances, non-finite values.

``python -m tests.stress.extreme [--big] [--only S] [--out DIR]`` (``make
stress`` runs it; ``--big`` adds the slow tier: a 700 x 700 net, 5,000 placed
instances) writes each case's source file and runs the command line on it as
a user would (``python -m nurbscomp``, default options):

* a case that must work is compressed at each of its tolerances and in
  lossless mode, decompressed with the default command, and held to
  ``nurbscomp eval``'s verdict (exit 0: within tol, same topology, valid,
  no new free edges);
* a case that must be refused must fail with one ``error:`` line (or a usage
  error) and the exit code it names, never ``internal error``.

One line per case and mode, then the failures; exit status 1 if any.  The
times and peak memory of the instanced assembly's compresses are printed
(issue 27: at 0.01 mm within 3x those of its lossless compress).
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from nurbscomp.errors import EXIT_INPUT, EXIT_USAGE

ROOT = Path(__file__).resolve().parents[2]


def part(offset: float = 0.0) -> object:
    """A filleted, drilled box beside a lofted B-spline solid, moved by
    ``offset`` mm along (1, 1, 1)."""
    import cadquery as cq

    box = cq.Workplane().box(10, 20, 5).edges("|Z").fillet(2).faces(">Z").workplane().hole(3)
    loft = cq.Workplane("XY").rect(20, 12).workplane(offset=15).circle(5).loft()
    shape = box.val().fuse(loft.val().translate(cq.Vector(40, 0, 0)))
    return shape.translate(cq.Vector(offset, offset, offset)).wrapped


def plate(thickness: float) -> object:
    """A 100 x 100 mm plate of B-spline faces (a box converted to NURBS)."""
    import cadquery as cq
    from OCP.BRepBuilderAPI import BRepBuilderAPI_NurbsConvert

    box = cq.Workplane().box(100, 100, thickness).val().wrapped
    return BRepBuilderAPI_NurbsConvert(box, True).Shape()


def net(n: int) -> object:
    """One B-spline face with an n x n cubic net on a gentle wave."""
    from .shapes import bspline_surface, face_on

    x, y = np.meshgrid(np.arange(n) * 0.1, np.arange(n) * 0.1, indexing="ij")
    poles = np.stack([x, y, 2 * np.sin(0.02 * x)], axis=-1)
    knots = np.arange(n - 2, dtype=float)  # cubic, clamped: n - 3 spans
    mults = [4] + [1] * (n - 4) + [4]
    return face_on(bspline_surface(poles, knots, mults, knots, mults, 3, 3))


def instances(path: Path, n: int) -> None:
    """An assembly of ``n`` placed instances of one part, by cadquery's XDE writer."""
    import cadquery as cq

    p = cq.Workplane().box(4, 3, 2).edges("|Z").fillet(0.5).faces(">Z").workplane().hole(1)
    a = cq.Assembly(name="top")
    k = int(n**0.5) + 1
    for i in range(n):
        a.add(p, name=f"p{i}", loc=cq.Location(cq.Vector((i % k) * 6, (i // k) * 6, 0)))
    a.export(str(path))


def with_value(src: Path, dst: Path, point: str, value: str) -> Path:
    """``src`` (STEP) with CARTESIAN_POINT ``#point``'s x written as ``value``."""
    text = src.read_text()
    pat = re.compile(rf"#{point} = CARTESIAN_POINT\('',\(([^,]*),")
    if not pat.search(text):
        raise ValueError(f"no CARTESIAN_POINT #{point}")
    dst.write_text(pat.sub(f"#{point} = CARTESIAN_POINT('',({value},", text, count=1))
    return dst


def _nonfinite(where: str) -> Callable[[Path], None]:
    """A source with 1e300 in a vertex or in a pole: an invalid B-rep OCCT reads."""

    def make(path: Path) -> None:
        from nurbscomp import occ

        src = path.with_suffix(".orig.step")
        occ.write_shape(part(), src, "STEP")
        text = src.read_text()
        if where == "vertex":
            m = re.search(r"VERTEX_POINT\('',#(\d+)\)", text)
        else:
            m = re.search(r"B_SPLINE_SURFACE_WITH_KNOTS\('',\d+,\d+,\(\s*\(#(\d+)", text)
        assert m is not None
        with_value(src, path, m.group(1), "1.E300")

    return make


def _step(build: Callable[[], object]) -> Callable[[Path], None]:
    def make(path: Path) -> None:
        from nurbscomp import occ

        occ.write_shape(build(), path, "STEP")

    return make


@dataclass
class Case:
    """A source and what the command line must do with it."""

    name: str
    make: Callable[[Path], None]
    tols: tuple[str, ...] = ("0.001", "0.01", "0.1", "1.0")
    lossless: bool = True
    #: None: it must work; else the exit code its refusal must have
    refused: int | None = None
    #: words a warning must hold at every tolerance
    warns: str = ""
    big: bool = False
    measure: bool = False  # print time and memory against lossless


def cases(big: bool = False) -> list[Case]:
    """The extreme cases (with ``big``, the slow tier too)."""
    out = [
        Case("far_1e6", _step(lambda: part(1e6))),
        Case("far_1e9", _step(lambda: part(1e9))),
        Case("tol_range_ends", _step(part), tols=("1e-6", "1e6"), lossless=False),
        Case("plate_1um", _step(lambda: plate(0.001)), tols=("0.01",), warns="thin against"),
        Case("instances_200", lambda p: instances(p, 200), tols=("0.01",)),
        Case("nonfinite_vertex", _nonfinite("vertex"), tols=("0.01",), refused=EXIT_INPUT),
        Case("nonfinite_pole", _nonfinite("pole"), tols=("0.01",), refused=EXIT_INPUT),
        *(
            Case(f"tol_{t}", _step(part), tols=(t,), lossless=False, refused=EXIT_USAGE)
            for t in ("1e-12", "1e-300", "5e-324", "1e15", "1e300")
        ),
    ]
    if big:
        out += [
            Case("net_700", _step(lambda: net(700)), tols=("0.01",), big=True),
            Case(
                "instances_5000",
                lambda p: instances(p, 5000),
                tols=("0.01",),
                big=True,
                measure=True,
            ),
        ]
    return out


@dataclass
class Outcome:
    case: str
    mode: str
    problems: list[str] = field(default_factory=list)
    seconds: float = 0.0
    peak_kb: int = 0

    def line(self) -> str:
        what = "ok" if not self.problems else "FAIL " + "; ".join(self.problems)
        took = f"{self.seconds:7.1f} s {self.peak_kb >> 10:6d} MB"
        return f"{self.case:22s} {self.mode:9s} {took}  {what}"


@dataclass
class Ran:
    returncode: int
    stdout: str
    stderr: str


def _cli(*args: str, cwd: Path) -> tuple[Ran, float, int]:
    """``nurbscomp ARGS`` in a process of its own: its result, seconds, and its
    own peak memory in KB (``os.wait4``'s, not every child's so far)."""
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    t = time.perf_counter()
    with tempfile.TemporaryFile() as out, tempfile.TemporaryFile() as err:
        p = subprocess.Popen(
            [sys.executable, "-m", "nurbscomp", *args], cwd=cwd, env=env, stdout=out, stderr=err
        )
        _, status, usage = os.wait4(p.pid, 0)
        p.returncode = os.waitstatus_to_exitcode(status)
        out.seek(0)
        err.seek(0)
        text = [f.read().decode(errors="replace") for f in (out, err)]
        ran = Ran(p.returncode, *text)
    return ran, time.perf_counter() - t, usage.ru_maxrss


def make_sources(names: list[str], work: Path, big: bool) -> None:
    """Write the source files of the cases ``names`` into ``work``."""
    for c in cases(big):
        if c.name in names:
            c.make(work / f"{c.name}.step")


def run_case(c: Case, work: Path) -> list[Outcome]:
    """Every mode of one case, in ``work`` (its source written there)."""
    src = work / f"{c.name}.step"
    modes = [("--tol", t) for t in c.tols] + ([("--lossless-brep", "")] if c.lossless else [])
    out = []
    for flag, tol in modes:
        o = Outcome(c.name, tol or "lossless")
        nzc = work / f"{c.name}.{o.mode}.nzc"
        args = [flag, tol] if tol else [flag]
        r, o.seconds, o.peak_kb = _cli("compress", "-f", *args, str(src), "-o", str(nzc), cwd=work)
        err = r.stderr
        if "internal error" in err or "Traceback" in err:
            o.problems.append(f"internal error: {err.strip().splitlines()[-1]}")
        elif c.refused is not None:
            if r.returncode != c.refused:
                o.problems.append(f"exit {r.returncode}, not {c.refused}: {err.strip()[-200:]}")
            if nzc.exists():
                o.problems.append("an output was written")
        elif r.returncode != 0:
            o.problems.append(f"compress exit {r.returncode}: {err.strip()[-200:]}")
        else:
            if c.warns and tol and c.warns not in err:
                o.problems.append(f"no warning saying {c.warns!r}")
            back = work / f"{c.name}.{o.mode}.back.step"
            d, _, _ = _cli("decompress", "-f", str(nzc), "-o", str(back), cwd=work)
            if d.returncode != 0:
                o.problems.append(f"decompress exit {d.returncode}: {d.stderr.strip()[-200:]}")
            else:
                e, _, _ = _cli("eval", str(src), str(nzc), cwd=work)
                if e.returncode != 0:
                    o.problems.append("eval: " + e.stdout.strip().splitlines()[-1])
        out.append(o)
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--big", action="store_true", help="the slow tier too")
    ap.add_argument("--only", default="", help="only cases whose name contains this")
    ap.add_argument("--out", help="keep the files here (default: a temporary folder)")
    ap.add_argument("--make", help=argparse.SUPPRESS)  # a child: write the sources there
    args = ap.parse_args(argv)
    chosen = [c for c in cases(args.big) if args.only in c.name]
    if args.make:
        make_sources([c.name for c in chosen], Path(args.make), args.big)
        return 0
    with tempfile.TemporaryDirectory(prefix="nurbscomp-extreme.") as tmp:
        work = Path(args.out) if args.out else Path(tmp)
        work.mkdir(parents=True, exist_ok=True)
        # the sources are made in a child: this process, without OCP, stays
        # small, and so the peak memory its children report is their own
        # (Linux counts a child's image from before its exec)
        make = [sys.executable, "-m", "tests.stress.extreme", "--make", str(work)]
        make += ["--only", args.only] + (["--big"] if args.big else [])
        subprocess.run(make, check=True, cwd=ROOT)
        results: list[Outcome] = []
        for c in chosen:
            for o in run_case(c, work):
                print(o.line(), flush=True)
                results.append(o)
            if c.measure:
                by = {o.mode: o for o in results if o.case == c.name}
                lossy, exact = by["0.01"], by["lossless"]
                print(
                    f"{c.name}: 0.01 mm {lossy.seconds / exact.seconds:.2f}x the time and "
                    f"{lossy.peak_kb / exact.peak_kb:.2f}x the memory of lossless "
                    f"({lossy.seconds:.1f} s / {exact.seconds:.1f} s, "
                    f"{lossy.peak_kb >> 10} MB / {exact.peak_kb >> 10} MB)"
                )
    failed = [o for o in results if o.problems]
    print(f"{len(results)} runs, {len(failed)} failed")
    return 1 if failed else 0


if __name__ == "__main__":
    raise SystemExit(main())
