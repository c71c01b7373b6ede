"""Decode speed against OCCT's own reader (issue 30), in one run.

For each corpus file (STEP or IGES) and each mode (0.01 mm, lossless-brep):
OCCT's read of the source (``occ.read_cad``), then for its container the
table decode (``pipeline.decode``), the build with the per-entity builder
(``topology.slow_model_to_shape``) and with the BinTools-stream builder
(``topology.model_to_shape``), and of each build the seconds spent projecting
the pcurves the container left out.  Medians of ``--repeat`` runs; the
ratios are decode (tables + build) / OCCT read, before (per-entity) and after
(stream).

    python benchmarks/decode_speed.py CORPUS_DIR [--containers DIR] [--repeat 3]

Containers are made in a temporary folder unless ``--containers`` holds them
(named ``<stem>.nzc`` and ``<stem>.lb.nzc``).
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path
from typing import Any

from nurbscomp import occ, pipeline
from nurbscomp.occ import topology

SUFFIXES = {".stp", ".step", ".igs", ".iges"}


class _Projections:
    """Seconds spent in ``topology.rebuild_pcurves`` while installed."""

    def __init__(self) -> None:
        self.seconds = 0.0
        self._orig = topology.rebuild_pcurves

    def __enter__(self) -> _Projections:
        def timed(*a: Any, **kw: Any) -> Any:
            t = time.perf_counter()
            try:
                return self._orig(*a, **kw)
            finally:
                self.seconds += time.perf_counter() - t

        topology.rebuild_pcurves = timed  # type: ignore[assignment]
        return self

    def __exit__(self, *exc: object) -> None:
        topology.rebuild_pcurves = self._orig  # type: ignore[assignment]


def _median(n: int, fn: Any, *args: Any) -> tuple[float, float]:
    """Median seconds of ``fn(*args)`` and of the projections inside it."""
    total, proj = [], []
    for _ in range(n):
        with _Projections() as p:
            t = time.perf_counter()
            fn(*args)
            total.append(time.perf_counter() - t)
        proj.append(p.seconds)
    return statistics.median(total), statistics.median(proj)


def _container(src: Path, folder: Path, lossless: bool) -> Path:
    dst = folder / (src.stem + (".lb.nzc" if lossless else ".nzc"))
    if not dst.exists():
        pipeline.compress_file(src, dst, tol=None if lossless else 0.01, lossless=lossless)
    return dst


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("corpus", type=Path)
    ap.add_argument("--containers", type=Path)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    files = sorted(p for p in args.corpus.iterdir() if p.suffix.lower() in SUFFIXES)
    tmp = tempfile.TemporaryDirectory()
    folder = args.containers or Path(tmp.name)
    head = (
        "| file | mode | OCCT read s | tables s | build before s | build after s "
        "| of which pcurves s | decode/read before | after |"
    )
    print(head)
    print("|" + "---|" * 9)
    sums: dict[str, list[float]] = {}
    for src in files:
        read_s, _ = _median(args.repeat, occ.read_cad, src)
        for lossless in (False, True):
            nzc = _container(src, folder, lossless)
            c = pipeline.read_container(nzc)
            tables_s, _ = _median(args.repeat, pipeline.decode, c)
            m, _ = pipeline.decode(c)
            slow_s, _ = _median(args.repeat, topology.slow_model_to_shape, m)
            fast_s, proj_s = _median(args.repeat, topology.model_to_shape, m)
            mode = "lossless-brep" if lossless else "0.01 mm"
            before, after = (tables_s + slow_s) / read_s, (tables_s + fast_s) / read_s
            s = sums.setdefault(mode, [0.0] * 5)
            for i, v in enumerate((read_s, tables_s, slow_s, fast_s, proj_s)):
                s[i] += v
            print(
                f"| {src.name} | {mode} | {read_s:.3f} | {tables_s:.3f} | {slow_s:.3f} "
                f"| {fast_s:.3f} | {proj_s:.3f} | {before:.2f}x | {after:.2f}x |"
            )
    for mode, (r, t, sl, fa, pr) in sums.items():
        print(
            f"| **total** | {mode} | {r:.3f} | {t:.3f} | {sl:.3f} | {fa:.3f} | {pr:.3f} "
            f"| {(t + sl) / r:.2f}x | {(t + fa) / r:.2f}x |"
        )
    print("fast-builder fallbacks:", dict(topology.FAST_STATS))


if __name__ == "__main__":
    main()
