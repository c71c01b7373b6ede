"""The scale row of ``make bench`` (issue 30): a generated assembly of hundreds
of distinct parts, 20-50 MB of STEP, compressed and decompressed, with its
times as ratios to OCCT's STEP read and write of the same file and shape, and
peak memory as a ratio to the read's.

The parts are made with cadquery from a seeded random generator, so every run
makes the same file: filleted blocks with holes (planes, cylinders, tori and
B-spline blends), lofts between a circle and a B-spline section (B-spline
faces), revolved profiles (surfaces of revolution) and shells with a hollowed
face (offset and trimmed faces), each a separate product of one assembly,
each placed apart so that none is an instance of another.

Every measurement runs in a fresh process that reports its wall time and its
own peak resident set (``ru_maxrss``), so one step's memory does not count in
another's; the assembly is made in a process of its own too (Linux hands a
process's peak RSS down to the children it forks).  Usage::

    python benchmarks/scale.py [--parts 800] [--work DIR] > docs/benchmarks-scale.md
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

#: What each timed step runs in its own process (argv[1] the input, argv[2]
#: the output): imports and set-up, untimed, then the timed operation; the
#: process prints {"s": the operation's wall seconds, "rss_mb": peak RSS}.
_STEPS = {
    "read": ("from nurbscomp.occ import files", "files.read_cad(Path(sys.argv[1]))"),
    "compress": (
        "from nurbscomp import occ, pipeline",
        "pipeline.compress_file(Path(sys.argv[1]), Path(sys.argv[2]), tol=0.01, force=True)",
    ),
    "decode": (
        "from nurbscomp import occ, pipeline",
        "pipeline.decode_file(Path(sys.argv[1]))",
    ),
    "decompress": (
        "from nurbscomp import occ, pipeline",
        "pipeline.decompress_file(Path(sys.argv[1]), Path(sys.argv[2]), force=True)",
    ),
    "write": (
        "from nurbscomp import occ, pipeline\n"
        "shape, _, _ = pipeline.decode_file(Path(sys.argv[1]))",
        'occ.files.write_shape(shape, Path(sys.argv[2]), "step")',
    ),
}

_HARNESS = """
import json, resource, sys, time
from pathlib import Path
{setup}
occ.files if "occ" in dir() else None  # OCP loaded before the clock starts
T0 = time.perf_counter()
{op}
print(json.dumps({{"s": time.perf_counter() - T0,
                  "rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}}))
"""


def timed(step: str, src: Path, dst: Path) -> dict[str, float]:
    """Run one step in a fresh process; its wall time and peak RSS."""
    setup, op = _STEPS[step]
    code = _HARNESS.format(setup=setup, op=op)
    r = subprocess.run(
        [sys.executable, "-c", code, str(src), str(dst)],
        capture_output=True,
        text=True,
        cwd=ROOT,
        check=True,
    )
    return dict(json.loads(r.stdout.strip().splitlines()[-1]))


def make_assembly(parts: int, path: Path, seed: int = 30) -> None:
    """Write the generated assembly of ``parts`` distinct parts to ``path``."""
    import random

    import cadquery as cq

    rng = random.Random(seed)
    asm = cq.Assembly(name="scale")
    for i in range(parts):
        kind = i % 4
        a, b, c = (rng.uniform(10, 40) for _ in range(3))
        if kind == 0:  # filleted block with holes
            w = cq.Workplane("XY").box(a, b, c).edges("|Z").fillet(min(a, b) / 5)
            w = w.faces(">Z").workplane().rarray(a / 3, b / 3, 2, 2).hole(min(a, b) / 8)
            w = w.edges(">Z").fillet(min(a, b, c) / 20)
        elif kind == 1:  # loft from a circle to a spline section
            pts = [
                (a / 2 * rng.uniform(0.7, 1.0), 0),
                (0, b / 2 * rng.uniform(0.7, 1.0)),
                (-a / 2 * rng.uniform(0.7, 1.0), 0),
                (0, -b / 2 * rng.uniform(0.7, 1.0)),
            ]
            w = (
                cq.Workplane("XY")
                .circle(min(a, b) / 2)
                .workplane(offset=c)
                .spline(pts, periodic=True)
                .close()
                .loft()
            )
        elif kind == 2:  # revolved profile
            w = (
                cq.Workplane("XZ")
                .moveTo(2, 0)
                .lineTo(a / 2, 0)
                .threePointArc((a / 2 + c / 4, c / 2), (a / 3, c))
                .lineTo(2, c)
                .close()
                .revolve(360, (0, 0, 0), (0, 1, 0))
            )
        else:  # shelled block
            w = cq.Workplane("XY").box(a, b, c).faces(">Z").shell(-min(a, b, c) / 10)
        at = cq.Vector(60.0 * (i % 20), 60.0 * (i // 20), 0)
        loc = cq.Location(at, cq.Vector(0, 0, 1), 7 * i)
        asm.add(w, name=f"part{i}", loc=loc, color=cq.Color(*(rng.random() for _ in range(3))))
    asm.save(str(path), exportType="STEP")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--parts", type=int, default=800)  # about 30 MB of STEP
    ap.add_argument("--work", type=Path, default=None, help="keep the files here")
    a = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        work = a.work or Path(tmp)
        work.mkdir(parents=True, exist_ok=True)
        src = work / f"scale{a.parts}.step"
        if not src.exists():  # in a child: a process's peak RSS passes to the children it forks
            code = "import sys; from pathlib import Path; sys.path.insert(0, sys.argv[3]); "
            code += "import scale; scale.make_assembly(int(sys.argv[1]), Path(sys.argv[2]))"
            here = str(Path(__file__).resolve().parent)
            subprocess.run([sys.executable, "-c", code, str(a.parts), str(src), here], check=True)
        nzc, out, ref = work / "scale.nzc", work / "back.step", work / "occt.step"
        got = {
            "read": timed("read", src, src),
            "compress": timed("compress", src, nzc),
            "decode": timed("decode", nzc, nzc),
            "decompress": timed("decompress", nzc, out),
            "write": timed("write", nzc, ref),
        }
        size, packed = src.stat().st_size, nzc.stat().st_size
    rd, wr = got["read"], got["write"]
    rows = [
        ("compress (0.01 mm) ÷ OCCT read", got["compress"]["s"] / rd["s"], "≤ 6×"),
        ("decode .nzc → shape ÷ OCCT read", got["decode"]["s"] / rd["s"], "≤ 0.3×"),
        ("decompress → STEP ÷ OCCT STEP write", got["decompress"]["s"] / wr["s"], "≤ 1.5×"),
        ("compress peak RSS ÷ read's", got["compress"]["rss_mb"] / rd["rss_mb"], "≤ 2×"),
    ]
    print("# Scale: a generated assembly (issue 30)\n")
    print(
        f"Written by `make bench` (`benchmarks/scale.py --parts {a.parts}`): one STEP "
        f"file of {a.parts} distinct parts made by cadquery (filleted blocks with holes, "
        "lofts to B-spline sections, revolved profiles, shelled blocks, each its own "
        f"product with a colour), {size:,} bytes; container {packed:,} bytes "
        f"({size / packed:.1f}×) at 0.01 mm.  Each step runs in a fresh process.\n"
    )
    print("| step | seconds | peak RSS (MB) |\n|---|---:|---:|")
    for k, v in got.items():
        print(f"| {k} | {v['s']:.2f} | {v['rss_mb']:.0f} |")
    print("\n| ratio | measured | goal (issue 30) |\n|---|---:|---|")
    for name, v, goal in rows:
        print(f"| {name} | {v:.2f}× | {goal} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
