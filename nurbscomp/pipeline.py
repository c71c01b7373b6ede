"""The commands, the stages wired together: compress, decompress, info, test,
evaluate.

The stages themselves are in :mod:`nurbscomp.stages` (compress, decompress,
evaluate: in memory, on models, shapes and bytes); each command here takes
paths and options and returns a report (a plain dict that the CLI prints as
text or JSON).  Outputs go through ``paths.atomic_output``:
a failure or an interrupt leaves nothing behind.
"""

from __future__ import annotations

import hashlib
import logging
import os
import time
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

from . import budget, container, passthrough, product
from .errors import (
    InputError,
    NoBRepError,
)
from .lazy import lazy_module
from .paths import atomic_output, check_output, read_container, read_input
from .stages.common import (
    DEFAULT_TOL_MM,
    SUFFIX,
    TOL_WARN_FRACTION,
    _no_stage,
    default_compressed_name,
    default_decompressed_name,
    faces_by_type,
    one_blas_thread,
    read_source,
    source_format,
)
from .stages.compress import (
    Encoded,
    compress_report,
    encode_cad,
    max_net_displacement,
    shape_source,
    verify_encoded,
)
from .stages.decompress import (
    _convert,
    build,
    decode,
    decode_data,
    decode_file,
    output_uncertainty,
    read_text,
    step_pcurves,
    write,
)
from .stages.evaluate import evaluate_shapes, load_shape, write_heatmap

if TYPE_CHECKING:
    from . import occ
else:  # OCP takes seconds to import: only what builds or reads shapes pays for it
    occ = lazy_module("nurbscomp.occ")

log = logging.getLogger(__name__)

#: The commands (defined here), and the stages they wire (``nurbscomp.stages``),
#: which the API, the batch runner and the CLI take from here.
__all__ = [
    "DEFAULT_TOL_MM",
    "SUFFIX",
    "TOL_WARN_FRACTION",
    "Encoded",
    "build",
    "compress_file",
    "compress_report",
    "decode",
    "decode_data",
    "decode_file",
    "decompress_file",
    "default_compressed_name",
    "default_decompressed_name",
    "encode_cad",
    "evaluate",
    "evaluate_shapes",
    "faces_by_type",
    "info",
    "info_data",
    "load_shape",
    "max_net_displacement",
    "one_blas_thread",
    "read_container",
    "read_source",
    "read_text",
    "step_pcurves",
    "output_uncertainty",
    "shape_source",
    "source_format",
    "test_file",
    "verify_encoded",
    "write",
    "write_heatmap",
]


# ---------------------------------------------------------------- compress


#: A tolerance-mode container that makes its source no more than this many
#: times smaller is set against the source stored byte for byte (the text
#: model of ``--lossless``, a fraction of a second), and the smaller kept: a
#: thickened loft as an IGES surface model, one face of 120 edges kept
#: exact with its pcurves for OCCT's STEP reader, came out 48,597 bytes
#: within 0.1 mm and 28,870 byte for byte (xz -9e: 39,416).
EXACT_CHECK_RATIO = 16


def smaller_exact(src: Path, name: str, enc: Encoded) -> tuple[bytes, bytes, dict[str, Any]] | None:
    """The source file ``src`` (named ``name`` in META), its byte-exact
    container and that container's META, where ``enc`` is a tolerance-mode
    container at most :data:`EXACT_CHECK_RATIO` times smaller than the file
    (else the file is not read) and the byte-exact one is smaller still;
    else None.  The file itself is then what the user gets back: within any
    tolerance, and the smaller container."""
    if enc.lossless or len(enc.data) * EXACT_CHECK_RATIO < src.stat().st_size:
        return None
    data = read_input(src)
    try:
        blob, meta = passthrough.pack_file(data, name)
    except InputError:  # not a text the model takes (too large): the coded one stays
        return None
    return (data, blob, meta) if len(blob) < len(enc.data) else None


def exact_report(
    data: bytes, blob: bytes, meta: dict[str, Any], enc: Encoded, verified: bool
) -> dict[str, Any]:
    """The compress report of a byte-exact container kept by
    :func:`smaller_exact` in place of ``enc``'s, saying so."""
    out = passthrough.report(data, blob, meta, None, verified)
    out["warnings"] = [
        *enc.warnings,
        f"stored byte for byte: {len(blob)} bytes, smaller than the {len(enc.data)} "
        f"of the container coded within {enc.tol:g} mm",
    ]
    return out


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
    kept = smaller_exact(src_p, src_p.name, enc)
    stage("write")
    with atomic_output(dst_p, force, (src_p,)) as tmp:
        if kept is not None:
            tmp.write_bytes(kept[1])
            if verify:
                stage("check")
                passthrough.check_gives_back(read_container(tmp), kept[0])
        else:
            tmp.write_bytes(enc.data)
            if verify:
                stage("check")
                verify_encoded(enc, tmp.read_bytes())
    made = exact_report(*kept, enc, verify) if kept is not None else compress_report(enc, verify)
    return {
        "command": "compress",
        "input": str(src_p),
        "output": str(dst_p),
        **made,
        "seconds": time.perf_counter() - t0,
        "read_seconds": t_read,
    }


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
        "step_pcurves": step_pcurves(meta),
        "uncertainty": output_uncertainty(meta),
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
