"""Product data through OCCT's XDE (XCAF): read it from STEP/IGES, write it back.

Reading goes through ``STEPCAFControl_Reader`` / ``IGESCAFControl_Reader``
with names, colours and layers on (``files.read_cad(..., product=True)``):
the geometry is the reader's own transferred shape, the same one a plain
``STEPControl_Reader`` gives, and every XDE label (product, instance,
sub-shape) is mapped onto the ``SHAP`` row of its shape (rows are numbered
as ``topology.shape_to_model`` numbers them: post-order, one row per
TShape).  :func:`product_data` returns the plain :class:`ProductData`.

Writing builds a new XDE document from the decoded shape and the product
data and writes it through ``STEPCAFControl_Writer`` (in the source's
schema, with the source's header) or ``IGESCAFControl_Writer``.

:func:`view` is what the tests compare: a file as OCCT's XCAF reader sees it
(tree, names, placements, colour on every face, layers).
"""

from __future__ import annotations

import contextlib
import os
from collections import Counter
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
from OCP.APIHeaderSection import APIHeaderSection_MakeHeader
from OCP.BRep import BRep_Tool
from OCP.BRepTools import BRepTools
from OCP.IFSelect import IFSelect_ReturnStatus
from OCP.IGESCAFControl import IGESCAFControl_Reader, IGESCAFControl_Writer
from OCP.IGESControl import IGESControl_Controller
from OCP.Interface import Interface_HArray1OfHAsciiString, Interface_Static
from OCP.Quantity import Quantity_Color, Quantity_ColorRGBA, Quantity_TypeOfColor
from OCP.STEPCAFControl import (
    STEPCAFControl_Controller,
    STEPCAFControl_Reader,
    STEPCAFControl_Writer,
)
from OCP.STEPControl import STEPControl_AsIs
from OCP.TCollection import (
    TCollection_AsciiString,
    TCollection_ExtendedString,
    TCollection_HAsciiString,
)
from OCP.TDataStd import TDataStd_Name, TDataStd_NamedData
from OCP.TDF import TDF_ChildIterator, TDF_Label, TDF_LabelSequence, TDF_Tool
from OCP.TDocStd import TDocStd_Document
from OCP.TopAbs import TopAbs_FACE, TopAbs_FORWARD, TopAbs_Orientation
from OCP.TopExp import TopExp, TopExp_Explorer
from OCP.TopLoc import TopLoc_Location
from OCP.TopoDS import TopoDS_Iterator
from OCP.TopTools import TopTools_IndexedMapOfShape
from OCP.XCAFDoc import (
    XCAFDoc,
    XCAFDoc_Area,
    XCAFDoc_Centroid,
    XCAFDoc_ColorType,
    XCAFDoc_DocumentTool,
    XCAFDoc_ShapeTool,
    XCAFDoc_Volume,
)

from ..errors import RebuildError
from ..formats import sniff_format
from ..product import HEADER_FIELDS, HIDDEN, INSTANCE, NAMED, PRODUCT, SUBSHAPE, ProductData
from .exchange import (
    STEP_TIME_STAMP,
    check_readable,
    settled,
    static,
    step_settings,
    write_iges,
)
from .measure import faces as faces_of
from .mesh import face_meshes
from .topology import _trsf, _trsf_rows

# XDE's STEP options (read/write.stepcaf.*) and IGES's (write.iges.*) exist
# only once their controllers are set up; set them up now, so that setting
# them works in any order
STEPCAFControl_Controller.Init_s()
IGESControl_Controller.Init_s()

#: IGES is written in BRep mode (MSBO solids, shells and shared edges: entity
#: 186/514/504), as ``files.write_shape`` does, never in OCCT's default faces
#: mode (each face trimmed on its own, 0 solids and every edge free).
IGES_BREP_MODE = ("write.iges.brep.mode", "BRep")

_TYPES = [XCAFDoc_ColorType(i) for i in range(3)]
_ORIENT = [TopAbs_Orientation(i) for i in range(4)]
_RGB = Quantity_TypeOfColor.Quantity_TOC_RGB

#: ``write.step.schema`` for the FILE_SCHEMA identifiers' names (the first
#: row found in any of them).  AP203's second edition
#: (``AP203_CONFIGURATION_CONTROLLED_3D_DESIGN_…_MIM_LF``) is written in the
#: first's, the AP203 OCCT writes: the source's family.
_SCHEMAS = (
    ("AP242", "AP242DIS"),
    ("CONFIG_CONTROL_DESIGN", "AP203"),
    ("AP203", "AP203"),
    ("AUTOMOTIVE_DESIGN_CC", "AP214CD"),
    ("AUTOMOTIVE_DESIGN", "AP214IS"),
)


def new_document() -> Any:
    """An empty XDE document."""
    return TDocStd_Document(TCollection_ExtendedString("XmlXCAF"))


@contextlib.contextmanager
def auto_naming() -> Iterator[None]:
    """XDE's naming of unnamed shapes by their type (``SOLID``, ``COMPOUND``),
    on as OCCT has it by default, for the time of a transfer; the caller's
    setting back after.  It is one flag for the whole process, and cadquery's
    assembly export turns it off for good: without this, an IGES file read
    after a cadquery assembly was saved in the same process lost the names
    of its parts, and its container changed."""
    old = XCAFDoc_ShapeTool.AutoNaming_s()
    XCAFDoc_ShapeTool.SetAutoNaming_s(True)
    try:
        yield
    finally:
        XCAFDoc_ShapeTool.SetAutoNaming_s(old)


def caf_reader(fmt: str) -> tuple[Any, Any]:
    """(XDE reader, its plain reader) for ``"STEP"`` or ``"IGES"``, with names,
    colours and layers on, and the other XDE modes on too so that what the
    container drops can be named (:func:`dropped`)."""
    if fmt == "STEP":
        Interface_Static.SetIVal_s("read.stepcaf.subshapes.name", 1)
        caf: Any = STEPCAFControl_Reader()
        for mode in ("SetGDTMode", "SetPropsMode", "SetMatMode", "SetViewMode", "SetMetaMode"):
            getattr(caf, mode)(True)
        plain = caf.ChangeReader()
    else:
        caf = IGESCAFControl_Reader()
        plain = caf
    caf.SetColorMode(True)
    caf.SetNameMode(True)
    caf.SetLayerMode(True)
    return caf, plain


# ---------------------------------------------------------------- reading


def shape_rows(root: Any) -> tuple[Any, list[int], list[Any]]:
    """Number the TShapes under ``root`` as ``topology.shape_to_model`` does
    (post-order, one row per TShape keyed at the identity location, FORWARD).

    Returns
    -------
    keys : TopTools_IndexedMapOfShape
    rows : list of int
        ``rows[k - 1]`` is the row of the key of index ``k``.
    shapes : list of TopoDS_Shape
        The key shape of each row.
    """
    keys = TopTools_IndexedMapOfShape()
    rows: list[int] = []
    shapes: list[Any] = []
    stack: list[tuple[Any, Any]] = [
        (root.Located(TopLoc_Location()).Oriented(TopAbs_FORWARD), None)
    ]
    while stack:
        key, it = stack[-1]
        if it is None:
            if keys.FindIndex(key):
                stack.pop()
                continue
            keys.Add(key)
            rows.append(-1)
            it = TopoDS_Iterator(key, False, False)
            stack[-1] = (key, it)
        else:
            it.Next()
        while it.More():
            c = it.Value().Located(TopLoc_Location()).Oriented(TopAbs_FORWARD)
            if not keys.FindIndex(c):
                break
            it.Next()
        if it.More():
            stack.append((it.Value().Located(TopLoc_Location()).Oriented(TopAbs_FORWARD), None))
            continue
        rows[keys.FindIndex(key) - 1] = len(shapes)
        shapes.append(key)
        stack.pop()
    return keys, rows, shapes


def _entry(label: Any) -> str:
    s = TCollection_AsciiString()
    TDF_Tool.Entry_s(label, s)
    return str(s.ToCString())


def _name(label: Any) -> str | None:
    a = TDataStd_Name()  # OCP crashes in FindAttribute when the attribute is absent
    if label.IsAttribute(TDataStd_Name.GetID_s()) and label.FindAttribute(
        TDataStd_Name.GetID_s(), a
    ):
        return str(a.Get().ToExtString())
    return None


def _seq(fill: Any, *args: Any) -> list[Any]:
    """The labels ``fill(*args, sequence)`` puts in a sequence, as labels of
    their own (``Value`` refers into the sequence, which Python frees)."""
    s = TDF_LabelSequence()
    fill(*args, s)
    return [_own(s.Value(i)) for i in range(1, s.Length() + 1)]


def _own(label: Any) -> Any:
    """A label by value (OCP returns some labels as references into their container)."""
    return label.Father().FindChild(label.Tag(), False)


def _colours(label: Any) -> list[tuple[float, float, float, float] | None]:
    out: list[tuple[float, float, float, float] | None] = []
    for t in _TYPES:
        c = Quantity_ColorRGBA()
        if XCAFDoc_DocumentTool.ColorTool_s(label.Root()).GetColor_s(label, t, c):
            rgb = c.GetRGB()
            out.append((rgb.Red(), rgb.Green(), rgb.Blue(), c.Alpha()))
        else:
            out.append(None)
    return out


class _Builder:
    """Collects nodes, placements and colours into a :class:`ProductData`."""

    def __init__(self, root: Any) -> None:
        self.keys, self.rows, _ = shape_rows(root)
        self.p: dict[str, list[Any]] = {
            k: [] for k in ("kind", "parent", "ref", "orient", "place", "flags", "colour", "names")
        }
        self.places: dict[tuple[float, ...], int] = {}
        self.colours: dict[tuple[float, ...], int] = {}
        self.node_of: dict[str, int] = {}
        self.missing = 0

    def row(self, shape: Any) -> int:
        if shape.IsNull():
            return -1
        k = self.keys.FindIndex(shape.Located(TopLoc_Location()).Oriented(TopAbs_FORWARD))
        return self.rows[k - 1] if k else -1

    def place(self, loc: Any) -> int:
        if loc.IsIdentity():
            return -1
        t = loc.Transformation()
        key = (t.Form().value, *_trsf_rows(t))
        if key not in self.places:
            self.places[key] = len(self.places)
        return self.places[key]

    def add(self, label: Any, kind: int, parent: int, ref: int, shape: Any) -> int:
        i = len(self.p["kind"])
        self.node_of[_entry(label)] = i
        name = _name(label)
        cols = []
        for c in _colours(label):
            if c is not None and c not in self.colours:
                self.colours[c] = len(self.colours)
            cols.append(-1 if c is None else self.colours[c])
        hidden = not XCAFDoc_DocumentTool.ColorTool_s(label.Root()).IsVisible_s(label)
        loc = XCAFDoc_ShapeTool.GetLocation_s(label) if kind == INSTANCE else shape.Location()
        for k, v in (
            ("kind", kind),
            ("parent", parent),
            ("ref", ref),
            ("orient", shape.Orientation().value if not shape.IsNull() else 0),
            ("place", self.place(loc)),
            ("flags", (NAMED if name is not None else 0) | (HIDDEN if hidden else 0)),
            ("colour", cols),
            ("names", name or ""),
        ):
            self.p[k].append(v)
        return i


def product_data(doc: Any, root: Any, fmt: str, plain: Any) -> ProductData:
    """The product data of an XDE document read from a file whose
    transferred shape is ``root`` (``plain`` is the plain STEP/IGES reader,
    for the STEP header)."""
    st = XCAFDoc_DocumentTool.ShapeTool_s(doc.Main())
    b = _Builder(root)
    products = _seq(st.GetShapes)
    for lab in products:
        shape = XCAFDoc_ShapeTool.GetShape_s(lab)
        row = -1 if XCAFDoc_ShapeTool.IsAssembly_s(lab) else b.row(shape)
        if row < 0 and not XCAFDoc_ShapeTool.IsAssembly_s(lab):
            b.missing += 1
        b.add(lab, PRODUCT, -1, row, shape)
    for k, lab in enumerate(products):
        if XCAFDoc_ShapeTool.IsAssembly_s(lab):
            for c in _seq(XCAFDoc_ShapeTool.GetComponents_s, lab):
                ref = TDF_Label()
                XCAFDoc_ShapeTool.GetReferredShape_s(c, ref)
                b.add(c, INSTANCE, k, b.node_of[_entry(ref)], XCAFDoc_ShapeTool.GetShape_s(c))
        for s in _seq(XCAFDoc_ShapeTool.GetSubShapes_s, lab):
            shape = XCAFDoc_ShapeTool.GetShape_s(s)
            row = b.row(shape)
            if row < 0:
                b.missing += 1
                continue
            b.add(s, SUBSHAPE, k, row, shape)
    lt = XCAFDoc_DocumentTool.LayerTool_s(doc.Main())
    layer_names, layer_hidden, members = [], [], []
    for lab in _seq(lt.GetLayerLabels):
        name = TCollection_ExtendedString()
        lt.GetLayer(lab, name)
        layer_names.append(str(name.ToExtString()))
        layer_hidden.append(not lt.IsVisible(lab))
        labels = _seq(XCAFDoc_DocumentTool.LayerTool_s(doc.Main()).GetShapesOfLayer_s, lab)
        found = [b.node_of.get(_entry(x), -1) for x in labels]
        b.missing += sum(1 for x in found if x < 0)
        members.append([x for x in found if x >= 0])
    n = len(b.p["kind"])
    pl = sorted(b.places, key=b.places.__getitem__)
    data = ProductData(
        kind=np.array(b.p["kind"], np.int64),
        parent=np.array(b.p["parent"], np.int64),
        ref=np.array(b.p["ref"], np.int64),
        orient=np.array(b.p["orient"], np.int64),
        place=np.array(b.p["place"], np.int64),
        flags=np.array(b.p["flags"], np.int64),
        colour=np.array(b.p["colour"], np.int64).reshape(n, 3),
        names=list(b.p["names"]),
        forms=np.array([k[0] for k in pl], np.int64),
        placements=np.array([k[1:] for k in pl], float).reshape(len(pl), 3, 4),
        colours=np.array(sorted(b.colours, key=b.colours.__getitem__), float).reshape(-1, 4),
        layer_names=layer_names,
        layer_hidden=np.array(layer_hidden, bool),
        layer_members=members,
        header=step_header(plain) if fmt == "STEP" else {},
    )
    data.dropped = dropped(doc, b.missing)
    return data


def step_header(reader: Any) -> dict[str, list[str]]:
    """The STEP header's fields (``product.HEADER_FIELDS``) of a read STEP model.

    Each header entity is read on its own: OCCT calls the header made only
    when FILE_NAME, FILE_SCHEMA and FILE_DESCRIPTION are all there, and
    taking that as "no header" lost FILE_SCHEMA with a missing
    FILE_DESCRIPTION, so an AP203 source came back as AP214
    (:func:`step_schema`).  A missing entity's fields are left out."""
    h = APIHeaderSection_MakeHeader(reader.StepModel())  # null-safe accessors

    def text(x: Any) -> str:
        try:
            return str(x.ToCString())
        except UnicodeDecodeError:  # OCP decodes as UTF-8: take the bytes as Latin-1
            return str(TCollection_ExtendedString(x.String(), False).ToExtString())

    def one(x: Any) -> list[str]:
        return [] if x is None else [text(x)]

    def many(n: int, get: Any) -> list[str]:
        return [text(get(i)) for i in range(1, n + 1)]

    fields = {
        "schema": many(h.NbSchemaIdentifiers(), h.SchemaIdentifiersValue),
        "name": one(h.Name()),
        "time_stamp": one(h.TimeStamp()),
        "author": many(h.NbAuthor(), h.AuthorValue),
        "organization": many(h.NbOrganization(), h.OrganizationValue),
        "preprocessor_version": one(h.PreprocessorVersion()),
        "originating_system": one(h.OriginatingSystem()),
        "authorisation": one(h.Authorisation()),
        "description": many(h.NbDescription(), h.DescriptionValue),
        "implementation_level": one(h.ImplementationLevel()),
    }
    return {k: fields[k] for k in HEADER_FIELDS if fields[k]}


def _count_attr(doc: Any, guid: Any) -> int:
    """Labels under the shapes label that carry an attribute of this GUID."""
    n = 0
    it = TDF_ChildIterator(XCAFDoc_DocumentTool.ShapesLabel_s(doc.Main()), True)
    while it.More():
        if it.Value().IsAttribute(guid):
            n += 1
        it.Next()
    return n


def dropped(doc: Any, missing: int = 0) -> list[str]:
    """What the XDE document holds that the container does not keep, by name and count."""
    main = doc.Main()
    dt = XCAFDoc_DocumentTool.DimTolTool_s(main)
    counts = {
        "PMI dimensions": len(_seq(dt.GetDimensionLabels)),
        "PMI geometric tolerances": len(_seq(dt.GetGeomToleranceLabels)),
        "PMI datums": len(_seq(dt.GetDatumLabels)),
        "saved views": len(_seq(XCAFDoc_DocumentTool.ViewTool_s(main).GetViewLabels)),
        "notes": XCAFDoc_DocumentTool.NotesTool_s(main).NbNotes(),
        "materials": len(_seq(XCAFDoc_DocumentTool.MaterialTool_s(main).GetMaterialLabels)),
        "visualisation materials": len(
            _seq(XCAFDoc_DocumentTool.VisMaterialTool_s(main).GetMaterials)
        ),
        "styles on nested instances (SHUO)": _count_attr(doc, XCAFDoc.SHUORefGUID_s()),
        "validation properties (volume)": _count_attr(doc, XCAFDoc_Volume.GetID_s()),
        "validation properties (area)": _count_attr(doc, XCAFDoc_Area.GetID_s()),
        "validation properties (centroid)": _count_attr(doc, XCAFDoc_Centroid.GetID_s()),
        "user-defined attribute sets": _count_attr(doc, TDataStd_NamedData.GetID_s()),
        "labels whose shape is not in the geometry": missing,
    }
    return [f"{n} {what}" for what, n in counts.items() if n]


# ---------------------------------------------------------------- writing


def _extended(text: str) -> Any:
    """An OCCT Unicode string of ``text`` (OCP passes a ``str`` as UTF-8 bytes,
    which OCCT would otherwise read one byte per character)."""
    return TCollection_ExtendedString(text, True)


def _rgba(c: np.ndarray) -> Any:
    r, g, b, a = (float(x) for x in c)
    return Quantity_ColorRGBA(Quantity_Color(r, g, b, _RGB), a)


def to_document(p: ProductData, shapes: list[Any]) -> Any:
    """A new XDE document holding ``p`` over the decoded shapes (``shapes[row]``
    is the key shape of ``SHAP`` row ``row``, as :func:`shape_rows` gives)."""
    with auto_naming():
        return _to_document(p, shapes)


def _to_document(p: ProductData, shapes: list[Any]) -> Any:
    doc = new_document()
    main = doc.Main()
    st = XCAFDoc_DocumentTool.ShapeTool_s(main)
    ct = XCAFDoc_DocumentTool.ColorTool_s(main)
    lt = XCAFDoc_DocumentTool.LayerTool_s(main)

    def place(i: int) -> Any:
        """A new location for node ``i`` (never shared: XDE's STEP writer tells
        located shapes apart by their location's identity)."""
        k = int(p.place[i])
        return TopLoc_Location(_trsf(p.placements[k], int(p.forms[k]))) if k >= 0 else None

    def located(i: int) -> Any:
        s = shapes[int(p.ref[i])].Oriented(_ORIENT[int(p.orient[i])])
        loc = place(i)
        return s if loc is None else s.Located(loc)

    assemblies = set(p.parent[p.kind == INSTANCE].tolist())
    labels: dict[int, Any] = {}
    auto = XCAFDoc_ShapeTool.AutoNaming_s()
    XCAFDoc_ShapeTool.SetAutoNaming_s(False)
    try:
        for i in np.flatnonzero(p.kind == PRODUCT).tolist():
            if i in assemblies or p.ref[i] < 0:
                labels[i] = st.NewShape()
            else:
                labels[i] = st.AddShape(located(i), False, False)
        for i in np.flatnonzero(p.kind == INSTANCE).tolist():
            loc = place(i) or TopLoc_Location()
            labels[i] = st.AddComponent(labels[int(p.parent[i])], labels[int(p.ref[i])], loc)
        st.UpdateAssemblies()  # an assembly's shape exists from here on
        subs: dict[tuple[int, Any], _SubShapes] = {}
        for i in np.flatnonzero(p.kind == SUBSHAPE).tolist():
            part = labels[int(p.parent[i])]
            kind = shapes[int(p.ref[i])].ShapeType()
            if (int(p.parent[i]), kind) not in subs:
                subs[int(p.parent[i]), kind] = _SubShapes(XCAFDoc_ShapeTool.GetShape_s(part), kind)
            sub = subs[int(p.parent[i]), kind].find(p, i, shapes)
            labels[i] = st.AddSubShape(part, sub or located(i))
    finally:
        XCAFDoc_ShapeTool.SetAutoNaming_s(auto)
    for i, lab in labels.items():
        if lab.IsNull():
            raise RebuildError(f"product node {i}: XDE refuses its shape")
        if p.flags[i] & NAMED:
            TDataStd_Name.Set_s(lab, _extended(p.names[i]))
        for t, c in zip(_TYPES, p.colour[i].tolist()):
            if c >= 0:
                ct.SetColor(lab, _rgba(p.colours[c]), t)
        if p.flags[i] & HIDDEN:
            ct.SetVisibility(lab, False)
    for name, hidden, members in zip(p.layer_names, p.layer_hidden.tolist(), p.layer_members):
        layer = lt.AddLayer(_extended(name), not hidden)
        for x in members:
            lt.SetLayer(labels[x], layer, False)
    return doc


class _SubShapes:
    """The sub-shapes of one type in a part's shape, by the shape they locate.

    Made once per part and type: looking each sub-shape node up by a scan of
    all of them cost 0.13 s of a 0.18 s STEP write of featuretype (629 named
    faces)."""

    def __init__(self, whole: Any, kind: Any) -> None:
        subs = TopTools_IndexedMapOfShape()
        TopExp.MapShapes_s(whole, kind, subs)
        plain = TopLoc_Location()
        self._keys = TopTools_IndexedMapOfShape()  # the sub-shapes, unlocated
        self._located: list[list[Any]] = []  # per key, its sub-shapes in map order
        for j in range(1, subs.Extent() + 1):
            s = subs.FindKey(j)
            k = self._keys.Add(s.Located(plain))
            if k > len(self._located):
                self._located.append([])
            self._located[k - 1].append(s)

    def find(self, p: ProductData, i: int, shapes: list[Any]) -> Any:
        """The sub-shape node ``i`` names: the one on the node's ``SHAP`` row
        whose location has the node's placement (XDE needs the very
        sub-shape, location included, not an equal copy); None if there is
        none (XDE also takes a compound of sub-shapes, which is no sub-shape)."""
        k = self._keys.FindIndex(shapes[int(p.ref[i])])
        if k == 0:
            return None
        n = int(p.place[i])
        want = None if n < 0 else p.placements[n].reshape(-1).tolist()
        for s in self._located[k - 1]:
            loc = s.Location()
            if (want is None and loc.IsIdentity()) or (
                want is not None and _trsf_rows(loc.Transformation()) == want
            ):
                return s.Oriented(_ORIENT[int(p.orient[i])])
        return None


def step_schema(header: dict[str, list[str]]) -> str:
    """``write.step.schema`` for a source header (AP214IS when unknown)."""
    ids = " ".join(header.get("schema", [])).upper()
    for prefix, schema in _SCHEMAS:
        if prefix in ids:
            return schema
    return "AP214IS"


def write(
    p: ProductData,
    root: Any,
    path: str | os.PathLike[str],
    fmt: str,
    unit: str,
    name: str = "",
    system: str = "",
    pcurves: bool = True,
    uncertainty: float | None = None,
) -> None:
    """Write a decoded shape with its product data to STEP or IGES.

    ``root`` is the shape decoded from the container: its ``SHAP`` rows are
    numbered again (:func:`shape_rows`) to find each node's shape.  STEP is
    written in the source's schema (:func:`step_schema`) with its header
    fields, assembly occurrences numbered 1, 2 …; IGES with fixed dates.
    Header fields the source did not have (an IGES source's) are ``name``,
    ``system`` as originating system and ``exchange.STEP_TIME_STAMP``, as
    ``files.write_shape`` writes them, so the output depends on nothing else.
    Without ``pcurves``, STEP edges get their 3-D curves only; ``uncertainty``
    as ``files.write_shape``'s.

    Raises
    ------
    RebuildError
        XDE or the writer refuses the shapes (for STEP, any failure of the
        write: XDE translates the shapes only then).
    OutputError
        The IGES file cannot be written.
    """
    doc = to_document(p, shape_rows(root)[2])
    if fmt == "IGES":
        with (
            static("write.iges.unit", unit),
            static(*IGES_BREP_MODE),
        ):
            w = IGESCAFControl_Writer()
            w.SetColorMode(True)
            w.SetNameMode(True)
            w.SetLayerMode(True)
            write_iges(w, lambda: w.Transfer(doc), Path(path), uncertainty, "product")
        return
    schema = step_schema(p.header)
    with (
        static("write.step.unit", unit),
        static("write.step.schema", schema),
        static("write.stepcaf.subshapes.name", "1"),
    ):
        sw: Any = STEPCAFControl_Writer()
        sw.SetColorMode(True)
        sw.SetNameMode(True)
        sw.SetLayerMode(True)
        # set once the writer exists (its constructor may reset it), for the
        # transfer and the write (which translates the shapes)
        with step_settings(pcurves, uncertainty):
            if not sw.Transfer(doc, STEPControl_AsIs):
                raise RebuildError("the STEP writer refused the product")
            model = sw.ChangeWriter().Model()
            default = {
                "name": [name],
                "time_stamp": [STEP_TIME_STAMP],
                "originating_system": [system],
            }
            _set_header(model, {**default, **p.header})
            settle = schema == "AP203" or (p.kind == INSTANCE).any()  # dates, occurrences
            with settled(model) if settle else contextlib.nullcontext():
                status = sw.Write(str(path))
    if status != IFSelect_ReturnStatus.IFSelect_RetDone:
        # XDE's Transfer only collects; the shapes are translated on Write, so
        # a shape OCCT cannot write fails here (the folder was checked before)
        raise RebuildError(f"the STEP writer refused the shape ({status.name})")


def _set_header(model: Any, header: dict[str, list[str]]) -> None:
    """FILE_NAME and FILE_DESCRIPTION from the source (FILE_SCHEMA is the writer's)."""
    h = APIHeaderSection_MakeHeader(model)

    def s(x: str) -> Any:
        return TCollection_HAsciiString(x)

    for key, setter in (
        ("name", h.SetName),
        ("time_stamp", h.SetTimeStamp),
        ("preprocessor_version", h.SetPreprocessorVersion),
        ("originating_system", h.SetOriginatingSystem),
        ("authorisation", h.SetAuthorisation),
        ("implementation_level", h.SetImplementationLevel),
    ):
        if header.get(key):
            setter(s(header[key][0]))
    lists: tuple[tuple[str, Any], ...] = (
        ("author", h.SetAuthor),
        ("organization", h.SetOrganization),
        ("description", h.SetDescription),
    )
    for key, setter in lists:
        if header.get(key):
            vals = header[key]
            arr = Interface_HArray1OfHAsciiString(1, len(vals))
            for i, v in enumerate(vals, 1):
                arr.SetValue(i, s(v))
            setter(arr)


# ---------------------------------------------------------------- what a reader sees


def read_document(path: str | os.PathLike[str]) -> Any:
    """A STEP or IGES file read by OCCT's XCAF reader (names, colours, layers)."""
    p = Path(path)
    fmt = sniff_format(p, check_readable(p))
    caf, _ = caf_reader(fmt)
    if caf.ReadFile(str(p)) != IFSelect_ReturnStatus.IFSelect_RetDone:
        raise RebuildError(f"cannot read {p.name}")
    doc = new_document()
    with auto_naming():
        if not caf.Transfer(doc):
            raise RebuildError(f"nothing transfers from {p.name}")
    return doc


def round_trip(src: str | os.PathLike[str], dst: str | os.PathLike[str]) -> None:
    """OCCT's own XCAF read -> write of ``src`` to ``dst`` (STEP in the source's
    schema, or IGES by ``dst``'s extension): what the tests compare with."""
    s = Path(src)
    fmt = sniff_format(s, check_readable(s))
    caf, plain = caf_reader(fmt)
    caf.ReadFile(str(s))
    doc = new_document()
    with auto_naming():
        caf.Transfer(doc)
    if Path(dst).suffix.lower() in (".igs", ".iges"):
        with static(*IGES_BREP_MODE):
            w: Any = IGESCAFControl_Writer()
            w.Transfer(doc)
            w.ComputeModel()
            w.Write(str(dst))
        return
    schema = step_schema(step_header(plain) if fmt == "STEP" else {})
    with static("write.step.schema", schema), static("write.stepcaf.subshapes.name", "1"):
        sw = STEPCAFControl_Writer()
        sw.Transfer(doc, STEPControl_AsIs)
        sw.Write(str(dst))


def _r(x: float) -> float:
    return round(x, 6) + 0.0


def view(path: str | os.PathLike[str], points: bool = False) -> dict[str, Any]:
    """A file as OCCT's XCAF reader sees it, for comparisons.

    ``points``: also give ``face_points``, parallel to ``face_colours``: per
    face, the centres of its mesh triangles (``occ.mesh.face_meshes``, in the
    part's own coordinates), so that faces can be paired by where they are
    when a reader splits one (:func:`match_faces`).

    Returns
    -------
    dict
        ``tree``: nested (name, placement rounded to 1e-6, children) from the
        free shapes; ``parts`` and ``instances``: multisets of names;
        ``face_colours``: per leaf occurrence, the surface colour of every
        face (the face's own, else the nearest of its part and the
        instances above it), rounded to 1e-6; ``sub_shape_names``: the
        multiset of sub-shape label names; ``layers``: layer name ->
        sorted member names.
    """
    doc = read_document(path)
    st = XCAFDoc_DocumentTool.ShapeTool_s(doc.Main())
    lt = XCAFDoc_DocumentTool.LayerTool_s(doc.Main())

    def colour(label: Any) -> tuple[float, ...] | None:
        for t in (_TYPES[1], _TYPES[0]):
            c = Quantity_ColorRGBA()
            if XCAFDoc_DocumentTool.ColorTool_s(doc.Main()).GetColor_s(label, t, c):
                rgb = c.GetRGB()
                return tuple(_r(v) for v in (rgb.Red(), rgb.Green(), rgb.Blue(), c.Alpha()))
        return None

    parts: Counter[str] = Counter()
    instances: Counter[str] = Counter()
    faces: list[Any] = []
    where: dict[tuple[str, int], np.ndarray] = {}
    sub_names: Counter[str] = Counter()

    def placement(label: Any) -> list[float]:
        t = XCAFDoc_ShapeTool.GetLocation_s(label).Transformation()
        return [_r(v) for v in _trsf_rows(t)]

    def walk(label: Any, inherited: tuple[float, ...] | None, path: str) -> dict[str, Any]:
        name = _name(label) or ""
        own = colour(label)
        if XCAFDoc_ShapeTool.IsAssembly_s(label):
            kids = []
            for c in _seq(XCAFDoc_ShapeTool.GetComponents_s, label):
                ref = TDF_Label()
                XCAFDoc_ShapeTool.GetReferredShape_s(c, ref)
                cname = _name(c) or ""
                instances[cname] += 1
                sub = walk(ref, colour(c) or own or inherited, f"{path}/{cname}")
                kids.append({"instance": cname, "placement": placement(c), "of": sub})
            parts[name] += 0
            return {"assembly": name, "children": kids}
        parts[name] += 1
        base = own or inherited
        subs = TopTools_IndexedMapOfShape()
        sub_colour: list[tuple[float, ...]] = []
        for s in _seq(XCAFDoc_ShapeTool.GetSubShapes_s, label):
            sub_names[_name(s) or ""] += 1
            sc = colour(s)
            if sc is not None:
                ex = TopExp_Explorer(XCAFDoc_ShapeTool.GetShape_s(s), TopAbs_FACE)
                while ex.More():
                    if not subs.FindIndex(ex.Current()):
                        subs.Add(ex.Current())
                        sub_colour.append(sc)
                    ex.Next()
        shape = XCAFDoc_ShapeTool.GetShape_s(label)
        if points:
            index = TopTools_IndexedMapOfShape()
            TopExp.MapShapes_s(shape, TopAbs_FACE, index)
            centres = [
                p[t].mean(axis=1) if len(t) else _inner_point(f)
                for f, (p, t) in zip(faces_of(shape), face_meshes(shape))
            ]
        ex = TopExp_Explorer(shape, TopAbs_FACE)
        k = 0
        while ex.More():
            j = subs.FindIndex(ex.Current())
            faces.append((path, k, sub_colour[j - 1] if j else base))
            if points:
                where[path, k] = centres[index.FindIndex(ex.Current()) - 1]
            k += 1
            ex.Next()
        return {"part": name}

    tree = [walk(lab, None, _name(lab) or "") for lab in _seq(st.GetFreeShapes)]
    layers = {}
    for lab in _seq(lt.GetLayerLabels):
        name = TCollection_ExtendedString()
        lt.GetLayer(lab, name)
        members = sorted(_name(x) or "" for x in _seq(lt.GetShapesOfLayer_s, lab))
        layers[str(name.ToExtString())] = members
    faces.sort(key=lambda f: (f[0], f[1]))
    out = {
        "tree": tree,
        "parts": dict(parts),
        "instances": dict(instances),
        "face_colours": faces,
        "sub_shape_names": dict(sub_names),
        "layers": layers,
    }
    if points:
        out["face_points"] = [where[f[0], f[1]] for f in faces]
    return out


def _inner_point(face: Any) -> np.ndarray:
    """One point of a face OCCT could not mesh: its surface at the middle of
    its UV bounds, shape (1, 3)."""
    u0, u1, v0, v1 = BRepTools.UVBounds_s(face)
    p = BRep_Tool.Surface_s(face).Value((u0 + u1) / 2, (v0 + v1) / 2)
    return np.array([[p.X(), p.Y(), p.Z()]])


def match_faces(a: dict[str, Any], b: dict[str, Any]) -> list[tuple[int, int]]:
    """Pairs (i, j) of faces of two :func:`view` results made with ``points``:
    each face of ``a`` with the face of ``b`` (of the same occurrence path)
    that holds most of its triangle centres' nearest neighbours, and each
    face of ``b`` likewise with one of ``a``.  A face a reader split in two
    pairs each piece with the whole; a face that has no triangles, or whose
    path ``b`` lacks, pairs with nothing (j or i = -1)."""
    from scipy.spatial import cKDTree

    def one_way(x: dict[str, Any], y: dict[str, Any]) -> list[int]:
        by_path: dict[str, list[int]] = {}
        for j, f in enumerate(y["face_colours"]):
            by_path.setdefault(f[0], []).append(j)
        trees: dict[str, tuple[Any, np.ndarray]] = {}
        for path, js in by_path.items():
            pts = [y["face_points"][j] for j in js]
            owner = np.repeat(js, [len(p) for p in pts])
            if len(owner):
                trees[path] = (cKDTree(np.concatenate(pts)), owner)
        out = []
        for i, f in enumerate(x["face_colours"]):
            pts = x["face_points"][i]
            if f[0] not in trees or not len(pts):
                out.append(-1)
                continue
            tree, owner = trees[f[0]]
            near = owner[tree.query(pts)[1]]
            out.append(int(np.bincount(near).argmax()))
        return out

    ab, ba = one_way(a, b), one_way(b, a)
    return [(i, j) for i, j in enumerate(ab)] + [(i, j) for j, i in enumerate(ba)]
