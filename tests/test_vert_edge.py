"""Format 2.0 EDGE surfaces by prediction (issue 28 item 2, docs/format.md §2.7):
a representation's surface is picked among the surfaces of its edge's faces,
or escaped; 1.x files keep their layout."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from nurbscomp import container, pipeline, serialize
from nurbscomp.errors import BadReferenceError, FormatError, LimitError, SectionError
from nurbscomp.model import RepKind

from . import fuzz

GOLDEN = Path(__file__).resolve().parent / "golden"
NAMES = (
    "bracket.lossless.nzc",
    "loft.tol0.01.nzc",
    "teapot.faces.tol0.01.nzc",
    "assembly.lossless.nzc",
)


def _repacked(name: str) -> tuple[object, bytes]:
    """A golden file (1.x) decoded, and its model as a 2.0 lossless container."""
    m, meta = fuzz.decoded((GOLDEN / name).read_bytes())
    return m, fuzz.pack_model(m, meta)


def _decode(data: bytes):  # type: ignore[no-untyped-def]
    c = container.unpack(data)
    assert c.revision == container.REVISION >= 3  # 2.0 and later
    return pipeline.decode(c)[0]


@pytest.mark.parametrize("name", NAMES)
def test_picked_surfaces_round_trip(name: str) -> None:
    m, data = _repacked(name)
    back = _decode(data)
    np.testing.assert_array_equal(back.edge_reps, m.edge_reps)


def test_every_pcurve_surface_is_a_face_surface_of_its_edge() -> None:
    """On the golden models every surface of a representation is one of its
    edge's candidates: nothing is escaped, and most picks are 0."""
    for name in NAMES:
        m, _ = _repacked(name)
        cands = serialize.edge_candidates(m)
        reps = m.edge_reps
        on = reps[:, 1] != RepKind.CURVE3D
        picks = serialize._picks(reps[on, 4], reps[on, 0], cands)
        assert (picks >= 0).all(), name
        assert (picks == 0).mean() > 0.4, name


@pytest.mark.parametrize(
    ("pick", "error", "match"),
    [(7, BadReferenceError, "picks surface"), (-2, SectionError, "below -1")],
)
def test_hostile_picks_are_refused(monkeypatch, pick: int, error: type, match: str) -> None:
    m, meta = fuzz.decoded((GOLDEN / "bracket.lossless.nzc").read_bytes())
    # the picks as stored (2.11: against their predictions)
    monkeypatch.setattr(
        serialize.edges, "_unpredict", lambda p, d, e, c: np.full(len(p), pick, np.int64)
    )
    data = fuzz.pack_model(m, meta)
    with pytest.raises(error, match=match):
        _decode(data)
    assert issubclass(error, FormatError)


def test_escaped_surfaces_round_trip(monkeypatch) -> None:
    """Every surface escaped (a writer that predicts nothing) decodes the same."""
    m, meta = fuzz.decoded((GOLDEN / "loft.lossless.nzc").read_bytes())
    monkeypatch.setattr(serialize.edges, "_picks", lambda v, e, c: np.full(len(v), -1, np.int64))
    back = _decode(fuzz.pack_model(m, meta))
    np.testing.assert_array_equal(back.edge_reps, m.edge_reps)


def test_candidate_walks_are_bounded() -> None:
    m, _ = fuzz.decoded((GOLDEN / "bracket.lossless.nzc").read_bytes())
    serialize.edge_candidates(m)
    with pytest.raises(LimitError):
        serialize.edge_candidates(m, cap=3)


def test_tolerance_codes_are_exact() -> None:
    """Quarter powers (what the lossy writer widens to) are coded as integers
    and read back bit for bit; other values, 0 and 1.0 stay floats."""
    k = np.arange(-200, 40)
    tols = np.concatenate([np.exp2(k / 4), [1e-7, 0.0, 1.0, 3.3e-3, 5e-324]])
    w = serialize.BlockWriter()
    serialize._write_tolerances(w, tols)
    r = serialize.BlockReader(bytes(w), "VERT")
    back = serialize._read_tolerances(r, len(tols), "VERT")
    r.done()
    assert back.view(np.int64).tolist() == tols.view(np.int64).tolist()
    codes = serialize.BlockReader(bytes(w), "VERT").ints()
    assert (codes[: len(k)] == np.where(k == 0, 0, k)).all()


def test_widened_tolerances_are_whole_powers_of_two() -> None:
    """assembly.round_up: the smallest power of 2 at or above each value,
    bit for bit, so each is coded as a multiple of 4."""
    from nurbscomp.encode.assembly import round_up

    x = np.array([1e-7, 2.0**-23, 2.0**-23 * (1 + 2.0**-52), 3e-3, 0.75, 1.0, 1.5, 7e5])
    y = round_up(x)
    assert (y >= x).all() and (y < 2 * x).all()
    assert (np.frexp(y)[0] == 0.5).all()  # a power of two, bit for bit
    assert y[1] == x[1] and y[2] == 2.0**-22 and y[5] == 1.0 and y[6] == 2.0
    w = serialize.BlockWriter()
    serialize._write_tolerances(w, y)
    codes = serialize.BlockReader(bytes(w), "EDGE").ints()
    assert (codes % 4 == 0).all() and (codes[[0, 1, 2, 3, 6, 7]] != 0).all()  # 1.0: a float


def test_tolerance_code_out_of_range_is_refused() -> None:
    w = serialize.BlockWriter()
    w.ints([5000])
    w.floats(np.zeros(0))
    with pytest.raises(SectionError, match="tolerance code"):
        serialize._read_tolerances(serialize.BlockReader(bytes(w), "EDGE"), None, "EDGE")


@pytest.mark.parametrize("name", ["loft.tol0.01.nzc", "teapot.tol0.01.nzc"])
def test_lossy_tolerances_round_trip(name: str) -> None:
    m, data = _repacked(name)
    back = _decode(data)
    assert back.vertex_tol.view(np.int64).tolist() == m.vertex_tol.view(np.int64).tolist()
    assert back.edge_tol.view(np.int64).tolist() == m.edge_tol.view(np.int64).tolist()


# ------------------------------------------------- round 2: vertices beside exact curves


def test_short_coordinates_are_cheap() -> None:
    """Vertices beside exact curves whose coordinates are short floats stay floats."""
    from nurbscomp.encode import assembly

    p = np.array(
        [
            [25.0, 31.75, -8.0],  # short
            [0.1, 0.25, 0.5],  # 0.1 is not
            [0.0, -1024.5, 3.0],
            [np.pi, 1.0, 2.0],
        ]
    )
    assert assembly._short(p).tolist() == [True, False, True, False]


def test_a_brepcheck_fault_at_loose_vertices_keeps_them_first() -> None:
    """A face that faults around vertices snapped beside an exact curve gets
    those vertices back (and nothing else: no tighter code, no pcurves);
    another face climbs the usual ladder."""
    from types import SimpleNamespace

    from nurbscomp.encode import validity

    plan = SimpleNamespace(
        verts_of=[[0, 1], [2, 3]],
        faces_of=[[0], [1]],
        loose_v=frozenset({1, 3}),
        still_v=set(),
        tight_f=set(),
        keep_e=set(),
        keep_f=set(),
        tightened_calls=[],
    )
    plan.with_leaders = lambda recs: recs
    plan.faces_rec = ["s0", "s1"]
    plan.edges_rec = ["c0", "c1"]
    plan.edges_of = [[0], [1]]
    plan.edge_recs = lambda f: [plan.edges_rec[e] for e in plan.edges_of[f]]
    plan.coded, plan.m = None, None
    plan.whole = lambda edges: False  # no pcurve re-approximated here
    plan.ungrid = lambda faces, why: False  # no analytic record on a grid here
    plan.ease = lambda faces: set()  # no SPATIAL2 net here
    calls: list[list[str]] = []
    orig = validity.nets.tighten
    validity.nets.tighten = lambda coded, m, recs, level: calls.append(sorted(recs))
    try:
        validity._Plan.brepcheck(plan, set(), {0})  # type: ignore[arg-type]
        assert plan.still_v == {1} and not calls and not plan.keep_f
        plan.loose_v = frozenset()  # the next candidate: vertex 1 stays, face 0 faults again
        validity._Plan.brepcheck(plan, set(), {0})  # type: ignore[arg-type]
        assert calls == [["c0", "s0"]]
    finally:
        validity.nets.tighten = orig


def test_vertices_beside_exact_lines_and_circles_snap(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A filleted box (planes, cylinders, lines, circles: every curve exact)
    turned and moved to coordinates that are neither short floats nor
    repeats: its vertices go to the grid, their tolerances cover the move,
    the ranges of their lines and circles still follow them, and the part
    stays valid and within tol."""
    from OCP.BRepBuilderAPI import BRepBuilderAPI_Transform
    from OCP.gp import gp_Ax1, gp_Dir, gp_Pnt, gp_Trsf, gp_Vec

    from nurbscomp import occ
    from nurbscomp.encode import assembly
    from tests.stress.files import write_step
    from tests.stress.shapes import entries

    monkeypatch.setattr(assembly, "MIN_LOOSE", 0)
    entry = {e.name: e for e in entries(0)}["fillet_box_02"]
    move, turn = gp_Trsf(), gp_Trsf()
    move.SetTranslation(gp_Vec(0.123456789, 0.2718281828, 0.31415926))
    turn.SetRotation(gp_Ax1(gp_Pnt(0, 0, 0), gp_Dir(1, 2, 3)), 0.3)  # no coordinate repeats
    move.Multiply(turn)
    src = tmp_path / "moved.step"
    write_step(BRepBuilderAPI_Transform(entry.build(), move, True).Shape(), src, "moved")
    tol = 0.01
    report = pipeline.compress_file(src, tmp_path / "moved.nzc", tol=tol)
    assert report["verified"] and report["validity"]["fallback"] == ""
    c = container.unpack((tmp_path / "moved.nzc").read_bytes())
    kind = serialize.BlockReader(c.get("VERT"), "VERT").ints()
    assert (kind == 1).mean() > 0.5
    m = pipeline.decode(c)[0]
    src_m, _ = occ.shape_to_model(occ.read_cad(src).shape)
    moved = np.sqrt(((m.vertex_point - src_m.vertex_point) ** 2).sum(-1))
    assert moved.max() <= tol / 2
    assert (m.vertex_tol[moved > 0] >= moved[moved > 0]).all()
    from nurbscomp.rules import ranges

    assert (ranges.range_kinds(m) == serialize.RANGE_VERTICES).any()
    shape = pipeline.decode_file(tmp_path / "moved.nzc")[0]
    assert occ.is_valid(shape)
    assert occ.deviation(occ.read_cad(src).shape, shape, n=5, tol=tol).max() <= tol


def test_grid_vertices_by_prediction_round_trip() -> None:
    """Grid integers from their neighbours' (docs/format.md §2.6): residuals
    back to the same integers, and smaller than plain deltas on a model whose
    neighbours sit near each other."""
    nbr = [[1, 3], [0, 2], [1], [0], []]
    rows = np.array([0, 1, 2, 3, 4])
    q = np.array([[1000, 5, 7], [1003, 5, 9], [1003, 8, 9], [999, 4, 7], [-50, 0, 0]])
    pred = serialize._grid_predictions(nbr, rows, q)
    assert pred.tolist() == [[0, 0, 0], q[0].tolist(), q[1].tolist(), q[0].tolist(), q[3].tolist()]
    back = serialize._grid_from_residuals(nbr, rows, q - pred)
    assert back.tolist() == q.tolist()


def test_quad_corners_are_predicted_by_parallelograms() -> None:
    """Format 2.6 (docs/format.md §2.6, "Quad faces"): on a box every vertex is
    a corner of three four-edge wires; a grid vertex whose three other corners
    of a face came before it is predicted exactly (an axis-aligned box is a
    parallelogram on every face), and the residuals read back; a 2.5 reader's
    rule gives other points from the same residuals."""
    import copy

    import cadquery as cq

    from nurbscomp import occ
    from nurbscomp.serialize.vertices import _read_vertices, _write_vertices, vertex_quads

    m, _ = occ.shape_to_model(cq.Workplane().box(10, 20, 30).val().wrapped)
    quads = vertex_quads(m)
    assert sorted(quads) == list(range(8)) and all(len(t) == 3 for t in quads.values())
    for v, triples in quads.items():
        for x, y, z in triples:  # x, z share an edge with v; y is opposite
            assert len({v, x, y, z}) == 4
    tol = 0.01
    h = serialize.vertex_grid(tol)
    m.vertex_point = np.rint(m.vertex_point / h).astype(np.int64) * h
    nbr = serialize.vertex_neighbours(m)
    rows = np.arange(8)
    q = np.rint(m.vertex_point / h).astype(np.int64)
    res = q - serialize._grid_predictions(nbr, rows, q, quads)
    assert (res == 0).all(-1).sum() >= 4  # the corners a parallelogram closes
    assert serialize._grid_from_residuals(nbr, rows, res, quads).tolist() == q.tolist()
    raw = _write_vertices(m, tol)
    for revision, same in ((container.REVISION, True), (8, False)):
        back = copy.deepcopy(m)
        _read_vertices(raw, back, tol, revision)
        assert (back.vertex_point == m.vertex_point).all() == same


@pytest.mark.parametrize("name", ["loft.tol0.01.nzc", "teapot.tol0.01.nzc"])
def test_lossy_vertices_round_trip_bit_for_bit(name: str) -> None:
    """A 1.x lossy golden file, its vertices snapped to the 2.0 grid and packed as
    2.0: the same points back, bit for bit, the grid ones as residuals."""
    from nurbscomp import writer

    m, meta = fuzz.decoded((GOLDEN / name).read_bytes())
    h = serialize.vertex_grid(float(meta["tolerance_mm"]))
    m.vertex_point = np.rint(m.vertex_point / h).astype(np.int64) * h
    m.side_joins = np.zeros((0, 5), np.int64)
    data = fuzz.pack_fast(writer.model_to_sections(m, meta), 0)
    c = container.unpack(data)
    kind = serialize.BlockReader(c.get("VERT"), "VERT").ints()
    assert kind.all()
    back = _decode(data)
    assert back.vertex_point.view(np.int64).tolist() == m.vertex_point.view(np.int64).tolist()


def test_hostile_grid_residuals_wrap_harmlessly(monkeypatch) -> None:
    """Residuals that add up past int64 wrap (docs/format.md §2.6): the reader
    neither raises nor warns, and every point is a finite grid point."""
    import warnings

    from nurbscomp import writer

    m, meta = fuzz.decoded((GOLDEN / "loft.tol0.01.nzc").read_bytes())
    h = serialize.vertex_grid(float(meta["tolerance_mm"]))
    m.vertex_point = np.rint(m.vertex_point / h).astype(np.int64) * h
    m.side_joins = np.zeros((0, 5), np.int64)
    big = np.full((len(m.vertex_point), 3), 2**62, np.int64)
    monkeypatch.setattr(
        serialize.vertices, "_grid_predictions", lambda nbr, rows, q, quads=None: q - big[: len(q)]
    )
    data = fuzz.pack_fast(writer.model_to_sections(m, meta), 0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        back = _decode(data)
    assert np.isfinite(back.vertex_point).all()
    assert not np.array_equal(back.vertex_point, m.vertex_point)
