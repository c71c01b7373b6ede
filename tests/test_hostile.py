"""Hostile containers (issue 11): built, not damaged.  A valid container is
decoded, its model or META edited, and packed again with valid CRCs.  Each
must end fast with one ``FormatError`` line, or decode within the budget."""

from __future__ import annotations

import dataclasses
import json
import time
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

import nurbscomp
from nurbscomp import (
    budget,
    container,
    entropy,
    model,
    occ,
    passthrough,
    pipeline,
    serialize,
)
from nurbscomp.cli import cli, show
from nurbscomp.encode import pcurves
from nurbscomp.errors import (
    EXIT_CONTAINER,
    BadReferenceError,
    CorruptError,
    FormatError,
    InputError,
    LimitError,
    SectionError,
    VerifyError,
)
from nurbscomp.model import BRepModel, RepKind, ShapeType
from nurbscomp.occ import files
from nurbscomp.rules import joins

from . import fuzz
from .conftest import SAMPLES

GOLDEN = Path(__file__).resolve().parent / "golden"
BASE = GOLDEN / "bracket.lossless.nzc"


def with_meta(raw: bytes, base: Path = BASE) -> bytes:
    """``base`` with its META section replaced by ``raw`` (every CRC valid)."""
    c = container.unpack(base.read_bytes())
    secs = [(s.tag, raw if s.tag == "META" else s.raw) for s in c.sections]
    return container.pack(secs, c.flags, (entropy.Coder.STORED,))


def _meta(**edits: object) -> dict[str, object]:
    c = container.unpack(BASE.read_bytes())
    return {**json.loads(c.get("META")), **edits}


def _cli_one_line(tmp_path: Path, data: bytes, *args: str) -> str:
    """Run ``nurbscomp ARGS FILE`` on ``data``: exit 4 (a damaged container), one
    error line, nothing left."""
    src = tmp_path / "case.nzc"
    src.write_bytes(data)
    r = CliRunner().invoke(cli, [*args, str(src)])
    assert r.exit_code == EXIT_CONTAINER, r.output
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"error: {src}: "), r.stderr
    assert "internal error" not in r.stderr and "Undiagnosed" not in r.stderr
    assert "no specific check" not in r.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["case.nzc"]
    return lines[0]


META_CASES = {
    "5000-digit integer": b'{"mode": "lossless", "source_bytes": ' + b"7" * 5000 + b"}",
    "10^400 source_bytes": json.dumps(_meta(source_bytes=10**400)).encode(),
    "1e400 source_bytes": json.dumps(_meta()).encode().replace(b'"source_bytes"', b'"x"')[:-1]
    + b', "source_bytes": 1e400}',
    "negative source_bytes": json.dumps(_meta(source_bytes=-1)).encode(),
    "lone surrogate": json.dumps(_meta(source_name="a\ud800b")).encode(),
    "CR and BEL": json.dumps(_meta(source_name="a\r\x07b")).encode(),
    "C1 control": json.dumps(_meta(writer="x\x9bx")).encode(),
    "long name": json.dumps(_meta(source_name="n" * 5000)).encode(),
    "NaN tolerance": json.dumps(_meta(mode="tolerance", tolerance_mm=float("nan"))).encode(),
    "unit as a number": json.dumps(_meta(unit=10**30)).encode(),
}


@pytest.mark.parametrize("case", sorted(META_CASES))
def test_meta_abuse_is_one_line(tmp_path: Path, case: str) -> None:
    data = with_meta(META_CASES[case])
    with pytest.raises(SectionError, match="META"):
        pipeline.decode(container.unpack(data))
    for cmd in ("info", "test", "decompress"):
        line = _cli_one_line(tmp_path, data, cmd)
        assert "META" in line


def test_meta_size_is_bounded(tmp_path: Path) -> None:
    """A 5 MB name: refused by the section's size, before JSON is parsed."""
    data = with_meta(json.dumps(_meta(source_name="n" * 5_000_000)).encode())
    with pytest.raises(LimitError, match="META: 5000"):
        pipeline.decode(container.unpack(data))
    _cli_one_line(tmp_path, data, "decompress")


def test_meta_text_for_writers() -> None:
    """What compress stores of a file name: control characters and undecodable
    bytes replaced, length cut; the reader accepts the result."""
    name = "a\rb\x07c\udcff" + "x" * 3000
    clean = serialize.meta_text(name)
    assert clean.startswith("a\ufffdb\ufffdc\ufffdxx") and len(clean) == serialize.MAX_META_TEXT
    raw = json.dumps(_meta(source_name=clean, writer=serialize.meta_text("w"))).encode()
    meta = serialize.read_meta(raw)
    assert meta["source_name"] == clean


def test_printed_text_is_escaped(tmp_path: Path) -> None:
    assert show("a\rb\x07c\u202ed\ud800") == "a\\rb\\x07c\\u202ed\\ud800"
    assert show("é ok") == "é ok"
    src = tmp_path / "x\r\x07y.nzc"
    src.write_bytes(BASE.read_bytes())
    r = CliRunner().invoke(cli, ["info", str(src)])
    assert r.exit_code == 0, r.output
    assert "\r" not in r.output and "\x07" not in r.output
    assert "x\\r\\x07y.nzc" in r.output
    bad = tmp_path / "z\x1b[31m.nzc"
    bad.write_bytes(b"junk")
    r = CliRunner().invoke(cli, ["info", str(bad)])
    assert r.exit_code == EXIT_CONTAINER and "\x1b" not in r.stderr and "z\\x1b[31m.nzc" in r.stderr


def test_goldens_meta_still_reads() -> None:
    for p in sorted(GOLDEN.glob("*.nzc")):
        c = container.unpack(p.read_bytes())
        if c.flags & container.FLAG_EXACT:  # the file itself: passthrough reads its META
            meta = passthrough.read(c)[0]
        else:
            meta = serialize.read_meta(c.get("META"))
        assert isinstance(meta["source_name"], str)


def test_all_meta_errors_are_format_errors() -> None:
    for raw in META_CASES.values():
        with pytest.raises(FormatError):
            serialize.read_meta(raw)


# ---------------------------------------------------------------- the budget and the walks


def _model(name: str = "loft.lossless.nzc") -> tuple[BRepModel, dict[str, object]]:
    return fuzz.decoded((GOLDEN / name).read_bytes())


def _decode(data: bytes, fmt: str | None = None) -> BRepModel:
    return pipeline.decode(container.unpack(data), fmt=fmt)[0]


def _paths(m: BRepModel, s: int) -> int:
    """Sub-shape references below ``s``, the slow way (small models only)."""
    a, b = int(m.child_start[s]), int(m.child_start[s + 1])
    return 1 + sum(_paths(m, int(c)) for c in m.child_shape[a:b])


@pytest.mark.parametrize(("depth", "width"), [(3, 2), (6, 3), (1, 5)])
def test_references_are_counted_with_sharing_unfolded(depth: int, width: int) -> None:
    m, _ = _model()
    fuzz.nest(m, depth, width)
    e = budget.expansion(m)
    assert e.references == _paths(m, m.root_shape)
    assert e.depth == budget.expansion(_model()[0]).depth + depth


def test_shared_compounds_40_deep_fail_fast(tmp_path: Path) -> None:
    """A compound holding the one below it twice, 40 levels: 2^40 x the loft."""
    m, meta = _model()
    fuzz.nest(m, 40, 2)
    data = fuzz.pack_model(m, meta)
    assert len(data) < 10_000
    t = time.perf_counter()
    with pytest.raises(LimitError, match="sub-shape references once sharing is unfolded"):
        _decode(data)
    assert time.perf_counter() - t < 5
    for cmd in ("test", "info", "decompress"):
        assert "sub-shape references" in _cli_one_line(tmp_path, data, cmd)


@pytest.mark.slow
def test_a_100000_deep_chain_fails_fast(tmp_path: Path) -> None:
    m, meta = _model()
    fuzz.nest(m, 100_000, 1)
    data = fuzz.pack_model(m, meta)
    assert len(data) < 10_000
    t = time.perf_counter()
    with pytest.raises(LimitError, match="levels of nested sub-shapes"):
        _decode(data)
    assert time.perf_counter() - t < 5
    assert "levels of nested" in _cli_one_line(tmp_path, data, "test")


def test_limit_scale_raises_the_limits(tmp_path: Path) -> None:
    m, meta = _model()
    fuzz.nest(m, 1_000, 1)
    src = tmp_path / "chain.nzc"
    src.write_bytes(fuzz.pack_model(m, meta))
    r = CliRunner().invoke(cli, ["test", str(src)])
    assert r.exit_code == EXIT_CONTAINER and "levels of nested" in r.stderr
    r = CliRunner().invoke(cli, ["test", "--limit-scale", "2", str(src)])
    assert r.exit_code == 0, r.stderr
    r = CliRunner().invoke(cli, ["test", "--limit-scale", "0", str(src)])
    assert r.exit_code == 2
    # the limits scale down too: a golden file is then refused
    g = GOLDEN / "teapot.lossless.nzc"
    r = CliRunner().invoke(cli, ["info", "--limit-scale", "0.0001", str(g)])
    assert r.exit_code == EXIT_CONTAINER
    assert "table rows" in r.stderr and "more than the 100 " in r.stderr
    assert budget.DEFAULT.scaled(1e6).depth == budget.DEPTH_CEILING


def test_unreached_nested_wires_are_walked_once(tmp_path: Path) -> None:
    """Wires nested twice per level, 40 levels, under a face nothing reaches:
    ``info`` (which runs joins.face_vertices) returns at once."""
    m, meta = _model()
    fuzz.unreached_wires(m, 40, 2)
    data = fuzz.pack_model(m, meta)
    t = time.perf_counter()
    src = tmp_path / "wires.nzc"
    src.write_bytes(data)
    r = CliRunner().invoke(cli, ["info", str(src)])
    assert r.exit_code == 0, r.stderr
    assert time.perf_counter() - t < 5
    src.unlink()
    verts = joins.face_vertices(_decode(data))
    assert verts[-1] == verts[0] or verts[-1]  # the new face reaches the wire's vertices
    line = _cli_one_line(tmp_path, data, "test")  # OCCT refuses a wire in a wire
    assert "does not rebuild" in line


@pytest.mark.slow
def test_located_instances_are_flattened_by_iges_only() -> None:
    m, meta = _model("bracket.lossless.nzc")
    one = budget.expansion(m)
    fuzz.instances(m, 1000)
    data = fuzz.pack_model(m, meta)
    e = budget.expansion(_decode(data))
    assert e.references == 1000 * one.references + 1
    assert e.iges_bytes > 900 * one.iges_bytes
    assert e.step_bytes < 10 * one.step_bytes
    with pytest.raises(LimitError, match="IGES output would take"):
        _decode(data, "IGES")
    assert _decode(data, "STEP") is not None
    m, meta = _model("bracket.lossless.nzc")
    fuzz.instances(m, 10_000)
    with pytest.raises(LimitError):
        _decode(fuzz.pack_model(m, meta), "STEP")


def test_huge_net_and_computed_pcurves() -> None:
    m, meta = _model()
    fuzz.huge_net(m, 1000, 1000, 25)
    data = fuzz.pack_model(m, meta)
    assert len(data) < 20_000
    with pytest.raises(LimitError, match="STEP output would take"):
        _decode(data, "STEP")
    m, meta = _model("teapot.tol0.01.nzc")
    fuzz.huge_net(m, 200, 300, 25)  # OCCT's projection onto it: over 30 s a pcurve
    with pytest.raises(LimitError, match="units of work projecting"):
        _decode(fuzz.pack_model(m, meta))
    m, meta = _model("bracket.lossless.nzc")
    fuzz.computed_pcurves(m, 1000)
    e = budget.expansion(m)
    assert e.pcurves == budget.pcurves_to_compute(m)[0] > 50_000
    limits = dataclasses.replace(budget.DEFAULT, pcurves=e.pcurves - 1)
    with pytest.raises(LimitError, match="pcurves to compute"):
        pipeline.decode(container.unpack(fuzz.pack_model(m, meta)), limits)


@pytest.mark.parametrize(
    "name", ["loft.lossless.nzc", "teapot.tol0.01.nzc", "bracket.lossless.nzc"]
)
@pytest.mark.parametrize(("n", "degree"), [(10, 3), (30, 25), (100, 9)])
def test_pcurves_onto_a_surface_with_no_area_are_refused(name: str, n: int, degree: int) -> None:
    """The structure fuzzer's slowest cases: pcurves to compute on a net whose
    poles lie on one line (OCCT: 70 ms to 43 s a pcurve, from 10 x 10 cubic to
    100 x 100 of degree 25) are refused before OCCT builds anything."""
    m, meta = _model(name)
    fuzz.huge_net(m, n, n, degree)  # a ramp: every pole on the x axis
    fuzz.computed_pcurves(m, 1)
    t = time.perf_counter()
    with pytest.raises((CorruptError, LimitError)) as e:
        _decode(fuzz.pack_model(m, meta))
    assert time.perf_counter() - t < 5
    if e.type is CorruptError:
        assert "no area" in str(e.value)


def _knots(n: int, degree: int) -> tuple[np.ndarray, np.ndarray]:
    mults = np.ones(n - degree + 1, np.int64)
    mults[[0, -1]] = degree + 1
    return np.linspace(0.0, 1.0, n - degree + 1), mults


def _computed(face: object) -> bytes:
    """A container of ``face`` (an OCP face) with every pcurve left to compute."""
    m, _ = occ.shape_to_model(face)
    reps = m.edge_reps
    on = (reps[:, 1] == RepKind.ON_SURFACE) | (reps[:, 1] == RepKind.ON_CLOSED_SURFACE)
    reps[on, 2] = model.REBUILD
    reps[reps[:, 1] == RepKind.ON_CLOSED_SURFACE, 3] = model.REBUILD
    m.edge_rep_range[on] = 0.0
    m.edge_rep_uv[on] = 0.0
    return fuzz.pack_model(m, _model()[1])


def _net_face(n: int, degree: int) -> bytes:
    """A face on an n x n planar net of ``degree``, bounded by its iso curves
    (3-D curves on the surface), every pcurve left to compute."""
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeFace
    from OCP.Geom import Geom_BSplineSurface

    from nurbscomp.occ import geometry

    k, mults = _knots(n, degree)
    poles = np.zeros((n, n, 3))
    poles[:, :, 0] = np.arange(n)[:, None]
    poles[:, :, 1] = np.arange(n)[None, :]
    surf = Geom_BSplineSurface(
        geometry._tcol_points2(poles),
        geometry._tcol_reals(k),
        geometry._tcol_reals(k),
        geometry._tcol_ints(mults),
        geometry._tcol_ints(mults),
        degree,
        degree,
        False,
        False,
    )
    return _computed(BRepBuilderAPI_MakeFace(surf, 0.0, 1.0, 0.0, 1.0, 1e-7).Face())


def _revolution_face(n: int, degree: int) -> bytes:
    """A face on the surface of revolution of an n-pole zigzag curve of ``degree``."""
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeFace
    from OCP.Geom import Geom_BSplineCurve, Geom_SurfaceOfRevolution
    from OCP.gp import gp_Ax1, gp_Dir, gp_Pnt

    from nurbscomp.occ import geometry

    k, mults = _knots(n, degree)
    poles = np.zeros((n, 3))
    poles[:, 0] = np.arange(n)
    poles[:, 1] = 20.0 + 5.0 * (np.arange(n) % 2)
    curve = Geom_BSplineCurve(
        geometry._tcol_points1(poles),
        geometry._tcol_reals(k),
        geometry._tcol_ints(mults),
        degree,
        False,
    )
    surf = Geom_SurfaceOfRevolution(curve, gp_Ax1(gp_Pnt(0, 0, 0), gp_Dir(1, 0, 0)))
    return _computed(BRepBuilderAPI_MakeFace(surf, 0.0, 1.0, 0.0, 3.0, 1e-7).Face())


def test_projections_off_their_surface_are_refused(tmp_path: Path) -> None:
    """A 100 x 100 planar net of degree 9 with the loft's edges to project onto
    it, off the surface (OCCT: 9.7 s; 1 million units a point, 23 points or
    more an edge) is refused before OCCT builds anything; a 30 x 30 cubic one
    (0.1 s) is not."""
    m, meta = _model()
    fuzz.plane_net(m, 100, 100, 9)
    fuzz.computed_pcurves(m, 1)
    data = fuzz.pack_model(m, meta)
    assert len(data) < 10_000
    with pytest.raises(LimitError, match="units of work projecting"):
        _decode(data)
    assert "units of work projecting" in _cli_one_line(tmp_path, data, "test")
    m, meta = _model()
    fuzz.plane_net(m, 30, 30, 3)
    fuzz.computed_pcurves(m, 1)
    e = budget.expansion(_decode(fuzz.pack_model(m, meta)))
    assert 0 < e.projection < budget.DEFAULT.projection


@pytest.mark.parametrize(
    ("make", "n", "degree"),
    [(_net_face, 100, 9), (_net_face, 100, 25), (_revolution_face, 60, 9)],
    ids=["net-100-9", "net-100-25", "revolution-60-9"],
)
def test_projections_onto_their_surface_are_bounded(make, n: int, degree: int) -> None:
    """Edges that lie on their surface, pcurves to compute: OCCT took 1.5 s
    (100 x 100, degree 9), 31 s (degree 25) and 25 s (a revolution of a
    60-pole curve of degree 9, counted as 64 units before) for the four;
    each container is under 10 KB and refused before anything is built."""
    data = make(n, degree)
    assert len(data) < 10_000
    with pytest.raises(LimitError, match="units of work projecting"):
        _decode(data)
    # within limits raised for a trusted file: decoded (not built here)
    m = pipeline.decode(container.unpack(data), budget.DEFAULT.scaled(1e4))[0]
    assert budget.expansion(m).pcurves == 4


def test_projection_work_grows_with_the_container() -> None:
    """Past the floor, a container's bytes buy ``projection_ratio`` units each."""
    lim = budget.DEFAULT
    assert lim.sized(1_000).projection == lim.projection
    assert lim.sized(100_000).projection == 100_000 * lim.projection_ratio
    assert lim.scaled(2).sized(100_000).projection == 200_000 * lim.projection_ratio
    assert lim.sized(100_000).pcurves == lim.pcurves


def test_the_writer_stays_within_the_default_budget(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """With the default projection limit at half of what the loft's container
    leaves to compute, compress keeps the costliest pcurves and verifies its
    container with those limits (without ``drop_pcurves``'s budget, verify
    refuses it)."""
    src = SAMPLES / "loft.step"
    pipeline.compress_file(src, tmp_path / "a.nzc", tol=0.01)
    full = budget.expansion(_decode((tmp_path / "a.nzc").read_bytes()))
    assert full.projection > 0
    small = dataclasses.replace(budget.DEFAULT, projection=full.projection // 2, projection_ratio=0)
    monkeypatch.setattr(budget, "DEFAULT", small)
    pipeline.compress_file(src, tmp_path / "b.nzc", tol=0.01)
    c = container.unpack((tmp_path / "b.nzc").read_bytes())
    half = budget.expansion(pipeline.decode(c, small)[0])
    assert 0 < half.projection <= small.projection
    assert half.pcurves < full.pcurves
    monkeypatch.setattr(pcurves, "_within_budget", lambda m, reps, limits: [])
    with pytest.raises(VerifyError, match="default limits"):
        pipeline.compress_file(src, tmp_path / "c.nzc", tol=0.01)


def test_curve_samples_follow_occt() -> None:
    """23 points, or (degree + 1) per knot interval (OCCT counts those within
    the edge's range), rounded up to 23 + 22 k
    (ShapeConstruct_ProjectCurveOnSurface::Perform)."""

    def curve(n: int, degree: int, bezier: bool = False) -> model.BSplineCurve:
        k, mults = _knots(n, degree)
        return model.BSplineCurve(np.zeros((n, 3)), None, k, mults, degree, False, bezier)

    assert budget.curve_samples([curve(4, 3)], 0) == 23
    assert budget.curve_samples([curve(8, 3)], 0) == 23  # 5 intervals x 4 = 20
    assert budget.curve_samples([curve(9, 3)], 0) == 45  # 24 points
    assert budget.curve_samples([curve(100, 9)], 0) == 925  # 910
    assert budget.curve_samples([curve(100, 9, True)], 0) == 23  # a Bezier curve
    line = model.Analytic(model.Kind.LINE, np.zeros((2, 3)), np.zeros(0))
    assert budget.curve_samples([line], 0) == 23
    trimmed = model.Derived(model.Kind.TRIMMED_CURVE, 0, np.zeros((0, 3)), np.array([0.0, 1.0]))
    assert budget.curve_samples([curve(100, 9), trimmed], 1) == 925


def test_a_singular_location_to_a_negative_power_is_refused() -> None:
    """A located reference whose datum is singular and raised to a negative
    power has no matrix (the fuzzer's odd_matrices, seed 11 cases 580 and
    647): a SectionError naming the location, not an undiagnosed LinAlgError."""
    m, meta = _model()
    (k,) = fuzz.add_datums(m, np.zeros((1, 3, 4)), 6)
    m.locations[k] = model.Location(m.locations[k].datums, (-3,))
    refs = np.flatnonzero(m.child_shape >= 0)
    m.child_loc[int(refs[0])] = k
    with pytest.raises(SectionError, match="singular matrix to a negative power"):
        _decode(fuzz.pack_model(m, meta))


def test_degenerate_rows() -> None:
    """Poles on one line or at one point: degenerate; on a plane: not; a
    coded net not decoded yet (NaN): not; a trimmed surface on a degenerate
    basis: degenerate."""
    m, _ = _model("teapot.tol0.01.nzc")
    rows = [r for r, g in enumerate(m.surfaces) if isinstance(g, model.BSplineSurface)]
    g = m.surfaces[rows[0]]
    assert isinstance(g, model.BSplineSurface)
    line = dataclasses.replace(g, poles=g.poles.copy())
    line.poles[..., 1:] = 0.0
    point = dataclasses.replace(g, poles=np.ones_like(g.poles))
    plane = dataclasses.replace(g, poles=g.poles.copy())
    plane.poles[..., 2] = 0.0
    nan = dataclasses.replace(g, poles=np.full_like(g.poles, np.nan))
    trimmed = model.Derived(model.Kind.TRIMMED_SURFACE, 0, np.zeros((0, 3)), np.zeros(4))
    assert budget.degenerate_rows([line, point, plane, nan, trimmed]) == [
        True,
        True,
        False,
        False,
        True,
    ]
    assert not any(budget.degenerate_rows(m.surfaces))


@pytest.mark.parametrize("where", ["itself", "its parent"])
def test_cycles_are_refused(tmp_path: Path, where: str) -> None:
    m, meta = _model()
    parents = np.repeat(np.arange(len(m.shape_type)), np.diff(m.child_start))
    k = len(parents) - 1  # the root's last reference
    m.child_shape[k] = parents[k] if where == "itself" else parents[k] + 1
    if where == "its parent":
        fuzz.nest(m, 1, 1)  # a parent for the root to point at
    data = fuzz.pack_model(m, meta)
    with pytest.raises(BadReferenceError, match="cycle"):
        _decode(data)
    assert "cycle" in _cli_one_line(tmp_path, data, "test")


def test_curve_placements_match_the_paths() -> None:
    """joins.curve_placements (one pass, parents first) against every path."""
    for name in ("bracket.lossless.nzc", "loft.faces.tol0.01.nzc"):
        m, _ = _model(name)
        fuzz.instances(m, 2)  # every curve under two placements: none kept
        assert joins.curve_placements(m) == {}
        m, _ = _model(name)
        got = joins.curve_placements(m)
        want = _placements_by_paths(m)
        assert got.keys() == want.keys() and got
        assert all(np.array_equal(got[c], want[c]) for c in got)


def _placements_by_paths(m: BRepModel) -> dict[int, np.ndarray]:
    mats = [joins.location_matrix(m, k) for k in range(len(m.locations))]
    tidx = m.type_index()
    at: dict[int, list[np.ndarray]] = {}

    def walk(s: int, t: np.ndarray) -> None:
        if m.shape_type[s] == ShapeType.EDGE:
            for q in np.flatnonzero(m.edge_reps[:, 0] == tidx[s]).tolist():
                if m.edge_reps[q, 1] == RepKind.CURVE3D:
                    c = int(m.edge_reps[q, 2])
                    at.setdefault(c, []).append(t @ mats[int(m.edge_reps[q, 6])])
            return
        for k in range(m.child_start[s], m.child_start[s + 1]):
            c = int(m.child_shape[k])
            if m.shape_type[c] != ShapeType.VERTEX:
                walk(c, t @ mats[int(m.child_loc[k])])

    walk(m.root_shape, mats[m.root_loc])
    return {c: ts[0] for c, ts in at.items() if all(np.array_equal(x, ts[0]) for x in ts)}


def test_reader_walks_deep_shapes_without_recursion() -> None:
    """OCCT shapes nested 3,000 deep (past Python's recursion limit) read back
    into the same tables."""
    m, _ = _model()
    fuzz.nest(m, 3_000, 1)
    shape = occ.model_to_shape(m)
    back, _ = occ.shape_to_model(shape)
    assert model.differences(m, back) == []


# ---------------------------------------------------------------- STEP input screening


def _deep_step(tmp_path: Path, n: int, quoted: str = "") -> Path:
    text = (SAMPLES / "loft.step").read_text()
    i = text.index("DATA;") + len("DATA;\n")
    bad = f"#999999=CARTESIAN_POINT('{quoted}'," + "(" * n + "0.0" + ")" * n + ");\n"
    p = tmp_path / f"deep{n}.step"
    p.write_text(text[:i] + bad + text[i:])
    return p


def test_deeply_nested_step_is_screened(tmp_path: Path) -> None:
    """100,000 nested parentheses crash OCCT's STEP parser: refused first."""
    p = _deep_step(tmp_path, 100_000)
    prefix = "#999999=CARTESIAN_POINT('',"  # its "(" is level 1
    with pytest.raises(InputError, match="nested more than 1000 deep"):
        files.screen_step(p)
    r = CliRunner().invoke(cli, ["compress", "--lossless-brep", str(p)])
    assert r.exit_code == 1
    assert r.stderr.strip().splitlines() == [
        f"error: {p}: STEP parentheses nested more than 1000 deep (at byte "
        f"{p.read_bytes().index(b'#999999=') + len(prefix) + files.MAX_STEP_NESTING - 1}); "
        "OCCT's parser cannot read it"
    ]
    assert sorted(x.name for x in tmp_path.iterdir()) == [p.name]
    # byte-exact mode reads no geometry: it keeps the file, byte for byte
    r = CliRunner().invoke(cli, ["compress", "--lossless", str(p), "-o", str(tmp_path / "x.nzc")])
    assert r.exit_code == 0, r.output
    assert nurbscomp.original(tmp_path / "x.nzc") == p.read_bytes()


@pytest.mark.slow
def test_screening_reads_strings_and_chunks(tmp_path: Path, monkeypatch) -> None:
    """Parentheses inside a string (with an escaped apostrophe) do not count,
    and the depth and the quoting carry across the scan's chunks."""
    files.screen_step(_deep_step(tmp_path, 998, quoted="it''s " + "(" * 5000))
    monkeypatch.setattr(files, "_SCAN_CHUNK", 7)
    files.screen_step(_deep_step(tmp_path, 998, quoted="x''" + "(" * 2000))
    with pytest.raises(InputError):
        files.screen_step(_deep_step(tmp_path, 1000, quoted="''"))
    for p in sorted(SAMPLES.glob("*.step")):
        files.screen_step(p)


@pytest.mark.slow
def test_table_rows_are_bounded_before_any_loop() -> None:
    """A container may declare millions of rows in a few KB (the body inflates
    to 256 MB): refused by their count before the budget's own loops."""
    m, meta = _model()
    n = len(m.shape_type) + len(m.child_shape) + len(m.edge_reps) + len(m.vertex_reps)
    n += len(m.surfaces) + len(m.curves3d) + len(m.curves2d)
    n += sum(len(loc.datums) for loc in m.locations)
    data = fuzz.pack_model(m, meta)
    pipeline.decode(container.unpack(data), dataclasses.replace(budget.DEFAULT, rows=n))
    with pytest.raises(LimitError, match=f"{n:,} table rows"):
        pipeline.decode(container.unpack(data), dataclasses.replace(budget.DEFAULT, rows=n - 1))
    verts = 1_100_000  # unreached vertices: no reference, no path, only rows
    fuzz.add_shapes(m, [ShapeType.VERTEX] * verts, [[] for _ in range(verts)])
    m.vertex_point = np.zeros((len(m.vertex_point) + verts, 3))
    m.vertex_tol = np.zeros(len(m.vertex_point))
    m.vertex_reps = np.zeros((0, 5), np.int64)
    m.vertex_rep_params = np.zeros((0, 2))
    data = fuzz.pack_model(m, meta)
    assert len(data) < 100_000
    t = time.perf_counter()
    with pytest.raises(LimitError, match="table rows"):
        _decode(data)
    assert time.perf_counter() - t < 10


def test_chains_of_geometry_bases_are_bounded() -> None:
    """A trimmed surface on a trimmed surface on …, 10,000 deep, under face 0:
    its depth is counted in one pass (memoised) and refused."""
    from nurbscomp.model import Derived, Kind

    m, meta = _model()
    s = int(m.face_surface[0])
    first = len(m.surfaces)
    box = np.array([0.0, 1.0, 0.0, 1.0])
    m.surfaces += [
        Derived(Kind.TRIMMED_SURFACE, s if i == 0 else first + i - 1, np.zeros((0, 3)), box)
        for i in range(10_000)
    ]
    m.face_surface[0] = len(m.surfaces) - 1
    data = fuzz.pack_model(m, meta)
    t = time.perf_counter()
    with pytest.raises(LimitError, match="10,001 levels of geometry on geometry"):
        _decode(data)
    assert time.perf_counter() - t < 5
    assert budget.expansion(_model()[0]).bases <= 2


def test_overflowing_locations_and_weights_are_refused(tmp_path: Path) -> None:
    """Found by the structure-aware fuzzer (seed 1, cases 7145 and 5427): a
    1e100 scale raised to the power 2^31 - 1 crashed OCCT's STEP writer, and
    weights of 1e-300 and 1e300 on poles at 2e100 its pcurve projection."""
    m, meta = _model()
    rows = np.array([[[1e100, 0, 0, 0], [0, 1e100, 0, 0], [0, 0, 1e100, 0]]])
    (k,) = fuzz.add_datums(m, rows, 6)
    m.locations[k] = model.Location(m.locations[k].datums, (2**31 - 1,))
    m.root_loc = k
    data = fuzz.pack_model(m, meta)
    with pytest.raises(SectionError, match="LOCS: location .* not finite or out of range"):
        _decode(data)
    assert "LOCS" in _cli_one_line(tmp_path, data, "decompress")
    m, meta = _model()
    (t, i) = next((t, i) for t, i in fuzz._bsplines(m) if t is m.curves3d)
    g = t[i]
    w = np.ones(len(g.poles))
    w[0], w[-1] = 1e-300, 1e300
    t[i] = dataclasses.replace(g, weights=w)
    with pytest.raises(SectionError, match="CRV3 row .*: weights must be within"):
        _decode(fuzz.pack_model(m, meta))
