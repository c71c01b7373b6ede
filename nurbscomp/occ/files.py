"""Reading STEP / IGES files into shapes and writing shapes to STEP, IGES or BREP.

Every reader and writer status is checked; a failure is an ``InputError`` or
``OutputError`` with a one-line message.  OCCT converts lengths to millimetres
on reading; the file's own unit is reported so that the output can be written
back in it.
"""

from __future__ import annotations

import contextlib
import os
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from OCP.APIHeaderSection import APIHeaderSection_MakeHeader
from OCP.BinTools import BinTools
from OCP.BRepTools import BRepTools
from OCP.IFSelect import IFSelect_ReturnStatus
from OCP.IGESControl import IGESControl_Reader, IGESControl_Writer
from OCP.Interface import Interface_Static
from OCP.Message import Message
from OCP.StepBasic import StepBasic_Product
from OCP.STEPControl import STEPControl_AsIs, STEPControl_Reader, STEPControl_Writer
from OCP.TCollection import TCollection_HAsciiString
from OCP.TColStd import TColStd_SequenceOfAsciiString
from OCP.TopAbs import TopAbs_COMPOUND

from ..errors import InputError, NoBRepError, OutputError, RebuildError
from ..formats import (  # noqa: F401 (re-exported: they were defined here)
    BREP_SUFFIXES,
    IGES_SUFFIXES,
    STEP_SUFFIXES,
    output_format,
    sniff_format,
)
from ..units import UNITS_MM
from .exchange import (  # noqa: F401 (re-exported: they were defined here)
    IGES_DATE,
    STEP_TIME_STAMP,
    SURFACE_CURVES,
    check_readable,
    fix_iges_dates,
    settle_model,
    settled,
    static,
    step_settings,
    write_iges,
)

# OCCT prints progress and statistics to stdout; the CLI owns stdout.
Message.DefaultMessenger_s().ChangePrinters().Clear()

_STEP_UNIT_NAMES = {
    "millimetre": "MM",
    "millimeter": "MM",
    "centimetre": "CM",
    "centimeter": "CM",
    "metre": "M",
    "meter": "M",
    "kilometre": "KM",
    "kilometer": "KM",
    "micrometre": "UM",
    "micrometer": "UM",
    "micron": "UM",
    "inch": "INCH",
    "foot": "FT",
    "feet": "FT",
    "mile": "MI",
    "mil": "MIL",
    "thou": "MIL",
    "microinch": "UIN",
}

_IGES_UNIT_FLAGS = {
    1: "INCH",
    2: "MM",
    4: "FT",
    5: "MI",
    6: "M",
    7: "KM",
    8: "MIL",
    9: "UM",
    10: "CM",
    11: "UIN",
}


_STEP_MARKERS = {
    b"STYLED_ITEM": "colours",
    b"PRESENTATION_LAYER_ASSIGNMENT": "layers",
    b"NEXT_ASSEMBLY_USAGE_OCCURRENCE": "assembly structure",
    b"DIMENSIONAL_": "PMI",
    b"DRAUGHTING_CALLOUT": "PMI",
    b"PROPERTY_DEFINITION": "properties",
}


@dataclass
class CadFile:
    """What a CAD file gave: the shape, its unit, its format, and warnings."""

    shape: Any
    unit: str
    source_format: str
    warnings: list[str] = field(default_factory=list)
    #: Product data (names, tree, colours, layers, header) when read with
    #: ``product=True``: a ``nurbscomp.product.ProductData``.
    product: Any = None
    #: False for a STEP file that holds no pcurve (no ``PCURVE`` entity): its
    #: edges have 3-D curves only, and OCCT's reader computed the pcurves
    #: (:func:`step_has_pcurves`).
    pcurves: bool = True


#: Deepest nesting of parentheses a STEP file may have (real files: under 10).
#: OCCT's STEP parser recurses on it: measured, 10,000 levels parse and
#: 100,000 crash the process (SIGSEGV).
MAX_STEP_NESTING = 1_000
_SCAN_CHUNK = 1 << 24


def screen_step(path: Path) -> None:
    """Refuse a STEP file that would crash OCCT's parser, with a byte scan
    (not a parser): parentheses outside strings nested deeper than
    ``MAX_STEP_NESTING``.  A string is what lies between an odd apostrophe and
    the next (``''`` inside a string toggles twice, as it should).

    Raises
    ------
    InputError
        The nesting is too deep (the message gives the byte offset).
    """
    depth, quoted, at = 0, False, 0
    with open(path, "rb") as fh:
        while chunk := fh.read(_SCAN_CHUNK):
            b = np.frombuffer(chunk, np.uint8)
            # only apostrophes and parentheses (bytes 39, 40, 41) move the state:
            # the scan runs over them alone, a tenth of the bytes of a STEP file
            at_mark = np.flatnonzero((b >= ord("'")) & (b <= ord(")")))
            c = b[at_mark]
            q = np.cumsum(c == ord("'"), dtype=np.int64)
            inside = (q + quoted) % 2 == 1
            step = (c == ord("(")).astype(np.int64) - (c == ord(")"))
            step[inside] = 0
            level = depth + np.cumsum(step)
            if len(level) and level.max() > MAX_STEP_NESTING:
                where = at + int(at_mark[np.argmax(level > MAX_STEP_NESTING)])
                raise InputError(
                    f"STEP parentheses nested more than {MAX_STEP_NESTING} deep "
                    f"(at byte {where}); OCCT's parser cannot read it"
                )
            depth = int(level[-1]) if len(level) else depth
            quoted = bool((int(q[-1]) + quoted) % 2) if len(q) else quoted
            at += len(chunk)


_PCURVE = re.compile(rb"PCURVE\s*\(")


def step_has_pcurves(data: bytes) -> bool:
    """Whether a STEP file's text holds a ``PCURVE`` (or ``BOUNDED_PCURVE``)
    instance, upper or lower case; a ``.PCURVE_S1.`` enumeration is no pcurve."""
    return _PCURVE.search(data.upper()) is not None


def read_cad(path: str | os.PathLike[str], product: bool = False, own: bool = False) -> CadFile:
    """Read a STEP (AP203/214/242) or IGES file into one shape, in millimetres.

    With ``product``, the file is read through OCCT's XDE readers
    (``xcaf.caf_reader``): the shape is the same, and ``CadFile.product``
    holds the product data; the warnings then name what that leaves out.
    ``own`` is for a file this process has just written (the STEP check's
    round trip): it is not screened, and nothing it holds is named.

    Raises
    ------
    InputError
        The file is missing, empty, not STEP/IGES, fails to parse, or holds
        nothing OCCT can turn into a B-rep.
    """
    p = Path(path)
    head = check_readable(p)
    fmt = sniff_format(p, head)
    if fmt == "STEP" and not own:
        screen_step(p)
    caf: Any = None
    reader: Any = None
    if product:
        from . import xcaf

        caf, reader = xcaf.caf_reader(fmt)
    elif fmt == "STEP":
        reader = STEPControl_Reader()
    else:
        reader = IGESControl_Reader()
    if fmt == "STEP":
        # tessellated entities (AP242) hold no B-rep to store, and OCCT 7.9's
        # transfer of a malformed one can crash the process: never read them
        # (set after the reader exists: its controller's first set-up resets it)
        Interface_Static.SetIVal_s("read.step.tessellated", 0)
    status = reader.ReadFile(str(p))
    if status != IFSelect_ReturnStatus.IFSelect_RetDone:
        raise InputError(f"cannot parse {fmt} file ({status.name.removeprefix('IFSelect_')})")
    if fmt == "STEP":
        names = [TColStd_SequenceOfAsciiString() for _ in range(3)]
        reader.FileUnits(*names)
        lengths = [names[0].Value(i).ToCString() for i in range(1, names[0].Length() + 1)]
        unit = _STEP_UNIT_NAMES.get(lengths[0].lower(), "MM") if lengths else "MM"
    else:
        unit = _IGES_UNIT_FLAGS.get(reader.IGESModel().GlobalSection().UnitFlag(), "MM")
    if reader.NbRootsForTransfer() == 0:
        raise NoBRepError(f"the {fmt} file holds no shape to transfer")
    doc = None
    if caf is not None:
        from . import xcaf

        doc = xcaf.new_document()
        with xcaf.auto_naming():
            caf.Transfer(doc)
    else:
        reader.TransferRoots()
    if reader.NbShapes() == 0:
        raise NoBRepError(f"nothing in the {fmt} file transfers to a B-rep")
    shape = reader.OneShape()
    # XDE's transfer of nothing is an empty compound
    if shape.IsNull() or (shape.ShapeType() == TopAbs_COMPOUND and shape.NbChildren() == 0):
        raise NoBRepError(f"nothing in the {fmt} file transfers to a B-rep")
    text = p.read_bytes() if fmt == "STEP" and not own else b""
    pcurves = not text or step_has_pcurves(text)
    if doc is not None:
        data = xcaf.product_data(doc, shape, fmt, reader)
        warnings = [f"not stored: {', '.join(data.dropped)}"] if data.dropped else []
        return CadFile(shape, unit, fmt, warnings, data, pcurves)
    warnings = []
    if own:
        pass
    elif fmt == "STEP":
        warnings = _step_losses(text)
    else:
        warnings = ["IGES colours, levels and names are not stored"]
    return CadFile(shape, unit, fmt, warnings, pcurves=pcurves)


def _step_losses(data: bytes) -> list[str]:
    """Name what a STEP file's text holds that the container does not keep."""
    found = sorted({what for marker, what in _STEP_MARKERS.items() if marker in data})
    if re.search(rb"PRODUCT\s*\(\s*'[^']", data):
        found.append("names")
    if not found:
        return []
    return [f"not stored: {', '.join(found)} (geometry and topology only)"]


def write_shape(
    shape: Any,
    path: str | os.PathLike[str],
    fmt: str,
    unit: str = "MM",
    name: str = "",
    system: str = "",
    products: bool = True,
    product: Any = None,
    pcurves: bool = True,
    uncertainty: float | None = None,
) -> None:
    """Write a shape to STEP, IGES or BREP.

    With ``product`` (the ``product.ProductData`` of the shape's model), STEP
    and IGES are written through OCCT's XDE writers with its tree, names,
    colours, layers, schema and header (``xcaf.write``).

    STEP output depends on nothing but its arguments: the header's FILE_NAME
    gets ``name``, ``system`` as the originating system and the fixed
    ``STEP_TIME_STAMP`` rather than the wall clock, and the PRODUCT is named
    after ``name`` (without its extension), so writing the same shape twice
    gives the same bytes.

    Parameters
    ----------
    shape : TopoDS_Shape
        In millimetres.
    path : path
    fmt : str
        ``"STEP"``, ``"IGES"`` or ``"BREP"`` (see ``output_format``).
    unit : str
        A key of ``UNITS_MM``: the length unit written to the file.
    name, system : str
        STEP only: FILE_NAME's name and originating system.
    products : bool
        STEP only: name the PRODUCTs after ``name`` (off for a file only read
        back, by the STEP check: it walks every entity of the model).
    pcurves : bool
        STEP only: write each edge's pcurves (``SURFACE_CURVE``s), or its 3-D
        curve alone (``write.surfacecurve.mode`` 0): what a STEP source without
        pcurves had.  The file is then smaller and quicker to write, and
        independent of the pcurves the shape has.
    uncertainty : float, optional
        STEP and IGES: the length uncertainty (IGES: resolution) written to
        the file, in mm; None, the average tolerance of the shape, as OCCT
        writes it (``exchange.precision``).

    Raises
    ------
    RebuildError
        The STEP or IGES writer refuses the shape (a shape decoded from a
        damaged container, say).
    OutputError
        The file cannot be written.
    """
    p = Path(path)
    if unit not in UNITS_MM:
        raise OutputError(f"unknown length unit {unit!r}")
    if product is not None and fmt != "BREP":
        from . import xcaf

        xcaf.write(product, shape, p, fmt, unit, name, system, pcurves, uncertainty)
        return
    if fmt == "BREP":
        if not BRepTools.Write_s(shape, str(p)):
            raise OutputError("cannot write BREP")
        return
    if fmt == "IGES":
        w = IGESControl_Writer("IN" if unit == "INCH" else unit, 1)
        write_iges(w, lambda: w.AddShape(shape), p, uncertainty, "shape")
        return
    Interface_Static.SetCVal_s("write.step.unit", unit)
    Interface_Static.SetCVal_s("write.step.schema", "AP214IS")
    sw = STEPControl_Writer()
    # set once the writer exists (its constructor may reset it)
    with step_settings(pcurves, uncertainty):
        status = sw.Transfer(shape, STEPControl_AsIs)
    if status != IFSelect_ReturnStatus.IFSelect_RetDone:
        raise RebuildError(f"the STEP writer refused the shape ({status.name})")
    if products:
        _name_products(sw.Model(), Path(name).stem or "shape")
    header = APIHeaderSection_MakeHeader(sw.Model())
    header.SetName(TCollection_HAsciiString(name))
    header.SetTimeStamp(TCollection_HAsciiString(STEP_TIME_STAMP))
    header.SetOriginatingSystem(TCollection_HAsciiString(system))
    with settled(sw.Model()) if products else contextlib.nullcontext():
        status = sw.Write(str(p))
    if status != IFSelect_ReturnStatus.IFSelect_RetDone:
        raise OutputError(f"cannot write STEP ({status.name})")


def _name_products(model: Any, name: str) -> None:
    """Name the PRODUCTs of a STEP model after ``name`` (``name``, ``name 2`` …)."""
    products = 0
    for i in range(1, model.NbEntities() + 1):
        e = model.Value(i)
        if isinstance(e, StepBasic_Product):
            products += 1
            label = TCollection_HAsciiString(name if products == 1 else f"{name} {products}")
            e.SetName(label)
            e.SetId(label)


def bintools_bytes(shape: Any) -> bytes:
    """OCCT's own binary BRep of a shape (``BinTools``), for comparison."""
    import tempfile

    with tempfile.TemporaryDirectory() as d:
        f = os.path.join(d, "s.bin")
        BinTools.Write_s(shape, f)
        return Path(f).read_bytes()


def step_round_trip(
    shape: Any,
    unit: str = "MM",
    product: Any = None,
    folder: Path | None = None,
    pcurves: bool = True,
    uncertainty: float | None = None,
) -> Any:
    """The shape as OCCT reads it back after writing it to STEP (in a temporary
    file, in ``folder`` if given: the caller removes that).

    With ``product`` (a ``product.ProductData`` of the shape's model) the file
    is written as ``decompress`` writes it, through OCCT's XDE writer
    (``xcaf.write``): its STEP differs from the plain writer's, and so may
    what the reader makes of it.  ``pcurves``, ``uncertainty``: as
    :func:`write_shape`'s.
    """
    import tempfile

    with contextlib.ExitStack() as stack:
        d = folder or stack.enter_context(tempfile.TemporaryDirectory())
        f = Path(d) / "rt.step"
        write_shape(
            shape,
            f,
            "STEP",
            unit,
            products=False,
            product=product,
            pcurves=pcurves,
            uncertainty=uncertainty,
        )
        return read_cad(f, own=True).shape
