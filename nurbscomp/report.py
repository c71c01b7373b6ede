"""The typed report of ``nurbscomp.evaluate``: what the ``eval`` command prints."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np


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
        with; None when neither applies.
    max_deviation_mm, mean_deviation_mm : float or None
        Over all sampled points (the mean: of each face's mean); None when the
        face counts differ (faces are paired by index).
    worst_faces : list of FaceDeviation
        The worst faces first.
    face_max_mm, face_mean_mm : ndarray, shape (F,)
        Per face of the reconstruction; empty when the face counts differ.
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

    @property
    def within_tolerance(self) -> bool | None:
        """Every sampled point within ``tolerance_mm``; None if either is unknown."""
        if self.tolerance_mm is None or self.max_deviation_mm is None:
            return None
        return self.max_deviation_mm <= self.tolerance_mm

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
        )
