"""The whole model <-> its sections: the order and presence of the sections
(``layout``, ``check_layout``), writing them all (``model_to_sections``),
reading them all with every reference checked (``read_sections``)."""

from __future__ import annotations

from collections.abc import Callable, Collection
from typing import Any, cast

import numpy as np

from .. import budget, container, product
from ..errors import BadReferenceError, CorruptError
from ..model import (
    EC,
    REBUILD,
    VC,
    BRepModel,
    Derived,
    PointRepKind,
    RepKind,
    Table,
)
from .edges import _read_edges, _read_faces, _resolve_picks, _write_edges, _write_faces
from .geometry import SWEPT, _read_geometry, _write_geometry
from .meta import read_meta, tolerance, write_meta
from .nets import (
    Tables,
    _net_shapes,
    _read_nets,
    _read_sides,
    _shapes,
    _write_nets,
    _write_sides,
    coded_rows,
)
from .topology import _read_locations, _read_shapes, _write_locations, _write_shapes
from .vertices import _read_vertices, _write_vertices


def model_to_sections(
    m: BRepModel, meta: dict[str, Any], t: Tables, only: Collection[str] | None = None
) -> list[tuple[str, bytes]]:
    """The sections of a container holding ``m`` and the tables ``t`` (made by
    ``writer.tables``: in tolerance mode, ``m`` holds the *decoded* poles of
    the nets ``t`` codes, so that what the decoder rebuilds is ``m``).

    ``only``: the tags wanted (the others are not written; a measure of some
    sections' size needs no more)."""
    meta = {**meta, "unit": m.unit, "source_format": m.source_format}
    tol = float(meta.get("tolerance_mm") or 0.0)
    writers: list[tuple[str, Callable[[], bytes]]] = [
        ("META", lambda: write_meta(meta)),
        ("LOCS", lambda: _write_locations(m)),
        ("SURF", lambda: _write_geometry(m.surfaces, 3, t.rows(Table.SURFACE))),
        ("SNET", lambda: _write_nets(t.snet, _net_shapes(m.surfaces, t, Table.SURFACE), True)),
        ("CRV3", lambda: _write_geometry(m.curves3d, 3, t.rows(Table.CURVE3D))),
        ("CNET", lambda: _write_nets(t.cnet, _net_shapes(m.curves3d, t, Table.CURVE3D), False)),
        ("CRV2", lambda: _write_geometry(m.curves2d, 2)),
        # B-rep exact: large models' SHAP as arrays, which decode in a few
        # numpy calls (docs/format.md §2.5.1)
        ("SHAP", lambda: _write_shapes(m, arrays=meta.get("mode") == "lossless")),
        ("VERT", lambda: _write_vertices(m, tol)),
        ("EDGE", lambda: _write_edges(m, t.range_how)),
        ("FACE", lambda: _write_faces(m)),
        *([("SIDE", lambda: _write_sides(m))] if len(m.side_joins) else []),
        *([("PROD", lambda: _write_product(m))] if m.product is not None else []),
    ]
    return [(tag, write()) for tag, write in writers if only is None or tag in only]


def _write_product(m: BRepModel) -> bytes:
    assert m.product is not None
    return product.write(m.product, (m.child_start, m.child_shape))


SECTIONS = ("META", "LOCS", "SURF", "SNET", "CRV3", "CNET", "CRV2", "SHAP", "VERT", "EDGE", "FACE")
#: What each revision (``container.VERSIONS``: 1 is format 1.1, 2 is 1.2)
#: adds, after the sections of the revisions before it.
ADDED = {1: ("SIDE",), 2: ("PROD",)}


def layout(revision: int) -> tuple[str, ...]:
    """The sections a file of ``revision`` holds, in order (as far as this reader knows)."""
    return SECTIONS + tuple(t for k, tags in sorted(ADDED.items()) if k <= revision for t in tags)


def check_layout(tags: list[str], revision: int, newer: bool = False) -> None:
    """Check a container's section tags: every section of ``SECTIONS``, in its order.

    A section this reader does not know is refused, except in a file that is
    ``newer`` than the versions this reader knows within format 1 (a 1.y past
    1.2, which no writer makes: 1.x added sections only with a minor bump), where
    it is skipped (docs/format.md, §0).

    Raises
    ------
    CorruptError
        A section is missing, out of order, or unknown.
    """
    order = layout(revision)
    known = [t for t in tags if t in order]
    for t in tags:
        if t not in order and not newer:
            raise CorruptError(f"unknown section {t!r} (position {tags.index(t)})")
    for t in SECTIONS:
        if t not in known:
            raise CorruptError(f"missing section {t}")
    expect = [t for t in order if t in known]  # the sections a later minor added are optional
    if known != expect:
        bad = next(i for i, (a, b) in enumerate(zip(known, expect)) if a != b)
        raise CorruptError(f"section {known[bad]} out of order (position {tags.index(known[bad])})")


def read_sections(
    get: Any,
    revision: int | None = None,
    limits: budget.Limits | None = budget.DEFAULT,
) -> tuple[BRepModel, dict[str, Any], Tables]:
    """The tables of a container from a section lookup ``get(tag) -> bytes``,
    every reference checked: the model (coded poles still NaN, ranges left to
    rules still zero) and the :class:`Tables` for ``decode.apply``.

    ``revision`` is the file's version (``container.Container.revision``;
    default: the one this writer writes): it says which sections there are and
    how each is laid out.
    ``limits`` is the decoding budget (``budget.check_structure``), checked on
    the tables before any net is decoded or any walk over the shapes is made;
    None skips it (a container just written).

    Raises
    ------
    CorruptError
        A section is missing, or a subclass: ``SectionError`` (a section does
        not decode; its tag and where), ``BadReferenceError`` (an index points
        outside its table).
    LimitError
        Coded nets larger than a reader allocates, or a shape past ``limits``.
    """
    with np.errstate(all="ignore"):  # overflows become non-finite values, refused by name
        rev = container.REVISION if revision is None else revision
        return _read_sections(get, rev, limits)


def _optional(get: Any, tag: str) -> bytes | None:
    """A section a later version added, or None where the file has none
    (``get`` is a container's, raising ``CorruptError``, or a dict's)."""
    try:
        return cast(bytes, get(tag))
    except (CorruptError, KeyError):
        return None


def _read_sections(
    get: Any, revision: int, limits: budget.Limits | None
) -> tuple[BRepModel, dict[str, Any], Tables]:
    meta = read_meta(get("META"), revision)
    m = BRepModel()
    m.unit = str(meta.get("unit", "MM"))
    m.source_format = str(meta.get("source_format", "STEP"))
    tol = tolerance(meta)
    _read_locations(get("LOCS"), m)
    m.surfaces = _read_geometry(get("SURF"), "SURF", 3, revision)
    m.curves3d = _read_geometry(get("CRV3"), "CRV3", 3, revision)
    m.curves2d = _read_geometry(get("CRV2"), "CRV2", 2, revision)
    _read_shapes(get("SHAP"), m, revision, limits)
    _read_vertices(get("VERT"), m, tol, revision)
    cap = np.inf if limits is None else limits.references
    _read_faces(get("FACE"), m)  # before EDGE: 2.11 predicts from the faces
    range_how, picks = _read_edges(get("EDGE"), m, revision, cap)
    if picks is not None:
        counts = m.counts()
        if len(m.face_surface) != counts["face"] or len(m.edge_tol) != counts["edge"]:
            raise BadReferenceError("edge or face table does not match the shapes table")
        _resolve_picks(m, picks, cap)
    check_references(m)
    if limits is not None:
        budget.check_structure(m, limits)
    coded_surfaces = coded_rows(m.surfaces)
    snet = _read_nets(
        get("SNET"), len(coded_surfaces), "SNET", _shapes(m.surfaces, coded_surfaces), revision
    )
    sides = _optional(get, "SIDE") if "SIDE" in layout(revision) else None
    if sides is not None:
        _read_sides(sides, m, set(coded_surfaces))
    crows = coded_rows(m.curves3d)
    cnet = _read_nets(get("CNET"), len(crows), "CNET", _shapes(m.curves3d, crows), revision)
    prod = _optional(get, "PROD") if "PROD" in layout(revision) else None
    if prod is not None:
        # format 2.3: a sub-shape is numbered by its place in its product's walk
        shapes = (m.child_start, m.child_shape) if revision >= 6 else None
        m.product = product.read(prod, len(m.shape_type), shapes)
    return m, meta, Tables(snet, cnet, range_how)


def check_references(m: BRepModel) -> None:
    """Raise ``BadReferenceError`` unless every index in ``m`` points into its table."""
    ns, n3, n2, nl = len(m.surfaces), len(m.curves3d), len(m.curves2d), len(m.locations)
    counts = m.counts()

    def within(a: np.ndarray, lo: int, hi: int, what: str) -> None:
        if len(a) and (a.min() < lo or a.max() >= hi):
            at = int(np.flatnonzero((a < lo) | (a >= hi))[0])
            raise BadReferenceError(f"{what} (entry {at} of its kind) refers to a missing entry")

    for g in m.surfaces:
        if isinstance(g, Derived):
            if g.kind in SWEPT:
                within(np.array([g.basis]), 0, n3, "a swept surface")
    for table, n in ((m.curves3d, n3), (m.curves2d, n2)):
        for g in table:
            if isinstance(g, Derived):
                within(np.array([g.basis]), 0, n, "a derived curve")
    within(m.child_loc, 0, nl, "a sub-shape location")
    within(np.array([m.root_loc]), 0, nl, "the root location")
    if len(m.vertex_tol) != counts["vertex"] or len(m.edge_tol) != counts["edge"]:
        raise BadReferenceError("vertex or edge table does not match the shapes table")
    if len(m.face_surface) != counts["face"]:
        raise BadReferenceError("face table does not match the shapes table")
    within(m.face_surface, 0, ns, "a face surface")
    within(m.face_loc, 0, nl, "a face location")
    reps = m.edge_reps
    kind = reps[:, EC.KIND]
    two = kind == RepKind.ON_TWO_SURFACES
    c3 = kind == RepKind.CURVE3D
    within(reps[c3, EC.CURVE], -1, n3, "an edge curve")
    within(reps[~two & ~c3, EC.CURVE], REBUILD, n2, "an edge pcurve")
    within(reps[kind == RepKind.ON_CLOSED_SURFACE, EC.CURVE2], REBUILD, n2, "a seam pcurve")
    if (reps[~two & ~c3, EC.CURVE] == -1).any() or (
        reps[kind == RepKind.ON_CLOSED_SURFACE, EC.CURVE2] == -1
    ).any():
        raise BadReferenceError("an edge pcurve refers to a missing entry")
    seam = reps[kind == RepKind.ON_CLOSED_SURFACE]
    if ((seam[:, EC.CURVE] == REBUILD) != (seam[:, EC.CURVE2] == REBUILD)).any():
        raise BadReferenceError("a seam has one pcurve stored and the other one computed")
    within(reps[~c3, EC.SURFACE], 0, ns, "an edge surface")
    within(reps[two, EC.SURFACE2], 0, ns, "an edge surface")
    within(reps[:, EC.LOC], 0, nl, "an edge location")
    within(reps[two, EC.LOC2], 0, nl, "an edge location")
    within(m.edge_rep_cont, 0, 7, "a continuity")
    vr = m.vertex_reps
    within(vr[:, VC.KIND], 0, 3, "a vertex representation kind")
    within(vr[vr[:, VC.KIND] == PointRepKind.ON_CURVE, VC.CURVE], 0, n3, "a vertex curve")
    pcurve = vr[:, VC.KIND] == PointRepKind.ON_CURVE_ON_SURFACE
    within(vr[pcurve, VC.CURVE], 0, n2, "a vertex pcurve")
    within(vr[vr[:, VC.KIND] != PointRepKind.ON_CURVE, VC.SURFACE], 0, ns, "a vertex surface")
    within(vr[:, VC.LOC], 0, nl, "a vertex location")
    types = m.shape_type
    within(types, 0, 8, "a shape type")
