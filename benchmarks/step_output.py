"""Decompress to STEP with and without pcurves (issue 30 item 3), measured.

For each named corpus file: OCCT's read and STEP write of the source's shape;
for its 0.01 mm container the tables, the build, and our STEP write as
decompress does it (pcurves written, ``write.surfacecurve.mode`` 1), then the
build without the pcurves the container left out and the write with
``write.surfacecurve.mode`` 0; bytes of both files, and whether the file
without pcurves reads back with the same topology counts.  Medians of 3.

    python benchmarks/step_output.py CORPUS_DIR CONTAINER_DIR STEM [STEM ...]

(``CONTAINER_DIR/STEM.nzc`` made with ``nurbscomp compress --tol 0.01``.)
"""

from __future__ import annotations

import statistics
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

from OCP.Interface import Interface_Static

from nurbscomp import occ, pipeline
from nurbscomp.model import REBUILD
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
        keep = m.edge_reps[:, 2] != REBUILD
        bare: Any = replace(m)
        bare.edge_reps, bare.edge_rep_range = m.edge_reps[keep], m.edge_rep_range[keep]
        bare.edge_rep_uv, bare.edge_rep_cont = m.edge_rep_uv[keep], m.edge_rep_cont[keep]
        bare_s, bare_shape = _med(topology.model_to_shape, bare)
        w1, _ = _med(pipeline.write, shape, d / "a.stp", "STEP", m.unit, meta, m.product)
        Interface_Static.SetIVal_s("write.surfacecurve.mode", 0)
        try:
            w0, _ = _med(pipeline.write, bare_shape, d / "b.stp", "STEP", m.unit, meta, m.product)
        finally:
            Interface_Static.SetIVal_s("write.surfacecurve.mode", 1)
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
