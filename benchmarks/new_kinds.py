"""Parts of kinds neither the corpus nor the stress generator holds, made with
cadquery and checked end to end (docs/ratio-plan.md §28).

    python benchmarks/new_kinds.py OUT_DIR

Writes text cut into a plate, a swept helical thread, a polar pattern of
filleted holes, a nested coloured assembly, a sphere cut by planes and a
torus cut by a slot (three also as IGES, BRep mode), then for each: compress
at 0.01 and 0.1 mm and B-rep exact, ``nurbscomp eval`` of the container and
of the decompressed file against the source.  Prints one line per check and
exits 1 if any failed.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import cadquery as cq

TOLS = ("0.01", "0.1")


def _iges(shape: cq.Workplane, path: Path) -> None:
    from OCP.IGESControl import IGESControl_Writer
    from OCP.Interface import Interface_Static

    Interface_Static.SetIVal_s("write.iges.brep.mode", 1)
    w = IGESControl_Writer("MM", 1)
    w.AddShape(shape.val().wrapped)
    w.ComputeModel()
    w.Write(str(path))


def make(out: Path) -> list[Path]:
    """The parts, as STEP (and IGES for three of them), in ``out``."""
    out.mkdir(parents=True, exist_ok=True)
    parts: dict[str, cq.Workplane] = {}
    parts["text_plate"] = (
        cq.Workplane().box(60, 20, 5).faces(">Z").workplane().text("NZC 28", 8, -1.5, combine="cut")
    )
    helix = cq.Wire.makeHelix(pitch=2.0, height=10, radius=5)
    profile = (
        cq.Workplane("XZ").center(5, 0).polyline([(0, -0.6), (0.8, 0), (0, 0.6)]).close().wire()
    )
    parts["helix_thread"] = cq.Workplane().add(
        cq.Solid.sweep(profile.val(), [], helix, isFrenet=True)
    )
    parts["polar_holes"] = (
        cq.Workplane()
        .circle(30)
        .circle(10)
        .extrude(8)
        .edges("%CIRCLE")
        .fillet(1.5)
        .faces(">Z")
        .workplane()
        .polarArray(20, 0, 360, 8)
        .hole(4)
    )
    sphere = cq.Workplane().sphere(20).cut(cq.Workplane().box(50, 50, 50).translate((0, 0, 30)))
    parts["cut_sphere"] = sphere.cut(cq.Workplane().box(5, 50, 50).translate((12, 0, 0)))
    parts["slot_torus"] = (
        cq.Workplane().add(cq.Solid.makeTorus(20, 5)).cut(cq.Workplane().box(8, 60, 20))
    )
    files = []
    for name, shape in parts.items():
        cq.exporters.export(shape, str(out / f"{name}.step"))
        files.append(out / f"{name}.step")
        if name in ("text_plate", "polar_holes", "slot_torus"):
            _iges(shape, out / f"{name}.igs")
            files.append(out / f"{name}.igs")
    bolt = cq.Workplane().cylinder(20, 2).faces(">Z").fillet(0.5)
    nut = cq.Workplane().polygon(6, 8).extrude(4).faces(">Z").chamfer(0.5)
    sub = cq.Assembly(name="fastener").add(bolt, name="bolt", color=cq.Color("gray"))
    sub.add(nut, name="nut", loc=cq.Location((0, 0, 5)), color=cq.Color("yellow"))
    top = cq.Assembly(name="top")
    for i in range(4):
        top.add(sub, name=f"f{i}", loc=cq.Location((i * 15, 0, 0), (0, 0, 1), 30 * i))
    rail = cq.Workplane().box(70, 10, 2).translate((22.5, 0, -11))
    top.add(rail, name="rail", color=cq.Color("blue"))
    top.export(str(out / "nested_asm.step"))
    files.append(out / "nested_asm.step")
    return files


def _run(*args: str) -> int:
    cmd = [sys.executable, "-m", "nurbscomp.cli", *args]
    return subprocess.run(cmd, capture_output=True).returncode


def check(src: Path) -> list[str]:
    """One line per mode: the exit codes of compress, eval, decompress and
    eval of the decompressed file (all 0 when it passes), and the bytes."""
    lines = []
    for tol in (*TOLS, None):
        nzc = src.with_name(f"{src.name}.{tol or 'exact'}.nzc")
        how = ["--tol", tol] if tol else ["--lossless-brep"]
        codes = [_run("compress", "-q", "-f", *how, str(src), "-o", str(nzc))]
        codes.append(_run("eval", str(src), str(nzc), *(["--tol", tol] if tol else [])))
        if tol:
            back = src.with_name(f"back.{tol}.{src.name}")
            codes.append(_run("decompress", "-q", "-f", str(nzc), "-o", str(back)))
            codes.append(_run("eval", str(src), str(back), "--tol", tol))
        size = nzc.stat().st_size if nzc.exists() else 0
        verdict = "PASS" if not any(codes) else "FAIL"
        mode = tol or "B-rep exact"
        lines.append(f"{verdict} {src.name} {mode}: {src.stat().st_size} -> {size} bytes {codes}")
    return lines


def main() -> int:
    out = Path(sys.argv[1])
    failed = 0
    for src in make(out):
        for line in check(src):
            print(line, flush=True)
            failed += line.startswith("FAIL")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
