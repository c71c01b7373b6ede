"""The typed reports the API returns: :class:`CompressReport` (``compress(...,
report=True)``), :class:`InfoReport` (``info``) and :class:`EvalReport`
(``evaluate``, also named :class:`Report`), each with ``to_dict()`` and
``to_json()``; and the verdict of ``eval`` (:func:`verdict`).

The command line prints the same fields (``--json``); a report is made from
the pipeline's dict by ``from_dict``, which ignores what only the command line
prints (``command``, ``output``, ``seconds``).
"""

from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass, field
from typing import Any

import numpy as np


def _plain(v: Any) -> Any:
    """``v`` with numpy arrays and scalars made lists and Python numbers (JSON's types)."""
    if isinstance(v, np.ndarray):
        return v.tolist()
    if isinstance(v, np.generic):
        return v.item()
    if isinstance(v, dict):
        return {str(k): _plain(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_plain(x) for x in v]
    return v


class _Typed:
    """What every report offers: ``to_dict``, ``to_json``, and the fields by
    name, ``r["mode"]`` as ``r.mode``, with ``keys()`` (so code written for
    the dicts the API returned before keeps working)."""

    def to_dict(self) -> dict[str, Any]:
        """The fields, nested reports as dicts, arrays as lists."""
        return {k: _plain(_asdict(getattr(self, k))) for k in self.keys()}

    def to_json(self, indent: int | None = 2) -> str:
        """:meth:`to_dict` as JSON text."""
        return json.dumps(self.to_dict(), indent=indent)

    def __getitem__(self, key: str) -> Any:
        if key not in self.keys():
            raise KeyError(key)
        return getattr(self, key)

    def keys(self) -> list[str]:
        """The field names (with ``r[key]``: ``dict(r)``, ``{**r}``)."""
        return [f.name for f in dataclasses.fields(self)]  # type: ignore[arg-type]

    @classmethod
    def from_dict(cls, r: dict[str, Any]) -> Any:
        """From the pipeline's report dict: the keys that are fields."""
        names = {f.name for f in dataclasses.fields(cls)}  # type: ignore[arg-type]
        return cls(**{k: v for k, v in r.items() if k in names})


def _asdict(v: Any) -> Any:
    if dataclasses.is_dataclass(v) and not isinstance(v, type):
        return dataclasses.asdict(v)
    if isinstance(v, list):
        return [_asdict(x) for x in v]
    return v


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
class Report(_Typed):
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
        # the eval dict nests counts, validity and free edges by side
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


#: ``evaluate``'s report, by the name of its kind (``Report`` is the same class).
EvalReport = Report


@dataclass(frozen=True)
class CompressReport(_Typed):
    """What a compression did (``compress(..., report=True)``; the fields of
    ``nurbscomp compress --json`` but the command line's own).

    Attributes
    ----------
    input_bytes, output_bytes : int
        The source's size (the file, or the STEP written from a shape) and
        the container's.
    ratio : float or None
        ``input_bytes / output_bytes``; None for a shape in memory, which has
        no file (its ``input_bytes`` is 0).
    mode : str
        ``"tolerance"``, ``"lossless"`` (the B-rep exact), ``"exact"`` (the
        file byte for byte) or ``"passthrough"`` (a file with no B-rep, kept
        byte for byte).
    tolerance_mm : float or None
        The tolerance asked for; None in the lossless and byte-for-byte modes.
    coded_tolerance_mm : float or None
        The tolerance the container was coded within (what it says): the one
        asked for, or a tenth or a hundredth of it where coding the whole part
        tighter gave a smaller container than the remedies for faces OCCT's
        reader or BRepCheck would mend (a warning says so).
    source_format : str
        ``"STEP"``, ``"IGES"`` or ``"BREP"`` (a shape in memory).
    verified : bool
        The container was decoded and checked.
    warnings : list of str
    unit : str or None
        The source's length unit (tolerance and lossless modes).
    counts : dict
        Sub-shapes of the source by type (tolerance and lossless modes).
    faces_by_type, faces_by_method : dict
        Faces by surface type; by the coding method chosen (tolerance mode).
    max_bound_mm, max_curve_bound_mm : float
        The largest certified bound of a face's surface, of a 3-D curve.
    certified_faces : int
        Faces with a certified bound (coded nets).
    pcurves_rebuilt : int
    step_safe : bool
        Whether the STEP check ran (``step_safe`` and a tolerance mode).
    product : dict or None
        The product data's summary (parts, instances, names, colours).
    product_bytes : int
    validity : dict
        What the validity stage did (tolerance mode).
    sha256, model : str or None
        Byte-for-byte modes: the file's SHA-256, the text model used.
    reason : str or None
        Passthrough mode: why the file holds no B-rep.
    """

    input_bytes: int
    output_bytes: int
    ratio: float | None
    mode: str
    tolerance_mm: float | None
    source_format: str
    verified: bool
    coded_tolerance_mm: float | None = None
    warnings: list[str] = field(default_factory=list)
    unit: str | None = None
    counts: dict[str, int] = field(default_factory=dict)
    faces_by_type: dict[str, int] = field(default_factory=dict)
    faces_by_method: dict[str, int] = field(default_factory=dict)
    max_bound_mm: float = 0.0
    max_curve_bound_mm: float = 0.0
    certified_faces: int = 0
    pcurves_rebuilt: int = 0
    step_safe: bool = False
    product: dict[str, Any] | None = None
    product_bytes: int = 0
    validity: dict[str, Any] = field(default_factory=dict)
    sha256: str | None = None
    model: str | None = None
    reason: str | None = None


@dataclass(frozen=True)
class InfoReport(_Typed):
    """What a container holds (``info``; the fields of ``nurbscomp info --json``
    but ``command``).

    Attributes
    ----------
    input : str
        The path, or ``"<bytes>"``.
    format_version : str
        ``"major.minor"``.
    mode : str
        ``"tolerance"``, ``"lossless"``, ``"exact"`` or ``"passthrough"``.
    lossless, passthrough : bool
    tolerance_mm : float or None
    source_format, source_name : str or None
    source_bytes : int or None
    writer : str or None
    file_bytes : int
        The container's size.
    coder : str
        The body's entropy coder (``"lzma"``, ``"stored"``, ...).
    body_stored_bytes : int
    section_raw_bytes : dict
        Bytes of each section, by tag, as decoded.
    unit : str or None
    shapes : dict
        Sub-shapes by type (B-rep containers).
    faces_by_type : dict
    geometry : dict
        Counts of surfaces, 3-D curves and pcurves (B-rep containers).
    product, product_tree : dict or None
        The product data's summary and tree.
    reason : str
        Passthrough: why the file was stored verbatim.
    sha256, model : str or None
        Byte-for-byte containers: the file's SHA-256, the text model.
    step_pcurves : bool
        Whether ``decompress`` writes pcurves into STEP output (False: the
        source STEP had none, docs/format.md §3.1).
    uncertainty : float or None
        The length uncertainty (mm) ``decompress`` writes into STEP and IGES
        output; None: OCCT's default, the shape's average tolerance (§3.1).
    """

    input: str
    format_version: str
    mode: str
    lossless: bool
    passthrough: bool
    tolerance_mm: float | None
    source_format: str | None
    source_name: str | None
    source_bytes: int | None
    writer: str | None
    file_bytes: int
    coder: str
    body_stored_bytes: int
    section_raw_bytes: dict[str, int]
    unit: str | None = None
    shapes: dict[str, int] = field(default_factory=dict)
    faces_by_type: dict[str, int] = field(default_factory=dict)
    geometry: dict[str, int] = field(default_factory=dict)
    product: dict[str, Any] | None = None
    product_tree: Any = None
    reason: str = ""
    sha256: str | None = None
    model: str | None = None
    step_pcurves: bool = True
    uncertainty: float | None = None
