"""Evaluate's stages: a CAD file or container's shape (``load_shape``), the
deviation between two shapes (``evaluate_shapes``), and its heatmap picture
(``write_heatmap``)."""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import (
    InputError,
)
from ..lazy import lazy_module
from ..paths import atomic_output
from ..report import verdict
from .common import SUFFIX
from .decompress import decode_file

if TYPE_CHECKING:
    from .. import occ
else:  # OCP takes seconds to import: only what builds or reads shapes pays for it
    occ = lazy_module("nurbscomp.occ")


def load_shape(path: str | os.PathLike[str]) -> tuple[Any, float | None]:
    """The shape of a CAD file (STEP, IGES, or ``.nzc`` decoded), and the
    tolerance its container was coded with (0 for a lossless one; None: not a
    container)."""
    if str(path).endswith(SUFFIX):
        shape, _, meta = decode_file(path)
        exact = meta.get("mode") in ("lossless", "exact")
        return shape, 0.0 if exact else meta.get("tolerance_mm")
    return occ.read_cad(path).shape, None


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
    from .. import heatmap

    if "face_max_mm" not in report:
        raise InputError("no heatmap: the two shapes have different face counts")
    meshes = occ.face_meshes(shape)
    dev = np.asarray(report["face_max_mm"], float)
    dst = Path(path)
    with atomic_output(dst, force) as tmp:
        # a lossless container's tolerance, 0, marks no face
        heatmap.render(meshes, dev, report.get("tolerance_mm") or None, tmp, title=title)
