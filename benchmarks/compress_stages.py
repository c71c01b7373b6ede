"""Where compress spends its time, stage by stage (issue 30, item 4), in one run.

For each corpus file (STEP or IGES): OCCT's plain read of the source
(``occ.read_cad``), then ``pipeline.compress_file(path, out, tol=TOL)`` (STEP
check and verify on) with a timer round each stage.  Each stage's time is
*exclusive* (a stage called inside another is taken out of it), in wall
seconds and in this process's CPU seconds (``time.process_time``, all its
threads); the round-trip children's CPU (``os.times``) is summed per file.
CPU seconds hold up on a machine others load, wall seconds do not.

    python benchmarks/compress_stages.py CORPUS_DIR [--tol 0.01] [--serial] [--out DIR]

``--serial`` answers "no spare core" wherever compress asks
(``occ.spare_core``), as it mostly is under ``make bench`` (two workers on
two cores): the round trips then run after BRepCheck, not beside it.  The
sha256 of each container is printed, to compare two trees' outputs.
"""

from __future__ import annotations

import argparse
import collections
import functools
import hashlib
import os
import tempfile
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from nurbscomp import container, occ, pipeline
from nurbscomp.encode import nets, validity
from nurbscomp.occ import isolated, topology
from nurbscomp.stages import compress as stage_compress

SUFFIXES = {".stp", ".step", ".igs", ".iges"}

#: (object, attribute, stage) of each function timed.
STAGES: list[tuple[Any, str, str]] = [
    (pipeline, "read_source", "XDE read of the source"),
    (occ, "shape_to_model", "shape -> tables"),
    (nets, "code_model", "net search (nets.code_model)"),
    (occ, "edge_points", "edge points, sewn pairs"),
    (occ, "sewn_edge_pairs", "edge points, sewn pairs"),
    (validity._Plan, "_grid_pays", "analytic grid choice (_grid_pays)"),
    (validity._Plan, "candidate", "assembling candidates"),
    (validity, "build", "candidate builds (model_to_shape)"),
    (occ, "failures", "BRepCheck (occ.failures)"),
    (occ.RoundTrip, "ask", "waiting on round-trip children"),
    (occ.RoundTrip, "__enter__", "forking round trips"),
    (validity._Floor, "signatures", "face signatures (source, floor)"),
    (container, "pack", "entropy stage (container.pack)"),
    (stage_compress, "model_to_sections", "sections (model_to_sections)"),
    (pipeline, "verify_encoded", "verify"),
    (occ, "thin_solids", "thin solids, diagonal"),
    (occ, "diagonal", "thin solids, diagonal"),
    (validity, "vertex_neighbours", "plan set-up"),
    (validity._Plan, "step", "plan rungs"),
    (validity._Plan, "brepcheck", "plan rungs"),
    (validity, "lossy_target", "validity stage, the rest"),
    (pipeline, "compress_file", "compress, the rest"),
]


class Timers:
    """Exclusive wall and CPU seconds per stage, in the main thread."""

    def __init__(self) -> None:
        self.wall: collections.Counter[str] = collections.Counter()
        self.cpu: collections.Counter[str] = collections.Counter()
        self.calls: collections.Counter[str] = collections.Counter()
        self._stack: list[list[float]] = []

    def wrap(self, f: Callable[..., Any], stage: str) -> Callable[..., Any]:
        @functools.wraps(f)
        def timed(*a: Any, **k: Any) -> Any:
            if threading.current_thread() is not threading.main_thread():
                return f(*a, **k)
            w, c = time.perf_counter(), time.process_time()
            self._stack.append([0.0, 0.0])
            try:
                return f(*a, **k)
            finally:
                dw, dc = time.perf_counter() - w, time.process_time() - c
                inner = self._stack.pop()
                self.wall[stage] += dw - inner[0]
                self.cpu[stage] += dc - inner[1]
                self.calls[stage] += 1
                if self._stack:
                    self._stack[-1][0] += dw
                    self._stack[-1][1] += dc

        return timed

    def install(self) -> None:
        for obj, name, stage in STAGES:
            setattr(obj, name, self.wrap(getattr(obj, name), stage))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("corpus", type=Path)
    ap.add_argument("--tol", type=float, default=0.01)
    ap.add_argument("--serial", action="store_true", help="no spare core, as under make bench")
    ap.add_argument("--out", type=Path, help="keep the containers here")
    ap.add_argument("--lossless", action="store_true", help="--lossless-brep instead of --tol")
    args = ap.parse_args()
    if args.serial:

        def never() -> bool:
            return False

        isolated.spare_core = topology.spare_core = occ.spare_core = never  # type: ignore[assignment]
    timers = Timers()
    timers.install()
    out = args.out or Path(tempfile.mkdtemp(prefix="compress-stages-"))
    out.mkdir(parents=True, exist_ok=True)
    files = sorted(p for p in args.corpus.iterdir() if p.suffix.lower() in SUFFIXES)
    total = collections.Counter[str]()
    print("| file | read s | compress s | ÷ | rounds | trips ", end="")
    print("| CPU read | CPU compress + children | ÷ | sha256 |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---|")
    for p in files:
        w, c = time.perf_counter(), time.process_time()
        occ.read_cad(p)
        read_w, read_c = time.perf_counter() - w, time.process_time() - c
        dst = out / f"{p.name}.nzc"
        t0 = os.times()
        w, c = time.perf_counter(), time.process_time()
        r = pipeline.compress_file(p, dst, tol=args.tol, lossless=args.lossless, force=True)
        comp_w, comp_c = time.perf_counter() - w, time.process_time() - c
        t1 = os.times()
        kids = t1.children_user + t1.children_system - t0.children_user - t0.children_system
        v = r["validity"]  # empty for --lossless
        rounds, trips = v.get("rounds", 0), v.get("step_round_trips", 0)
        sha = hashlib.sha256(dst.read_bytes()).hexdigest()[:16]
        total.update(read_w=read_w, read_c=read_c, comp_w=comp_w, comp_c=comp_c, kids=kids)
        print(
            f"| {p.name} | {read_w:.3f} | {comp_w:.2f} | {comp_w / read_w:.1f}× | {rounds} "
            f"| {trips} | {read_c:.3f} | {comp_c:.2f} + {kids:.2f} "
            f"| {(comp_c + kids) / read_c:.1f}× | {sha} |",
            flush=True,
        )
    print(
        f"\ncorpus: read {total['read_w']:.2f} s, compress {total['comp_w']:.2f} s "
        f"({total['comp_w'] / total['read_w']:.2f}×); CPU: read {total['read_c']:.2f} s, "
        f"compress {total['comp_c']:.2f} s + children {total['kids']:.2f} s "
        f"({(total['comp_c'] + total['kids']) / total['read_c']:.2f}×)\n"
    )
    print("| stage | calls | wall s | share | CPU s | share |")
    print("|---|---:|---:|---:|---:|---:|")
    for stage, s in timers.wall.most_common():
        print(
            f"| {stage} | {timers.calls[stage]} | {s:.2f} | {s / total['comp_w']:.0%} "
            f"| {timers.cpu[stage]:.2f} | {timers.cpu[stage] / total['comp_c']:.0%} |"
        )


if __name__ == "__main__":
    main()
