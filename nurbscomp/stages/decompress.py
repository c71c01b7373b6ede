"""Decompress's stages: container -> model (``decode``, the decoding budget
and every reference checked), model -> shape (``build``), shape -> STEP, IGES
or BREP file (``write``), and a file kept byte for byte given back in the
format asked for."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path
from typing import TYPE_CHECKING, Any

from .. import budget, container, passthrough, product, serialize
from ..decode import sections_to_model
from ..errors import (
    CorruptError,
    InputError,
    NurbscompError,
    OutputError,
    RebuildError,
    UndiagnosedError,
)
from ..lazy import lazy_module
from ..model import (
    BRepModel,
)
from ..paths import read_container
from .common import SUFFIX, one_blas_thread, read_source

if TYPE_CHECKING:
    from .. import occ
else:  # OCP takes seconds to import: only what builds or reads shapes pays for it
    occ = lazy_module("nurbscomp.occ")


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
        declared = budget.declared(serialize.read_meta(c.get("META"), c.revision))
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


def build(m: BRepModel, pcurves: bool = True) -> Any:
    """The shape of a decoded model (``encode.validity.build``, imported on first use:
    commands that build no shape start without OCP); without ``pcurves``, those
    the model leaves to compute are not (:func:`step_pcurves`)."""
    from ..encode import validity

    return validity.build(m, pcurves=pcurves)


def step_pcurves(meta: dict[str, Any]) -> bool:
    """Whether STEP output of a container gets pcurves: not where META's
    ``step_pcurves`` is false (the source STEP had none, and the encoder's STEP
    check read its candidate back written without them)."""
    return meta.get("step_pcurves") is not False


def output_uncertainty(meta: dict[str, Any]) -> float | None:
    """The length uncertainty (mm) STEP and IGES output of a container is
    written with (an IGES file's resolution): META's ``uncertainty`` (the
    encoder's STEP check read its candidate back written so), or None
    (absent: OCCT's default, the shape's average tolerance)."""
    v = meta.get("uncertainty")
    return float(v) if v is not None else None


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
            shape,
            path,
            fmt,
            unit,
            name=name,
            system=meta.get("writer") or "",
            product=product_data,
            pcurves=step_pcurves(meta),
            uncertainty=output_uncertainty(meta),
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
    ``limits`` (and the output size of ``fmt``, if given).  For ``fmt``
    ``"STEP"`` and a container whose STEP gets no pcurves (:func:`step_pcurves`)
    the shape is only fit to be written so: the pcurves the container leaves
    out are not computed."""
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
    # a shape for a STEP file without pcurves needs none (write: the same file)
    return build(m, fmt != "STEP" or step_pcurves(meta)), m, meta


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
