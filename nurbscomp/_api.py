"""The Python API: ``nurbscomp.compress``, ``decompress``, ``info``, ``evaluate``.

Re-exported by ``nurbscomp/__init__.py`` (the module is private, as
``scipy.fft._basic`` is).  Every function runs the stages the CLI runs
(``pipeline``): a path or STEP/IGES bytes is read by the reader of
``nurbscomp compress``, an in-memory shape enters the same encoder without a
file, and the container bytes are the CLI's, bit for bit.  OCP and cadquery
are imported on the first call that needs them, not with ``nurbscomp``.
"""

from __future__ import annotations

import math
import numbers
import os
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal, Union, overload

from . import budget, container, passthrough, pipeline
from .errors import ArgumentError, InputError, NoBRepError
from .formats import sniff_format
from .lazy import lazy_module
from .report import CompressReport, InfoReport, Report
from .units import check_tolerance, parse_length

if TYPE_CHECKING:
    from . import occ
else:
    occ = lazy_module("nurbscomp.occ")

#: What ``compress`` and ``evaluate`` take: a path, STEP/IGES (or container) bytes,
#: or a shape (``cadquery.Shape``, ``Workplane``, ``Assembly``, OCP ``TopoDS_Shape``).
Source = Union[str, "os.PathLike[str]", bytes, bytearray, memoryview, Any]
#: What ``decompress`` and ``info`` take: a ``.nzc`` file's path or its bytes.
Data = Union[str, "os.PathLike[str]", bytes, bytearray, memoryview]
#: A tolerance: a number of millimetres, or a length with a unit as ``--tol``
#: takes it (``"5um"``, ``"0.01mm"``, ``"1mil"``).
Length = float | str

_BYTES = (bytes, bytearray, memoryview)


def _check_tol(tol: Any) -> float:
    """``tol`` in mm: a real number (not a bool) of mm, or a string that
    ``nurbscomp.units.parse_length`` reads (``--tol``'s syntax); positive and
    finite.  Anything else raises ``ArgumentError``."""
    if isinstance(tol, str):
        try:
            return parse_length(tol)
        except ValueError as e:
            raise ArgumentError(f"tol: {e}") from None
    if isinstance(tol, bool) or not isinstance(tol, numbers.Real):
        raise ArgumentError(
            "tol must be a number of mm or a length with a unit such as '5um', "
            f"not {_what(tol) if tol is not None else 'None'}"
        )
    t = float(tol)
    if not (math.isfinite(t) and t > 0):
        raise ArgumentError(f"tol must be a positive, finite number of mm, not {t!r}")
    return t


def _what(obj: Any) -> str:
    return f"{type(obj).__module__}.{type(obj).__qualname__}"


def _source_name(data: bytes) -> str:
    """A file name for STEP/IGES bytes, by content (``data.step``, ``data.igs``)."""
    fmt = sniff_format(Path("data"), data[: 1 << 16])
    return "data.step" if fmt == "STEP" else "data.igs"


@overload
def compress(
    obj: Source,
    *,
    tol: Length = ...,
    lossless: bool | Literal["exact", "brep"] = ...,
    verify: bool = ...,
    step_safe: bool = ...,
    report: Literal[False] = ...,
) -> bytes: ...


@overload
def compress(
    obj: Source,
    *,
    tol: Length = ...,
    lossless: bool | Literal["exact", "brep"] = ...,
    verify: bool = ...,
    step_safe: bool = ...,
    report: Literal[True],
) -> tuple[bytes, CompressReport]: ...


def compress(
    obj: Source,
    *,
    tol: Length = pipeline.DEFAULT_TOL_MM,
    lossless: bool | Literal["exact", "brep"] = False,
    verify: bool = True,
    step_safe: bool = True,
    report: bool = False,
) -> bytes | tuple[bytes, CompressReport]:
    """Compress a CAD model into ``.nzc`` container bytes.

    Parameters
    ----------
    obj : path, bytes, cadquery.Shape, cadquery.Workplane, cadquery.Assembly or TopoDS_Shape
        A STEP or IGES file (its path, or its bytes), or a shape in memory,
        in millimetres.  A ``Workplane`` gives its shapes (one, or a compound
        of several); an ``Assembly`` is written to STEP by cadquery's XDE
        writer and read back, so that its tree, names and colours are kept.
    tol : float or str, optional
        Tolerance (default 0.01 mm): no point of a coded B-spline surface or
        curve moves further (certified).  A number is in mm; a string is a
        length with a unit, as ``--tol`` takes it: ``"5um"``, ``"0.01mm"``,
        ``"1mil"``, ``"0.0004in"`` (a bare number in a string is in mm).
        Checked, then ignored, with ``lossless``.
    lossless : bool, "exact" or "brep", optional
        ``"exact"``: the file itself, byte for byte (``--lossless``; a path or
        bytes only: :func:`original` gives them back, SHA-256 checked).
        ``"brep"``: every number of the B-rep bit for bit, the same shape back
        (``--lossless-brep``).  True is ``"exact"`` for a path or bytes and
        ``"brep"`` for a shape in memory, which has no file to keep.
    verify : bool, optional
        Decode the container and check it against what was encoded (as
        ``nurbscomp compress`` does; ``--no-verify``).
    step_safe : bool, optional
        As ``--step-safe`` (the default) and ``--no-step-safe``.
    report : bool, optional
        Also return a :class:`CompressReport` (what ``nurbscomp compress
        --json`` prints: sizes, ratio, mode, certified bounds, counts).

    Returns
    -------
    bytes, or (bytes, CompressReport) with ``report``
        The container: the same bytes ``nurbscomp compress`` writes for the
        same file and options.  A valid STEP/IGES file that holds no B-rep is
        stored verbatim (a passthrough container), as the CLI does.

    Raises
    ------
    nurbscomp.errors.InputError
        The file is missing or not STEP/IGES, or the shape has no faces.
    nurbscomp.errors.ArgumentError
        ``obj`` is none of the above, or ``tol`` is not a positive, finite
        length (a bool, None, NaN, infinity, zero, a string with no known
        unit...).
    nurbscomp.errors.NurbscompError
        Any other failure (one-line message).

    Examples
    --------
    >>> import cadquery as cq, nurbscomp
    >>> data = nurbscomp.compress(cq.Workplane().box(1, 2, 3).val(), tol=0.001)
    >>> data[:4]
    b'\\x89NZC'
    """
    checked = _check_tol(tol)
    if lossless not in (False, True, "exact", "brep"):
        raise ArgumentError(f"lossless must be a bool, 'exact' or 'brep', not {lossless!r}")
    try:
        t = None if lossless else check_tolerance(checked)
    except ValueError as e:  # outside what the format codes (units.TOL_RANGE_MM)
        raise ArgumentError(str(e)) from None
    data, made = _compress(obj, t, lossless, verify, step_safe)
    return (data, CompressReport.from_dict(made())) if report else data


#: A compress report, made when asked for (``compress(..., report=True)``).
_Made = Callable[[], dict[str, Any]]


def _compress(
    obj: Source,
    tol: float | None,
    lossless: bool | Literal["exact", "brep"],
    verify: bool,
    step_safe: bool,
) -> tuple[bytes, _Made]:
    """:func:`compress`'s container, and its report's maker."""
    file_like = isinstance(obj, (*_BYTES, str, os.PathLike))
    if lossless == "exact" or (lossless is True and file_like):
        return _compress_exact(obj, verify)
    opts: dict[str, Any] = {"tol": tol, "lossless": bool(lossless), "step_safe": step_safe}
    if isinstance(obj, _BYTES):
        data = bytes(obj)
        name = _source_name(data)
        with tempfile.TemporaryDirectory(prefix="nurbscomp.") as d:
            path = Path(d) / name
            path.write_bytes(data)
            return _compress_file(path, name, verify, opts)
    if isinstance(obj, (str, os.PathLike)):
        path = Path(obj)
        return _compress_file(path, path.name, verify, opts)
    if occ.cq.is_assembly(obj):
        with tempfile.TemporaryDirectory(prefix="nurbscomp.") as d:
            path = Path(d) / "assembly.step"
            occ.cq.write_assembly(obj, path)
            return _compress_file(path, "", verify, opts)
    shape = occ.cq.to_topods(obj)
    if shape is None:
        raise ArgumentError(
            f"cannot compress a {_what(obj)}: give a path, STEP/IGES bytes, a cadquery "
            "Shape, Workplane or Assembly, or a TopoDS_Shape"
        )
    enc = pipeline.encode_cad(pipeline.shape_source(shape), "", 0, for_verify=verify, **opts)
    if verify:
        pipeline.verify_encoded(enc, enc.data)
    return enc.data, lambda: pipeline.compress_report(enc, verify)


def _compress_exact(obj: Source, verify: bool) -> tuple[bytes, _Made]:
    """The byte-exact container of a file (path or bytes), and its report's maker."""
    if isinstance(obj, _BYTES):
        data, name = bytes(obj), _source_name(bytes(obj))
    elif isinstance(obj, (str, os.PathLike)):
        try:
            data, name = Path(obj).read_bytes(), Path(obj).name
        except OSError as e:
            raise InputError(e.strerror or str(e)) from None
    else:
        raise ArgumentError(
            f"lossless='exact' keeps a file: give a path or bytes, not a {_what(obj)}"
        )
    return _pack_verbatim(data, name, None, verify)


def _pack_verbatim(data: bytes, name: str, reason: str | None, verify: bool) -> tuple[bytes, _Made]:
    """``passthrough.pack_file``, read back when ``verify``; and its report's maker."""
    blob, meta = passthrough.pack_file(data, name, reason)
    if verify:
        passthrough.check_gives_back(container.unpack(blob), data)
    return blob, lambda: passthrough.report(data, blob, meta, reason, verify)


def original(data: Data) -> bytes:
    """The file a byte-exact container holds (``compress(..., lossless=True)``
    of a file), byte for byte; its SHA-256 is checked.

    Raises
    ------
    nurbscomp.errors.InputError
        The container holds a B-rep, not a file (tolerance or ``"brep"`` mode:
        :func:`decompress` gives its shape).
    nurbscomp.errors.FormatError
        The bytes are not a sound container.

    Examples
    --------
    >>> import nurbscomp
    >>> step = b"ISO-10303-21;\\nHEADER;\\nENDSEC;\\nDATA;\\nENDSEC;\\nEND-ISO-10303-21;\\n"
    >>> nurbscomp.original(nurbscomp.compress(step, lossless=True)) == step
    True
    """
    if isinstance(data, _BYTES):
        c = container.unpack(bytes(data))
    elif isinstance(data, (str, os.PathLike)):
        c = pipeline.read_container(Path(data))
    else:
        raise ArgumentError(f"cannot read a {_what(data)}: give a .nzc path or its bytes")
    if not c.flags & passthrough.VERBATIM:
        raise InputError("the container holds a B-rep, not a file: decompress() gives its shape")
    return passthrough.read(c)[1]


def _compress_file(
    path: Path, name: str, verify: bool, opts: dict[str, Any]
) -> tuple[bytes, _Made]:
    """``pipeline.compress_file``'s stages on a file, to bytes (``name`` goes to
    META), and the report's maker."""
    try:
        cad = pipeline.read_source(path)
    except NoBRepError as e:
        reason = str(e)
    else:
        enc = pipeline.encode_cad(cad, name, path.stat().st_size, for_verify=verify, **opts)
        exact = pipeline.smaller_exact(path, name, enc) if name else None  # a file of the user's
        if exact is not None:
            source, blob, meta = exact
            if verify:
                passthrough.check_gives_back(container.unpack(blob), source)
            return blob, lambda: pipeline.exact_report(source, blob, meta, enc, verify)
        if verify:
            pipeline.verify_encoded(enc, enc.data)
        return enc.data, lambda: pipeline.compress_report(enc, verify)
    return _pack_verbatim(path.read_bytes(), name or path.name, reason, verify)


def _decode(data: Data, limit_scale: float) -> tuple[Any, Any, dict[str, Any]]:
    limits = budget.DEFAULT.scaled(limit_scale)
    if isinstance(data, _BYTES):
        return pipeline.decode_data(bytes(data), limits)
    if isinstance(data, (str, os.PathLike)):
        return pipeline.decode_file(data, limits)
    raise ArgumentError(f"cannot decompress a {_what(data)}: give a .nzc path or its bytes")


def decompress(data: Data, raw: bool = False, *, limit_scale: float = 1.0) -> Any:
    """Decode a ``.nzc`` container into a shape.

    Parameters
    ----------
    data : path or bytes
        The container.
    raw : bool, optional
        Return OCP's ``TopoDS_Shape`` rather than a cadquery object.
    limit_scale : float, optional
        The decoding budget times this (``--limit-scale``), for a trusted
        container larger than the limits allow.

    Returns
    -------
    cadquery.Shape, cadquery.Assembly or TopoDS_Shape
        In millimetres.  A ``cadquery.Assembly`` when the container holds an
        assembly (product data with instances: its tree, placements, names
        and colours), else the ``cadquery.Shape`` subclass of the shape
        (``Solid``, ``Compound`` …); with ``raw``, always the OCP shape.  The
        shape is the one ``nurbscomp decompress`` writes.

    Raises
    ------
    nurbscomp.errors.FormatError
        The bytes are not a sound container (a subclass says how).
    nurbscomp.errors.InputError
        The path is missing, or the container holds a file verbatim
        (passthrough: there is no B-rep to build).

    Examples
    --------
    >>> import cadquery as cq, nurbscomp
    >>> s = nurbscomp.decompress(nurbscomp.compress(cq.Workplane().sphere(5).val()))
    >>> round(s.Volume())
    524
    """
    shape, m, _ = _decode(data, limit_scale)
    if raw:
        return shape
    p = m.product
    if p is not None and _has_instances(p):
        return occ.cq.to_assembly(p, shape)
    return occ.cq.to_cadquery(shape)


def _has_instances(p: Any) -> bool:
    """Whether product data holds an assembly (instances of parts), not one part."""
    from .product import summary

    return bool(summary(p)["instances"])


def info(data: Data) -> InfoReport:
    """What a container holds, without building its shape.

    Parameters
    ----------
    data : path or bytes
        The container.

    Returns
    -------
    InfoReport
        The fields of ``nurbscomp info --json``: format version, mode,
        tolerance, unit, source name and format, counts of shapes and
        geometry, faces by type, bytes per section, product data.
        ``input`` is the path, or ``"<bytes>"``.  ``r.to_json()`` gives
        JSON; ``r["mode"]`` reads a field as ``r.mode`` does.
    """
    if isinstance(data, _BYTES):
        return InfoReport.from_dict(pipeline.info_data(bytes(data)))
    if isinstance(data, (str, os.PathLike)):
        return InfoReport.from_dict(pipeline.info(data))
    raise ArgumentError(f"cannot read a {_what(data)}: give a .nzc path or its bytes")


def _load(obj: Source) -> tuple[Any, float | None, str]:
    """The shape of anything ``evaluate`` takes, the tolerance of its container
    (None if it is none, or lossless), and a name for the report."""
    if isinstance(obj, (str, os.PathLike)):
        shape, tol = pipeline.load_shape(obj)
        return shape, tol, str(obj)
    if isinstance(obj, _BYTES):
        data = bytes(obj)
        if data[:4] == container.MAGIC:
            shape, _, meta = pipeline.decode_data(data)
            return shape, meta.get("tolerance_mm"), "<bytes>"
        with tempfile.TemporaryDirectory(prefix="nurbscomp.") as d:
            path = Path(d) / _source_name(data)
            path.write_bytes(data)
            return occ.read_cad(path).shape, None, "<bytes>"
    shape = occ.cq.to_topods(obj)
    if shape is None:
        raise ArgumentError(
            f"cannot evaluate a {_what(obj)}: give a path, bytes, a cadquery shape or a "
            "TopoDS_Shape"
        )
    return shape, None, "<shape>"


def evaluate(
    original: Source,
    reconstructed: Source,
    *,
    tol: Length | None = None,
    worst: int = 5,
    heatmap: str | os.PathLike[str] | None = None,
    force: bool = False,
) -> Report:
    """The error between a model and its reconstruction (``nurbscomp eval``).

    Parameters
    ----------
    original, reconstructed : path, bytes or shape
        STEP, IGES or ``.nzc`` files (paths or bytes), or shapes as
        :func:`compress` takes them.  Faces are paired by index: points
        sampled inside each original face are measured against the
        reconstructed face of the same index.
    tol : float or str, optional
        The tolerance to report against, as :func:`compress` takes it (mm, or
        a length with a unit: ``"5um"``); default (None): the one
        ``reconstructed`` was coded with, if it is a container.
    worst : int, optional
        How many of the worst faces to list.
    heatmap : path, optional
        Also write a PNG of the reconstruction, each face coloured by its
        deviation (as ``eval --heatmap``), atomically, as the CLI writes.
    force : bool, optional
        Overwrite an existing ``heatmap`` file (``--force``).

    Returns
    -------
    Report

    Raises
    ------
    nurbscomp.errors.ArgumentError
        ``tol`` is not None nor a positive, finite length.
    nurbscomp.errors.OutputError
        ``heatmap`` exists and ``force`` is not set, or may not be written
        (checked before any work is done).

    Examples
    --------
    >>> import cadquery as cq, nurbscomp
    >>> part = cq.Workplane().box(1, 2, 3).edges().fillet(0.2).val()
    >>> r = nurbscomp.evaluate(part, nurbscomp.compress(part, tol=0.001))
    >>> r.same_topology, r.within_tolerance
    (True, True)
    """
    t = None if tol is None else _check_tol(tol)
    heat = Path(heatmap) if heatmap is not None else None
    if heat is not None:
        pipeline.check_output(heat, force)
    a, _, name_a = _load(original)
    b, coded_tol, name_b = _load(reconstructed)
    r = pipeline.evaluate_shapes(a, b, worst, tol=coded_tol if t is None else t)
    r = {"original": name_a, "reconstructed": name_b, **r}
    if heat is not None:
        pipeline.write_heatmap(b, r, heat, force=force, title=Path(name_b).name)
    return Report.from_dict(r)
