"""The stages wired together: compress, decompress, info, test.

Each function takes paths and options and returns a report (a plain dict that
the CLI prints as text or JSON).  Outputs go through ``paths.atomic_output``:
a failure or an interrupt leaves nothing behind.
"""

from __future__ import annotations

import collections
import dataclasses
import functools
import hashlib
import logging
import os
import tempfile
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar, cast

import numpy as np
from threadpoolctl import threadpool_limits

from . import budget, container, passthrough, product, serialize, units
from ._version import version
from .decode import sections_to_model
from .errors import (
    CorruptError,
    InputError,
    LimitError,
    NoBRepError,
    NurbscompError,
    OutputError,
    RebuildError,
    UndiagnosedError,
    UnsupportedError,
    VerifyError,
)
from .formats import FORMAT_SUFFIX
from .lazy import lazy_module
from .model import (
    BRepModel,
    BSplineCurve,
    BSplineSurface,
    Derived,
    Kind,
    differences,
    nonfinite,
)
from .paths import atomic_output, check_output, read_container, read_input
from .report import verdict
from .writer import model_to_sections

if TYPE_CHECKING:
    from . import occ
else:  # OCP takes seconds to import: only what builds or reads shapes pays for it
    occ = lazy_module("nurbscomp.occ")

log = logging.getLogger(__name__)

DEFAULT_TOL_MM = units.DEFAULT_TOL_MM
#: A tolerance above this fraction of the part's bounding-box diagonal is warned of.
TOL_WARN_FRACTION = 0.1
SUFFIX = ".nzc"

_F = TypeVar("_F", bound=Any)


def one_blas_thread(fn: _F) -> _F:
    """Run ``fn`` with BLAS held to one thread.

    The codec's linear algebra works on tiny matrices (the D-map's least
    squares, eq. 18-24), where OpenBLAS's thread start-up and spinning cost
    far more than the arithmetic, and on a busy machine 100x more (measured).
    """

    @functools.wraps(fn)
    def run(*args: Any, **kwargs: Any) -> Any:
        with threadpool_limits(limits=1, user_api="blas"):
            return fn(*args, **kwargs)

    return cast(_F, run)


# ---------------------------------------------------------------- output paths


def default_compressed_name(src: Path) -> Path:
    """``part.step`` -> ``part.step.nzc``."""
    return src.with_name(src.name + SUFFIX)


def default_decompressed_name(src: Path) -> Path:
    """``part.step.nzc`` -> ``part.step``; ``part.nzc`` -> ``part.step``."""
    if src.name.endswith(SUFFIX):
        stem = Path(src.name[: -len(SUFFIX)])
        if stem.suffix.lower() in (".step", ".stp", ".igs", ".iges", ".brep", ".p21"):
            return src.with_name(stem.name)
        return src.with_name(stem.name + ".step")
    return src.with_name(src.name + ".step")


def source_format(path: Path) -> str:
    """The format of the file a container was made from (``"STEP"``, ``"IGES"``,
    or ``"BREP"`` for a shape given in memory), from its META alone: what
    ``decompress -c`` writes when no ``--format`` is given.

    Raises
    ------
    InputError, FormatError
        As :func:`read_container`; a META that does not read.
    """
    c = read_container(path)
    if c.flags & passthrough.VERBATIM:
        return str(passthrough.read(c)[0]["source_format"])
    fmt = str(serialize.read_meta(c.get("META")).get("source_format", "STEP"))
    return fmt if fmt in FORMAT_SUFFIX else "STEP"


@one_blas_thread
def decode(
    c: container.Container,
    limits: budget.Limits | None = budget.DEFAULT,
    fmt: str | None = None,
) -> tuple[BRepModel, dict[str, Any]]:
    """The model and metadata a checked container holds.

    ``limits`` is the decoding budget (``budget.check_structure``, with the
    projection work allowed for the container's size: ``Limits.sized``), and
    the estimated size of a ``fmt`` output (the format about to be written,
    ``budget.check_output``) if given; None skips it (a container compress has
    just written, whose own checks :func:`verify_encoded` makes; the structure
    fuzzer's seeds).

    Raises
    ------
    FormatError
        A subclass: ``CorruptError`` (sections missing, out of order, or
        disagreeing with the header), ``SectionError``, ``BadReferenceError``,
        ``LimitError`` (see :func:`nurbscomp.decode.sections_to_model`).
    UndiagnosedError
        The last resort: a ``ValueError``, ``IndexError``, ``KeyError``,
        ``TypeError``, ``ArithmeticError`` or ``RecursionError`` that no
        specific check caught.  The checks in ``serialize`` are meant to make
        this unreachable; the fuzzer counts it as a failure.
    """
    if c.flags & passthrough.VERBATIM:
        cad, meta = _verbatim_cad(c)
        return _cad_model(cad), meta
    serialize.check_layout(c.tags(), c.revision, newer=c.major == 1 and c.minor > 2)
    if limits is not None:
        # what the writer declared it decodes into is admitted, up to a ceiling
        declared = budget.declared(serialize.read_meta(c.get("META")))
        limits = limits.sized(c.file_bytes).admit(declared)
    try:
        m, meta = sections_to_model(c.get, c.revision, limits)
    except NurbscompError:
        raise
    except (ValueError, IndexError, KeyError, TypeError, ArithmeticError, RecursionError) as e:
        raise UndiagnosedError(
            f"container does not decode ({type(e).__name__}: {e}); no specific check caught it"
        ) from None
    if bool(c.flags & container.FLAG_LOSSLESS) != (meta["mode"] == "lossless"):
        raise CorruptError("the header's lossless flag (offset 6) disagrees with META's mode")
    if limits is not None and fmt is not None:
        budget.check_output(m, fmt, c.file_bytes, limits)
    return m, meta


def build(m: BRepModel) -> Any:
    """The shape of a decoded model (``encode.validity.build``, imported on first use:
    commands that build no shape start without OCP)."""
    from .encode import validity

    return validity.build(m)


def write(
    shape: Any,
    path: Path,
    fmt: str,
    unit: str,
    meta: dict[str, Any],
    product_data: product.ProductData | None = None,
) -> None:
    """Write a decoded shape; the STEP header is taken from the container's META.

    FILE_NAME's name is the source file's name and its originating system the
    writer named in META; the time stamp is fixed (``occ.exchange.STEP_TIME_STAMP``),
    so the same container always gives the same bytes.  With product data
    (format 1.2), STEP and IGES are written through OCCT's XDE writers with
    the source's tree, names, colours, layers, schema and header
    (``occ.xcaf.write``).

    Raises
    ------
    OutputError
        The file cannot be written.
    RebuildError
        OCCT fails on the shape while writing it.
    """
    name = meta.get("source_name") or ""
    name = name[: -len(SUFFIX)] if name.endswith(SUFFIX) else name
    try:
        occ.write_shape(
            shape, path, fmt, unit, name=name, system=meta.get("writer") or "", product=product_data
        )
    except NurbscompError:
        raise
    except OSError as e:
        raise OutputError(f"cannot write {path.name}: {e.strerror or e}") from None
    except Exception as e:  # OCCT raises Standard_Failure subclasses on bad shapes
        raise RebuildError(
            f"the decoded shape cannot be written ({type(e).__name__}: {e})"
        ) from None


def decode_file(
    path: str | os.PathLike[str],
    limits: budget.Limits = budget.DEFAULT,
    fmt: str | None = None,
) -> tuple[Any, BRepModel, dict[str, Any]]:
    """Decode a ``.nzc`` file into an in-memory shape (millimetres), within
    ``limits`` (and the output size of ``fmt``, if given)."""
    return _decode_shape(read_container(Path(path)), limits, fmt)


def decode_data(
    data: bytes,
    limits: budget.Limits = budget.DEFAULT,
    fmt: str | None = None,
) -> tuple[Any, BRepModel, dict[str, Any]]:
    """:func:`decode_file` for a container's bytes in memory."""
    return _decode_shape(container.unpack(data), limits, fmt)


def _decode_shape(
    c: container.Container, limits: budget.Limits, fmt: str | None
) -> tuple[Any, BRepModel, dict[str, Any]]:
    """The shape, model and META of a container: built from its tables, or, for a
    byte-exact one, read by OCCT from the file it holds."""
    if c.flags & passthrough.VERBATIM:
        cad, meta = _verbatim_cad(c)
        return cad.shape, _cad_model(cad), meta
    m, meta = decode(c, limits, fmt)
    return build(m), m, meta


def _verbatim_cad(c: container.Container) -> tuple[Any, dict[str, Any]]:
    """The ``occ.CadFile`` OCCT reads from the file a verbatim container holds.

    Raises
    ------
    InputError
        The file holds no B-rep (it was stored byte for byte for that reason).
    FormatError
        The container is damaged (``passthrough.read``).
    """
    meta, data = passthrough.read(c)
    if "reason" in meta:
        raise InputError("a passthrough container holds a file verbatim, not a B-rep")
    return read_text(data, str(meta["source_format"])), meta


def read_text(data: bytes, fmt: str) -> Any:
    """:func:`read_source` of a STEP or IGES file's bytes (through a temporary file:
    OCCT's readers take a path)."""
    with tempfile.TemporaryDirectory(prefix="nurbscomp.") as d:
        p = Path(d) / ("source.igs" if fmt == "IGES" else "source.step")
        p.write_bytes(data)
        return read_source(p)


def _cad_model(cad: Any) -> BRepModel:
    """The model of a read file, exact, with its unit, format and product data."""
    m, _ = occ.shape_to_model(cad.shape)
    m.unit, m.source_format, m.product = cad.unit, cad.source_format, cad.product
    return m


def _convert(data: bytes, have: str, dst: Path, want: str, meta: dict[str, Any]) -> dict[str, Any]:
    """Write the file ``data`` (of format ``have``) as ``want``: OCCT reads it,
    and it is written as a decoded shape is (``write``).  The unit and counts."""
    cad = read_text(data, have)
    write(cad.shape, dst, want, cad.unit, meta, cad.product)
    return {"unit": cad.unit, "counts": occ.counts(cad.shape)}


# ---------------------------------------------------------------- compress


def _no_stage(name: str) -> None:
    """The default ``stage`` callback: no progress display."""


def faces_by_type(m: BRepModel) -> dict[str, int]:
    """Faces counted by the kind of their surface (a trimmed surface by its basis)."""
    out: collections.Counter[str] = collections.Counter()
    for s in m.face_surface.tolist():
        g = m.surfaces[s]
        while isinstance(g, Derived) and g.kind in (Kind.TRIMMED_SURFACE, Kind.OFFSET_SURFACE):
            g = m.surfaces[g.basis]
        out[g.kind.name.lower()] += 1
    return dict(sorted(out.items()))


@dataclasses.dataclass
class Encoded:
    """A model coded into container bytes, with what the report and the check need
    (:func:`encode_cad`)."""

    data: bytes
    model: BRepModel  # the model read from the source
    target: BRepModel  # what the container holds
    cad: Any  # the occ.CadFile read (or made from a shape)
    meta: dict[str, Any]
    lossless: bool
    tol: float | None
    step_safe: bool
    lossy_report: Any  # encode.assembly.LossyReport, tolerance mode only
    pcurves_rebuilt: int
    built: Any  # the shape built from ``target`` (validity stage, or lossless for verify)
    validity: Any  # encode.validity.ValidityReport, tolerance mode only
    warnings: list[str]


def read_source(src: Path) -> Any:
    """The ``occ.CadFile`` of a STEP/IGES file, product data included.

    Raises
    ------
    NoBRepError
        A valid file that holds no B-rep faces (stored verbatim by the callers).
    InputError
        The file cannot be read (OCCT's failures included, in one line).
    """
    try:
        cad = occ.read_cad(src, product=True)
        if occ.counts(cad.shape)["faces"] == 0:
            raise NoBRepError(
                f"the {cad.source_format} file holds no B-rep faces (only curves or points)"
            )
    except NurbscompError:
        raise
    except Exception as e:
        raise InputError(f"OCCT failed to read the file ({type(e).__name__}: {e})") from None
    return cad


def shape_source(shape: Any, unit: str = "MM") -> Any:
    """An ``occ.CadFile`` for an in-memory ``TopoDS_Shape`` (in millimetres):
    source format ``"BREP"``, no product data.

    Raises
    ------
    NoBRepError
        The shape is null or has no faces.
    """
    if shape.IsNull() or occ.counts(shape)["faces"] == 0:
        raise NoBRepError("the shape holds no B-rep faces")
    return occ.CadFile(shape, unit, "BREP")


@one_blas_thread
def encode_cad(
    cad: Any,
    name: str,
    source_bytes: int,
    *,
    tol: float | None = DEFAULT_TOL_MM,
    lossless: bool = False,
    step_safe: bool = True,
    for_verify: bool = True,
) -> Encoded:
    """Code the shape of ``cad`` (an ``occ.CadFile``) into container bytes;
    ``name`` and ``source_bytes`` go to META (see :func:`compress_file`).

    ``for_verify``: the caller will run :func:`verify_encoded`.  In lossless
    mode the shape it checks is then built here, from the model, while the
    entropy stage packs the container in another thread (LZMA releases the
    GIL): the decoded model must be this model bit for bit, so it builds this
    shape.  In tolerance mode the validity stage builds it anyway."""
    m, warnings = occ.shape_to_model(cad.shape)
    bad = nonfinite(m, serialize.MAX_COORD)
    if bad is not None:  # an invalid B-rep OCCT still reads: refused in both modes alike
        raise InputError(f"{bad}: a value is not finite or out of range")
    try:  # what no reader decodes by default, even as declared, is not written
        budget.check_structure(m, budget.ADMITTED)
    except LimitError as e:
        raise UnsupportedError(f"{e}; not compressed") from None
    m.unit, m.source_format, m.product = cad.unit, cad.source_format, cad.product
    meta = {
        "mode": "lossless" if lossless else "tolerance",
        "tolerance_mm": None if lossless else tol,
        "source_name": serialize.meta_text(name),
        "source_bytes": source_bytes,
        "writer": f"nurbscomp {version()}",
    }
    flags = container.FLAG_LOSSLESS if lossless else 0

    def pack(target: BRepModel, codes: dict[Any, Any]) -> bytes:
        target.product = m.product  # exact in every mode, placements included
        # what it decodes into, for a reader to admit (budget.Limits.admit)
        declared = budget.declare(target)
        sections = model_to_sections(
            target, {**meta, "decoded": declared} if declared else meta, codes
        )
        # lossless is the fast mode: a quick entropy search (entropy.compress)
        return container.pack(sections, flags, thorough=not lossless)

    rebuilt, built, vreport = 0, None, None
    codes: dict[Any, Any] = {}
    if lossless:
        target, lossy_report = m, None
        if for_verify:  # beside the build of the shape verify_encoded checks
            with ThreadPoolExecutor(1) as pool:
                packing = pool.submit(pack, target, codes)
                built = build(target)
                data = packing.result()
        else:
            data = pack(target, codes)
    else:
        assert tol is not None and tol > 0
        from .encode import validity

        size = occ.diagonal(cad.shape)
        if tol > size * TOL_WARN_FRACTION:
            warnings.append(
                f"tolerance {tol:g} mm is more than {TOL_WARN_FRACTION:.0%} of the part's size "
                f"({size:.3g} mm across its bounding box): its shape may not be kept"
            )
        for i, bound in occ.thin_solids(cad.shape, tol):
            change = f"up to {bound:.0%} of it" if bound <= 1 else "more than all of it"
            warnings.append(
                f"solid {i + 1} is thin against the tolerance: faces moving by {tol:g} mm "
                f"could change its volume by {change}; a wall thinner than twice the "
                "tolerance may cross itself (a smaller --tol keeps it)"
            )

        t = validity.lossy_target(m, cad.shape, tol, step_safe, pack)
        target, codes, lossy_report, rebuilt = t.model, t.codes, t.report, t.pcurves_rebuilt
        built, vreport = t.shape, t.validity
        if vreport.step_skipped:
            warnings.append(f"no STEP check: {vreport.step_skipped}")
        # packed while the STEP check of its last round ran, if it had one
        data = t.early if t.early is not None else pack(target, codes)
    return Encoded(
        data,
        m,
        target,
        cad,
        meta,
        lossless,
        tol,
        step_safe,
        lossy_report,
        rebuilt,
        built,
        vreport,
        warnings,
    )


@one_blas_thread
def verify_encoded(enc: Encoded, data: bytes) -> None:
    """Decode ``data`` (the container as written) and check it against what was
    encoded: the same model bit for bit, product data, the certified bound,
    the topology counts.

    It is decoded under the limits ``decompress`` applies by default (with
    what the container declares it decodes into admitted, ``budget.Limits.admit``),
    and its output in the source's format estimated: every container
    ``compress`` writes is restored by the default command.  The pcurves the
    container leaves to compute must be within the default limits whatever
    its size (``budget.DEFAULT.pcurves`` and ``.projection``): how many it
    leaves is the writer's choice (``encode.pcurves.drop_pcurves``).

    Raises
    ------
    VerifyError
        Any difference (a bug), a limit the container is refused by, or more
        pcurves to compute than the default limits allow.
    """
    try:
        back, _ = decode(container.unpack(data), budget.DEFAULT, enc.model.source_format)
    except LimitError as e:
        raise VerifyError(f"the container is past a reader's default limits: {e}") from None
    count, work = budget.pcurves_to_compute(back)
    if count > budget.DEFAULT.pcurves or work > budget.DEFAULT.projection:
        raise VerifyError(
            f"the container leaves {count:,} pcurves ({work:,} units of work) to compute, "
            "past a reader's default limits"
        )
    diff = differences(enc.target, back)
    if enc.target.product is not None and not (
        back.product is not None and back.product.same(enc.target.product)
    ):
        diff.append("product data")
    if diff:
        raise VerifyError(f"decoded container differs from the input: {', '.join(diff)}")
    worst = max_net_displacement(enc.model, back)
    if enc.tol is not None and not enc.lossless and worst > enc.tol:
        raise VerifyError(f"a decoded control net moved {worst:g} mm > tol {enc.tol:g} mm")
    # the decoded model is the target bit for bit, so it builds the
    # shape built from it (by the validity stage, or beside the lossless packing)
    built = build(back) if enc.built is None else enc.built
    if occ.counts(built) != occ.counts(enc.cad.shape):
        raise VerifyError("decoded shape has other topology counts than the input")


def compress_report(enc: Encoded, verified: bool) -> dict[str, Any]:
    """The report of a compression, less ``command``, ``input``, ``output`` and times."""
    m, lossy_report, src_bytes = enc.model, enc.lossy_report, enc.meta["source_bytes"]
    return {
        "input_bytes": src_bytes,
        "output_bytes": len(enc.data),
        "ratio": src_bytes / len(enc.data) if src_bytes else None,
        "mode": enc.meta["mode"],
        "tolerance_mm": enc.meta["tolerance_mm"],
        "geometry": "exact"
        if enc.lossless
        else "B-spline surfaces and 3-D curves coded, vertices on them snapped; "
        + (
            "analytic geometry on grids where that is smaller; pcurves exact"
            if lossy_report and "analytic" in lossy_report.face_method
            else "pcurves and analytic geometry exact"
        ),
        "faces_by_method": lossy_report.method_counts() if lossy_report else {},
        "face_method_list": lossy_report.face_method if lossy_report else [],
        "max_bound_mm": float(lossy_report.face_bound.max(initial=0.0)) if lossy_report else 0.0,
        "max_curve_bound_mm": float(lossy_report.edge_bound.max(initial=0.0))
        if lossy_report
        else 0.0,
        "certified_faces": int((lossy_report.face_bound > 0).sum()) if lossy_report else 0,
        "sampled_faces": 0,
        "pcurves_rebuilt": enc.pcurves_rebuilt,
        "validity": dataclasses.asdict(enc.validity) if enc.validity else {},
        "step_safe": enc.step_safe and not enc.lossless,
        "unit": m.unit,
        "source_format": m.source_format,
        "counts": occ.counts(enc.cad.shape),
        "faces_by_type": faces_by_type(m),
        "product": product.summary(m.product) if m.product is not None else None,
        "product_bytes": len(product.write(m.product)) if m.product is not None else 0,
        "verified": verified,
        "warnings": [*enc.cad.warnings, *enc.warnings],
    }


def compress_file(
    src: str | os.PathLike[str],
    dst: str | os.PathLike[str] | None = None,
    *,
    tol: float | None = DEFAULT_TOL_MM,
    lossless: bool = False,
    exact: bool = False,
    force: bool = False,
    verify: bool = True,
    step_safe: bool = True,
    stage: Callable[[str], None] | None = None,
) -> dict[str, Any]:
    """Compress a STEP/IGES file into a ``.nzc`` container.

    The stages are :func:`read_source`, :func:`encode_cad`,
    :func:`verify_encoded` and :func:`compress_report`, which
    ``nurbscomp.compress`` (the Python API) runs too.

    Parameters
    ----------
    tol : float
        Tolerance in mm: every B-spline surface net and 3-D B-spline curve is
        coded so that no pole, hence no point, moves further (certified).
        Vertices whose edges all have coded curves move by at most tol/2
        (their curves and net corners with them); pcurves, the other
        vertices and analytic geometry are exact.
    lossless : bool
        Store every number of the B-rep bit for bit (the container says so):
        the same shape back, not the same file.
    exact : bool
        Store the file itself, byte for byte, through the text model
        (``passthrough.compress_file``; OCCT does not read it).  ``tol`` and
        ``lossless`` do not apply.
    verify : bool
        Decode what was written and check it against what was encoded before
        renaming the output into place.
    step_safe : bool
        Keep exact whatever OCCT's STEP reader would "repair" (new edges or
        faces) when the decompressed STEP is read back, so the STEP output
        keeps what OCCT's own round trip keeps.  Off, files are smaller and
        the in-memory / BREP result is still valid and within tol.
    stage : callable, optional
        Called with ``"read"``, ``"code"``, ``"write"``, ``"check"`` as each
        stage starts (a progress display).
    """
    t0 = time.perf_counter()
    stage = stage or _no_stage
    src_p = Path(src)
    dst_p = Path(dst) if dst is not None else default_compressed_name(src_p)
    check_output(dst_p, force, (src_p,))
    stage("read")
    if exact:
        return passthrough.compress_file(src_p, dst_p, None, force=force, t0=t0, verify=verify)
    try:
        cad = read_source(src_p)
    except NoBRepError as e:  # a valid file all the same: stored verbatim
        return passthrough.compress_file(src_p, dst_p, str(e), force=force, t0=t0, verify=verify)
    t_read = time.perf_counter() - t0
    stage("code")
    enc = encode_cad(
        cad,
        src_p.name,
        src_p.stat().st_size,
        tol=tol,
        lossless=lossless,
        step_safe=step_safe,
        for_verify=verify,
    )
    stage("write")
    with atomic_output(dst_p, force, (src_p,)) as tmp:
        tmp.write_bytes(enc.data)
        if verify:
            stage("check")
            verify_encoded(enc, tmp.read_bytes())
    return {
        "command": "compress",
        "input": str(src_p),
        "output": str(dst_p),
        **compress_report(enc, verify),
        "seconds": time.perf_counter() - t0,
        "read_seconds": t_read,
    }


def max_net_displacement(a: BRepModel, b: BRepModel) -> float:
    """Largest pole displacement between the B-spline surfaces and 3-D curves of two models.

    The certified bound of docs/design.md §4: knots, degrees and weights are equal, so
    no point of a surface or curve moves further than its farthest pole.
    """
    worst = 0.0
    pairs = [*zip(a.surfaces, b.surfaces), *zip(a.curves3d, b.curves3d)]
    for x, y in pairs:
        if isinstance(x, (BSplineSurface, BSplineCurve)) and type(x) is type(y):
            if x.poles.shape != y.poles.shape:
                return float("inf")
            worst = max(worst, float(np.sqrt(((x.poles - y.poles) ** 2).sum(-1)).max()))
    return worst


# ---------------------------------------------------------------- decompress, info, test


def decompress_file(
    src: str | os.PathLike[str],
    dst: str | os.PathLike[str] | None = None,
    *,
    force: bool = False,
    limits: budget.Limits = budget.DEFAULT,
    stage: Callable[[str], None] | None = None,
) -> dict[str, Any]:
    """Decode a ``.nzc`` container and write STEP, IGES or BREP (by extension),
    if the shape and the output's estimated size are within ``limits``.
    ``stage`` is called with ``"decode"`` and ``"write"`` as they start."""
    t0 = time.perf_counter()
    stage = stage or _no_stage
    src_p = Path(src)
    dst_p = Path(dst) if dst is not None else default_decompressed_name(src_p)
    if passthrough.is_verbatim(src_p):
        return passthrough.decompress_file(src_p, dst_p, force=force, convert=_convert)
    check_output(dst_p, force, (src_p,))
    fmt = occ.output_format(dst_p)
    stage("decode")
    shape, m, meta = decode_file(src_p, limits, fmt)
    stage("write")
    with atomic_output(dst_p, force, (src_p,)) as tmp:
        write(shape, tmp, fmt, m.unit, meta, m.product)
        size = tmp.stat().st_size
    return {
        "command": "decompress",
        "input": str(src_p),
        "output": str(dst_p),
        "format": fmt,
        "unit": m.unit,
        "output_bytes": size,
        "counts": occ.counts(shape),
        "seconds": time.perf_counter() - t0,
    }


def info(src: str | os.PathLike[str], limits: budget.Limits = budget.DEFAULT) -> dict[str, Any]:
    """:func:`info_data` of a ``.nzc`` file; ``input`` is its path."""
    p = Path(src)
    return info_data(read_input(p), str(p), limits)


def info_data(
    data: bytes, name: str = "<bytes>", limits: budget.Limits = budget.DEFAULT
) -> dict[str, Any]:
    """What a container holds: version, mode, unit, counts, bytes per section
    (``report.InfoReport``'s fields, and ``command``); ``name`` is the ``input``
    it reports."""
    c = container.unpack(data)
    if c.flags & passthrough.VERBATIM:
        return passthrough.info(c, name, len(data))
    m, meta = decode(c, limits)
    return {
        "command": "info",
        "input": name,
        "format_version": f"{c.major}.{c.minor}",
        "lossless": bool(c.flags & container.FLAG_LOSSLESS),
        "passthrough": False,
        "mode": meta.get("mode"),
        "tolerance_mm": meta.get("tolerance_mm"),
        "unit": m.unit,
        "source_format": m.source_format,
        "source_name": meta.get("source_name"),
        "source_bytes": meta.get("source_bytes"),
        "writer": meta.get("writer"),
        "file_bytes": len(data),
        "coder": container.entropy.Coder(c.coder).name.lower()
        if c.coder in {int(x) for x in container.entropy.Coder}
        else c.coder,
        "body_stored_bytes": c.stored_length,
        "section_raw_bytes": {s.tag: len(s.raw) for s in c.sections},
        "shapes": m.counts(),
        "faces_by_type": faces_by_type(m),
        "geometry": {
            "surfaces": len(m.surfaces),
            "curves3d": len(m.curves3d),
            "curves2d": len(m.curves2d),
        },
        "product": product.summary(m.product) if m.product is not None else None,
        "product_tree": product.tree(m.product) if m.product is not None else None,
    }


def test_file(
    src: str | os.PathLike[str], limits: budget.Limits = budget.DEFAULT
) -> dict[str, Any]:
    """Integrity check, like ``xz -t``: every checksum, every reference, the
    decoding budget, a full rebuild."""
    p = Path(src)
    if passthrough.is_verbatim(p):
        meta, data = passthrough.read(read_container(p))  # SHA-256 checked
        return {
            "command": "test",
            "input": str(p),
            "ok": True,
            "passthrough": "reason" in meta,
            "exact": meta["mode"] == "exact",
            "sha256": hashlib.sha256(data).hexdigest(),
            "faces": 0,
        }
    shape, m, _ = decode_file(p, limits)
    return {
        "command": "test",
        "input": str(p),
        "ok": True,
        "faces": len(m.face_surface),
        "counts": occ.counts(shape),
    }


def load_shape(path: str | os.PathLike[str]) -> tuple[Any, float | None]:
    """The shape of a CAD file (STEP, IGES, or ``.nzc`` decoded), and the
    tolerance its container was coded with (0 for a lossless one; None: not a
    container)."""
    if str(path).endswith(SUFFIX):
        shape, _, meta = decode_file(path)
        exact = meta.get("mode") in ("lossless", "exact")
        return shape, 0.0 if exact else meta.get("tolerance_mm")
    return occ.read_cad(path).shape, None


def evaluate(
    original: str | os.PathLike[str],
    reconstructed: str | os.PathLike[str],
    worst: int = 5,
    *,
    tol: float | None = None,
    heatmap: str | os.PathLike[str] | None = None,
    force: bool = False,
) -> dict[str, Any]:
    """The paper's "error evaluation" between two CAD files (STEP, IGES or .nzc):
    :func:`evaluate_shapes` on the shapes they hold.

    ``tol`` defaults to the tolerance the reconstructed container was coded
    with, if it is one.  With ``heatmap``, a picture of the deviation is
    written there (:func:`write_heatmap`; never over an existing file
    without ``force``).
    """
    heat = Path(heatmap) if heatmap is not None else None
    if heat is not None:
        check_output(heat, force, (Path(original), Path(reconstructed)))
    a, _ = load_shape(original)
    b, coded_tol = load_shape(reconstructed)
    r = evaluate_shapes(a, b, worst, tol=coded_tol if tol is None else tol)
    r = {"command": "eval", "original": str(original), "reconstructed": str(reconstructed), **r}
    if heat is not None:
        write_heatmap(b, r, heat, force=force, title=Path(reconstructed).name)
    return r


def evaluate_shapes(a: Any, b: Any, worst: int = 5, *, tol: float | None = None) -> dict[str, Any]:
    """Deviation, topology, validity and free edges between two shapes, and
    the verdict on them (``report.verdict``: within ``tol``, same topology,
    valid kept, free edges kept).

    Faces are paired by index in ``TopExp.MapShapes`` order; points sampled
    inside each face of ``a`` are measured against the face of ``b``.  Where
    the face counts agree, the report has the worst and mean deviation, the
    ``worst`` worst faces (1-based) and each face's maximum and mean
    (``face_max_mm``, ``face_mean_mm``, in ``b``'s face order).
    """
    ca, cb = occ.counts(a), occ.counts(b)
    out: dict[str, Any] = {
        "counts": {"original": ca, "reconstructed": cb},
        "same_topology": ca == cb,
        "valid": {"original": occ.is_valid(a), "reconstructed": occ.is_valid(b)},
        "free_edges": {"original": occ.free_edges(a), "reconstructed": occ.free_edges(b)},
        "tolerance_mm": tol,
    }
    if ca["faces"] == cb["faces"]:
        mx, mean = occ.deviation_stats(a, b)
        order = np.argsort(-mx, kind="stable")[:worst]
        out["max_deviation_mm"] = float(mx.max(initial=0.0))
        out["mean_deviation_mm"] = float(mean.mean()) if len(mean) else 0.0
        out["worst_faces"] = [{"face": int(i) + 1, "max_mm": float(mx[i])} for i in order]
        out["face_max_mm"] = mx.tolist()
        out["face_mean_mm"] = mean.tolist()
    return {**out, **verdict(out)}


def write_heatmap(
    shape: Any,
    report: dict[str, Any],
    path: str | os.PathLike[str],
    *,
    force: bool = False,
    title: str = "",
) -> None:
    """Render ``shape`` with each face coloured by its deviation in ``report``
    (:func:`evaluate_shapes`) to a PNG at ``path`` (``nurbscomp.heatmap``).

    Raises
    ------
    InputError
        The report has no per-face deviation (the face counts differ).
    OutputError
        ``path`` may not be written (see :func:`atomic_output`).
    """
    from . import heatmap

    if "face_max_mm" not in report:
        raise InputError("no heatmap: the two shapes have different face counts")
    meshes = occ.face_meshes(shape)
    dev = np.asarray(report["face_max_mm"], float)
    dst = Path(path)
    with atomic_output(dst, force) as tmp:
        # a lossless container's tolerance, 0, marks no face
        heatmap.render(meshes, dev, report.get("tolerance_mm") or None, tmp, title=title)
