"""What the pcurves a container leaves out cost, per option (issue 30 item 2).

For each corpus file at 0.01 mm, three writer policies (no format change):
``drop`` (today: every pcurve that can be projected is left out), ``iso``
(pcurves that are 2-D lines along u or v are stored, the rest left out:
``encode.pcurves.STORE_ISO_LINES``) and ``keep`` (nothing left out).  For
each: container bytes, pcurves left to compute, and the decode (tables +
build) and projection seconds (medians of ``--repeat``), with OCCT's read of
the source for the ratio.

    python benchmarks/pcurve_options.py CORPUS_DIR [--repeat 3] [FILE ...]
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path
from typing import Any

from nurbscomp import budget, occ, pipeline
from nurbscomp.encode import pcurves
from nurbscomp.occ import topology

SUFFIXES = {".stp", ".step", ".igs", ".iges"}


def _decode_times(nzc: Path, n: int) -> tuple[float, float, int]:
    """Median decode seconds (tables + build), projection seconds, pcurves to compute."""
    orig = topology.rebuild_pcurves
    totals, projs = [], []
    count = 0
    for _ in range(n):
        spent = [0.0]

        def timed(*a: Any, _s: list[float] = spent, **kw: Any) -> Any:
            t = time.perf_counter()
            try:
                return orig(*a, **kw)
            finally:
                _s[0] += time.perf_counter() - t

        topology.rebuild_pcurves = timed  # type: ignore[assignment]
        try:
            t = time.perf_counter()
            _, m, _ = pipeline.decode_file(nzc)
            totals.append(time.perf_counter() - t)
        finally:
            topology.rebuild_pcurves = orig  # type: ignore[assignment]
        projs.append(spent[0])
        count = budget.pcurves_to_compute(m)[0]
    return statistics.median(totals), statistics.median(projs), count


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("corpus", type=Path)
    ap.add_argument("files", nargs="*")
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    files = sorted(p for p in args.corpus.iterdir() if p.suffix.lower() in SUFFIXES)
    if args.files:
        files = [p for p in files if p.name in args.files]
    orig_drop = pcurves.drop_pcurves
    print(
        "| file | OCCT read s | option | bytes | pcurves to compute "
        "| decode s | projections s | decode/read |"
    )
    print("|" + "---|" * 8)
    sums: dict[str, list[float]] = {}
    with tempfile.TemporaryDirectory() as d:
        for src in files:
            read_s = statistics.median(_t(occ.read_cad, src) for _ in range(args.repeat))
            for option in ("drop", "iso", "keep"):
                pcurves.STORE_ISO_LINES = option == "iso"
                if option == "keep":
                    pcurves.drop_pcurves = lambda m, e, f: m  # type: ignore[assignment]
                try:
                    dst = Path(d) / f"{src.stem}.{option}.nzc"
                    pipeline.compress_file(src, dst, tol=0.01, force=True)
                finally:
                    pcurves.drop_pcurves = orig_drop  # type: ignore[assignment]
                    pcurves.STORE_ISO_LINES = False
                size = dst.stat().st_size
                dec, proj, count = _decode_times(dst, args.repeat)
                s = sums.setdefault(option, [0.0] * 4)
                for i, v in enumerate((read_s, size, dec, proj)):
                    s[i] += v
                print(
                    f"| {src.name} | {read_s:.3f} | {option} | {size} | {count} | {dec:.3f} "
                    f"| {proj:.3f} | {dec / read_s:.2f}x |",
                    flush=True,
                )
    for option, (r, size, dec, proj) in sums.items():
        print(
            f"| **total** | {r:.3f} | {option} | {int(size)} | "
            f"| {dec:.3f} | {proj:.3f} | {dec / r:.2f}x |"
        )


def _t(fn: Any, *a: Any) -> float:
    t = time.perf_counter()
    fn(*a)
    return time.perf_counter() - t


if __name__ == "__main__":
    main()
