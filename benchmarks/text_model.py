"""The byte-exact STEP text model against xz -9e and OCCT's STEP read (issue 29).

For each corpus STEP file (read in place from ../shared/corpus) and a few STEP
files written by cadquery (a filleted part, an assembly with colours), in one
run: the source bytes; ``xz -9e`` bytes and time (the command line tool);
the STEP model's payload bytes (``nurbscomp.text.step.encode``, plus the
method byte ``nurbscomp.text`` adds); xz's bytes over the model's; the model's
encode time over xz's; its decode time over OCCT's STEP read of the same file
(``STEPControl_Reader`` ReadFile + TransferRoots); and the SHA-256 check.
Then the totals.  Usage: ``python benchmarks/text_model.py [--no-occt]``.
"""

from __future__ import annotations

import argparse
import hashlib
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
CORPUS = ROOT.parent / "shared" / "corpus"

from benchmarks.exact import best_of, xz  # noqa: E402
from nurbscomp.text import step  # noqa: E402


def occt_read(path: Path) -> float:
    """Seconds of OCCT's STEP read: ReadFile and TransferRoots."""
    from OCP.IFSelect import IFSelect_RetDone
    from OCP.STEPControl import STEPControl_Reader

    def run() -> None:
        r = STEPControl_Reader()
        assert r.ReadFile(str(path)) == IFSelect_RetDone
        r.TransferRoots()

    return best_of(run, 2)


def generated(folder: Path) -> list[Path]:
    """STEP files written by cadquery into ``folder``."""
    import cadquery as cq

    part = cq.Workplane().box(40, 30, 10).faces(">Z").hole(6).edges("|Z").fillet(3)
    loft = cq.Workplane().circle(10).workplane(offset=20).rect(8, 12).loft()
    out = []
    for name, shape in (("part", part), ("loft", loft)):
        p = folder / f"cq_{name}.step"
        cq.exporters.export(shape, str(p))
        out.append(p)
    asm = cq.Assembly()
    for i in range(6):
        asm.add(
            part, name=f"p{i}", color=cq.Color(i / 6, 0.2, 0.5), loc=cq.Location((50 * i, 0, 0))
        )
    asm.add(loft, name="loft", color=cq.Color("red"))
    p = folder / "cq_assembly.step"
    asm.save(str(p))
    out.append(p)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--no-occt", action="store_true", help="skip OCCT's read (no OCP)")
    a = ap.parse_args()
    files = sorted(p for p in CORPUS.iterdir() if p.suffix.lower() in (".step", ".stp"))
    with tempfile.TemporaryDirectory() as d:
        files += generated(Path(d))
        cols = "file | source | xz -9e | model | xz / model | encode / xz | decode / OCCT read"
        print(f"| {cols} | SHA-256 |")
        print("|---|---:|---:|---:|---:|---:|---:|---|")
        tot = [0, 0, 0]
        for p in files:
            data = p.read_bytes()
            xb, xt = xz(p)
            payload: list[bytes | None] = []
            et = best_of(lambda: payload.append(step.encode(data)), 2)  # noqa: B023
            blob = payload[-1]
            assert blob is not None
            back: list[bytes] = []
            dt = best_of(lambda: back.append(step.decode(blob, len(data))), 3)  # noqa: B023
            same = hashlib.sha256(back[-1]).digest() == hashlib.sha256(data).digest()
            ot = None if a.no_occt else occt_read(p)
            size = 1 + len(blob)
            tot[0] += len(data)
            tot[1] += xb
            tot[2] += size
            occ = f"{dt / ot:.3f} ({dt:.2f} / {ot:.2f} s)" if ot else f"- ({dt:.2f} s)"
            print(
                f"| {p.name} | {len(data):,} | {xb:,} | {size:,} | {xb / size:.2f} "
                f"| {et / xt:.2f} ({et:.2f} / {xt:.2f} s) | {occ} "
                f"| {'equal' if same else 'DIFFERS'} |"
            )
        print(f"| total | {tot[0]:,} | {tot[1]:,} | {tot[2]:,} | {tot[1] / tot[2]:.3f} | | | |")


if __name__ == "__main__":
    main()
