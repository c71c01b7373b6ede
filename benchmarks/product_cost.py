"""What product data (format 1.2's PROD section) costs, file by file.

``python benchmarks/product_cost.py`` (``make bench-product``) reads every CAD
file of the corpus (``../shared/corpus``) and ``samples/assembly.step`` twice,
through OCCT's XDE readers and through the plain ones, and prints a Markdown
table: whether the geometry sections are byte-identical either way, the PROD
section's raw bytes, what it adds to the lossless container (the body is
compressed with it), the product structure (parts / assemblies / instances /
sub-shapes), colours, layers, what is dropped, and the read times.  Lossless
containers only: PROD is the same section in tolerance mode.
"""

from __future__ import annotations

import time
from pathlib import Path

from nurbscomp import container, occ, product, writer

ROOT = Path(__file__).resolve().parent.parent
CORPUS = ROOT.parent / "shared" / "corpus"
CAD = (".step", ".stp", ".igs", ".iges")


def sections(cad: occ.CadFile, path: Path, with_product: bool) -> list[tuple[str, bytes]]:
    """The lossless container sections of ``cad`` (with its product data or without)."""
    m, _ = occ.shape_to_model(cad.shape)
    m.unit, m.source_format = cad.unit, cad.source_format
    m.product = cad.product if with_product else None
    meta = {
        "mode": "lossless",
        "tolerance_mm": None,
        "source_name": path.name,
        "source_bytes": path.stat().st_size,
        "writer": "product_cost",
    }
    return writer.model_to_sections(m, meta)


def main() -> None:
    files = sorted(p for p in CORPUS.iterdir() if p.suffix.lower() in CAD)
    files.append(ROOT / "samples" / "assembly.step")
    print(
        "| file | geometry identical | PROD raw | container + | container without | "
        "parts/assemblies/instances/sub-shapes | colours | layers | dropped | XDE / plain read s |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|")
    before = after = 0
    for f in files:
        t0 = time.perf_counter()
        a = occ.read_cad(f, product=True)
        t1 = time.perf_counter()
        b = occ.read_cad(f)
        t2 = time.perf_counter()
        with_p, without = sections(a, f, True), sections(b, f, False)
        same = [s for s in with_p if s[0] != "PROD"] == without
        n1, n0 = len(container.pack(with_p, 1)), len(container.pack(without, 1))
        before, after = before + n0, after + n1
        s = product.summary(a.product)
        shape = f"{s['parts']}/{s['assemblies']}/{s['instances']}/{s['sub_shapes']}"
        print(
            f"| {f.name} | {same} | {len(product.write(a.product))} | {n1 - n0} | {n0} | "
            f"{shape} | {s['colours']} | {s['layers']} | {'; '.join(s['dropped']) or '-'} | "
            f"{t1 - t0:.2f} / {t2 - t1:.2f} |"
        )
    share = 100 * (after / before - 1)
    print(f"\ntotal: {before} -> {after} bytes (+{after - before}, {share:.2f}%)")


if __name__ == "__main__":
    main()
