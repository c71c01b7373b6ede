"""The format layer: the B-rep model <-> the payloads of a container's sections.

Sections, in the order they are written and read (docs/format.md gives the
array-by-array layout of each):

====  ==========================================================
META  JSON: unit, source format, mode, tolerance, source name/size
LOCS  datums (3x4 matrices) and locations (datum, power chains)
SURF  surface table
SNET  coded B-spline surface nets (tolerance mode; empty when lossless)
CRV3  3-D curve table
CNET  coded B-spline 3-D curve poles (tolerance mode; empty when lossless)
CRV2  2-D curve table (pcurves)
SHAP  shape types, flags, and sub-shape references
VERT  vertex points, tolerances, point representations
EDGE  edge tolerances, flags, curve representations
FACE  face surface, location, tolerance, natural-restriction flag
SIDE  (1.1, optional) net sides set to another net's side
PROD  (1.2, optional) product data: tree, names, colours, layers, header
====  ==========================================================

A module per group of sections: :mod:`.geometry` (SURF, CRV3, CRV2),
:mod:`.topology` (LOCS, SHAP), :mod:`.vertices` (VERT), :mod:`.edges` (EDGE,
FACE), :mod:`.nets` (SNET, CNET, SIDE), :mod:`.meta` (META); :mod:`.limits`
holds what a reader refuses, and :mod:`.sections` the whole model's order,
writing and reading.  The names below are this package's interface.
"""

from __future__ import annotations

from ..streams import BlockReader, BlockWriter
from .edges import (
    RANGE_NATURAL,
    RANGE_OF_3D,
    RANGE_STORED,
    RANGE_VERTICES,
    RANGE_ZERO,
    _picks,
    edge_candidates,
)
from .geometry import (
    COPY,
    EVEN_READ,
    EVEN_WRITE,
    GRID_LENGTHS,
    GRID_MAX,
    GRID_MIN,
    GRIDDED,
    K_EVEN,
    K_EXPLICIT,
    K_REPEAT,
    K_SIMPLE,
    K_UNIT,
    MAX_GRID_INT,
    REPEAT_MIN,
    SWEPT,
    _KnotWriter,
    _read_geometry,
    _write_geometry,
)
from .limits import (
    MAX_CODED_POLES,
    MAX_COORD,
    MAX_DEGREE,
    MAX_LEVEL,
    MAX_NET_POLES,
    finite,
)
from .meta import (
    MAX_META_BYTES,
    MAX_META_DIGITS,
    MAX_META_TEXT,
    MAX_SOURCE_BYTES,
    meta_text,
    parse_meta,
    read_meta,
    tolerance,
    write_meta,
)
from .nets import (
    NET_STREAMS,
    NetTable,
    Tables,
    _read_nets,
    _read_sides,
    _write_nets,
    _write_sides,
    coded_rows,
)
from .sections import (
    ADDED,
    SECTIONS,
    check_layout,
    check_references,
    layout,
    model_to_sections,
    read_sections,
)
from .topology import (
    _read_shapes,
    _write_shape_arrays,
    _write_shapes,
    walk_section,
)
from .vertices import (
    MAX_QUARTER,
    QUARTERS,
    _grid_from_residuals,
    _grid_predictions,
    _read_tolerances,
    _write_tolerances,
    quarter_power,
    vertex_grid,
    vertex_neighbours,
    vertex_quads,
)

__all__ = [
    "ADDED",
    "BlockReader",
    "BlockWriter",
    "COPY",
    "EVEN_READ",
    "EVEN_WRITE",
    "GRIDDED",
    "GRID_LENGTHS",
    "GRID_MAX",
    "GRID_MIN",
    "K_EVEN",
    "K_EXPLICIT",
    "K_REPEAT",
    "K_SIMPLE",
    "K_UNIT",
    "MAX_CODED_POLES",
    "MAX_COORD",
    "MAX_DEGREE",
    "MAX_GRID_INT",
    "MAX_LEVEL",
    "MAX_META_BYTES",
    "MAX_META_DIGITS",
    "MAX_META_TEXT",
    "MAX_NET_POLES",
    "MAX_QUARTER",
    "MAX_SOURCE_BYTES",
    "NET_STREAMS",
    "NetTable",
    "QUARTERS",
    "RANGE_NATURAL",
    "RANGE_OF_3D",
    "RANGE_STORED",
    "RANGE_VERTICES",
    "RANGE_ZERO",
    "REPEAT_MIN",
    "SECTIONS",
    "SWEPT",
    "Tables",
    "_KnotWriter",
    "_grid_from_residuals",
    "_grid_predictions",
    "_picks",
    "_read_geometry",
    "_read_nets",
    "_read_shapes",
    "_read_sides",
    "_read_tolerances",
    "_write_geometry",
    "_write_nets",
    "_write_shape_arrays",
    "_write_shapes",
    "walk_section",
    "_write_sides",
    "_write_tolerances",
    "check_layout",
    "check_references",
    "coded_rows",
    "edge_candidates",
    "finite",
    "layout",
    "meta_text",
    "model_to_sections",
    "quarter_power",
    "parse_meta",
    "read_meta",
    "write_meta",
    "read_sections",
    "tolerance",
    "vertex_grid",
    "vertex_neighbours",
    "vertex_quads",
]
