"""Lines through their edges' vertices (format 2.2, docs/format.md §2.3;
encode.assembly._thread, rules.joins.through_vertices): a line used by
one edge is stored with no values and made again from the decoded vertices,
within its bound of the source's line, its range a rule."""

from __future__ import annotations

from pathlib import Path

import cadquery as cq
import numpy as np
import pytest

from nurbscomp import container, occ, pipeline, serialize
from nurbscomp.encode import assembly
from nurbscomp.errors import BadReferenceError, SectionError
from nurbscomp.model import EC, REBUILD, Analytic, Kind, RepKind
from nurbscomp.occ import topology
from nurbscomp.rules import joins
from nurbscomp.rules.ranges import RANGE_VERTICES
from nurbscomp.serialize import geometry

from .conftest import (
    assert_comes_back,
    assert_step_keeps_floor,
    compressed_part,
    through_curves,
    through_rows,
)


def _part(path: Path) -> Path:
    """A plate with a slot and a chamfer, slightly rotated (its lines are no
    axis lines)."""
    shape = (
        cq.Workplane()
        .box(40, 25, 8)
        .faces(">Z")
        .workplane()
        .slot2D(18, 6, angle=20)
        .cutThruAll()
        .edges("|Z")
        .chamfer(1.5)
        .rotate((0, 0, 0), (1, 1, 0.3), 17)
    )
    cq.exporters.export(shape, str(path))
    return path


@pytest.fixture(scope="module")
def plate(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path, dict]:
    return compressed_part(tmp_path_factory, _part, "plate")


def test_lines_go_through_their_vertices(plate) -> None:
    src, nzc, rep = plate
    assert rep["verified"] and rep["max_bound_mm"] <= 0.01
    tables, _, rows, lines = through_rows(nzc, 5, Kind.LINE)  # format 2.2 and later
    assert len(rows) >= len(lines) // 2 > 0
    back, _ = pipeline.decode(container.unpack(nzc.read_bytes()))  # the decoded model
    reps = back.edge_reps
    table = joins.end_vertices(back)
    for i in rows:
        (q,) = np.flatnonzero((reps[:, EC.KIND] == RepKind.CURVE3D) & (reps[:, EC.CURVE] == i))
        assert tables.range_how[q] == RANGE_VERTICES  # a rule, no floats
        ends = joins.edge_ends(table, int(reps[q, EC.EDGE]))
        a, b = (back.vertex_point[ends[o]] for o in (joins.FORWARD, joins.REVERSED))
        g = back.curves3d[i]
        assert np.array_equal(g.frame[0], a)  # the origin is the FORWARD vertex, bit for bit
        assert np.isclose(np.linalg.norm(g.frame[1]), 1.0, atol=1e-15)
        assert back.edge_rep_range[q][0] == 0.0
        assert np.allclose(g.frame[0] + back.edge_rep_range[q][1] * g.frame[1], b, atol=1e-12)
    assert_comes_back(src, nzc, 0.01)


def test_the_step_output_keeps_the_floor(plate, tmp_path: Path) -> None:
    src, nzc, _ = plate
    assert_step_keeps_floor(occ.read_cad(src), nzc, tmp_path)


def test_the_line_moves_within_its_bound(plate) -> None:
    """Each new line's ends are within its bound of the source line's ends;
    the edge's tolerance covers that bound."""
    src, nzc, _ = plate
    source, _ = topology.shape_to_model(occ.read_cad(src).shape)
    back, _ = pipeline.decode(container.unpack(nzc.read_bytes()))
    reps = back.edge_reps
    for i in through_curves(back, Kind.LINE):
        (q,) = np.flatnonzero((reps[:, EC.KIND] == RepKind.CURVE3D) & (reps[:, EC.CURVE] == i))
        was, now = source.curves3d[i], back.curves3d[i]
        t0, t1 = source.edge_rep_range[q]
        u0, u1 = back.edge_rep_range[q]
        for t, u in ((t0, u0), (t1, u1), ((t0 + t1) / 2, (u0 + u1) / 2)):
            d = np.linalg.norm(was.frame[0] + t * was.frame[1] - (now.frame[0] + u * now.frame[1]))
            assert d <= min(0.01, back.edge_tol[reps[q, EC.EDGE]])


def test_a_line_whose_edge_keeps_its_pcurve_stays(plate) -> None:
    """assembly.unthread: a kept (stored) pcurve is parameterized on the
    source line, so that line comes back with its range."""
    src, nzc, _ = plate
    source, _ = topology.shape_to_model(occ.read_cad(src).shape)
    back, _ = pipeline.decode(container.unpack(nzc.read_bytes()))
    (i, *_) = through_curves(back, Kind.LINE)
    reps = back.edge_reps
    (q,) = np.flatnonzero((reps[:, EC.KIND] == RepKind.CURVE3D) & (reps[:, EC.CURVE] == i))
    edge = reps[q, EC.EDGE]
    cand = back
    # a pcurve on it computed by the decoder changes nothing; a stored one does
    pcurve = [edge, RepKind.ON_SURFACE, REBUILD, -1, 0, -1, 0, 0]
    cand.edge_reps = np.vstack([reps, pcurve])
    assert assembly.unthread(cand, source) is cand
    cand.edge_reps[-1, EC.CURVE] = 0
    out = assembly.unthread(cand, source)
    assert out.curves3d[i] is source.curves3d[i]
    assert np.array_equal(out.edge_rep_range[q], source.edge_rep_range[q])
    assert len(through_curves(out, Kind.LINE)) == len(through_curves(back, Kind.LINE)) - 1


def test_the_reader_refuses_what_breaks_the_rule(plate) -> None:
    _, nzc, _ = plate
    c = container.unpack(nzc.read_bytes())
    m, _, _ = serialize.read_sections(c.get, c.revision)
    (i, j, *_) = through_curves(m, Kind.LINE)
    reps = m.edge_reps
    (q,) = np.flatnonzero((reps[:, EC.KIND] == RepKind.CURVE3D) & (reps[:, EC.CURVE] == i))
    (r,) = np.flatnonzero((reps[:, EC.KIND] == RepKind.CURVE3D) & (reps[:, EC.CURVE] == j))
    two = m.edge_reps.copy()
    two[r, EC.CURVE] = i  # two edges on one line through vertices
    m.edge_reps = two
    with pytest.raises(BadReferenceError, match="used by 2 edges"):
        joins.through_vertices(m)
    m.edge_reps = reps
    m.curves3d = list(m.curves3d)
    m.curves3d[j] = m.curves3d[i]  # a copy of it
    with pytest.raises(BadReferenceError):
        joins.through_vertices(m)


@pytest.mark.parametrize(
    "kind, frame, through, code, revision",
    [
        (Kind.LINE, (2, 3), (1,), 176, 5),  # 2.2
        (Kind.CIRCLE, (3, 3), (1, -1), 177, 7),  # 2.4: along the axis (177), against (178)
    ],
)
def test_the_kind_codes_only_in_crv3_of_their_version(
    kind: Kind, frame: tuple, through: tuple, code: int, revision: int
) -> None:
    rows = [Analytic(kind, np.zeros(frame), np.zeros(frame[0] - 2), through=t) for t in through]
    raw = geometry._write_geometry(rows, 3, revision=revision)
    back = geometry._read_geometry(raw, "CRV3", 3, revision=revision)
    assert [(g.kind, g.through) for g in back] == [(kind, t) for t in through]
    with pytest.raises(SectionError, match=f"unknown geometry kind {code}"):
        geometry._read_geometry(raw, "CRV3", 3, revision=revision - 1)
    with pytest.raises(SectionError, match=f"unknown geometry kind {code}"):
        geometry._read_geometry(raw, "SURF", 3, revision=revision)
    with pytest.raises(ValueError):
        geometry._write_geometry(rows, 3, revision=revision - 1)


def test_lossless_has_none(plate, tmp_path: Path) -> None:
    src, _, _ = plate
    out = tmp_path / "x.nzc"
    pipeline.compress_file(src, out, lossless=True)
    c = container.unpack(out.read_bytes())
    assert not through_curves(serialize.read_sections(c.get, c.revision)[0], Kind.LINE)
