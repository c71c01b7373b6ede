"""Where a container's bytes are, section by section (issue 28).

``python benchmarks/sections.py > docs/benchmarks-sections.md`` (part of
``make bench``) compresses every CAD file of the corpus (``../shared/corpus``)
at 0.001, 0.01 and 0.1 mm and lossless with ``pipeline.compress_file``
(``verify=False``: the container's bytes are the same as with the check),
unpacks each container and prints, per section, its raw bytes and its bytes
when that section alone is compressed with ``lzma`` (xz format, preset
9 | extreme; the .xz framing adds about 57 bytes to each).  A totals table
(summed over the files) comes first, then one table per file, and the bits per
coded pole: SNET (CNET) bytes, xz alone, x 8 over the poles of the coded
surface (curve) rows (first occurrences; a CNET copy or iso-boundary row counts
its poles too).  Last, ``SHAP``'s bits per edge use (issue 28's goal: 2): the
section's raw bytes (the walk's range-coded stream and its header) x 8 over
the references from wires to edges.  ``--keep DIR`` keeps the containers in DIR.
"""

from __future__ import annotations

import argparse
import lzma
import tempfile
from collections import defaultdict
from pathlib import Path

from nurbscomp import container, pipeline, serialize

ROOT = Path(__file__).resolve().parent.parent
CORPUS = ROOT.parent / "shared" / "corpus"
CAD = (".step", ".stp", ".igs", ".iges")
MODES = (0.001, 0.01, 0.1, None)  # None: lossless
ORDER = serialize.layout(container.REVISION)


def xz(raw: bytes) -> int:
    """Bytes of ``raw`` compressed alone by xz -9e."""
    return len(lzma.compress(raw, preset=9 | lzma.PRESET_EXTREME))


def measure(src: Path, tol: float | None, dst: Path) -> dict[str, tuple[int, int]]:
    """Per section tag, (raw bytes, xz bytes) of ``src``'s container; under
    ``"file"`` the container's bytes, under ``"poles"`` the coded surface and
    curve poles."""
    pipeline.compress_file(src, dst, tol=tol, lossless=tol is None, force=True, verify=False)
    data = dst.read_bytes()
    c = container.unpack(data)
    out = {s.tag: (len(s.raw), xz(s.raw)) for s in c.sections}
    out["file"] = (len(data), len(data))
    m, _, _ = serialize.read_sections(c.get, c.revision, None)
    surf = sum(m.surfaces[i].poles[..., 0].size for i in serialize.coded_rows(m.surfaces))
    crv = sum(len(m.curves3d[i].poles) for i in serialize.coded_rows(m.curves3d))
    out["poles"] = (surf, crv)
    wires = (m.shape_type == 5).nonzero()[0]
    kids = [m.child_shape[m.child_start[w] : m.child_start[w + 1]] for w in wires]
    out["edge uses"] = (sum(int((m.shape_type[k] == 6).sum()) for k in kids), 0)
    return out


def label(tol: float | None) -> str:
    return "lossless" if tol is None else f"{tol:g} mm"


def table(rows: dict[float | None, dict[str, tuple[int, int]]]) -> list[str]:
    """A Markdown table: a row per section, raw and xz bytes per mode."""
    head = " | ".join(f"{label(t)} raw | {label(t)} xz" for t in MODES)
    out = [f"| section | {head} |", "|---" + "|---:" * 2 * len(MODES) + "|"]
    tags = [t for t in ORDER if any(t in rows[m] for m in MODES)]
    for tag in tags:
        cells = " | ".join(
            f"{rows[m].get(tag, (0, 0))[0]:,} | {rows[m].get(tag, (0, 0))[1]:,}" for m in MODES
        )
        out.append(f"| {tag} | {cells} |")
    sums = " | ".join(
        f"{sum(rows[m][t][i] for t in tags if t in rows[m]):,}" for m in MODES for i in (0, 1)
    )
    out.append(f"| sum of sections | {sums} |")
    files = "".join(f" | | **{rows[m]['file'][0]:,}**" for m in MODES)
    out.append(f"| **container**{files} |")
    return out


def bits_per_pole(rows: dict[float | None, dict[str, tuple[int, int]]]) -> list[str]:
    out = [
        "| tolerance | coded surface poles | SNET bits/pole | coded curve poles | "
        "CNET bits/pole | SNET+CNET bits/pole |",
        "|---|---:|---:|---:|---:|---:|",
    ]
    for m in MODES[:-1]:
        sp, cp = rows[m]["poles"]
        s, c = 8 * rows[m]["SNET"][1], 8 * rows[m]["CNET"][1]
        out.append(
            f"| {label(m)} | {sp:,} | {s / sp:.2f} | {cp:,} | {c / cp:.2f} | "
            f"{(s + c) / (sp + cp):.2f} |"
        )
    return out


def edge_uses(per_file: dict[str, dict[float | None, dict[str, tuple[int, int]]]]) -> list[str]:
    """SHAP's bits per edge use at 0.01 mm (the section is the same at every
    tolerance; B-rep-exact containers of 2,048 references or more hold the
    arrays instead), per file and in all."""
    out = ["| file | edge uses | SHAP bytes | bits per edge use |", "|---|---:|---:|---:|"]
    uses = shap = 0
    for name, rows in per_file.items():
        u, b = rows[0.01]["edge uses"][0], rows[0.01]["SHAP"][0]
        uses, shap = uses + u, shap + b
        out.append(f"| {name} | {u:,} | {b:,} | {8 * b / max(u, 1):.2f} |")
    out.append(f"| **total** | **{uses:,}** | **{shap:,}** | **{8 * shap / max(uses, 1):.2f}** |")
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--keep", type=Path, help="keep the containers in this folder")
    args = ap.parse_args()
    files = sorted(p for p in CORPUS.iterdir() if p.suffix.lower() in CAD)
    per_file: dict[str, dict[float | None, dict[str, tuple[int, int]]]] = {}
    total: dict[float | None, dict[str, tuple[int, int]]] = {
        m: defaultdict(lambda: (0, 0)) for m in MODES
    }
    with tempfile.TemporaryDirectory() as tmp:
        folder = args.keep or Path(tmp)
        folder.mkdir(parents=True, exist_ok=True)
        for f in files:
            per_file[f.name] = {}
            for m in MODES:
                dst = folder / f"{f.name}.{label(m).replace(' ', '')}.nzc"
                r = per_file[f.name][m] = measure(f, m, dst)
                for k, (a, b) in r.items():
                    x, y = total[m][k]
                    total[m][k] = (x + a, y + b)
    print("# Bytes per section\n")
    print("Made by `benchmarks/sections.py` (`make bench`). Each corpus file compressed with")
    print("the defaults at each tolerance and lossless; per section of the container, its raw")
    print("bytes and its bytes when compressed alone by xz -9e (Python's `lzma`, .xz framing,")
    print("about 57 bytes a section). The container compresses all sections as one body, so")
    print("it is smaller than the sum of the sections' xz bytes.\n")
    print("## Corpus totals\n")
    print("\n".join(table(total)) + "\n")
    print("Bits per coded pole (xz bytes of the section alone x 8 / poles of its coded rows):\n")
    print("\n".join(bits_per_pole(total)) + "\n")
    print("`SHAP`: bits per edge use (its raw bytes x 8 / the references from wires to")
    print("edges; the same section at every tolerance, the walk of docs/format.md")
    print("§2.5.1, where the B-rep-exact containers of large models hold its arrays):\n")
    print("\n".join(edge_uses(per_file)) + "\n")
    for name, rows in per_file.items():
        print(f"## {name}\n")
        print("\n".join(table(rows)) + "\n")


if __name__ == "__main__":
    main()
