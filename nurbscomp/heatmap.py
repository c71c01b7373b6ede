"""A picture of the error: faces coloured by their deviation, drawn offscreen with VTK.

Takes plain numpy data (each face's triangles, from ``occ.face_meshes``, and
its deviation in mm) and writes a PNG: the whole model on the left, a colour
bar in mm with the tolerance marked, and the worst face on its own on the
right, with the rest of the model faint around it.  VTK (which OCP's wheel
brings) renders without a display (EGL or OSMesa).
"""

from __future__ import annotations

import os
from typing import Any

import numpy as np

#: Size of the picture, pixels (width, height).
SIZE = (1200, 800)
#: The colour map (viridis, sampled): low deviation dark blue, high yellow.
_VIRIDIS = (
    (0.0, (0.267, 0.005, 0.329)),
    (0.25, (0.230, 0.322, 0.546)),
    (0.5, (0.128, 0.567, 0.551)),
    (0.75, (0.369, 0.789, 0.383)),
    (1.0, (0.993, 0.906, 0.144)),
)
#: Faces beyond the tolerance.
_OVER = (0.85, 0.10, 0.10)
_TEXT = (0.1, 0.1, 0.1)
#: The worst face's outline.
_MARK = (0.9, 0.0, 0.75)


def _vtk() -> Any:
    """VTK's modules, imported on first use (seconds), with its logging muted
    (it warns on stderr that there is no X display before it falls back to EGL)."""
    import vtkmodules.vtkCommonCore as core
    import vtkmodules.vtkRenderingOpenGL2  # noqa: F401 (registers the render window)
    from vtkmodules import vtkRenderingFreeType  # noqa: F401 (text)

    core.vtkObject.GlobalWarningDisplayOff()
    core.vtkLogger.SetStderrVerbosity(core.vtkLogger.VERBOSITY_OFF)
    import vtkmodules.all as vtk

    return vtk


def colour_range(dev: np.ndarray, tol: float | None) -> float:
    """Top of the colour scale: the largest deviation, or the tolerance when that
    is larger (so that it can be marked); 1 µm when both are 0."""
    top = max(float(dev.max(initial=0.0)), tol or 0.0)
    return top if top > 0 else 1e-3


def _polydata(vtk: Any, meshes: list[tuple[np.ndarray, np.ndarray]], values: np.ndarray) -> Any:
    """One polydata of every face's triangles, each triangle carrying its face's value."""
    from vtkmodules.util.numpy_support import numpy_to_vtk, numpy_to_vtkIdTypeArray

    pts, cells, scal, base = [], [], [], 0
    for (p, t), v in zip(meshes, values.tolist()):
        if len(t) == 0:
            continue
        pts.append(p)
        cells.append(t + base)
        scal.append(np.full(len(t), v))
        base += len(p)
    poly = vtk.vtkPolyData()
    if not pts:
        return poly
    points = vtk.vtkPoints()
    points.SetData(numpy_to_vtk(np.ascontiguousarray(np.vstack(pts)), deep=True))
    poly.SetPoints(points)
    conn = np.ascontiguousarray(np.vstack(cells).ravel().astype(np.int64))
    offsets = np.arange(0, len(conn) + 1, 3, dtype=np.int64)
    tris = vtk.vtkCellArray()
    tris.SetData(
        numpy_to_vtkIdTypeArray(offsets, deep=True), numpy_to_vtkIdTypeArray(conn, deep=True)
    )
    poly.SetPolys(tris)
    s = numpy_to_vtk(np.concatenate(scal), deep=True)
    s.SetName("deviation")
    poly.GetCellData().SetScalars(s)
    return poly


def _lookup(vtk: Any, top: float, tol: float | None) -> Any:
    ctf = vtk.vtkColorTransferFunction()
    for x, rgb in _VIRIDIS:
        ctf.AddRGBPoint(x * top, *rgb)
    lut = vtk.vtkLookupTable()
    lut.SetNumberOfTableValues(256)
    lut.SetTableRange(0.0, top)
    for i in range(256):
        x = top * i / 255
        over = tol is not None and x > tol * (1 + 1e-9)
        lut.SetTableValue(i, *(_OVER if over else ctf.GetColor(x)), 1.0)
    lut.SetAboveRangeColor(*_OVER, 1.0)
    lut.UseAboveRangeColorOn()
    if tol is not None:
        lut.SetAnnotation(tol, f"tol {tol:g}")
    return lut


def _surface_actor(vtk: Any, poly: Any, lut: Any, top: float) -> Any:
    normals = vtk.vtkPolyDataNormals()
    normals.SetInputData(poly)
    normals.ConsistencyOff()
    normals.SplittingOn()
    normals.SetFeatureAngle(60)
    mapper = vtk.vtkPolyDataMapper()
    mapper.SetInputConnection(normals.GetOutputPort())
    mapper.SetLookupTable(lut)
    mapper.SetScalarModeToUseCellData()
    mapper.SetScalarRange(0.0, top)
    mapper.SetResolveCoincidentTopologyToPolygonOffset()
    actor = vtk.vtkActor()
    actor.SetMapper(mapper)
    actor.GetProperty().SetAmbient(0.25)
    actor.GetProperty().SetDiffuse(0.8)
    return actor


def _edges_actor(
    vtk: Any,
    poly: Any,
    colour: tuple[float, float, float] = (0.15, 0.15, 0.15),
    width: float = 1.0,
) -> Any:
    """The faces' borders (every face is meshed apart, so its border is a boundary)."""
    fe = vtk.vtkFeatureEdges()
    fe.SetInputData(poly)
    fe.BoundaryEdgesOn()
    fe.FeatureEdgesOff()
    fe.ManifoldEdgesOff()
    fe.NonManifoldEdgesOff()
    fe.ColoringOff()
    mapper = vtk.vtkPolyDataMapper()
    mapper.SetInputConnection(fe.GetOutputPort())
    mapper.ScalarVisibilityOff()
    actor = vtk.vtkActor()
    actor.SetMapper(mapper)
    actor.GetProperty().SetColor(*colour)
    actor.GetProperty().SetLineWidth(width)
    return actor


def _text(vtk: Any, text: str, x: float, y: float, size: int, bold: bool = False) -> Any:
    t = vtk.vtkTextActor()
    t.SetInput(text)
    t.GetPositionCoordinate().SetCoordinateSystemToNormalizedViewport()
    t.GetPositionCoordinate().SetValue(x, y)
    p = t.GetTextProperty()
    p.SetFontSize(size)
    p.SetColor(*_TEXT)
    p.SetBold(bold)
    p.SetVerticalJustificationToTop()
    return t


def _look_at(
    renderer: Any, bounds: tuple[float, ...], direction: np.ndarray, zoom: float = 0.95
) -> None:
    """Point the camera at ``bounds`` from ``direction`` (unit), Z up unless that is the view."""
    cam = renderer.GetActiveCamera()
    c = np.array(
        [(bounds[0] + bounds[1]) / 2, (bounds[2] + bounds[3]) / 2, (bounds[4] + bounds[5]) / 2]
    )
    cam.SetFocalPoint(*c)
    cam.SetPosition(*(c + direction))
    up = np.array([0.0, 0.0, 1.0])
    if abs(float(np.dot(up, direction))) > 0.95:
        up = np.array([0.0, 1.0, 0.0])
    cam.SetViewUp(*up)
    renderer.ResetCamera(*bounds)
    cam.Zoom(zoom)


def _mean_normal(p: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Area-weighted mean normal of a face's triangles (zero for a closed face)."""
    if len(t) == 0:
        return np.zeros(3)
    n = np.cross(p[t[:, 1]] - p[t[:, 0]], p[t[:, 2]] - p[t[:, 0]]).sum(0)
    return n


def render(
    meshes: list[tuple[np.ndarray, np.ndarray]],
    dev: np.ndarray,
    tol: float | None,
    path: str | os.PathLike[str],
    *,
    title: str = "",
    size: tuple[int, int] = SIZE,
) -> None:
    """Write the deviation picture of a model as a PNG.

    Parameters
    ----------
    meshes : list of (ndarray, ndarray)
        Per face, its nodes (n, 3) and triangles (t, 3) (``occ.face_meshes``).
    dev : ndarray, shape (F,)
        Per face, its sampled deviation in mm (``evaluate``'s ``face_max_mm``).
    tol : float or None
        The tolerance in mm, marked on the colour bar; faces beyond it are red.
    path : path
        The PNG to write.
    title : str
        The first line of the caption (the reconstructed file's name, say).
    size : (int, int)
        Width and height in pixels.
    """
    vtk = _vtk()
    dev = np.asarray(dev, float)
    top = colour_range(dev, tol)
    lut = _lookup(vtk, top, tol)
    poly = _polydata(vtk, meshes, dev)
    worst = int(np.argmax(dev)) if len(dev) else -1

    window = vtk.vtkRenderWindow()
    window.SetOffScreenRendering(1)
    window.SetSize(*size)
    window.SetMultiSamples(4)

    main = vtk.vtkRenderer()
    main.SetViewport(0.0, 0.0, 0.64, 1.0)
    main.SetBackground(1.0, 1.0, 1.0)
    main.AddActor(_surface_actor(vtk, poly, lut, top))
    main.AddActor(_edges_actor(vtk, poly))
    window.AddRenderer(main)
    if poly.GetNumberOfPoints():
        _look_at(main, poly.GetBounds(), np.array([1.0, -1.3, 0.9]), 1.0)
    over = int((dev > tol).sum()) if tol is not None else 0
    lines = [
        title or "deviation per face",
        f"max {dev.max(initial=0.0):.3g} mm (face #{worst + 1}), mean of the face maxima "
        f"{dev.mean() if len(dev) else 0.0:.3g} mm, {len(dev)} faces",
        (f"tolerance {tol:g} mm: {over} faces beyond it" if tol is not None else "no tolerance"),
    ]
    main.AddViewProp(_text(vtk, lines[0], 0.02, 0.98, 20, bold=True))
    main.AddViewProp(_text(vtk, "\n".join(lines[1:]), 0.02, 0.935, 15))

    if worst >= 0 and len(meshes[worst][1]):  # the worst face outlined where it is
        one = _polydata(vtk, [meshes[worst]], dev[worst : worst + 1])
        main.AddActor(_edges_actor(vtk, one, _MARK, 3.0))

    side = vtk.vtkRenderer()
    side.SetViewport(0.64, 0.34, 1.0, 1.0)
    side.SetBackground(0.95, 0.95, 0.95)
    window.AddRenderer(side)
    if worst >= 0 and len(meshes[worst][1]):
        p, t = meshes[worst]
        side.AddActor(_surface_actor(vtk, one, lut, top))
        side.AddActor(_edges_actor(vtk, one))
        ghost = vtk.vtkPolyDataMapper()
        ghost.SetInputData(poly)
        ghost.ScalarVisibilityOff()
        context = vtk.vtkActor()
        context.SetMapper(ghost)
        context.GetProperty().SetColor(0.7, 0.7, 0.7)
        context.GetProperty().SetOpacity(0.12)
        side.AddActor(context)
        n = _mean_normal(p, t)
        lo, hi = p.min(0), p.max(0)
        diag = float(np.linalg.norm(hi - lo)) or 1.0
        direction = n / np.linalg.norm(n) if np.linalg.norm(n) > 1e-9 * diag**2 else None
        if direction is None:
            direction = np.array([1.0, -1.3, 0.9]) / np.linalg.norm([1.0, -1.3, 0.9])
        bounds = (lo[0], hi[0], lo[1], hi[1], lo[2], hi[2])
        _look_at(side, tuple(float(b) for b in bounds), direction * diag * 3, 0.8)
        side.ResetCameraClippingRange()
    side.AddViewProp(
        _text(
            vtk,
            f"worst face #{worst + 1}: {dev.max(initial=0.0):.3g} mm\n"
            "(outlined in magenta on the left)"
            if worst >= 0
            else "no face",
            0.03,
            0.97,
            16,
            bold=True,
        )
    )

    legend = vtk.vtkRenderer()
    legend.SetViewport(0.64, 0.0, 1.0, 0.34)
    legend.SetBackground(1.0, 1.0, 1.0)
    window.AddRenderer(legend)
    bar = vtk.vtkScalarBarActor()
    bar.SetLookupTable(lut)
    bar.SetOrientationToHorizontal()
    bar.SetTitle("max deviation per face (mm)\n")
    bar.SetNumberOfLabels(5)
    bar.SetLabelFormat("%.3g")
    bar.SetDrawAnnotations(tol is not None)
    bar.SetAnnotationTextScaling(False)
    bar.GetPositionCoordinate().SetCoordinateSystemToNormalizedViewport()
    bar.GetPositionCoordinate().SetValue(0.06, 0.2)
    bar.SetWidth(0.88)
    bar.SetHeight(0.55)
    bar.SetBarRatio(0.3)
    bar.UnconstrainedFontSizeOn()
    for prop in (bar.GetTitleTextProperty(), bar.GetLabelTextProperty()):
        prop.SetColor(*_TEXT)
        prop.SetShadow(False)
        prop.SetItalic(False)
        prop.SetBold(False)
    bar.GetTitleTextProperty().SetFontSize(18)
    bar.GetLabelTextProperty().SetFontSize(15)
    bar.GetAnnotationTextProperty().SetColor(*_OVER)
    bar.GetAnnotationTextProperty().SetFontSize(17)
    bar.GetAnnotationTextProperty().SetBold(True)
    bar.GetAnnotationTextProperty().SetItalic(False)
    legend.AddViewProp(bar)

    window.Render()
    grab = vtk.vtkWindowToImageFilter()
    grab.SetInput(window)
    grab.ReadFrontBufferOff()
    grab.Update()
    writer = vtk.vtkPNGWriter()
    writer.SetFileName(os.fspath(path))
    writer.SetInputConnection(grab.GetOutputPort())
    writer.Write()
    window.Finalize()
