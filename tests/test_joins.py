"""Coincident boundaries coded once (issue 10, "no new gaps"): twin curves,
joined net sides, vertex clusters, and the format 1.1 parts that carry them."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from nurbscomp import codec, container, decode, nearby, occ, pipeline, serialize
from nurbscomp.encode import coincide
from nurbscomp.errors import BadReferenceError, SectionError
from nurbscomp.model import BSplineCurve, BSplineSurface, ShapeType
from nurbscomp.rules import joins

from .conftest import SAMPLES

GOLDEN = Path(__file__).resolve().parent / "golden"


def _curve(poles: np.ndarray, knots=(0.0, 1.0), mults=None, degree: int = 3) -> BSplineCurve:
    mults = np.array(mults if mults is not None else [degree + 1, degree + 1])
    return BSplineCurve(poles, None, np.array(knots, float), mults, degree, False)


def test_vertex_clusters_link_chains_within_eps() -> None:
    p = np.array([[0, 0, 0], [5e-8, 0, 0], [1e-7, 0, 0], [1, 0, 0], [1, 5e-8, 0]], float)
    assert coincide.vertex_clusters(p, 1e-7).tolist() == [0, 0, 0, 3, 3]
    assert coincide.vertex_clusters(np.zeros((0, 3)), 1e-7).tolist() == []


def test_twin_curves_reversed_same_and_not() -> None:
    rng = np.random.default_rng(0)
    a = rng.normal(size=(4, 3))
    curves = [
        _curve(a),
        _curve(a[::-1] + 1e-8),  # a, reversed: a twin
        _curve(a + 1e-3),  # apart by more than eps
        _curve(a.copy(), knots=(0.0, 0.3, 1.0), mults=[3, 1, 3], degree=2),  # other knots
        _curve(a.copy()),  # an ISO row: leads, never follows
    ]
    got = coincide.twin_curves(curves, {0, 1, 2, 3, 4}, 1e-6, iso={4})
    assert set(got) == {0, 1}  # 4 leads 0 (same order) and 1 (reversed)
    assert got[0][:2] == (4, 0) and got[1][:2] == (4, 1)
    assert got[1][2] < 1e-7


def test_twin_sides_of_two_patches_and_join() -> None:
    rng = np.random.default_rng(1)
    a = rng.normal(size=(4, 5, 3))
    b = rng.normal(size=(3, 5, 3))
    b[-1] = a[0, ::-1]  # b's row u=1 is a's row u=0, reversed

    def surf(p: np.ndarray) -> BSplineSurface:
        nu, nv = p.shape[:2]
        return BSplineSurface(
            p, None, np.array([0.0, 1.0]), np.array([0.0, 1.0]), np.array([nu, nu]),
            np.array([nv, nv]), nu - 1, nv - 1, False, False, True,
        )  # fmt: skip

    sa, sb = surf(a), surf(b.copy())
    got = coincide.twin_sides([sa, sb], [0, 1], 1e-6)
    assert got == {(1, 1): ((0, 0), 1, 0.0)}
    moved = replace(sa, poles=a + 1e-3)
    joined = joins.joined_sides(sb, moved, np.array([1, 1, 0, 0, 1]))
    assert np.array_equal(joined[-1], (a + 1e-3)[0, ::-1])
    assert np.array_equal(joined[:-1], b[:-1])


def _faces_iges(step: Path, dst: Path) -> Path:
    from tests.golden.make_golden import faces_iges

    return faces_iges(step, dst)


@pytest.mark.slow
@pytest.mark.parametrize("sample", ["teapot.step", "blob.step", "loft.step"])
def test_surface_model_keeps_its_free_edges(sample: str, tmp_path: Path) -> None:
    """Each face with edges of its own (IGES faces mode): the decoded faces must
    meet wherever the source's do, counted as free edges sewn at 1e-7."""
    src = _faces_iges(
        Path(__file__).resolve().parent.parent / "samples" / sample, tmp_path / "s.igs"
    )
    nzc = tmp_path / "s.nzc"
    pipeline.compress_file(src, nzc, tol=0.1)
    shape = pipeline.decode_file(nzc)[0]
    assert occ.free_edges_sewn(shape) <= occ.free_edges_sewn(occ.read_cad(src).shape)


def _golden_sections(name: str) -> tuple[int, dict[str, bytes]]:
    c = container.unpack((GOLDEN / f"{name}.nzc").read_bytes())
    return c.revision, {s.tag: s.raw for s in c.sections}


def _decode(revision: int, secs: dict[str, bytes]):
    return decode.sections_to_model(secs.__getitem__, revision)


def test_side_section_is_checked() -> None:
    minor, secs = _golden_sections("teapot.faces.tol0.01")
    m, _ = _decode(minor, secs)
    assert len(m.side_joins) > 0
    bad = m.side_joins.copy()
    bad[0, 2] = len(m.surfaces) + 5  # a leader outside the table
    with pytest.raises(BadReferenceError, match="SIDE row 0"):
        _decode(minor, {**secs, "SIDE": serialize._write_sides(replace(m, side_joins=bad))})
    bad = m.side_joins.copy()
    bad[0, 1] = 7  # no such side
    with pytest.raises(SectionError, match="no such side"):
        _decode(minor, {**secs, "SIDE": serialize._write_sides(replace(m, side_joins=bad))})
    # a 1.0 reader's view: without SIDE the nets are not joined, and nothing fails
    plain, _ = _decode(minor, {k: v for k, v in secs.items() if k != "SIDE"})
    assert len(plain.side_joins) == 0


def test_copy_code_is_checked() -> None:
    code = codec.NetCode(
        codec.Method.COPY, codec.Quant.TOL, 0, 0, np.array([3, 0]), np.zeros(0), 0, 0
    )
    curves = [_curve(np.zeros((4, 3))) for _ in range(3)]
    with pytest.raises(ValueError, match="no B-spline curve"):
        decode.twin_copy(code, 2, curves, set())  # row 2 - 3 = -1
    ok = replace(code, ints=np.array([2, 1]))
    curves[0] = _curve(np.arange(12, dtype=float).reshape(4, 3))
    assert np.array_equal(decode.twin_copy(ok, 2, curves, set()), curves[0].poles[::-1])
    with pytest.raises(ValueError, match="not a copy"):
        decode.twin_copy(ok, 2, curves, {0})  # a copy of a copy


def test_curve_placements_match_occt(tmp_path: Path) -> None:
    """An IGES surface model whose faces sit in frames of their own: each
    placed curve's first pole is where OCCT puts the edge's start."""
    from OCP.BRep import BRep_Tool
    from OCP.BRepAdaptor import BRepAdaptor_Curve
    from OCP.TopAbs import TopAbs_EDGE
    from OCP.TopExp import TopExp
    from OCP.TopoDS import TopoDS
    from OCP.TopTools import TopTools_IndexedMapOfShape

    from tests.stress.files import write_iges
    from tests.stress.shapes import _fillet_cyl

    src = tmp_path / "f.igs"
    write_iges(_fillet_cyl(5.0, 8.0, 1.0, None), src, 0)  # faces mode
    cad = occ.read_cad(src)
    m, _ = occ.shape_to_model(cad.shape)
    assert len(m.locations) > 1  # the reader placed the faces
    where = joins.curve_placements(m)
    em = TopTools_IndexedMapOfShape()
    TopExp.MapShapes_s(cad.shape, TopAbs_EDGE, em)
    reps = m.edge_reps
    checked = 0
    for q in np.flatnonzero(reps[:, 1] == 0).tolist():
        c = int(reps[q, 2])
        g = m.curves3d[c] if c >= 0 else None
        if not isinstance(g, BSplineCurve) or c not in where:
            continue
        edge = TopoDS.Edge(em.FindKey(int(reps[q, 0]) + 1))
        if BRep_Tool.Degenerated_s(edge):
            continue
        p = BRepAdaptor_Curve(edge).Value(float(g.knots[0]))
        got = joins.placed(g.poles[:1], where[c])[0]
        assert np.allclose(got, [p.X(), p.Y(), p.Z()], atol=1e-9)
        checked += 1
    assert checked >= 4


def test_located_surface_model_keeps_its_free_edges(tmp_path: Path) -> None:
    """Faces in frames of their own, each with its own edges: twins are found
    in the model's frame and copied across the two placements."""
    from tests.stress.files import write_iges
    from tests.stress.shapes import _fillet_cyl

    src = tmp_path / "f.igs"
    write_iges(_fillet_cyl(5.0, 8.0, 1.0, None), src, 0)
    nzc = tmp_path / "f.nzc"
    pipeline.compress_file(src, nzc, tol=0.01)
    shape = pipeline.decode_file(nzc)[0]
    assert occ.free_edges_sewn(shape) <= occ.free_edges_sewn(occ.read_cad(src).shape)


@pytest.mark.slow
@pytest.mark.corpus
def test_corner_pins_follow_the_format_minor(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, one_coding: None
) -> None:
    """Format 1.2 pins a net's corner to a vertex only within the net's grid
    step (joins.pin_radius); a 1.1 reader pins within tol.  On an IGES model
    of 10 um trimmed faces at 0.1 mm, the 1.1 rule pulls corners that lie at
    no vertex by up to 13 um (nets held to 1.7 um), the 1.2 rule does not."""
    from nurbscomp.model import differences

    from .conftest import CORPUS

    # the nets are read under 1.1's rules too: only methods 1.x has
    monkeypatch.setattr(codec, "SURFACE_SEARCH", codec.TIGHT_SEARCH)
    nzc = tmp_path / "b.nzc"
    pipeline.compress_file(CORPUS / "occt__bearing.iges", nzc, tol=0.1, step_safe=False)
    c = container.unpack(nzc.read_bytes())
    assert c.revision >= 2
    now, _ = decode.sections_to_model(c.get, c.revision)
    old, meta, t = serialize.read_sections(c.get, c.revision)  # the tables as written,
    decode.apply(old, t, serialize.tolerance(meta), 1)  # decoded by the 1.1 rules
    assert differences(now, old), "the two rules gave the same nets: the test proves nothing"
    src, _ = occ.shape_to_model(occ.read_cad(CORPUS / "occt__bearing.iges").shape)
    assert pipeline.max_net_displacement(src, now) <= 0.1


def test_close_pairs_finds_what_the_tree_finds() -> None:
    """nearby.close_pairs: every pair cKDTree.query_pairs finds, sorted, and
    nothing beyond r but by the slack; None where points pile up."""
    from scipy.spatial import cKDTree

    rng = np.random.default_rng(7)
    for n, d, r in [(0, 3, 1.0), (1, 3, 1.0), (500, 3, 0.05), (400, 6, 0.05), (300, 3, 0.0)]:
        pts = rng.random((n, d))
        if n > 100:  # exact duplicates and points a hair apart
            pts[::50] = pts[1::50]
            pts[2::50] = pts[3::50] + r * (1 - 1e-12)
        got = nearby.close_pairs(pts, r)
        assert got is not None
        want = cKDTree(pts).query_pairs(r) if n else set()
        assert got.tolist() == sorted(map(list, {tuple(p) for p in got.tolist()}))
        assert want <= {tuple(p) for p in got.tolist()}
        for i, j in got.tolist():
            assert np.sqrt(((pts[i] - pts[j]) ** 2).sum()) <= r * (1 + 1e-8)
    # points in one place: swept while few (every pair), a tree's job beyond
    assert len(nearby.close_pairs(np.zeros((300, 3)), 1.0)) == 300 * 299 // 2
    assert nearby.close_pairs(np.zeros((nearby._SWEEP_RUN + 2, 3)), 1.0) is None
    assert nearby.close_pairs(np.array([[0.0, 0, 0], [np.nan, 0, 0]]), 1.0) is None


def test_pairs_components_and_nearest_match_scipy() -> None:
    """nearby.within + coincide.first_of_components give scipy's connected components
    (each labelled by its first point), and coincide.nearest cKDTree's nearest
    points (of duplicates, the first), on random clouds with duplicates and chains."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    rng = np.random.default_rng(11)
    for n, r in [(2, 0.5), (200, 0.04), (600, 0.03), (50, 0.0)]:
        pts = rng.random((n, 3))
        dup = pts[1::7].copy()  # exact duplicates
        pts[: 7 * len(dup) : 7] = dup
        pairs = cKDTree(pts).query_pairs(r, output_type="ndarray")
        graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
        _, label = connected_components(graph, directed=False)
        first = np.full(label.max() + 1, n)
        np.minimum.at(first, label, np.arange(n))
        got = nearby.close_pairs(pts, r)
        assert got is not None
        assert nearby.within(pts, got, r).tolist() == sorted(pairs.tolist())
        assert coincide.vertex_clusters(pts, r).tolist() == first[label].tolist()
        queries = rng.random((97, 3))
        d, i = coincide.nearest(pts, queries)
        dt, it = cKDTree(pts).query(queries)
        assert np.allclose(d, dt, rtol=1e-12, atol=0)
        assert (pts[i] == pts[it]).all() and (i <= it).all()  # ties: the first of equals
    # a large cloud goes to the tree: the same distances
    big, queries = rng.random((3000, 3)), rng.random((2000, 3))
    assert len(big) * len(queries) > coincide._NEAREST_MAX
    d, i = coincide.nearest(big, queries)
    assert np.array_equal(i, cKDTree(big).query(queries)[1])


def test_bspline_points_match_scipy() -> None:
    """joins' point-by-point comparison evaluates B-splines with
    nurbscomp.bspline (no scipy.interpolate import): the same points as scipy's
    BSpline(extrapolate=False), NaN where it gives NaN, on random clamped,
    unclamped and multiple-knot splines."""
    from scipy.interpolate import BSpline

    from nurbscomp import bspline

    rng = np.random.default_rng(1)
    for _ in range(300):
        p = int(rng.integers(1, 9))
        n = int(rng.integers(p + 1, p + 15))
        inner = np.sort(rng.random(n - p - 1))
        if len(inner) > 1 and rng.random() < 0.3:
            inner[1] = inner[0]
        t = np.r_[[0.0] * (p + 1), inner, [1.0] * (p + 1)]
        if rng.random() < 0.2:
            t = np.sort(rng.random(n + p + 1))
            t = (t - t[p]) / (t[n] - t[p])
        c = rng.normal(size=(n, 4))
        x = np.r_[np.linspace(-0.1, 1.1, 4 * n + 8), t]
        want = BSpline(t, c, p, extrapolate=False)(x)
        got = bspline.points(t, c, p, x)
        assert (np.isnan(want) == np.isnan(got)).all()
        ok = ~np.isnan(want)
        assert np.allclose(got[ok], want[ok], rtol=0, atol=1e-12)


def _thick_loft() -> object:
    """A lofted solid through periodic spline sections, its top face removed and
    the rest thickened inwards (``BRepOffsetAPI_MakeThickSolid``): its top ring
    face is bounded by curves cut elsewhere than its side faces' boundaries."""
    import cadquery as cq
    from OCP.BRepOffsetAPI import BRepOffsetAPI_MakeThickSolid
    from OCP.TopTools import TopTools_ListOfShape

    rng = np.random.default_rng(1)
    wires = []
    for i in range(5):
        pts = [
            cq.Vector(
                np.cos(a) * (5 + rng.uniform(-1, 1)), np.sin(a) * (4 + rng.uniform(-1, 1)), 3 * i
            )
            for a in np.linspace(0, 2 * np.pi, 9)[:-1]
        ]
        wires.append(cq.Wire.assembleEdges([cq.Edge.makeSpline(pts, periodic=True)]))
    loft = cq.Solid.makeLoft(wires, False)
    top = TopTools_ListOfShape()
    top.Append(max(loft.Faces(), key=lambda f: f.Center().z).wrapped)
    thick = BRepOffsetAPI_MakeThickSolid()
    thick.MakeThickSolidByJoin(loft.wrapped, top, -0.5, 1e-3)
    thick.Build()
    return thick.Shape()


@pytest.mark.slow
def test_edges_that_meet_in_part_keep_meeting(tmp_path: Path, one_coding: None) -> None:
    """Faces-mode IGES (written at 1e-5) of a thick loft: its faces meet along
    edges cut at different points, or apart by up to their 1e-5 tolerances;
    the sewing of the free-edge measure joins them (``occ.sewn_edge_pairs``),
    point-wise coincidence does not.  Coded apart they opened 40 new free
    edges at 0.01 mm; their curves stay exact now."""
    from tests.stress.files import write_iges

    src = tmp_path / "thick.igs"
    write_iges(_thick_loft(), src, 0)
    source = occ.read_cad(src).shape
    pairs = occ.sewn_edge_pairs(source)
    m, _ = occ.shape_to_model(source)
    points = occ.edge_points(source, list(range(len(m.edge_tol))))
    whole = set(coincide.coincident_edges(points, 1e-6))
    assert len(set(pairs) - whole) > 20  # meeting in part: only the sewing sees them
    nzc = tmp_path / "thick.nzc"
    pipeline.compress_file(src, nzc, tol=0.01)
    shape = pipeline.decode_file(nzc)[0]
    assert occ.free_edges_sewn(shape) <= occ.free_edges_sewn(source)


def test_free_edges_count_faces_in_no_shell_beside_a_solid() -> None:
    """``occ.free_edges`` (what ``eval`` reports) counts a loose face's edges
    whether or not a solid sits beside it: a box and a loose square face
    have the square's 4, as the same face wrapped in a shell of its own
    (OCCT's STEP writer does that) has."""
    from OCP.BRep import BRep_Builder
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeFace
    from OCP.BRepPrimAPI import BRepPrimAPI_MakeBox
    from OCP.gp import gp_Pln
    from OCP.TopoDS import TopoDS_Compound, TopoDS_Shell

    box = BRepPrimAPI_MakeBox(1.0, 1.0, 1.0).Shape()
    face = BRepBuilderAPI_MakeFace(gp_Pln(), 5.0, 6.0, 5.0, 6.0).Face()
    b = BRep_Builder()
    loose, shelled, shell = TopoDS_Compound(), TopoDS_Compound(), TopoDS_Shell()
    b.MakeShell(shell)
    b.Add(shell, face)
    for c, part in ((loose, face), (shelled, shell)):
        b.MakeCompound(c)
        b.Add(c, box)
        b.Add(c, part)
    assert occ.free_edges(box) == 0
    assert occ.free_edges(loose) == occ.free_edges(shelled) == 4


@pytest.mark.slow
def test_surface_nets_anchored_at_their_face_vertices(tmp_path: Path) -> None:
    """Format 2.1: a SNET net's first pole is coded against a vertex of its
    face where that is cheaper (anchor k > 0); the container decodes within
    tol, and an anchor past the face's vertices is refused by name."""
    from .conftest import SAMPLES

    src, dst = SAMPLES / "blob.step", tmp_path / "blob.nzc"
    pipeline.compress_file(src, dst, tol=0.01, force=True)  # verified: within tol
    c = container.unpack(dst.read_bytes())
    assert c.revision == container.REVISION >= 4
    m, _, t = serialize.read_sections(c.get, c.revision, None)
    assert t.snet.anchor is not None and (t.snet.anchor > 0).sum() > len(t.snet.anchor) // 2
    rows = serialize.coded_rows(m.surfaces)
    cands = joins.surface_anchor_candidates(m, rows)
    at, corners = decode._surface_anchors(m, t.snet, rows)
    for k, row in enumerate(rows):
        a = int(t.snet.anchor[k])
        if a:
            assert np.array_equal(at[row], m.vertex_point[cands[row][a - 1]])
        else:
            assert row not in at
    # format 2.10: corners coded against vertices of the same candidates
    assert t.snet.corners is not None and (t.snet.corners > 0).sum() > len(rows)
    for k, row in enumerate(rows):
        for c, a in enumerate(t.snet.corners[k].tolist(), 1):
            if a:
                assert np.array_equal(corners[row][c], m.vertex_point[cands[row][a - 1]])
            else:
                assert c not in corners.get(row, {})
    bad = replace(t.snet, corners=t.snet.corners.copy())
    k = int(np.flatnonzero(bad.corners[:, 2] > 0)[0])
    bad.corners[k, 2] = len(cands[rows[k]]) + 1
    with pytest.raises(SectionError, match=f"net {k} .* no anchor vertex"):
        decode._surface_anchors(m, bad, rows)
    bad = replace(t.snet, anchor=t.snet.anchor.copy())
    k = int(np.flatnonzero(bad.anchor > 0)[0])
    bad.anchor[k] = len(cands[rows[k]]) + 1
    with pytest.raises(SectionError, match=f"net {k} .* no anchor vertex"):
        decode._surface_anchors(m, bad, rows)
    bad.anchor[k] = -1
    with pytest.raises(SectionError, match="no anchor vertex"):
        decode._surface_anchors(m, bad, rows)


def test_twin_of_a_side_with_knots_removed(tmp_path: Path) -> None:
    """A curve whose twin leads it and is a coded surface's side, that side's
    knots removed with the surface's (fewer poles): the copy takes the
    leader's knots and multiplicities.  It took the leader's poles with its
    own multiplicities, and the bound's knot refinement failed (an
    ``IndexError``, exit 70) on a swept square's IGES surface model."""
    import cadquery as cq

    path = cq.Workplane("XZ").spline([(0, 0), (10, 10), (20, 5), (30, 20)])
    swept = cq.Workplane("XY").rect(4, 4).sweep(path, transition="round")
    step = tmp_path / "sweep.step"
    cq.exporters.export(swept, str(step))
    src = _faces_iges(step, tmp_path / "sweep.igs")
    nzc = tmp_path / "sweep.nzc"
    report = pipeline.compress_file(src, nzc, tol=0.01)  # verify: decodes, within tol
    c = container.unpack(nzc.read_bytes())
    m, _ = decode.sections_to_model(c.get, c.revision)
    crv = [g for g in m.curves3d if isinstance(g, BSplineCurve)]
    # every B-spline row holds as many poles as its knots say
    assert all(len(g.poles) == int(g.mults.sum()) - g.degree - 1 for g in crv)
    got = pipeline.evaluate(src, nzc)
    assert got["within_tolerance"] and got["topology_same"], got
    assert report["verified"] and report["output_bytes"] < src.stat().st_size / 20


def _ends_by_walk(m, e_shape: int, tidx: np.ndarray) -> dict[int, int]:
    """The reference: an edge shape's first FORWARD and first REVERSED direct
    vertex children of location 0, walked one reference at a time."""
    out: dict[int, int] = {}
    for k in range(m.child_start[e_shape], m.child_start[e_shape + 1]):
        v, o = int(m.child_shape[k]), int(m.child_orient[k])
        if not 0 <= v < len(m.shape_type):
            continue
        if m.shape_type[v] == ShapeType.VERTEX and m.child_loc[k] == 0 and o in (0, 1):
            out.setdefault(o, int(tidx[v]))
    return out


@pytest.mark.parametrize("sample", ["assembly.step", "bracket.step", "loft.step", "rings.step"])
def test_end_vertices_match_a_walk_per_edge(sample: str) -> None:
    """``joins.end_vertices`` (one vectorised pass) gives each edge the ends a
    walk of its child list gives, also where the table is damaged: a
    reference out of the table, a vertex placed by a location, one edge's
    vertices reversed."""
    m, _ = occ.shape_to_model(occ.read_cad(SAMPLES / sample).shape)
    edges = np.flatnonzero(m.shape_type == ShapeType.EDGE)
    assert len(edges) >= 3
    hurt = replace(
        m,
        child_shape=m.child_shape.copy(),
        child_loc=m.child_loc.copy(),
        child_orient=m.child_orient.copy(),
    )
    k0 = int(m.child_start[edges[0]])
    hurt.child_shape[k0] = len(m.shape_type) + 5  # out of the table
    k1 = int(m.child_start[edges[1]])
    hurt.child_loc[k1] = 1  # placed: not an end
    k2 = int(m.child_start[edges[2]])
    hurt.child_orient[k2 : k2 + 2] = hurt.child_orient[k2 : k2 + 2][::-1]
    for model in (m, hurt):
        table = joins.end_vertices(model)
        tidx = model.type_index()
        assert table.shape == (len(edges), 2)
        for e, s in enumerate(edges.tolist()):
            assert joins.edge_ends(table, e) == _ends_by_walk(model, s, tidx), (sample, e)
    assert joins.edge_ends(joins.end_vertices(hurt), 0) != joins.edge_ends(joins.end_vertices(m), 0)
