"""Generate the small STEP sample files used by nurbscomp.

The script builds solids and surface models with cadquery and OCP and
writes them as AP214 STEP files (millimetres) next to this script:

``loft.step``
    A lofted freeform solid through four closed spline / ellipse sections.
``bracket.step``
    A machined bracket: box with holes, a pocket, fillets and chamfers.
``teapot.step``
    The Utah (Newell) teapot as 32 bicubic B-spline faces read from a
    ``.bpt`` Bezier patch file, sewn so that neighbouring patches share
    edges.
``blob.step``
    A smooth, bumpy, closed freeform solid made of 63 bicubic B-spline
    patches (9 x 7), in the spirit of the 63-patch "bunny" model.
``rings.step``
    A turned part (a cone frustum with a bore, its edges filleted) converted
    to rational B-splines (``BRepBuilderAPI_NurbsConvert``): its circles,
    cylinders, cones and tori as rational quadratic nets, the rows of arcs
    of format 2.14.
``crossed.step``
    Two cylinders of different radii crossed at right angles and fused:
    their intersection curves are B-splines, which an IGES surface model
    writes once per face, the second running the other way (format 2.17's
    mapped knot vectors).
``assembly.step``
    A cadquery ``Assembly`` with product data (format 1.2's ``PROD``): a
    plate with four bolts (one part placed three times, and a red one), a
    nested sub-assembly of two brackets (one mirrored) used twice, names,
    colours on parts, on an instance and on a single face, and two layers.

The output is deterministic: random perturbations use a fixed seed and the
STEP header (time stamp, author, organisation, ...) is fixed, so running the
script twice produces byte-identical files.

After writing, every file is read back with ``STEPControl_Reader`` and a short
summary (topology counts, surface types, ``BRepCheck_Analyzer`` validity) is
printed.

Usage
-----
::

    python samples/make_samples.py [TEAPOT_BPT] [--out-dir DIR]
"""

from __future__ import annotations

import argparse
import math
from collections import Counter
from collections.abc import Sequence
from pathlib import Path

import cadquery as cq
import numpy as np
from OCP.APIHeaderSection import APIHeaderSection_MakeHeader
from OCP.BRepAdaptor import BRepAdaptor_Surface
from OCP.BRepBuilderAPI import (
    BRepBuilderAPI_MakeFace,
    BRepBuilderAPI_MakeSolid,
    BRepBuilderAPI_NurbsConvert,
    BRepBuilderAPI_Sewing,
)
from OCP.BRepCheck import BRepCheck_Analyzer
from OCP.BRepGProp import BRepGProp
from OCP.BRepLib import BRepLib
from OCP.Geom import Geom_BSplineSurface
from OCP.gp import gp_Ax2, gp_Dir, gp_Pnt, gp_Trsf, gp_Vec
from OCP.GProp import GProp_GProps
from OCP.IFSelect import IFSelect_ReturnStatus
from OCP.Interface import Interface_Static
from OCP.Message import Message, Message_Gravity
from OCP.STEPControl import STEPControl_AsIs, STEPControl_Reader, STEPControl_Writer
from OCP.TColgp import TColgp_Array2OfPnt
from OCP.TCollection import TCollection_HAsciiString
from OCP.TColStd import TColStd_Array1OfInteger, TColStd_Array1OfReal
from OCP.TDataStd import TDataStd_Name
from OCP.TDF import TDF_Label, TDF_LabelSequence
from OCP.TopAbs import (
    TopAbs_EDGE,
    TopAbs_FACE,
    TopAbs_SHELL,
    TopAbs_SOLID,
    TopAbs_VERTEX,
)
from OCP.TopExp import TopExp
from OCP.TopoDS import TopoDS, TopoDS_Shape
from OCP.TopTools import TopTools_IndexedMapOfShape

#: Directory containing this script; samples are written here by default.
SAMPLES_DIR = Path(__file__).resolve().parent

#: Default location of the Newell teapot patch file (outside the repository).
DEFAULT_TEAPOT_BPT = SAMPLES_DIR.parent / ".." / "shared" / "corpus" / "teapot-mrep__teapot.bpt"

#: Fixed STEP header time stamp so that the output is reproducible.
FIXED_TIMESTAMP = "2000-01-01T00:00:00"

#: Seed for the random perturbations of the blob.
BLOB_SEED = 20240607


# ---------------------------------------------------------------------------
# Generic helpers
# ---------------------------------------------------------------------------


def _silence_occt_messages() -> None:
    """Only let OCCT print failures (hides the STEP transfer statistics)."""
    printers = Message.DefaultMessenger_s().Printers()
    for index in range(1, printers.Size() + 1):
        printers.Value(index).SetTraceLevel(Message_Gravity.Message_Fail)


def bezier_bspline_surface(poles: np.ndarray) -> Geom_BSplineSurface:
    """Build a clamped bicubic B-spline surface from a 4 x 4 Bezier net.

    Parameters
    ----------
    poles : numpy.ndarray
        Control points of shape ``(4, 4, 3)``; ``poles[i, j]`` is the pole in
        row ``i`` (u direction) and column ``j`` (v direction).

    Returns
    -------
    OCP.Geom.Geom_BSplineSurface
        Degree 3 x 3 surface with knots ``[0, 1]`` of multiplicity 4 in both
        directions, i.e. the Bezier patch written in B-spline form.
    """
    nu, nv, _ = poles.shape
    if (nu, nv) != (4, 4):
        raise ValueError(f"expected a 4x4 control net, got {nu}x{nv}")
    array = TColgp_Array2OfPnt(1, 4, 1, 4)
    for i in range(4):
        for j in range(4):
            x, y, z = (float(c) for c in poles[i, j])
            array.SetValue(i + 1, j + 1, gp_Pnt(x, y, z))
    knots = TColStd_Array1OfReal(1, 2)
    knots.SetValue(1, 0.0)
    knots.SetValue(2, 1.0)
    mults = TColStd_Array1OfInteger(1, 2)
    mults.SetValue(1, 4)
    mults.SetValue(2, 4)
    return Geom_BSplineSurface(array, knots, knots, mults, mults, 3, 3)


def sew_faces(faces: Sequence[TopoDS_Shape], tolerance: float) -> TopoDS_Shape:
    """Sew faces so that coincident boundaries become shared edges.

    Parameters
    ----------
    faces : sequence of OCP.TopoDS.TopoDS_Shape
        Faces to sew.
    tolerance : float
        Sewing tolerance (model units).

    Returns
    -------
    OCP.TopoDS.TopoDS_Shape
        Sewed shape: a shell, or a compound of shells and free faces.
    """
    sewing = BRepBuilderAPI_Sewing(tolerance)
    for face in faces:
        sewing.Add(face)
    sewing.Perform()
    return sewing.SewedShape()


def _fixed_header(model, name: str) -> None:
    """The STEP header every sample gets: fixed fields, so the same shape gives the same bytes."""
    header = APIHeaderSection_MakeHeader(model)
    header.SetName(TCollection_HAsciiString(name))
    header.SetTimeStamp(TCollection_HAsciiString(FIXED_TIMESTAMP))
    header.SetAuthorValue(1, TCollection_HAsciiString("nurbscomp"))
    header.SetOrganizationValue(1, TCollection_HAsciiString("nurbscomp"))
    header.SetOriginatingSystem(TCollection_HAsciiString("nurbscomp make_samples.py"))
    header.SetAuthorisation(TCollection_HAsciiString("none"))
    header.SetDescriptionValue(1, TCollection_HAsciiString(f"nurbscomp sample {name}"))


def write_step(shape: TopoDS_Shape, path: Path, name: str) -> None:
    """Write a shape to an AP214 STEP file in millimetres with a fixed header.

    Parameters
    ----------
    shape : OCP.TopoDS.TopoDS_Shape
        Shape to export.
    path : pathlib.Path
        Output file.
    name : str
        Product name and STEP header file name.

    Raises
    ------
    RuntimeError
        If the transfer or the write fails.
    """
    Interface_Static.SetCVal_s("write.step.schema", "AP214IS")
    Interface_Static.SetCVal_s("write.step.unit", "MM")
    Interface_Static.SetCVal_s("write.step.product.name", name)
    writer = STEPControl_Writer()
    status = writer.Transfer(shape, STEPControl_AsIs)
    if status != IFSelect_ReturnStatus.IFSelect_RetDone:
        raise RuntimeError(f"STEP transfer failed for {path}: {status}")
    _fixed_header(writer.Model(), name)
    status = writer.Write(str(path))
    if status != IFSelect_ReturnStatus.IFSelect_RetDone:
        raise RuntimeError(f"STEP write failed for {path}: {status}")


def make_assembly() -> tuple[cq.Assembly, dict[str, TopoDS_Shape]]:
    """A plate, four bolts and two bracket sub-assemblies (see the module docstring).

    Returns
    -------
    cadquery.Assembly
    dict
        Three faces of the plate part ("plate >Z", "plate <Z", "plate >X"),
        which :func:`write_assembly_step` names, colours and puts on a layer.
    """
    bolt = cq.Workplane().cylinder(20, 3).faces(">Z").workplane().polygon(6, 10).extrude(4)
    plate = cq.Workplane().box(60, 40, 5).edges("|Z").fillet(4)
    bracket = cq.Workplane().box(20, 10, 15).faces(">Y").workplane().hole(5)
    mirror, lift = gp_Trsf(), gp_Trsf()
    mirror.SetMirror(gp_Ax2(gp_Pnt(0, 0, 0), gp_Dir(1, 0, 0)))
    lift.SetTranslation(gp_Vec(0, 0, 10))
    sub = cq.Assembly(name="bracket set")
    left = cq.Location((-15, 0, 10))
    sub.add(bracket, name="left bracket", loc=left, color=cq.Color(0.2, 0.4, 0.8))
    sub.add(bracket, name="right bracket (mirrored)", loc=cq.Location(lift.Multiplied(mirror)))
    top = cq.Assembly(name="plate assembly")
    top.add(plate, name="plate", color=cq.Color(0.7, 0.7, 0.7))
    for k, (x, y) in enumerate([(-25, -15), (25, -15), (-25, 15), (25, 15)]):
        red = cq.Color(0.9, 0.1, 0.1) if k == 3 else None
        top.add(
            bolt, name=f"bolt {k + 1}", loc=cq.Location((x, y, 12), (0, 0, 1), 30 * k), color=red
        )
    top.add(sub, name="brackets", loc=cq.Location((0, 0, 2.5)))
    top.add(sub, name="brackets 2", loc=cq.Location((0, 20, 2.5), (0, 0, 1), 90))
    faces = {f"plate {sel}": plate.faces(sel).val().wrapped for sel in (">Z", "<Z", ">X")}
    return top, faces


def write_assembly_step(
    assy: cq.Assembly, faces: dict[str, TopoDS_Shape], path: Path, name: str
) -> None:
    """Write an assembly through OCCT's XDE writer (AP214, millimetres, fixed
    header), with what cadquery has no deterministic call for: the plate's
    top face named "top face" and green, and a layer "machined" holding its
    bottom face and its end face (named "end face").  (A colour or a layer
    set on an instance label is not written by OCCT 7.9's STEP writer, nor
    are sub-shape names: they are left out.)

    Raises
    ------
    RuntimeError
        If the transfer or the write fails.
    """
    from cadquery.occ_impl.assembly import toCAF
    from OCP.Quantity import Quantity_Color, Quantity_TypeOfColor
    from OCP.STEPCAFControl import STEPCAFControl_Writer
    from OCP.TCollection import TCollection_ExtendedString
    from OCP.XCAFDoc import XCAFDoc_ColorType, XCAFDoc_DocumentTool

    top, doc = toCAF(assy, coloredSTEP=True)
    tool = XCAFDoc_DocumentTool.ShapeTool_s(doc.Main())
    colours = XCAFDoc_DocumentTool.ColorTool_s(doc.Main())
    layers = XCAFDoc_DocumentTool.LayerTool_s(doc.Main())
    rgb = Quantity_TypeOfColor.Quantity_TOC_RGB
    surf = XCAFDoc_ColorType.XCAFDoc_ColorSurf
    shapes = TDF_LabelSequence()
    tool.GetShapes(shapes)
    plate = next(
        (
            shapes.Value(i)
            for i in range(1, shapes.Length() + 1)
            if _name(shapes.Value(i)) == "plate"
        ),
        None,
    )
    if plate is None:
        raise RuntimeError("the plate part is not in the document")
    for key, face_name, colour, layer in (
        ("plate >Z", "top face", (0.1, 0.8, 0.1), None),
        ("plate <Z", None, None, "machined"),
        ("plate >X", "end face", None, "machined"),
    ):
        sub = tool.AddSubShape(plate, faces[key])
        if sub.IsNull():
            raise RuntimeError(f"{key} is not a face of the plate")
        if face_name:
            TDataStd_Name.Set_s(sub, TCollection_ExtendedString(face_name))
        if colour:
            colours.SetColor(sub, Quantity_Color(*colour, rgb), surf)
        if layer:
            layers.SetLayer(sub, TCollection_ExtendedString(layer), False)
    tool.UpdateAssemblies()
    Interface_Static.SetCVal_s("write.step.schema", "AP214IS")
    Interface_Static.SetCVal_s("write.step.unit", "MM")
    Interface_Static.SetIVal_s("write.stepcaf.subshapes.name", 1)
    writer = STEPCAFControl_Writer()
    if not writer.Transfer(doc, STEPControl_AsIs):
        raise RuntimeError(f"STEP transfer failed for {path}")
    _fixed_header(writer.ChangeWriter().Model(), name)
    status = writer.Write(str(path))
    if status != IFSelect_ReturnStatus.IFSelect_RetDone:
        raise RuntimeError(f"STEP write failed for {path}: {status}")


def _name(label: TDF_Label) -> str | None:
    """A label's name (OCP crashes in ``FindAttribute`` when there is none)."""
    n = TDataStd_Name()
    if label.IsAttribute(TDataStd_Name.GetID_s()) and label.FindAttribute(n.GetID_s(), n):
        return str(n.Get().ToExtString())
    return None


def read_step(path: Path) -> TopoDS_Shape:
    """Read a STEP file and return its (single) resulting shape.

    Parameters
    ----------
    path : pathlib.Path
        STEP file to read.

    Returns
    -------
    OCP.TopoDS.TopoDS_Shape
        The shape built from all transferable roots.
    """
    reader = STEPControl_Reader()
    status = reader.ReadFile(str(path))
    if status != IFSelect_ReturnStatus.IFSelect_RetDone:
        raise RuntimeError(f"STEP read failed for {path}: {status}")
    reader.TransferRoots()
    return reader.OneShape()


def count_subshapes(shape: TopoDS_Shape) -> dict[str, int]:
    """Count distinct solids, shells, faces, edges and vertices of a shape.

    Parameters
    ----------
    shape : OCP.TopoDS.TopoDS_Shape
        Shape to inspect.

    Returns
    -------
    dict of str to int
        Number of unique sub-shapes per type.
    """
    counts = {}
    for label, kind in (
        ("solids", TopAbs_SOLID),
        ("shells", TopAbs_SHELL),
        ("faces", TopAbs_FACE),
        ("edges", TopAbs_EDGE),
        ("vertices", TopAbs_VERTEX),
    ):
        shape_map = TopTools_IndexedMapOfShape()
        TopExp.MapShapes_s(shape, kind, shape_map)
        counts[label] = shape_map.Extent()
    return counts


def face_surface_types(shape: TopoDS_Shape) -> dict[str, int]:
    """Count the faces of a shape by underlying surface type.

    Parameters
    ----------
    shape : OCP.TopoDS.TopoDS_Shape
        Shape to inspect.

    Returns
    -------
    dict of str to int
        Surface type name (e.g. ``"BSplineSurface"``) to number of faces.
    """
    shape_map = TopTools_IndexedMapOfShape()
    TopExp.MapShapes_s(shape, TopAbs_FACE, shape_map)
    types: Counter = Counter()
    for index in range(1, shape_map.Extent() + 1):
        face = TopoDS.Face_s(shape_map.FindKey(index))
        kind = BRepAdaptor_Surface(face).GetType().name
        types[kind.replace("GeomAbs_", "")] += 1
    return dict(sorted(types.items()))


def solid_volume(shape: TopoDS_Shape) -> float:
    """Return the volume enclosed by a shape.

    Parameters
    ----------
    shape : OCP.TopoDS.TopoDS_Shape
        Solid (or shape containing solids).

    Returns
    -------
    float
        Volume in cubic model units (negative if the solid is inside out).
    """
    props = GProp_GProps()
    BRepGProp.VolumeProperties_s(shape, props)
    return props.Mass()


# ---------------------------------------------------------------------------
# Samples
# ---------------------------------------------------------------------------


def _section(
    rx: float,
    ry: float,
    z: float,
    lobes: int = 0,
    amp: float = 0.0,
    phase: float = 0.0,
    centre: tuple[float, float] = (0.0, 0.0),
    n_points: int = 10,
) -> cq.Wire:
    """Closed periodic spline section for the loft.

    The section interpolates ``n_points`` points of the lobed ellipse
    ``r(a) = 1 + amp * cos(lobes * a + phase)`` scaled by ``(rx, ry)`` in the
    plane ``Z = z``. All sections start on the +X side so the loft does not
    twist.

    Parameters
    ----------
    rx, ry : float
        Semi-axes of the underlying ellipse.
    z : float
        Height of the section plane.
    lobes : int, optional
        Number of lobes of the radial modulation.
    amp : float, optional
        Relative amplitude of the modulation (0 gives an ellipse).
    phase : float, optional
        Angular phase of the modulation.
    centre : tuple of float, optional
        ``(x, y)`` centre of the section.
    n_points : int, optional
        Number of interpolated points.

    Returns
    -------
    cadquery.Wire
        Single-edge closed wire.
    """
    points = []
    for k in range(n_points):
        a = 2.0 * math.pi * k / n_points
        r = 1.0 + amp * math.cos(lobes * a + phase)
        points.append(
            cq.Vector(centre[0] + rx * r * math.cos(a), centre[1] + ry * r * math.sin(a), z)
        )
    return cq.Wire.assembleEdges([cq.Edge.makeSpline(points, periodic=True)])


def make_loft() -> TopoDS_Shape:
    """Build a freeform lofted solid through four different closed sections.

    The sections are an ellipse, a three-lobed and a five-lobed shape and a
    small shifted ellipse rotated by 90 degrees, all interpolated by closed
    periodic splines through the same number of points so that the loft
    surface stays compact.

    Returns
    -------
    OCP.TopoDS.TopoDS_Shape
        Closed solid with one B-spline side face and two planar caps.
    """
    sections = [
        _section(30.0, 18.0, 0.0),
        _section(24.0, 21.0, 25.0, lobes=3, amp=0.2),
        _section(18.0, 16.0, 55.0, lobes=5, amp=0.15, phase=0.4, centre=(2.0, 1.0)),
        _section(9.0, 12.0, 80.0, centre=(4.0, 2.0)),
    ]
    solid = cq.Solid.makeLoft(sections, ruled=False)
    if not solid.isValid():
        raise RuntimeError("loft construction produced an invalid solid")
    return solid.wrapped


def make_rings() -> TopoDS_Shape:
    """Build a turned part and convert it to rational B-splines.

    A cone frustum with a bore and its outer edges filleted, turned about
    a tilted axis so that no circle lies in a coordinate plane.

    Returns
    -------
    OCP.TopoDS.TopoDS_Shape
        The converted solid (every face a B-spline surface).
    """
    part = (
        cq.Workplane("XY")
        .circle(30.0)
        .workplane(offset=25.0)
        .circle(18.0)
        .loft()
        .faces(">Z")
        .workplane()
        .hole(12.0)
        .edges("not %LINE")
        .fillet(2.0)
        .val()
    )
    part = part.rotate(cq.Vector(0, 0, 0), cq.Vector(1, 2, 0), 23.0).translate(cq.Vector(5, -7, 11))
    return BRepBuilderAPI_NurbsConvert(part.wrapped, True).Shape()


def make_crossed() -> TopoDS_Shape:
    """Fuse a cylinder along z (radius 8) with one along x (radius 6), both
    40 long: two B-spline intersection curves.

    Returns
    -------
    OCP.TopoDS.TopoDS_Shape
        The fused solid.
    """
    a = cq.Workplane("XY").cylinder(40.0, 8.0)
    b = cq.Workplane("YZ").cylinder(40.0, 6.0)
    return a.union(b).val().wrapped


def make_bracket() -> TopoDS_Shape:
    """Build a filleted and chamfered mechanical bracket.

    An L-shaped part: a base plate with rounded corners and chamfered
    bottom edges, an upright web with rounded top edges and a filleted
    inner corner, three counterbored holes, a horizontal hole through the
    web and a rounded rectangular pocket in the underside.

    Returns
    -------
    OCP.TopoDS.TopoDS_Shape
        The bracket solid.
    """
    length, width, thick = 80.0, 50.0, 10.0
    # Base plate: rounded vertical corners, chamfered bottom edges.
    base = (
        cq.Workplane("XY")
        .box(length, width, thick)
        .edges("|Z")
        .fillet(6.0)
        .faces("<Z")
        .chamfer(1.0)
    )
    # Upright web at the -X end with rounded top edges.
    web = (
        cq.Workplane("XY")
        .workplane(offset=thick / 2.0)
        .center(-length / 2.0 + 6.0, 0)
        .rect(12.0, width)
        .extrude(35.0)
        .edges("|X and >Z")
        .fillet(5.0)
    )
    part = base.union(web)
    # Blend the inner corner between plate and web.
    part = part.edges(cq.selectors.BoxSelector((-28.5, -30, 4.0), (-27.5, 30, 6.0))).fillet(3.0)
    # Counterbored holes through the plate (workplane origin at (0, 0, 5)).
    part = (
        part.faces(">Z[-2]")
        .workplane(centerOption="ProjectedOrigin", origin=(0, 0, 0))
        .pushPoints([(10.0, -16.0), (10.0, 16.0), (31.0, 0.0)])
        .cboreHole(6.5, 11.0, 4.0)
    )
    # Horizontal hole through the web.
    part = (
        part.faces("<X").workplane(centerOption="ProjectedOrigin", origin=(0, 0, 28.0)).hole(10.0)
    )
    # Rounded rectangular pocket in the underside of the plate.
    pocket = (
        cq.Workplane("XY")
        .workplane(offset=-thick / 2.0)
        .center(8.0, 0)
        .sketch()
        .rect(30.0, 14.0)
        .vertices()
        .fillet(4.0)
        .finalize()
        .extrude(4.0)
    )
    part = part.cut(pocket)
    solid = part.val()
    if not solid.isValid():
        raise RuntimeError("bracket construction produced an invalid solid")
    return solid.wrapped


def read_bpt(path: Path) -> list[np.ndarray]:
    """Read a Bezier patch file in the ``.bpt`` format.

    The format is: a line with the number of patches, then for every patch a
    line ``"du dv"`` with the degrees followed by ``(du+1)*(dv+1)`` lines
    ``"x y z"``.

    Parameters
    ----------
    path : pathlib.Path
        File to read.

    Returns
    -------
    list of numpy.ndarray
        One ``(du+1, dv+1, 3)`` array of control points per patch.
    """
    tokens = path.read_text().split()
    pos = 0

    def take() -> str:
        nonlocal pos
        pos += 1
        return tokens[pos - 1]

    count = int(take())
    patches = []
    for _ in range(count):
        du, dv = int(take()), int(take())
        pts = [[float(take()) for _ in range(3)] for _ in range((du + 1) * (dv + 1))]
        patches.append(np.array(pts, dtype=float).reshape(du + 1, dv + 1, 3))
    if pos != len(tokens):
        raise ValueError(f"{path}: {len(tokens) - pos} unexpected trailing tokens")
    return patches


def make_teapot(bpt_path: Path, tolerance: float = 1e-6) -> TopoDS_Shape:
    """Build the Utah teapot as sewn bicubic B-spline faces.

    Each Bezier patch becomes a clamped bicubic ``Geom_BSplineSurface`` and a
    face bounded by its natural iso-curves. Boundaries that collapse to a
    point (lid top, bottom centre) become degenerated edges. The faces are
    sewn so that neighbouring patches share edges.

    Parameters
    ----------
    bpt_path : pathlib.Path
        Path of the teapot ``.bpt`` file (32 bicubic patches).
    tolerance : float, optional
        Face construction and sewing tolerance.

    Returns
    -------
    OCP.TopoDS.TopoDS_Shape
        Sewed shape (shells / compound) with one face per patch.
    """
    patches = read_bpt(bpt_path)
    faces = []
    for index, poles in enumerate(patches):
        surface = bezier_bspline_surface(poles)
        maker = BRepBuilderAPI_MakeFace(surface, tolerance)
        if not maker.IsDone():
            raise RuntimeError(f"teapot patch {index}: face construction failed")
        faces.append(maker.Face())
    sewed = sew_faces(faces, tolerance * 10.0)
    if count_subshapes(sewed)["faces"] != len(patches):
        raise RuntimeError("sewing changed the number of teapot faces")
    return sewed


def blob_control_net(n_u: int = 9, n_v: int = 7, seed: int = BLOB_SEED) -> np.ndarray:
    """Control net of a bumpy closed genus-0 B-spline surface.

    The surface is periodic in ``u`` (around the z axis, ``n_u`` poles) and
    clamped in ``v`` (south to north pole, ``n_v + 3`` pole rows). The first
    and last pole rows collapse to the poles; the second and penultimate rows
    lie in the horizontal plane through the respective pole, so the tangent
    plane is continuous there.

    Parameters
    ----------
    n_u : int, optional
        Number of spans (= poles) in the periodic direction.
    n_v : int, optional
        Number of spans in the pole-to-pole direction.
    seed : int, optional
        Seed for the deterministic random bumps.

    Returns
    -------
    numpy.ndarray
        Poles, array of shape ``(n_u, n_v + 3, 3)`` (mm).
    """
    rng = np.random.default_rng(seed)
    rows = n_v + 3
    # Latitude of each pole row, from the south (-pi/2) to the north pole.
    theta = np.linspace(-0.5 * math.pi, 0.5 * math.pi, rows)
    phi = 2.0 * math.pi * np.arange(n_u) / n_u
    # Ellipsoid semi-axes (mm) and random radial bumps per pole (the cubic
    # B-spline smooths them into an organic, bumpy surface).
    a, b, c = 32.0, 24.0, 28.0
    bumps = 1.0 + 0.22 * rng.uniform(-1.0, 1.0, size=(n_u, rows))
    poles = np.zeros((n_u, rows, 3))
    south = np.array([1.5, -0.8, -c])
    north = np.array([-2.0, 1.2, c * 1.05])
    for i in range(n_u):
        for j in range(rows):
            if j == 0:
                poles[i, j] = south
                continue
            if j == rows - 1:
                poles[i, j] = north
                continue
            if j in (1, rows - 2):
                # Ring in the tangent plane of the pole, mild radial noise.
                centre = south if j == 1 else north
                r = 9.0 * (1.0 + 0.25 * (bumps[i, j] - 1.0))
                poles[i, j] = centre + [
                    r * math.cos(phi[i]),
                    0.9 * r * math.sin(phi[i]),
                    0.0,
                ]
                continue
            ct, st = math.cos(theta[j]), math.sin(theta[j])
            # "Head" lean: shift the upper part along +x, belly bulge below.
            lean = 7.0 * max(st, 0.0) ** 2
            bulge = 1.0 + 0.12 * math.exp(-((theta[j] + 0.3) ** 2) / 0.2)
            r = bumps[i, j] * bulge
            poles[i, j] = [
                a * r * ct * math.cos(phi[i]) + lean,
                b * r * ct * math.sin(phi[i]),
                c * st * (1.0 + 0.08 * (bumps[i, j] - 1.0)),
            ]
    return poles


def blob_global_surface(poles: np.ndarray) -> Geom_BSplineSurface:
    """Bicubic B-spline surface, periodic in u and clamped in v.

    Parameters
    ----------
    poles : numpy.ndarray
        Control net of shape ``(n_u, n_v + 3, 3)`` as returned by
        :func:`blob_control_net`.

    Returns
    -------
    OCP.Geom.Geom_BSplineSurface
        Surface with uniform integer knots: ``u`` in ``[0, n_u]`` (periodic)
        and ``v`` in ``[0, n_v]``.
    """
    n_u, rows, _ = poles.shape
    n_v = rows - 3
    array = TColgp_Array2OfPnt(1, n_u, 1, rows)
    for i in range(n_u):
        for j in range(rows):
            array.SetValue(i + 1, j + 1, gp_Pnt(*(float(c) for c in poles[i, j])))
    u_knots = TColStd_Array1OfReal(1, n_u + 1)
    u_mults = TColStd_Array1OfInteger(1, n_u + 1)
    for k in range(n_u + 1):
        u_knots.SetValue(k + 1, float(k))
        u_mults.SetValue(k + 1, 1)
    v_knots = TColStd_Array1OfReal(1, n_v + 1)
    v_mults = TColStd_Array1OfInteger(1, n_v + 1)
    for k in range(n_v + 1):
        v_knots.SetValue(k + 1, float(k))
        v_mults.SetValue(k + 1, 4 if k in (0, n_v) else 1)
    return Geom_BSplineSurface(array, u_knots, v_knots, u_mults, v_mults, 3, 3, True, False)


def blob_bezier_net(global_surface: Geom_BSplineSurface) -> np.ndarray:
    """Piecewise Bezier control net of the global blob surface.

    The surface is made non-periodic (clamped) and every interior knot is raised to
    multiplicity 3 (the degree), which splits it at its knots into bicubic
    Bezier spans without changing its shape. The closing column (u = n_u) is
    set equal to the first one and the pole rows are set exactly to the pole
    points, so that patches built from this net share boundaries bit for bit.

    Parameters
    ----------
    global_surface : OCP.Geom.Geom_BSplineSurface
        Surface from :func:`blob_global_surface`. It is not modified.

    Returns
    -------
    numpy.ndarray
        Array of shape ``(3 * n_u + 1, 3 * n_v + 1, 3)``; patch ``(i, j)``
        uses ``net[3*i:3*i+4, 3*j:3*j+4]``.
    """
    surface = global_surface.Copy()  # OCP returns the concrete type
    u0, u1, v0, v1 = surface.Bounds()
    surface.SetUNotPeriodic()
    # SetUNotPeriodic leaves an unclamped knot vector: clamp it at [u0, u1].
    surface.Segment(u0, u1, v0, v1)
    for k in range(2, surface.NbUKnots()):
        surface.IncreaseUMultiplicity(k, 3)
    for k in range(2, surface.NbVKnots()):
        surface.IncreaseVMultiplicity(k, 3)
    n_u = surface.NbUKnots() - 1
    n_v = surface.NbVKnots() - 1
    if (surface.NbUPoles(), surface.NbVPoles()) != (3 * n_u + 1, 3 * n_v + 1):
        raise RuntimeError("unexpected pole count after knot insertion")
    net = np.array(
        [
            [
                [surface.Pole(a, b).X(), surface.Pole(a, b).Y(), surface.Pole(a, b).Z()]
                for b in range(1, surface.NbVPoles() + 1)
            ]
            for a in range(1, surface.NbUPoles() + 1)
        ]
    )
    if np.abs(net[-1] - net[0]).max() > 1e-9:
        raise RuntimeError("blob surface does not close in u")
    net[-1] = net[0]
    for row in (0, -1):
        if np.abs(net[:, row] - net[0, row]).max() > 1e-9:
            raise RuntimeError("blob pole row does not collapse to a point")
        net[:, row] = net[0, row]
    return net


def make_blob(n_u: int = 9, n_v: int = 7, tolerance: float = 1e-5) -> TopoDS_Shape:
    """Build a bumpy closed solid bounded by ``n_u * n_v`` bicubic patches.

    A global bicubic B-spline surface (periodic around the z axis, collapsed
    at both poles) is split at its knots into bicubic Bezier spans. Each span
    becomes a clamped bicubic B-spline face; the faces are sewn into a closed
    shell and made into a solid. The patches around each pole have one
    degenerated edge.

    Parameters
    ----------
    n_u : int, optional
        Number of patches around the z axis.
    n_v : int, optional
        Number of patches from pole to pole.
    tolerance : float, optional
        Sewing tolerance (mm).

    Returns
    -------
    OCP.TopoDS.TopoDS_Shape
        Valid, outward oriented solid with ``n_u * n_v`` faces.
    """
    poles = blob_control_net(n_u, n_v)
    net = blob_bezier_net(blob_global_surface(poles))
    faces = []
    for j in range(n_v):
        for i in range(n_u):
            patch = bezier_bspline_surface(net[3 * i : 3 * i + 4, 3 * j : 3 * j + 4])
            maker = BRepBuilderAPI_MakeFace(patch, 1e-7)
            if not maker.IsDone():
                raise RuntimeError(f"blob patch ({i}, {j}): face construction failed")
            faces.append(maker.Face())
    shell_shape = sew_faces(faces, tolerance)
    if shell_shape.ShapeType() != TopAbs_SHELL:
        raise RuntimeError(f"blob sewing gave {shell_shape.ShapeType()}, not a shell")
    solid = BRepBuilderAPI_MakeSolid(TopoDS.Shell_s(shell_shape)).Solid()
    BRepLib.OrientClosedSolid_s(solid)
    if solid_volume(solid) <= 0.0:
        raise RuntimeError("blob solid has non-positive volume")
    if not BRepCheck_Analyzer(solid).IsValid():
        raise RuntimeError("blob solid is not valid")
    return solid


# ---------------------------------------------------------------------------
# Driver
# ---------------------------------------------------------------------------


def report(path: Path) -> bool:
    """Re-read a STEP file and print its topology, surface types and validity.

    Parameters
    ----------
    path : pathlib.Path
        STEP file to check.

    Returns
    -------
    bool
        ``True`` if the re-read shape passes ``BRepCheck_Analyzer``.
    """
    shape = read_step(path)
    counts = count_subshapes(shape)
    valid = BRepCheck_Analyzer(shape).IsValid()
    print(f"{path.name}: {path.stat().st_size} bytes")
    print("  " + ", ".join(f"{k}={v}" for k, v in counts.items()))
    print("  surface types: " + ", ".join(f"{k}={v}" for k, v in face_surface_types(shape).items()))
    print(f"  valid (BRepCheck_Analyzer): {valid}")
    return valid


def main(argv: Sequence[str] | None = None) -> int:
    """Build, write and verify all samples.

    Parameters
    ----------
    argv : sequence of str, optional
        Command line arguments (defaults to ``sys.argv[1:]``).

    Returns
    -------
    int
        Process exit status: 0 if all files are valid, 1 otherwise.
    """
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "teapot_bpt",
        nargs="?",
        type=Path,
        default=DEFAULT_TEAPOT_BPT,
        help="teapot .bpt patch file (default: %(default)s)",
    )
    parser.add_argument(
        "--out-dir",
        type=Path,
        default=SAMPLES_DIR,
        help="output directory (default: the directory of this script)",
    )
    args = parser.parse_args(argv)
    _silence_occt_messages()
    out_dir: Path = args.out_dir
    out_dir.mkdir(parents=True, exist_ok=True)

    builders = {
        "loft": make_loft,
        "bracket": make_bracket,
        "teapot": lambda: make_teapot(args.teapot_bpt.resolve()),
        "blob": make_blob,
        "rings": make_rings,
        "crossed": make_crossed,
    }
    paths = []
    for name, build in builders.items():
        path = out_dir / f"{name}.step"
        write_step(build(), path, name)
        paths.append(path)
    write_assembly_step(*make_assembly(), out_dir / "assembly.step", "assembly")
    paths.append(out_dir / "assembly.step")

    all_valid = True
    for path in paths:
        all_valid &= report(path)
    return 0 if all_valid else 1


if __name__ == "__main__":
    raise SystemExit(main())
