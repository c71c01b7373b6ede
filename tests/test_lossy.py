"""Tolerance mode: every face within tol (measured independently), topology and validity kept."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

from nurbscomp import occ, pipeline
from nurbscomp.encode import assembly, nets, pcurves, validity
from nurbscomp.occ import xcaf

from .conftest import (
    CORPUS,
    SAMPLES,
    assert_step_keeps_floor,
    corpus_files,
    corpus_params,
    sample_files,
)


def _check(path: Path, tmp_path: Path, tol: float, step: bool = False, **kw) -> dict:
    nzc = tmp_path / "x.nzc"
    rep = pipeline.compress_file(path, nzc, tol=tol, **kw)
    _check_container(path, tmp_path, nzc, rep, tol, step)
    return rep


def _check_container(
    path: Path, tmp_path: Path, nzc: Path, rep: dict, tol: float, step: bool = False
) -> None:
    """``nzc``, compressed from ``path`` at ``tol`` with report ``rep``:
    verified within tol, decoded with the source's counts, within tol of it
    at sampled points, valid where it is, and (``step``) its STEP re-read
    keeping what OCCT's own round trip keeps."""
    cad = occ.read_cad(path)
    assert rep["verified"] and rep["max_bound_mm"] <= tol
    shape, _, meta = pipeline.decode_file(nzc)
    # a part whose remedies reach a quarter of its faces is coded tighter (stages.compress)
    assert meta["tolerance_mm"] == rep["coded_tolerance_mm"] <= tol
    assert occ.counts(shape) == occ.counts(cad.shape)
    dev = occ.deviation(cad.shape, shape, n=5, tol=tol)
    assert dev.max() <= tol, f"face {dev.argmax()} deviates {dev.max()} > {tol}"
    if occ.is_valid(cad.shape):
        assert occ.is_valid(shape)
    if step:
        assert_step_keeps_floor(cad, nzc, tmp_path)


@pytest.mark.slow
@pytest.mark.parametrize("path", sample_files(), ids=lambda p: p.name)
@pytest.mark.parametrize("tol", [0.001, 0.1])
def test_samples_within_tol(path: Path, tmp_path: Path, tol: float, made) -> None:
    nzc = made(path, tol)  # the run's container, its report beside it
    rep = json.loads(nzc.with_suffix(".json").read_text())
    _check_container(path, tmp_path, nzc, rep, tol)
    if path.name in ("teapot.step", "blob.step"):
        # freeform models: (nearly) every face coded, far smaller than the text
        assert rep["faces_by_method"].get("exact", 0) <= len(rep["face_method_list"]) // 4
        assert rep["output_bytes"] < path.stat().st_size / 10


def _read_brep(path: Path):
    from OCP.BRep import BRep_Builder
    from OCP.BRepTools import BRepTools
    from OCP.TopoDS import TopoDS_Shape

    shape = TopoDS_Shape()
    assert BRepTools.Read_s(shape, str(path), BRep_Builder())
    return shape


#: Containers of corpus files made with the defaults, by (file name, tol),
#: shared by the slow tests so that each is made once per session.
def _no_new_gaps(path: Path, tmp_path: Path, nzc: Path) -> None:
    """The decoded shape of ``nzc`` (as a .brep file holds it, no STEP reader
    mending it) has no more free edges sewn at 1e-7 than the source."""
    brep = tmp_path / "x.brep"
    pipeline.decompress_file(nzc, brep, force=True)
    back = _read_brep(brep)
    assert occ.free_edges_sewn(back) <= occ.free_edges_sewn(occ.read_cad(path).shape)


@pytest.mark.slow
@pytest.mark.corpus
def test_bearing_step_keeps_free_edges(tmp_path: Path, made) -> None:
    """bearing.iges at 0.01 mm decompressed to STEP read back with 39 free
    edges (sewn at 1e-7) where OCCT's own IGES -> STEP -> read has 34 and the
    source 29: the STEP check compared topology counts only, and those were
    the floor's.  Now free edges are held to the floor's too (30)."""
    path = CORPUS / "occt__bearing.iges"
    cad = occ.read_cad(path, product=True)
    nzc = made(path, 0.01)
    back = assert_step_keeps_floor(cad, nzc, tmp_path)
    assert occ.free_edges_sewn(back) <= 34


def test_step_losses_blames_new_free_edges() -> None:
    """A face whose re-read version has more free edges than the source's
    and the floor's is blamed; one at the floor's count, or below the
    source's, is not; without the free-edge counts none is."""
    sig = np.array([[1.0, x, 0.0, 0.0, 4, 4, 4] for x in range(4)])
    src, floor, back = (np.array(c) for c in ([0, 1, 0, 2], [0, 2, 0, 2], [1, 2, 0, 1]))
    assert validity.step_losses(sig, sig, sig, 0.01) == set()
    assert validity.step_losses(sig, sig, sig, 0.01, free=(src, floor, back)) == {0}
    # the re-read's faces in another order: paired by centroid
    turn = [3, 2, 1, 0]
    assert validity.step_losses(sig, sig, sig[turn], 0.01, free=(src, floor, back[turn])) == {0}


def test_step_keeps_counts_between_the_source_and_the_floor() -> None:
    """A re-read keeps what OCCT's round trip keeps when each count lies
    between the source's and the floor's; as far from the source on the
    other side is a change neither made."""
    src, floor = {"edges": 81, "faces": 37}, {"edges": 79, "faces": 37}
    assert validity.step_keeps(src, floor, {"edges": 80, "faces": 37})
    assert validity.step_keeps(src, floor, floor) and validity.step_keeps(src, floor, src)
    assert not validity.step_keeps(src, floor, {"edges": 83, "faces": 37})
    assert not validity.step_keeps(src, floor, {"edges": 81, "faces": 38})


@pytest.mark.slow
def test_blended_part_keeps_what_occts_round_trip_keeps(tmp_path: Path) -> None:
    """A part with many small fillets and blends (tests.stress.assemblies.blended,
    seed 6): 81 edges, 79 after OCCT's own round trip.  At 0.01 mm its
    decompressed STEP read back with 83 and passed, as close to the source
    as the floor on the other side; now 79 (28,627 bytes, was 27,883)."""
    from .stress import assemblies

    src = tmp_path / "blended.step"
    assemblies.blended(src, 6)
    cad = occ.read_cad(src, product=True)
    nzc = tmp_path / "x.nzc"
    pipeline.compress_file(src, nzc, tol=0.01)
    back = assert_step_keeps_floor(cad, nzc, tmp_path)
    assert occ.counts(back)["edges"] in (79, 80, 81)


def test_a_blame_of_spent_and_fresh_faces_climbs_the_fresh_ones() -> None:
    """A round that blames a face whose rungs are all spent together with
    one that has rungs left climbs the latter only (the spent one used to
    climb past the last rung: "6 is not a valid Rung", and compress died)."""
    cad = occ.read_cad(next(p for p in sample_files() if p.name == "bracket.step"))
    m, _ = occ.shape_to_model(cad.shape)
    plan = validity._Plan(m, 0.01, cad.shape)
    plan.gridded = frozenset()  # no analytic record on a grid: the rungs themselves
    plan.rung[0] = validity.Rung.PCURVES
    plan.step({0, 1})
    assert plan.rung[0] == validity.Rung.PCURVES and plan.rung[1] == validity.Rung.STILL
    plan.step({0})  # spent alone: its neighbours climb
    assert plan.rung[0] == validity.Rung.PCURVES and len(plan.rung) > 2


def test_a_plan_stops_when_the_same_faces_are_lost_past_their_neighbours(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """At the ``STALLED``-th round whose lost faces, all at their last rung,
    pass the blame to their neighbours, the plan's rounds stop (a lofted,
    filleted solid made 27 rounds at 0.01 mm, 13 of them so, and passed at
    once with the pole bound; now 16 rounds, the same bytes).  Faces that
    climb their rungs do not count."""
    cad = occ.read_cad(next(p for p in sample_files() if p.name == "bracket.step"))
    m, _ = occ.shape_to_model(cad.shape)

    def rounds(lost: list[set[int]]) -> int:
        plan = validity._Plan(m, 0.01, cad.shape)
        monkeypatch.setattr(plan, "ungrid", lambda *a: False)  # the rungs themselves
        plan.rung[0] = plan.rung[1] = validity.Rung.PCURVES
        script = iter(lost)
        monkeypatch.setattr(validity, "build", lambda *a, **k: None)
        monkeypatch.setattr(
            validity, "_check_candidate", lambda *a: (set(), set(), next(script), None)
        )
        vr = validity.ValidityReport()
        assert validity._rounds(plan, (set(), set()), None, vr, None, None) is None
        return vr.rounds

    assert validity.STALLED == 2
    assert rounds([{0}, {0}, {0}]) == 2  # twice past its neighbours: stop
    assert rounds([{0}, {2}, {1}, {0}]) == 3  # face 2 climbs in between: not counted
    assert rounds([{2}] * 8) == 7  # five rounds up face 2's rungs, then twice past them
    plan = validity._Plan(m, 0.01, cad.shape)
    plan.gridded = frozenset()
    assert plan.step({2}) is None  # a face with rungs left climbs: nothing passed on
    plan.rung[2] = validity.Rung.PCURVES
    assert plan.step({2}) == frozenset({2})


def test_a_fault_first_leaves_its_gridded_records_exact() -> None:
    """The first rung for a blamed face is to take the analytic records of
    the face and its edges off their grids; the rungs come after."""
    cad = occ.read_cad(next(p for p in sample_files() if p.name == "bracket.step"))
    m, _ = occ.shape_to_model(cad.shape)
    plan = validity._Plan(m, 0.01, cad.shape)
    plan.grid = True
    plan.candidate()
    f = next(
        f for f, r in enumerate(plan.faces_rec) if r in plan.gridded and r not in plan.through_s
    )
    plan.step({f})
    assert plan.faces_rec[f] in plan.exact and plan.reason[plan.faces_rec[f]] == "grid-step"
    assert f not in plan.rung
    _, _, report = plan.candidate()
    assert plan.faces_rec[f] not in report.gridded
    plan.step({f})  # nothing left on a grid there: the first rung
    assert plan.rung[f] == validity.Rung.STILL


def test_a_fault_first_takes_a_surface_off_its_vertex() -> None:
    """A plane or cylinder through a vertex (format 2.7) on a blamed face
    first goes back to its own origin, straightened still, not exact."""
    cad = occ.read_cad(next(p for p in sample_files() if p.name == "bracket.step"))
    m, _ = occ.shape_to_model(cad.shape)
    plan = validity._Plan(m, 0.01, cad.shape)
    plan.candidate()
    f = next(f for f, r in enumerate(plan.faces_rec) if r in plan.through_s)
    r = plan.faces_rec[f]
    plan.step({f})
    assert r in plan.plain_s and r not in plan.exact and f not in plan.rung
    cand, _, report = plan.candidate()
    assert r not in report.through_s and not cand.surfaces[r.row].through
    plan.step({f})  # then it is left exact, as a record on a grid is
    assert r in plan.exact or f in plan.rung


def test_the_floor_is_written_as_decompress_writes(monkeypatch: pytest.MonkeyPatch) -> None:
    """OCCT's own round trip of the source (the floor) is written with the
    source's product data, as the candidates and decompress write theirs:
    written plainly, a compound part's solids each get an uncertainty of
    their own (one per part through XDE), so OCCT's reader mends them at
    other precisions than in the file decompress writes."""
    made: list[tuple[object, object]] = []
    trip = validity._Floor.trip

    def record(self, shape, stack, product=None, nice=0):  # type: ignore[no-untyped-def]
        made.append((shape, product))
        return trip(self, shape, stack, product, nice)

    monkeypatch.setattr(validity._Floor, "trip", record)
    path = SAMPLES / "assembly.step"
    cad = occ.read_cad(path, product=True)
    m, _ = occ.shape_to_model(cad.shape)
    m.product = cad.product
    floor = validity._Floor(cad.shape, m.unit, validity.ValidityReport(), m.product)
    try:
        assert floor.floor_counts == occ.counts(cad.shape)
    finally:
        floor.close()
    assert made == [(cad.shape, cad.product)]


def _reversed_face(shape, k: int):  # type: ignore[no-untyped-def]
    """``shape``'s faces in one solid, face ``k`` turned the wrong way round."""
    from OCP.BRep import BRep_Builder
    from OCP.TopoDS import TopoDS_Shell, TopoDS_Solid

    b, shell, solid = BRep_Builder(), TopoDS_Shell(), TopoDS_Solid()
    b.MakeShell(shell)
    for i, f in enumerate(occ.faces(shape)):
        b.Add(shell, f.Reversed() if i == k else f)
    b.MakeSolid(solid)
    b.Add(solid, shell)
    return solid


def test_an_invalid_re_read_fails_the_step_check_with_no_faulty_face() -> None:
    """A re-read that BRepCheck rejects only as a solid (a face the wrong way
    round in its shell: no face, edge or shell carries the fault) has the
    source's counts, and passed the STEP check where the floor was valid;
    it now blames the faces along the edges the turned face shares."""
    import cadquery as cq

    box = cq.Workplane().box(10, 10, 10).edges("|Z").fillet(1).val().wrapped
    bad = _reversed_face(box, 3)
    assert occ.counts(bad) == occ.counts(box) and not occ.is_valid(bad)
    assert occ.failures(bad) == (set(), set())
    assert occ.faulty_faces(bad) == {0, 1, 3, 4, 6}

    class Back:
        def __init__(self, shape) -> None:  # type: ignore[no-untyped-def]
            self.shape = shape

        def ask(self, fn):  # type: ignore[no-untyped-def]
            return fn(self.shape)

    floor = validity._Floor(box, "MM", validity.ValidityReport())
    floor.__dict__.update(floor_counts=occ.counts(box), floor_valid=True, floor_free=0)
    floor._signatures["floor"] = occ.face_signatures(box)
    assert floor.losses(Back(box), 0.01) is None  # type: ignore[arg-type]
    lost = floor.losses(Back(bad), 0.01)  # type: ignore[arg-type]
    assert lost is not None and int(floor.model_face[3]) in lost
    floor.close()


@pytest.mark.corpus
@pytest.mark.slow
@pytest.mark.long
def test_multibody_assembly_keeps_what_occts_round_trip_keeps(tmp_path: Path) -> None:
    """An assembly written by OCCT's XDE writer whose one part is a compound
    of trj7's solid and sixty small filleted boxes, placed twice.  OCCT's own
    round trip (XDE, one uncertainty for the part, 0.2 mm) keeps the source's
    9,122 edges; the same source written plainly (one uncertainty per solid:
    1 mm for trj7's) reads back with 9,126.  The STEP check held candidates
    to the plain round trip, so a container whose STEP read back with 9,124
    edges passed (68,696 bytes at 0.01 mm); it is held to OCCT's own now."""
    from .stress import assemblies

    src = tmp_path / "multibody.step"
    assemblies.multibody(src, CORPUS / "occt__trj7_b1-ec-214.stp", boxes=60)
    cad = occ.read_cad(src, product=True)
    own = tmp_path / "own.step"
    xcaf.round_trip(src, own)
    floor = occ.counts(occ.read_cad(own, own=True).shape)
    nzc, out = tmp_path / "x.nzc", tmp_path / "out.step"
    pipeline.compress_file(src, nzc, tol=0.01)
    pipeline.decompress_file(nzc, out)
    got = occ.counts(occ.read_cad(out, own=True).shape)
    src_counts = occ.counts(cad.shape)
    assert validity.step_keeps(src_counts, floor, got), (src_counts, floor, got)


@pytest.mark.slow
@pytest.mark.parametrize("path", corpus_params(), ids=lambda p: p.name)
def test_corpus_within_tol(path: Path, tmp_path: Path, made) -> None:
    nzc = made(path, 0.01)  # made once for the run, with its report beside it
    rep = json.loads(nzc.with_suffix(".json").read_text())
    _check_container(path, tmp_path, nzc, rep, 0.01, step=True)
    _no_new_gaps(path, tmp_path, nzc)


#: The corpus's three slowest files at 0.001 and 0.1 mm (10 to 23 s each on
#: 2 cores): left to ``make stress`` (long), their 0.01 mm gaps checked by
#: ``test_corpus_within_tol``, so that ``make test`` stays under 10 minutes.
LONG_GAPS = ("NIST_MBE_PMI_2", "trj7_b1", "bearing")


@pytest.mark.slow
@pytest.mark.parametrize(
    "path, tol",
    [
        pytest.param(
            p,
            t,
            marks=[pytest.mark.long] if any(n in p.name for n in LONG_GAPS) else [],
            id=f"{t}-{p.name}",
        )
        for t in (0.001, 0.1)
        for p in corpus_files()
    ],
)
def test_corpus_no_new_gaps(path: Path, tmp_path: Path, tol: float, made) -> None:
    _no_new_gaps(path, tmp_path, made(path, tol))


#: Files known to grow with tol (strict xfails: the day one stops growing,
#: this test says so).  bearing.iges (issue 26's fidelity fix against issue
#: 10's promise) grew 17,894 / 17,938 / 18,020 bytes at 0.001 / 0.01 / 0.1 mm;
#: at the 2.0 branch point of issue 28 round 2 it no longer does (17,287 /
#: 17,286 / 17,266: by one byte between 0.001 and 0.01 mm), and vertices
#: beside copied curves do not snap so as to keep it so.  Format 2.5 (its
#: twins as offsets, the other vertices off the grids rounded to
#: MICRO_BITS) took it from 14,092 / 13,985 / 13,964 to 11,789 / 11,822 /
#: 11,603: smaller at every tol, but the validity ladder holds about twice
#: as many of its vertices at 0.01 mm as at 0.001, and a held vertex (with
#: the twins at its point) keeps all its bits.  Format 2.6: 11,591 / 11,626 /
#: 11,419.  The refined bound: 11,132 / 11,551 / 11,431.  Format 2.10 (curves
#: between their vertices): 10,962 / 10,986 / 10,352; with net corners against
#: vertices, 10,742 / 10,721 / 10,101: it no longer grows.
GROWS: dict[str, str] = {}


def _growth_cases() -> list[object]:
    """The corpus files, each known grower an xfail; the three of
    ``LONG_GAPS`` are left to ``make stress`` (long), as their gap checks
    are: their containers at 0.001 and 0.1 mm are then made by no test of
    ``make test`` (about 70 s of its 11-12 min on a slow machine, 2026-12-07;
    ``make bench`` shows their bytes at the three tolerances too)."""
    out: list[object] = []
    for p in corpus_files():
        marks = [pytest.mark.xfail(strict=True, reason=GROWS[p.name])] if p.name in GROWS else []
        if any(n in p.name for n in LONG_GAPS):
            marks.append(pytest.mark.long)
        out.append(pytest.param(p, marks=marks, id=p.name))
    return out


@pytest.mark.slow
@pytest.mark.parametrize("path", _growth_cases(), ids=lambda p: getattr(p, "name", str(p)))
def test_corpus_no_growth_with_tol(path: Path, made) -> None:
    """A larger tolerance never gives a larger container (issue 10)."""
    sizes = [made(path, tol).stat().st_size for tol in (0.001, 0.01, 0.1)]
    assert sizes == sorted(sizes, reverse=True), f"bytes at 0.001, 0.01, 0.1 mm: {sizes}"


@pytest.mark.slow
@pytest.mark.parametrize("path", sample_files(), ids=lambda p: p.name)
def test_samples_without_step_safety(path: Path, tmp_path: Path) -> None:
    rep = _check(path, tmp_path, 0.05, step_safe=False)
    assert not rep["step_safe"]


@pytest.mark.slow
def test_lossy_is_smaller_than_lossless(tmp_path: Path) -> None:
    from .conftest import SAMPLES

    p = SAMPLES / "blob.step"
    a = pipeline.compress_file(p, tmp_path / "a.nzc", lossless=True)
    b = pipeline.compress_file(p, tmp_path / "b.nzc", tol=0.01)
    assert b["output_bytes"] < a["output_bytes"]


@pytest.mark.parametrize("name", ["blob.step", "loft.step"])
def test_coded_curve_ends_meet_their_vertices(name: str, tmp_path: Path) -> None:
    """Decoded neighbours meet exactly: pinned ends sit on their vertices, bit for bit."""
    import numpy as np

    from nurbscomp import serialize
    from nurbscomp.model import BSplineCurve
    from nurbscomp.rules import joins

    from .conftest import SAMPLES

    nzc = tmp_path / "x.nzc"
    pipeline.compress_file(SAMPLES / name, nzc, tol=0.05, step_safe=False)
    m, _ = pipeline.decode(pipeline.read_container(nzc))
    cad = occ.read_cad(SAMPLES / name)
    src, _ = occ.shape_to_model(cad.shape)
    coded = {
        i
        for i, (a, b) in enumerate(zip(src.curves3d, m.curves3d))
        if isinstance(a, BSplineCurve) and not np.array_equal(a.poles, b.poles)
    }
    pins = joins.curve_end_pins(m, m.curves3d, coded | set(serialize.coded_rows(m.curves3d)), 0.05)
    assert pins, "no coded curve was pinned: the test would prove nothing"
    for c, ends in pins.items():
        for i, v in ends:
            assert (m.curves3d[c].poles[i] == m.vertex_point[v]).all()
    assert pipeline.max_net_displacement(src, m) <= 0.05


@pytest.mark.slow
@pytest.mark.parametrize("name", ["teapot.step", "blob.step"])
def test_iso_boundary_curves_are_their_surfaces_boundaries(name: str, tmp_path: Path) -> None:
    """An edge curve that is a surface's boundary comes back as the decoded boundary, bit for bit,
    and the decoded surface corners sit on the face's vertices."""
    import numpy as np

    from nurbscomp.encode import coincide
    from nurbscomp.model import BSplineCurve, BSplineSurface
    from nurbscomp.rules import joins

    from .conftest import SAMPLES

    tol = 0.05
    nzc = tmp_path / "x.nzc"
    pipeline.compress_file(SAMPLES / name, nzc, tol=tol, step_safe=False)
    m, _ = pipeline.decode(pipeline.read_container(nzc))
    src, _ = occ.shape_to_model(occ.read_cad(SAMPLES / name).shape)
    crows = {i for i, g in enumerate(src.curves3d) if isinstance(g, BSplineCurve)}
    srows = {i for i, g in enumerate(src.surfaces) if isinstance(g, BSplineSurface)}
    iso = coincide.iso_sources(src, crows, srows)
    moved = [
        c
        for c, (r, _, _, _) in iso.items()
        if not np.array_equal(m.surfaces[r].poles, src.surfaces[r].poles)
    ]
    assert moved, "no coded surface has an iso-boundary edge: the test would prove nothing"
    for c in moved:
        r, side, rev, _ = iso[c]
        assert np.array_equal(
            m.curves3d[c].poles, joins.boundary(m.surfaces[r].poles, side, bool(rev))
        )
    pins = joins.surface_corner_pins(m, m.surfaces, srows, tol)
    assert pins
    for r, corners in pins.items():
        for k, v in corners:
            assert (m.surfaces[r].poles[joins.CORNERS[k]] == m.vertex_point[v]).all()
    assert pipeline.max_net_displacement(src, m) <= tol


def test_feature_limit_holds_small_features_to_a_fraction_of_their_size() -> None:
    big = np.stack(
        [*np.meshgrid(np.arange(4.0), np.arange(3.0), indexing="ij"), np.zeros((4, 3))], -1
    )
    assert nets.feature_limit(big, 0.01) == 0.01
    tiny = big * 0.002  # rows 0.006 and 0.004 long: the shorter of the longest rows
    assert nets.feature_limit(tiny, 0.01) == pytest.approx(nets.FEATURE_FRACTION * 0.004)
    assert nets.feature_limit(tiny[:, 0], 0.01) == pytest.approx(nets.FEATURE_FRACTION * 0.006)
    assert nets.feature_limit(np.zeros((3, 3)), 0.01) == 0.01 / 1024  # a point


def test_vertices_that_would_merge_stay() -> None:
    exact = np.array([[0.0, 0, 0], [0.001, 0, 0], [5.0, 0, 0], [5.0, 0, 0], [9.0, 0, 0]])
    snapped = np.array([[0.0, 0, 0], [0.0, 0, 0], [5.0, 0, 0], [5.0, 0, 0], [9.0, 0, 0]])
    # 0 and 1 are two places landing on one point; 2 and 3 were one place already
    assert assembly._merging(exact, snapped).tolist() == [True, True, False, False, False]


def _curve_points(g, t: np.ndarray) -> np.ndarray:
    """A clamped B-spline curve record evaluated at ``t`` (scipy; rational too)."""
    from scipy.interpolate import BSpline

    w = np.ones(len(g.poles)) if g.weights is None else g.weights
    knots = np.repeat(g.knots, g.mults)
    h = BSpline(knots, np.column_stack([g.poles * w[:, None], w]), g.degree)(t)
    return h[:, :-1] / h[:, -1:]


@pytest.mark.slow
@pytest.mark.corpus
@pytest.mark.parametrize("name", ["occ22470.igs", "NIST_MBE_PMI_2.stp"])
def test_unit_curves_keep_every_edge_point_for_point(name: str) -> None:
    """Free 3-D curves go onto [0, 1]: each edge evaluates to the same points at
    its mapped range, and curves held by a stored pcurve keep their knots."""
    from nurbscomp.model import RepKind

    path = next(p for p in corpus_files() if p.name.endswith(name))
    m, _ = occ.shape_to_model(occ.read_cad(path).shape)
    keep = set(range(0, len(m.edge_tol), 2))  # every other edge keeps its pcurves
    d = pcurves.drop_pcurves(m, keep, set())
    u = pcurves.unit_curves(d)
    reps = d.edge_reps
    pc = (reps[:, 1] == RepKind.ON_SURFACE) | (reps[:, 1] == RepKind.ON_CLOSED_SURFACE)
    stored = set(reps[pc & (reps[:, 2] >= 0), 0].tolist())  # edges with a stored pcurve
    moved = held = 0
    for q in np.flatnonzero((reps[:, 1] == RepKind.CURVE3D) & (reps[:, 2] >= 0)).tolist():
        a, b = d.curves3d[reps[q, 2]], u.curves3d[reps[q, 2]]
        if a is b:
            continue
        assert int(reps[q, 0]) not in stored
        assert b.knots[0] == 0.0 and b.knots[-1] == 1.0
        moved += 1
        if a.periodic:
            continue
        t = np.linspace(*d.edge_rep_range[q], 5)
        s = np.linspace(*u.edge_rep_range[q], 5)
        scale = 1 + np.abs(a.poles).max()
        assert np.abs(_curve_points(a, t) - _curve_points(b, s)).max() <= 1e-9 * scale
    for e in stored:
        for q in np.flatnonzero((reps[:, 0] == e) & (reps[:, 1] == RepKind.CURVE3D)).tolist():
            if reps[q, 2] >= 0:
                held += 1
                assert u.curves3d[reps[q, 2]] is d.curves3d[reps[q, 2]]
    assert moved > 0 and held > 0


@pytest.mark.slow
@pytest.mark.parametrize("by_face, split", [(False, False), (False, True), (True, False)])
@pytest.mark.parametrize("name", ["teapot.step", "blob.step"])
def test_pcurve_cache_builds_the_same_shape(
    name: str, by_face: bool, split: bool, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, made
) -> None:
    """A build that reuses pcurves projected for another model (the validity
    stage's candidates) is the fresh build, bit for bit; so is one whose
    empty cache is filled by projections shared with a child (``split``).
    In 2.14's order (each projection alone, cached by edge) and in 2.15's
    (``by_face``: a face's projections carried along it, cached by face,
    never split)."""
    from OCP.BRepTools import BRepTools

    from nurbscomp.model import REBUILD, differences
    from nurbscomp.occ import topology

    handed: list[int] = []
    real_split = topology._split
    monkeypatch.setattr(topology, "_split", lambda *a: handed.append(real_split(*a)) or handed[-1])
    monkeypatch.setattr(topology, "SPLIT_PROJECTIONS", split)
    monkeypatch.setattr(topology, "SPLIT_MIN", 0)
    monkeypatch.setattr(topology, "spare_core", lambda: True)  # whatever the load

    path = next(p for p in sample_files() if p.name == name)
    models = []
    for tol in (0.001, 0.1):
        m = pipeline.decode_file(made(path, tol))[1]  # the run's containers
        assert m.pcurves_by_face  # a new container's rule
        m.pcurves_by_face = by_face
        models.append(m)
    assert all((m.edge_reps[:, 2] == REBUILD).any() for m in models)

    def text(shape) -> str:
        BRepTools.Write_s(shape, str(tmp_path / "s.brep"))
        return (tmp_path / "s.brep").read_text()

    # half the 3-D curves of one and half of the other: some pcurves cached, some not
    a, b = models
    assert len(a.curves3d) == len(b.curves3d)
    # (a face's cache entry needs every edge of the face the same: halves, not every other)
    half = len(a.curves3d) // 2
    mixed = dataclasses.replace(
        a,
        curves3d=[
            x if (i < half if by_face else i % 2) else y
            for i, (x, y) in enumerate(zip(a.curves3d, b.curves3d))
        ],
    )
    cache = occ.PcurveCache()
    misses = []
    handed.clear()  # the decodes' builds split too
    for m in (a, b, mixed, a):  # cold, cold, mixed, then every pcurve from the cache
        hits = cache.hits
        fresh, cached = occ.model_to_shape(m), occ.model_to_shape(m, cache)
        assert differences(occ.shape_to_model(cached)[0], occ.shape_to_model(fresh)[0]) == []
        assert text(cached) == text(fresh)
        misses.append(cache.misses)
    assert misses[1] < misses[2] < misses[1] + misses[0]  # the mixed model: some of each
    assert misses[3] == misses[2] and cache.hits > hits  # the last build: all from the cache
    # split: the four fresh builds, and the first cached one (its cache was empty)
    assert len(handed) == (5 if split else 0) and all(n > 0 for n in handed)


GOLDEN = Path(__file__).parent / "golden"


def _split_and_serial(name: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> list[int]:
    """Build a golden container's model serially and with its projections
    split with a child; assert the shapes are the same, bit for bit; return
    how many projections each split build took from the child."""
    from OCP.BRepTools import BRepTools

    from nurbscomp.model import differences
    from nurbscomp.occ import topology

    m, _ = pipeline.decode(pipeline.read_container(GOLDEN / name))
    handed: list[int] = []
    split = topology._split
    monkeypatch.setattr(topology, "_split", lambda *a: handed.append(split(*a)) or handed[-1])
    monkeypatch.setattr(topology, "SPLIT_MIN", 0)
    monkeypatch.setattr(topology, "spare_core", lambda: True)  # whatever the load

    def text(shape) -> str:
        BRepTools.Write_s(shape, str(tmp_path / "s.brep"))
        return (tmp_path / "s.brep").read_text()

    monkeypatch.setattr(topology, "SPLIT_PROJECTIONS", False)
    serial = occ.model_to_shape(m)
    monkeypatch.setattr(topology, "SPLIT_PROJECTIONS", True)
    for share in (0.45, 0.9):  # edges dealt out two ways
        monkeypatch.setattr(topology, "CHILD_SHARE", share)
        shape = occ.model_to_shape(m)
        assert text(shape) == text(serial)
        assert differences(occ.shape_to_model(shape)[0], occ.shape_to_model(serial)[0]) == []
    return handed


@pytest.mark.parametrize("name", ["blob.tol0.01.nzc", "teapot.faces.tol0.01.nzc"])
def test_split_projections_build_the_serial_shape(
    name: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A decode whose projections a forked child shares builds the shape a
    serial build gives, with the child's pcurves replayed."""
    handed = _split_and_serial(name, tmp_path, monkeypatch)
    assert len(handed) == 2 and 0 < handed[0] < handed[1]


def test_spare_core_rule(monkeypatch: pytest.MonkeyPatch) -> None:
    """Work is shared with a child only where another core looks idle."""
    import os

    from nurbscomp.occ import isolated

    monkeypatch.setattr(os, "sched_getaffinity", lambda pid: {0, 1}, raising=False)
    monkeypatch.setattr(isolated, "_others_running", lambda: 0)  # idle
    for load, spare in ((0.9, True), (1.5, True), (1.6, False), (2.3, False)):
        monkeypatch.setattr(os, "getloadavg", lambda load=load: (load, load, load))
        assert isolated.spare_core() is spare
    monkeypatch.setattr(isolated, "_others_running", lambda: 1)  # another process running
    assert isolated.spare_core() is False
    monkeypatch.setattr(os, "sched_getaffinity", lambda pid: {0}, raising=False)
    monkeypatch.setattr(os, "getloadavg", lambda: (0.0, 0.0, 0.0))
    monkeypatch.setattr(isolated, "_others_running", lambda: 0)
    assert isolated.spare_core() is False  # one core: nothing to share


@pytest.mark.skipif(not Path("/proc/self/task").is_dir(), reason="Linux's /proc")
def test_a_busy_process_is_seen_running() -> None:
    """A process spinning on the CPU counts among the others running; a
    niced one yields the core, and is not counted.  Each child is looked at
    by its own pid (``isolated._running``): what other processes of a
    shared machine do meanwhile cannot change the answer."""
    import os
    import subprocess
    import sys
    import time

    from nurbscomp.occ import isolated

    spin = "import time\nt = time.time()\nwhile time.time() - t < 5: pass"
    for nice, counted in ((0, True), (10, False)):
        p = subprocess.Popen([sys.executable, "-c", spin], preexec_fn=lambda n=nice: os.nice(n))
        try:
            time.sleep(0.3)
            # running, or runnable and waiting for a core: seen within a second
            seen = [isolated._running(p.pid) for _ in range(100) if not time.sleep(0.01)]
            assert (max(seen) >= 1) is counted, (nice, seen)
        finally:
            p.kill()
            p.wait()
    assert isolated._running(p.pid) == 0  # gone


def test_split_projections_survive_their_child(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """If the child dies, the parent projects its share: the same shape, none handed."""
    import os
    import signal

    from nurbscomp.occ import topology

    def dying(jobs):
        os.kill(os.getpid(), signal.SIGKILL)

    monkeypatch.setattr(topology, "_child_projections", dying)
    assert _split_and_serial("blob.tol0.01.nzc", tmp_path, monkeypatch) == [0, 0]


def test_fault_with_everything_exact_keeps_its_ranges(
    tmp_path: Path, one_coding: None, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A filleted box moved to x = 120 and written as faces-mode IGES: two
    faces on a surface of revolution keep a BRepCheck fault with their
    surface and curves exact and their pcurves stored, because
    ``pcurves.vertex_ranges`` moved their circle edges' ends (by up to 1e-3
    tol, past their 1e-7 tolerance).  The ladder's last rung keeps their
    vertices and ranges as read; without it every pcurve was stored (the
    "pcurves" fallback).  Its located faces are left as read
    (``encode.placed.bake`` off): baked, no face has the fault."""
    from OCP.BRepBuilderAPI import BRepBuilderAPI_Transform
    from OCP.gp import gp_Trsf, gp_Vec

    from nurbscomp.encode import placed
    from tests.stress.files import write_iges
    from tests.stress.shapes import entries

    entry = {e.name: e for e in entries(0)}["fillet_box_02"]
    move = gp_Trsf()
    move.SetTranslation(gp_Vec(120, 0, 0))
    src = tmp_path / "moved.igs"
    write_iges(BRepBuilderAPI_Transform(entry.build(), move, True).Shape(), src, 0)
    baked = pipeline.compress_file(src, tmp_path / "baked.nzc", tol=0.01)
    assert baked["validity"]["exact_faces"] == {} and baked["verified"]
    monkeypatch.setattr(placed, "bake", lambda m: None)
    report = pipeline.compress_file(src, tmp_path / "moved.nzc", tol=0.01)
    assert report["output_bytes"] > baked["output_bytes"]
    assert report["validity"]["fallback"] == ""
    exact = report["validity"]["exact_faces"]
    # the two faulty faces end exact: taken off their grids (their basis
    # circles: the first rung since format 2.0), or by the ladder
    assert exact.get("brepcheck", 0) + exact.get("grid-brepcheck", 0) == 2
    assert set(exact) <= {"brepcheck", "grid-brepcheck", "grid-step"}
    back = pipeline.decode_file(tmp_path / "moved.nzc")[0]
    assert occ.is_valid(back)
