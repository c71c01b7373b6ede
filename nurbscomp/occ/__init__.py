"""The only door to OCP (OpenCASCADE).

Everything that touches OCCT lives in this package; the rest of nurbscomp works
on the plain numpy data of :mod:`nurbscomp.model`.
"""

from . import cq
from .approx import compact_pcurve
from .files import (
    UNITS_MM,
    CadFile,
    bintools_bytes,
    output_format,
    read_cad,
    step_round_trip,
    write_shape,
)
from .isolated import ReaderCrash, ReaderTimeout, RoundTrip, share_cores, spare_core
from .measure import (
    counts,
    deviation,
    deviation_stats,
    diagonal,
    edge_points,
    edges_per_face,
    face_signatures,
    faces,
    failures,
    faulty_faces,
    free_edges,
    free_edges_per_face,
    free_edges_sewn,
    is_valid,
    model_order,
    sewn_edge_pairs,
    thin_solids,
)
from .mesh import face_meshes
from .topology import PcurveCache, model_to_shape, shape_to_model

__all__ = [
    "UNITS_MM",
    "CadFile",
    "PcurveCache",
    "ReaderCrash",
    "ReaderTimeout",
    "RoundTrip",
    "bintools_bytes",
    "compact_pcurve",
    "counts",
    "cq",
    "deviation",
    "deviation_stats",
    "diagonal",
    "edge_points",
    "edges_per_face",
    "face_meshes",
    "face_signatures",
    "faces",
    "failures",
    "faulty_faces",
    "free_edges",
    "free_edges_per_face",
    "free_edges_sewn",
    "is_valid",
    "model_order",
    "model_to_shape",
    "output_format",
    "read_cad",
    "sewn_edge_pairs",
    "thin_solids",
    "shape_to_model",
    "share_cores",
    "spare_core",
    "step_round_trip",
    "write_shape",
]
