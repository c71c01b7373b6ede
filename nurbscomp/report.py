"""The typed report of ``nurbscomp.evaluate``: what the ``eval`` command prints,
and its verdict (:func:`verdict`)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

#: How far a sampled point may be beyond the tolerance and still count within
#: it: the precision of the measure (points projected on the other face by
#: OCCT's extrema, to about 1e-9 mm on the corpus; a lossless container
#: measures 5e-9 mm against its source), not a margin of the coder.
MEASURE_SLACK_MM = 1e-6

#: The checks of :func:`verdict`, in the order the verdict names them.
CHECKS = ("within_tolerance", "topology_same", "valid_kept", "free_edges_kept")


def verdict(r: dict[str, Any]) -> dict[str, Any]:
    """The verdict on an ``eval`` report (``pipeline.evaluate_shapes``'s dict):

    * ``within_tolerance``: every sampled point within ``tolerance_mm`` (plus
      ``MEASURE_SLACK_MM``); None, not checked, without a tolerance or when
      the face counts differ (faces are paired by index);
    * ``topology_same``: the same counts of solids, shells, faces, edges, vertices;
    * ``valid_kept``: the reconstruction is valid wherever the original is;
    * ``free_edges_kept``: no more free edges than the original;
    * ``verdict``: ``"pass"`` if no check failed, else ``"fail"``, and
      ``failed``: the checks that failed.
    """
    tol, worst = r.get("tolerance_mm"), r.get("max_deviation_mm")
    out: dict[str, Any] = {
        "within_tolerance": None
        if tol is None or worst is None
        else bool(worst <= tol + MEASURE_SLACK_MM),
        "topology_same": r["counts"]["original"] == r["counts"]["reconstructed"],
        "valid_kept": bool(r["valid"]["reconstructed"] or not r["valid"]["original"]),
        "free_edges_kept": r["free_edges"]["reconstructed"] <= r["free_edges"]["original"],
    }
    failed = [k for k in CHECKS if out[k] is False]
    return {**out, "verdict": "fail" if failed else "pass", "failed": failed}


@dataclass(frozen=True)
class Counts:
    """Distinct sub-shapes of a shape."""

    solids: int
    shells: int
    faces: int
    edges: int
    vertices: int


@dataclass(frozen=True)
class FaceDeviation:
    """One face's largest sampled deviation (``face`` is 1-based, in
    ``TopExp.MapShapes`` order, as the CLI prints it)."""

    face: int
    max_mm: float


@dataclass(frozen=True)
class Report:
    """The error between an original shape and its reconstruction.

    Attributes
    ----------
    original, reconstructed : str
        The file names given, or ``"<bytes>"``, ``"<shape>"``.
    counts_original, counts_reconstructed : Counts
    same_topology : bool
        The counts are equal.
    valid_original, valid_reconstructed : bool
        BRepCheck's verdicts.
    free_edges_original, free_edges_reconstructed : int
    tolerance_mm : float or None
        The tolerance given, or the one the reconstructed container was coded
        with (0 for a lossless one); None when neither applies.
    max_deviation_mm, mean_deviation_mm : float or None
        Over all sampled points (the mean: of each face's mean); None when the
        face counts differ (faces are paired by index).
    worst_faces : list of FaceDeviation
        The worst faces first.
    face_max_mm, face_mean_mm : ndarray, shape (F,)
        Per face of the reconstruction; empty when the face counts differ.
    within_tolerance : bool or None
        Every sampled point within ``tolerance_mm`` (to the measure's
        precision, ``MEASURE_SLACK_MM``); None if either is unknown.
    valid_kept : bool
        Valid wherever the original is.
    free_edges_kept : bool
        No more free edges than the original.
    passed : bool
        No check of :func:`verdict` failed (``eval`` exits 0).
    failed : list of str
        The checks that failed, names from ``CHECKS``.
    """

    original: str
    reconstructed: str
    counts_original: Counts
    counts_reconstructed: Counts
    same_topology: bool
    valid_original: bool
    valid_reconstructed: bool
    free_edges_original: int
    free_edges_reconstructed: int
    tolerance_mm: float | None = None
    max_deviation_mm: float | None = None
    mean_deviation_mm: float | None = None
    worst_faces: list[FaceDeviation] = field(default_factory=list)
    face_max_mm: np.ndarray = field(default_factory=lambda: np.zeros(0))
    face_mean_mm: np.ndarray = field(default_factory=lambda: np.zeros(0))
    within_tolerance: bool | None = None
    valid_kept: bool = True
    free_edges_kept: bool = True
    passed: bool = True
    failed: list[str] = field(default_factory=list)

    @classmethod
    def from_dict(cls, r: dict[str, Any]) -> Report:
        """From the report dict of ``pipeline.evaluate`` (the CLI's JSON)."""
        return cls(
            original=r["original"],
            reconstructed=r["reconstructed"],
            counts_original=Counts(**r["counts"]["original"]),
            counts_reconstructed=Counts(**r["counts"]["reconstructed"]),
            same_topology=r["same_topology"],
            valid_original=r["valid"]["original"],
            valid_reconstructed=r["valid"]["reconstructed"],
            free_edges_original=r["free_edges"]["original"],
            free_edges_reconstructed=r["free_edges"]["reconstructed"],
            tolerance_mm=r.get("tolerance_mm"),
            max_deviation_mm=r.get("max_deviation_mm"),
            mean_deviation_mm=r.get("mean_deviation_mm"),
            worst_faces=[FaceDeviation(w["face"], w["max_mm"]) for w in r.get("worst_faces", [])],
            face_max_mm=np.asarray(r.get("face_max_mm", []), float),
            face_mean_mm=np.asarray(r.get("face_mean_mm", []), float),
            within_tolerance=r["within_tolerance"],
            valid_kept=r["valid_kept"],
            free_edges_kept=r["free_edges_kept"],
            passed=r["verdict"] == "pass",
            failed=list(r["failed"]),
        )
