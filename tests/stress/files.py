"""Write the stress corpus (:mod:`tests.stress.shapes`) to STEP and IGES files.

Each shape gives three files, named after its entry:

* ``<name>.step`` — AP214, ``STEPControl_Writer`` in ``STEPControl_AsIs`` mode;
* ``<name>.brep.igs`` — IGES in BRep mode (``IGESControl_Writer("MM", 1)``:
  manifold solids, shells, faces as entities 186/514/510);
* ``<name>.faces.igs`` — IGES in faces mode (``IGESControl_Writer("MM", 0)``:
  trimmed surfaces, entity 144, no shared topology).

The STEP header's time stamp and the IGES dates are fixed and products are
named after the entry, so the same shape gives the same bytes.

``python -m tests.stress.files DIR [--only S,...] [--seed N] [--together]`` writes
them all (``--together``: as one model, side by side).
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from OCP.APIHeaderSection import APIHeaderSection_MakeHeader
from OCP.IFSelect import IFSelect_ReturnStatus
from OCP.IGESControl import IGESControl_Writer
from OCP.Interface import Interface_Static
from OCP.Message import Message
from OCP.StepBasic import StepBasic_Product
from OCP.STEPControl import STEPControl_AsIs, STEPControl_Writer
from OCP.TCollection import TCollection_HAsciiString

from . import shapes as shapes_mod
from .shapes import Entry

# OCCT's writers print statistics on stdout; keep it for the reports
Message.DefaultMessenger_s().ChangePrinters().Clear()

#: (suffix, format) of the three files of each shape, in this order.
FORMATS = (("step", ".step"), ("brep", ".brep.igs"), ("faces", ".faces.igs"))

_STAMP = "1970-01-01T00:00:00"
_IGES_DATE = "19700101.000000"


class WriteError(RuntimeError):
    """An OCCT writer refused a shape."""


def write_step(shape: Any, path: Path, name: str) -> None:
    """AP214, AsIs, millimetres, with a fixed header."""
    Interface_Static.SetCVal_s("write.step.schema", "AP214IS")
    Interface_Static.SetCVal_s("write.step.unit", "MM")
    w = STEPControl_Writer()
    status = w.Transfer(shape, STEPControl_AsIs)
    if status != IFSelect_ReturnStatus.IFSelect_RetDone:
        raise WriteError(f"STEP transfer: {status.name}")
    model = w.Model()
    for i in range(1, model.NbEntities() + 1):
        e = model.Value(i)
        if isinstance(e, StepBasic_Product):
            e.SetName(TCollection_HAsciiString(name))
            e.SetId(TCollection_HAsciiString(name))
    header = APIHeaderSection_MakeHeader(model)
    header.SetName(TCollection_HAsciiString(path.name))
    header.SetTimeStamp(TCollection_HAsciiString(_STAMP))
    header.SetOriginatingSystem(TCollection_HAsciiString("nurbscomp stress corpus"))
    status = w.Write(str(path))
    if status != IFSelect_ReturnStatus.IFSelect_RetDone:
        raise WriteError(f"STEP write: {status.name}")


def write_iges(shape: Any, path: Path, brep_mode: int) -> None:
    """IGES in millimetres, BRep mode (1) or faces mode (0), with fixed dates."""
    w = IGESControl_Writer("MM", brep_mode)
    if not w.AddShape(shape):
        raise WriteError("IGES writer refused the shape")
    w.ComputeModel()
    gs = w.Model().GlobalSection()
    gs.SetDate(TCollection_HAsciiString(_IGES_DATE))
    gs.SetLastChangeDate(TCollection_HAsciiString(_IGES_DATE))
    w.Model().SetGlobalSection(gs)
    if not w.Write(str(path)):
        raise WriteError("IGES write failed")


def write_entry(
    entry: Entry,
    folder: str | Path,
    formats: Iterable[str] = ("step", "brep", "faces"),
    shape: Any = None,
) -> list[Path]:
    """Build one entry (unless ``shape`` is given) and write it; the paths written."""
    folder = Path(folder)
    shape = entry.build() if shape is None else shape
    if shape is None or shape.IsNull():
        raise WriteError(f"{entry.name}: the builder gave an empty shape")
    wanted = set(formats)
    out = []
    for fmt, suffix in FORMATS:
        if fmt not in wanted:
            continue
        p = folder / f"{entry.name}{suffix}"
        try:
            if fmt == "step":
                write_step(shape, p, entry.name)
            else:
                write_iges(shape, p, 1 if fmt == "brep" else 0)
        except BaseException:
            p.unlink(missing_ok=True)
            raise
        out.append(p)
    return out


def write_all(
    folder: str | Path,
    items: Iterable[Entry] | None = None,
    seed: int = 0,
    formats: Iterable[str] = ("step", "brep", "faces"),
    errors: list[tuple[str, str]] | None = None,
) -> list[Path]:
    """Write every entry (default: ``shapes.entries(seed)``) to ``folder``.

    Returns the paths written, entry by entry, each as STEP, IGES BRep, IGES
    faces.  An entry whose builder or writer fails is left out; when
    ``errors`` is given, (name, message) is appended to it, otherwise the
    error is raised.
    """
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    formats = tuple(formats)
    paths: list[Path] = []
    for e in shapes_mod.entries(seed) if items is None else items:
        try:
            paths += write_entry(e, folder, formats)
        except Exception as exc:
            if errors is None:
                raise
            errors.append((e.name, f"{type(exc).__name__}: {exc}"))
    return paths


def side_by_side(items: Iterable[Entry], errors: list[tuple[str, str]]) -> Any:
    """One compound of the shapes of ``items``, ten to a row 60 mm apart (their
    geometry moved, not located): a large model, the way an IGES surface
    model or a STEP file of many bodies holds them.  A shape that fails to
    build is left out and named in ``errors``."""
    from OCP.BRep import BRep_Builder
    from OCP.BRepBuilderAPI import BRepBuilderAPI_Transform
    from OCP.gp import gp_Trsf, gp_Vec
    from OCP.TopoDS import TopoDS_Compound

    b, out = BRep_Builder(), TopoDS_Compound()
    b.MakeCompound(out)
    for i, e in enumerate(items):
        try:
            shape = e.build()
        except Exception as exc:
            errors.append((e.name, f"{type(exc).__name__}: {exc}"))
            continue
        move = gp_Trsf()
        move.SetTranslation(gp_Vec(60.0 * (i % 10), 60.0 * (i // 10), 0.0))
        b.Add(out, BRepBuilderAPI_Transform(shape, move, True).Shape())
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description="Write the stress corpus to STEP and IGES files.")
    ap.add_argument("folder")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument(
        "--only", default="", help="only entries whose name contains one of these (a,b,...)"
    )
    ap.add_argument(
        "--together",
        action="store_true",
        help="one model of every shape asked for, side by side 60 mm apart (files together.*)",
    )
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    parts = args.only.split(",")
    items = [e for e in shapes_mod.entries(args.seed) if any(p in e.name for p in parts)]
    errors: list[tuple[str, str]] = []
    if args.together:
        whole = side_by_side(items, errors)
        Path(args.folder).mkdir(parents=True, exist_ok=True)
        paths = write_entry(Entry("together", "together", lambda: whole, ""), args.folder)
    else:
        paths = write_all(args.folder, items, errors=errors)
    for name, msg in errors:
        print(f"error: {name}: {msg}")
    size = sum(p.stat().st_size for p in paths)
    print(
        f"{len(paths)} files from {len(items)} shapes, {size / 1e6:.1f} MB,"
        f" {time.perf_counter() - t0:.1f} s"
    )
    return 1 if errors else 0


if __name__ == "__main__":
    raise SystemExit(main())
