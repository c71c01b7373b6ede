"""Decompress to STEP with and without pcurves (issue 30 item 3), measured.

For each named corpus file: OCCT's read and STEP write of the source's shape;
for its 0.01 mm container the tables, the build, and our STEP write with
pcurves, then the build without the pcurves the container left out
(``model_to_shape(..., pcurves=False)``) and the write without pcurves (as
``decompress`` writes a container whose META has ``step_pcurves`` false);
bytes of both files, and whether the file without pcurves reads back with the
same topology counts.  Medians of 3.

    python benchmarks/step_output.py CORPUS_DIR CONTAINER_DIR STEM [STEM ...]

(``CONTAINER_DIR/STEM.nzc`` made with ``nurbscomp compress --tol 0.01``.)
"""

from __future__ import annotations

import statistics
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from nurbscomp import occ, pipeline
from nurbscomp.occ import topology


def _med(fn: Any, *a: Any) -> tuple[float, Any]:
    ts, out = [], None
    for _ in range(3):
        t = time.perf_counter()
        out = fn(*a)
        ts.append(time.perf_counter() - t)
    return statistics.median(ts), out


def main() -> None:
    corpus, containers = Path(sys.argv[1]), Path(sys.argv[2])
    for stem in sys.argv[3:]:
        src = next(p for p in corpus.iterdir() if p.stem == stem)
        d = Path(tempfile.mkdtemp())
        read_s, cad = _med(occ.read_cad, src)
        occt_w, _ = _med(occ.write_shape, cad.shape, d / "o.stp", "STEP", cad.unit)
        c = pipeline.read_container(containers / f"{stem}.nzc")
        tab_s, (m, meta) = _med(pipeline.decode, c)
        build_s, shape = _med(topology.model_to_shape, m)
        bare_s, bare_shape = _med(topology.model_to_shape, m, None, False)
        whole, bare = ({**meta, "step_pcurves": v} for v in (True, False))  # META's say
        w1, _ = _med(pipeline.write, shape, d / "a.stp", "STEP", m.unit, whole, m.product)
        w0, _ = _med(pipeline.write, bare_shape, d / "b.stp", "STEP", m.unit, bare, m.product)
        back = occ.read_cad(d / "b.stp")
        same = occ.counts(back.shape) == occ.counts(shape)
        now, bare_ratio = (tab_s + build_s + w1) / occt_w, (tab_s + bare_s + w0) / occt_w
        print(
            f"| {stem} | {read_s:.3f} | {occt_w:.3f} | {tab_s:.3f} | {build_s:.3f} | {w1:.3f} "
            f"| {now:.2f}x | {bare_s:.3f} | {w0:.3f} | {bare_ratio:.2f}x "
            f"| {(d / 'a.stp').stat().st_size} | {(d / 'b.stp').stat().st_size} | {same} |",
            flush=True,
        )


if __name__ == "__main__":
    main()
