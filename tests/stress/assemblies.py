"""Assemblies and blended parts for the stress run, written by OCCT's XDE writer.

The shapes of :mod:`tests.stress.shapes` are written one product each by
OCCT's plain STEP writer; CAD systems write assemblies: several parts, some
placed more than once, some of them compounds of several solids (multi-body
parts), through a product structure.  OCCT's XDE writer
(``STEPCAFControl_Writer``) writes one shape representation per part, with
one uncertainty (the mean tolerance of the part, times 1.5, rounded down);
its plain writer, given the same compound, one per solid.  OCCT's reader
mends each representation at its own uncertainty, so the two files can read
back differently: what ``decompress`` writes goes the XDE way, and its STEP
check must be held to OCCT's round trip the same way (docs/method.md, 16).

* :func:`multibody`: one part, a compound of a given solid and small
  filleted boxes, placed twice;
* :func:`grouped`: parts of up to three stress-corpus solids each (every
  other part a compound), placed once or twice, rotated;
* :func:`blended`: one part with many small fillets and blends (a lofted
  body fused with a cylinder, every edge filleted), written as one product;
* :func:`filleted`: parts of small and variable fillets, one product each.

``python -m tests.stress.assemblies DIR`` writes :data:`CASES` to ``DIR``.
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import cadquery as cq
import numpy as np
from OCP.BRep import BRep_Builder
from OCP.BRepBuilderAPI import BRepBuilderAPI_Transform
from OCP.gp import gp_Ax1, gp_Dir, gp_Pnt, gp_Trsf, gp_Vec
from OCP.IFSelect import IFSelect_ReturnStatus
from OCP.STEPCAFControl import STEPCAFControl_Writer
from OCP.STEPControl import STEPControl_AsIs
from OCP.TCollection import TCollection_ExtendedString
from OCP.TDataStd import TDataStd_Name
from OCP.TDocStd import TDocStd_Document
from OCP.TopAbs import TopAbs_SOLID
from OCP.TopExp import TopExp_Explorer
from OCP.TopLoc import TopLoc_Location
from OCP.TopoDS import TopoDS_Compound
from OCP.XCAFDoc import XCAFDoc_DocumentTool

from nurbscomp.occ import exchange, read_cad

from . import shapes
from .files import WriteError, write_step


def _moved(shape: Any, dx: float = 0.0, dy: float = 0.0, dz: float = 0.0) -> Any:
    t = gp_Trsf()
    t.SetTranslation(gp_Vec(dx, dy, dz))
    return BRepBuilderAPI_Transform(shape, t, True).Shape()


def _placement(rng: np.random.Generator, at: tuple[float, float, float]) -> Any:
    """A random rotation about a random axis, then a move to ``at``."""
    turn = gp_Trsf()
    axis = gp_Dir(*(float(x) for x in rng.normal(size=3)))
    turn.SetRotation(gp_Ax1(gp_Pnt(0, 0, 0), axis), float(rng.uniform(0, 2 * math.pi)))
    move = gp_Trsf()
    move.SetTranslation(gp_Vec(*at))
    return TopLoc_Location(move.Multiplied(turn))


def write_assembly(
    path: Path, parts: Sequence[tuple[str, Any, Sequence[Any]]], schema: str = "AP214IS"
) -> None:
    """An XDE document of ``parts`` (name, shape, placements: one instance
    each) under one assembly, written by ``STEPCAFControl_Writer``."""
    doc = TDocStd_Document(TCollection_ExtendedString("XmlXCAF"))
    st = XCAFDoc_DocumentTool.ShapeTool_s(doc.Main())
    top = st.NewShape()
    TDataStd_Name.Set_s(top, TCollection_ExtendedString(path.stem))
    for name, shape, places in parts:
        label = st.AddShape(shape, False)
        TDataStd_Name.Set_s(label, TCollection_ExtendedString(name))
        for loc in places:
            st.AddComponent(top, label, loc)
    st.UpdateAssemblies()
    with exchange.static("write.step.schema", schema), exchange.static("write.step.unit", "MM"):
        w = STEPCAFControl_Writer()
        w.SetNameMode(True)
        if not w.Transfer(doc, STEPControl_AsIs):
            raise WriteError("XDE STEP transfer failed")
        if w.Write(str(path)) != IFSelect_ReturnStatus.IFSelect_RetDone:
            raise WriteError("XDE STEP write failed")


def _filleted_box() -> Any:
    return cq.Workplane().box(10, 10, 10).edges().fillet(1).val().wrapped


def multibody(path: Path, solid: Path | Any, boxes: int = 60) -> None:
    """One part, a compound of ``solid`` (a shape, or the first shape of a
    STEP/IGES file) and ``boxes`` filleted 10 mm boxes in a row beside it,
    placed twice.  The boxes' tolerances (1e-7) dilute the part's mean
    tolerance: OCCT's XDE writer gives the part one uncertainty, its plain
    writer gives ``solid`` its own."""
    shape = read_cad(solid).shape if isinstance(solid, Path) else solid
    b, comp = BRep_Builder(), TopoDS_Compound()
    b.MakeCompound(comp)
    b.Add(comp, shape)
    box = _filleted_box()
    for i in range(boxes):
        b.Add(comp, _moved(box, -300.0 - 20 * i))
    places = [TopLoc_Location(), _moved_location(0.0, 1000.0, 0.0)]
    write_assembly(path, [("multibody", comp, places)])


def _moved_location(dx: float, dy: float, dz: float) -> Any:
    t = gp_Trsf()
    t.SetTranslation(gp_Vec(dx, dy, dz))
    return TopLoc_Location(t)


def grouped(path: Path, group: int, seed: int = 0) -> None:
    """Parts of up to three solids of the stress corpus (fillets, shells,
    lofts, sweeps, revolves, features), eight solids in all, chosen by
    ``group``; the parts of more than one solid are compounds (multi-body
    parts); each part placed once or twice, rotated."""
    rng = np.random.default_rng([seed, group])
    cats = ("feature", "loft", "sweep", "fillet", "shell", "revolve")
    pool = shapes.interleaved([e for e in shapes.entries(seed) if e.category in cats])
    order = rng.permutation(len(pool))
    solids: list[tuple[str, Any]] = []
    for k in order.tolist():
        if len(solids) == 8:
            break
        shape = pool[k].build()
        ex = TopExp_Explorer(shape, TopAbs_SOLID)
        if ex.More():
            solids.append((pool[k].name, ex.Current()))
    b = BRep_Builder()
    parts = []
    for j in range(0, len(solids), 3):
        comp = TopoDS_Compound()
        b.MakeCompound(comp)
        for i, (_, s) in enumerate(solids[j : j + 3]):
            b.Add(comp, _moved(s, dz=70.0 * i))
        name = "+".join(n for n, _ in solids[j : j + 3])
        count = 1 + (j // 3) % 2
        places = [_placement(rng, (100.0 * (j + c), 0.0, 0.0)) for c in range(count)]
        parts.append((name, comp, places))
    write_assembly(path, parts)


def blended(path: Path, seed: int) -> None:
    """A part with many small fillets and blends: a loft from a periodic
    spline section to a rectangle, fused with a cross cylinder, every edge
    filleted (0.3 to 0.8 mm), written by OCCT's plain STEP writer as one
    product.  OCCT's own round trip of such a part loses edges of the
    source; nurbscomp's used to gain as many (81 -> 79 and 83 edges)."""
    rng = np.random.default_rng(seed)
    pts = [
        (math.cos(t) * float(rng.uniform(8, 12)), math.sin(t) * float(rng.uniform(5, 8)))
        for t in np.linspace(0, 2 * math.pi, 9)[:-1]
    ]
    w = cq.Workplane().spline(pts, periodic=True).close().workplane(offset=15).rect(10, 6).loft()
    cross = cq.Workplane().cylinder(30, 2.5).rotate((0, 0, 0), (1, 0, 0), 90)
    w = w.union(cross.translate((0, 0, 7))).edges().fillet(float(rng.uniform(0.3, 0.8)))
    write_step(w.val().wrapped, path, path.stem)


def filleted(path: Path, seed: int) -> None:
    """A part of small fillets, one product (plain STEP writer), by
    ``seed % 3``: a shelled housing with bosses and holes, its edges but the
    bottom's filleted (0.2 to 0.5 mm); a box with a slot, every edge given a
    variable fillet (0.3-0.8 to 0.8-1.5 mm, ``BRepFilletAPI_MakeFillet``); a
    plate with four ribs, filleted in three passes down to 0.1 mm."""
    from OCP.BRepFilletAPI import BRepFilletAPI_MakeFillet
    from OCP.TopAbs import TopAbs_EDGE
    from OCP.TopoDS import TopoDS

    rng = np.random.default_rng(seed)

    def r(a: float, b: float) -> float:
        return float(rng.uniform(a, b))

    kind = seed % 3
    if kind == 0:
        w = cq.Workplane().box(60, 40, 20).faces(">Z").shell(-2)
        spots = [(r(-20, 20), r(-12, 12)) for _ in range(3)]
        w = w.faces("<Z").workplane().pushPoints(spots).circle(r(2, 4)).extrude(r(4, 8))
        w = w.faces(">Z").workplane().rect(40, 24, forConstruction=True).vertices().hole(r(1.5, 3))
        shape = w.edges("not <Z").fillet(r(0.2, 0.5)).val().wrapped
    elif kind == 1:
        s = cq.Workplane().box(50, 30, 12).faces(">Z").workplane().slot2D(30, 8).cutBlind(-6)
        solid = s.val().wrapped
        mk = BRepFilletAPI_MakeFillet(solid)
        ex = TopExp_Explorer(solid, TopAbs_EDGE)
        while ex.More():
            mk.Add(r(0.3, 0.8), r(0.8, 1.5), TopoDS.Edge_s(ex.Current()))
            ex.Next()
        mk.Build()
        shape = mk.Shape()
    else:
        w = cq.Workplane().box(60, 40, 4)
        for k in range(4):
            w = w.union(cq.Workplane().box(2, 36, 8).translate((-22 + 14 * k, 0, 6)))
        w = w.edges("|Z").fillet(r(0.5, 1.0)).faces(">Z").edges().fillet(r(0.2, 0.4))
        shape = w.edges("not |Z").fillet(r(0.1, 0.3)).val().wrapped
    write_step(shape, path, path.stem)


#: (file name, writer) of the generated cases; each writer takes the path.
CASES: list[tuple[str, Callable[[Path], None]]] = [
    *((f"asm_grouped_{g:02d}.step", lambda p, g=g: grouped(p, g)) for g in range(4)),
    *((f"asm_blended_{s:02d}.step", lambda p, s=s: blended(p, s)) for s in (2, 6, 10, 14)),
    *((f"asm_filleted_{s:02d}.step", lambda p, s=s: filleted(p, s)) for s in (0, 1, 2, 4, 5, 7)),
    ("asm_multibody_sweep.step", lambda p: multibody(p, _sweep_solid(), boxes=20)),
]


def _sweep_solid() -> Any:
    entry = {e.name: e for e in shapes.entries(0)}["sweep_spline_01"]
    return entry.build()


def write_all(folder: Path, errors: list[tuple[str, str]] | None = None) -> list[Path]:
    """Write every case of :data:`CASES` to ``folder``; a case that fails is
    named in ``errors`` (raised when None)."""
    folder.mkdir(parents=True, exist_ok=True)
    out = []
    for name, write in CASES:
        p = folder / name
        try:
            write(p)
        except Exception as e:
            p.unlink(missing_ok=True)
            if errors is None:
                raise
            errors.append((name, f"{type(e).__name__}: {e}"))
            continue
        out.append(p)
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("folder")
    args = ap.parse_args(argv)
    errors: list[tuple[str, str]] = []
    paths = write_all(Path(args.folder), errors)
    for name, msg in errors:
        print(f"error: {name}: {msg}")
    print(f"{len(paths)} files")
    return 1 if errors else 0


if __name__ == "__main__":
    raise SystemExit(main())
