"""Byte-exact lossless (``compress --lossless``) against xz -9e and OCCT's read (issue 29).

For each corpus STEP/IGES file (read in place from ../shared/corpus) and a few
files written by OCCT here (a filleted part and an assembly as STEP, a part as
IGES in BRep mode), in one run:

* the source bytes, ``xz -9e`` bytes and time (the command-line tool, best of 3);
* the byte-exact container (``passthrough.pack``: the container the CLI
  writes, header and META included), its bytes, and the time to make it
  (``text.encode``'s model, or plain LZMA where that is smaller; best of 2);
* the time to give the file back from the container (``passthrough.read``:
  unpack, text model decode, SHA-256 check; best of 3), against OCCT's read of
  the same file (STEP: ``STEPControl_Reader``, IGES: ``IGESControl_Reader``,
  ReadFile + TransferRoots; best of 3);
* whether the bytes came back identical (SHA-256).

Prints a Markdown report (``make bench`` writes it to docs/benchmarks-exact.md).
Usage: ``python benchmarks/exact.py``.
"""

from __future__ import annotations

import hashlib
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
CORPUS = ROOT.parent / "shared" / "corpus"
CAD = (".step", ".stp", ".igs", ".iges")

from nurbscomp import container, passthrough  # noqa: E402


def best_of(f: Callable[[], object], n: int) -> float:
    """The shortest of ``n`` wall-clock timings of ``f()``, in seconds."""
    ts = []
    for _ in range(n):
        t = time.perf_counter()
        f()
        ts.append(time.perf_counter() - t)
    return min(ts)


def xz(path: Path) -> tuple[int, float]:
    """Bytes and seconds of ``xz -9e -c path``."""
    size: list[int] = []

    def run() -> None:
        r = subprocess.run(["xz", "-9e", "-c", str(path)], capture_output=True, check=True)
        size.append(len(r.stdout))

    t = best_of(run, 3)
    return size[-1], t


def occt_read(path: Path, fmt: str) -> float:
    """Seconds of OCCT's read of ``path``: ReadFile and TransferRoots."""
    from OCP.IFSelect import IFSelect_RetDone
    from OCP.IGESControl import IGESControl_Reader
    from OCP.STEPControl import STEPControl_Reader

    def run() -> None:
        r = STEPControl_Reader() if fmt == "STEP" else IGESControl_Reader()
        assert r.ReadFile(str(path)) == IFSelect_RetDone
        r.TransferRoots()

    return best_of(run, 3)


def generated(folder: Path) -> list[Path]:
    """STEP and IGES files written by OCCT from cadquery shapes (other writers'
    layouts than the corpus's)."""
    import cadquery as cq
    from OCP.IGESControl import IGESControl_Controller, IGESControl_Writer
    from OCP.Interface import Interface_Static

    part = (
        cq.Workplane()
        .box(40, 30, 10)
        .faces(">Z")
        .workplane()
        .hole(8)
        .edges("|Z")
        .fillet(3)
        .faces(">Z")
        .edges()
        .chamfer(0.8)
    )
    out = [folder / "cq_part.step", folder / "cq_assembly.step", folder / "cq_part_brep.igs"]
    cq.exporters.export(part, str(out[0]))
    asm = cq.Assembly()
    for i in range(6):
        asm.add(part, name=f"p{i}", loc=cq.Location((50 * i, 0, 0)), color=cq.Color("red"))
    asm.save(str(out[1]))
    IGESControl_Controller.Init_s()
    Interface_Static.SetCVal_s("write.iges.brep.mode", "BRep")
    w = IGESControl_Writer("MM", 1)
    w.AddShape(part.val().wrapped)
    w.ComputeModel()
    assert w.Write(str(out[2]))
    return out


def measure(path: Path) -> dict[str, object]:
    data = path.read_bytes()
    fmt = "IGES" if path.suffix.lower() in (".igs", ".iges") else "STEP"
    xz_bytes, xz_s = xz(path)
    blob = b""

    def pack() -> None:
        nonlocal blob
        blob = passthrough.pack(data, fmt, path.name)

    enc_s = best_of(pack, 2)
    back = b""

    def read() -> None:
        nonlocal back
        back = passthrough.read(container.unpack(blob))[1]

    dec_s = best_of(read, 3)
    return {
        "name": path.name,
        "source": len(data),
        "xz": xz_bytes,
        "nzc": len(blob),
        "model": passthrough.read(container.unpack(blob))[0]["model"],
        "enc_xz": enc_s / xz_s,
        "dec_read": dec_s / occt_read(path, fmt),
        "exact": hashlib.sha256(back).digest() == hashlib.sha256(data).digest(),
    }


def main() -> None:
    files = sorted(p for p in CORPUS.iterdir() if p.suffix.lower() in CAD)
    with tempfile.TemporaryDirectory() as d:
        made = generated(Path(d))
        rows = [measure(p) for p in files]
        gen = [measure(p) for p in made]
    w = print
    w("# Byte-exact lossless (`compress --lossless`) against xz -9e and OCCT's read\n")
    w(
        "Written by `make bench` (`benchmarks/exact.py`), one run on this machine. "
        "`.nzc` is the whole container the CLI writes (header and META with the SHA-256 "
        "included). Times are ratios measured in the same run: making the container over "
        "`xz -9e` of the file (the command-line tool, with its start-up), and giving "
        "the file back from the container (unpack, text model, SHA-256 check) over "
        "OCCT's read of the file (ReadFile + TransferRoots).\n"
    )
    head = (
        "| file | source bytes | xz -9e | .nzc | xz ÷ .nzc | model | compress ÷ xz time "
        "| restore ÷ OCCT read | byte-exact |"
    )
    for title, rs in (("Corpus", rows), ("Written by OCCT here", gen)):
        w(f"## {title}\n")
        w(head)
        w("|---|---:|---:|---:|---:|---|---:|---:|---|")
        for r in rs:
            w(
                f"| {r['name']} | {r['source']:,} | {r['xz']:,} | {r['nzc']:,} | "
                f"{r['xz'] / r['nzc']:.2f}× | {r['model']} | {r['enc_xz']:.2f} | "
                f"{r['dec_read']:.3f} | {'yes' if r['exact'] else '**NO**'} |"
            )
        tx = sum(int(r["xz"]) for r in rs)
        tn = sum(int(r["nzc"]) for r in rs)
        ts = sum(int(r["source"]) for r in rs)
        w(
            f"| **total** | {ts:,} | {tx:,} | {tn:,} | **{tx / tn:.2f}×** | | | | "
            f"{'all' if all(r['exact'] for r in rs) else '**not all**'} |\n"
        )
        w(
            f"Ratio to the source: xz -9e {ts / tx:.2f}×, byte-exact .nzc {ts / tn:.2f}×. "
            f"Lowest file: {min(float(r['xz']) / float(r['nzc']) for r in rs):.2f}× its xz -9e; "
            f"slowest compress {max(float(r['enc_xz']) for r in rs):.2f}× xz; slowest restore "
            f"{max(float(r['dec_read']) for r in rs):.3f}× OCCT's read.\n"
        )
    w(
        "Goals (issue 29): corpus total ≥ 1.6× xz -9e, no file below 1.2×; compress no "
        "slower than xz -9e; restore ≤ 0.2× OCCT's read; every file byte-exact."
    )


if __name__ == "__main__":
    main()
