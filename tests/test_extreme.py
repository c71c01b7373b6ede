"""Extreme inputs (issue 27): never an internal error.

A net no code is within tol for (a double's spacing near the quantizer's step,
far from the origin) is kept exact and counted; a tolerance outside what the
format codes is a usage error; a non-finite source value is one input error,
in both modes."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest
from click.testing import CliRunner

from nurbscomp import codec, occ, pipeline, units
from nurbscomp.cli import cli
from nurbscomp.errors import EXIT_INPUT, EXIT_USAGE, InputError

from .stress import extreme


def _part(tmp: Path, name: str, offset: float = 0.0) -> Path:
    """The stress run's extreme part (:func:`tests.stress.extreme.part`) as STEP."""
    path = tmp / name
    occ.write_shape(extreme.part(offset), path, "STEP")
    return path


@pytest.mark.slow
@pytest.mark.parametrize("offset, tol", [(1e6, 0.001), (1e9, 0.001), (1e9, 0.01), (0.0, 1e-6)])
def test_far_from_the_origin(tmp_path: Path, offset: float, tol: float) -> None:
    """1e9 mm from the origin a double's spacing is 1.2e-7 mm: at 0.001 mm no
    net code is within tol (it was 'internal error (ValueError: no code
    within ...)'); those nets are kept exact, for the reason 'precision'."""
    src = _part(tmp_path, "far.step", offset)
    nzc = tmp_path / "far.nzc"
    r = pipeline.compress_file(src, nzc, tol=tol)
    ev = pipeline.evaluate(src, nzc)
    assert ev["verdict"] == "pass", ev["failed"]
    kept = r["validity"]["exact_faces"].get("precision", 0)
    if offset >= 1e9 and tol <= 0.001:  # exact, or within the bound by SNET method 10 (2.0)
        chosen = sum(r["faces_by_method"].get(m.name.lower(), 0) for m in codec.CHOSEN)
        assert kept > 0 or chosen > 0  # or by the lifted methods 14-22 (2.14)
    if offset == 0:
        assert kept == 0


@pytest.mark.parametrize("tol", ["1e-12", "1e-300", "5e-324", "1e15", "1e300", "2km"])
def test_tolerances_outside_the_range_are_usage_errors(tmp_path: Path, tol: str) -> None:
    src = _part(tmp_path, "p.step")
    r = CliRunner().invoke(cli, ["compress", "--tol", tol, str(src)])
    assert r.exit_code == EXIT_USAGE, r.output
    lo, hi = units.TOL_RANGE_MM
    assert f"outside the range coded, {lo:g} to {hi:g} mm" in r.stderr
    assert not (tmp_path / "p.step.nzc").exists()


@pytest.mark.slow
def test_the_range_ends_are_coded(tmp_path: Path) -> None:
    src = _part(tmp_path, "p.step")
    for tol in units.TOL_RANGE_MM:
        r = CliRunner().invoke(cli, ["compress", "-f", "--json", "--tol", str(tol), str(src)])
        assert r.exit_code == 0, r.output
        assert json.loads(r.stdout.splitlines()[0])["tolerance_mm"] == tol


@pytest.mark.parametrize("mode", [{"lossless": True, "tol": None}, {"tol": 0.01}])
def test_non_finite_sources_are_one_input_error(tmp_path: Path, mode: dict) -> None:
    src = _part(tmp_path, "p.step")
    text = src.read_text()
    vertex = re.search(r"VERTEX_POINT\('',#(\d+)\)", text)
    net = re.search(r"B_SPLINE_SURFACE_WITH_KNOTS\('',\d+,\d+,\(\s*\(#(\d+)", text)
    assert vertex and net
    for point, value in ((vertex.group(1), "1.E300"), (net.group(1), "1.E300")):
        bad = extreme.with_value(src, tmp_path / "bad.step", point, value)
        with pytest.raises(InputError, match="a value is not finite or out of range"):
            pipeline.compress_file(bad, tmp_path / "bad.nzc", force=True, **mode)
    r = CliRunner().invoke(cli, ["compress", "-q", "--tol", "0.01", str(bad)])
    assert r.exit_code == EXIT_INPUT
    assert r.stderr.count("\n") == 1 and "not finite or out of range" in r.stderr
    assert "Warning" not in r.stderr and not (tmp_path / "bad.step.nzc").exists()


@pytest.mark.slow
def test_the_api_refuses_the_same_tolerances(tmp_path: Path) -> None:
    import nurbscomp
    from nurbscomp.errors import ArgumentError

    src = _part(tmp_path, "p.step")
    for tol in (1e-9, "2km", 1e300):
        with pytest.raises(ArgumentError, match="outside the range coded"):
            nurbscomp.compress(src, tol=tol)
    assert nurbscomp.compress(src, tol="1km")[:4] == b"\x89NZC"


def _faulty_box() -> object:
    """A box with one vertex moved off its edges (a BRepCheck fault)."""
    import cadquery as cq
    from OCP.BRep import BRep_Builder, BRep_Tool
    from OCP.gp import gp_Pnt

    box = cq.Workplane().box(4, 3, 2).val().wrapped
    v = cq.Shape.cast(box).Vertices()[0].wrapped
    p = BRep_Tool.Pnt_s(v)
    BRep_Builder().UpdateVertex(v, gp_Pnt(p.X() + 0.5, p.Y(), p.Z()), 1e-7)
    return box


def test_an_instanced_part_is_checked_once() -> None:
    """BRepCheck of 200 placements of one faulty part: the same faulty model
    rows as the whole walk over every placement, from one placement's check."""
    import cadquery as cq

    from nurbscomp.occ import measure

    part = _faulty_box()
    placed = [
        cq.Shape.cast(part).moved(cq.Location(cq.Vector(10 * i, 0, 0))).wrapped for i in range(200)
    ]
    whole = cq.Compound.makeCompound([cq.Shape.cast(s) for s in placed]).wrapped
    once = measure.once_each(whole)
    assert once is not None and occ.counts(once)["faces"] == 6
    assert occ.counts(whole)["faces"] == 1200
    got = occ.failures(whole)
    bad_e, bad_f = measure._failures(whole)  # every placement walked
    eo, fo = measure.model_order(whole, "edge"), measure.model_order(whole, "face")
    assert got == ({int(eo[e]) for e in bad_e}, {int(fo[f]) for f in bad_f})
    assert got[0] and len(got[0]) < 12  # the fault is found, on the part's edges
    assert measure.once_each(part) is None  # nothing met twice: the whole shape is checked


@pytest.mark.parametrize("thickness, warned", [(0.001, True), (0.03, True), (1.0, False)])
def test_a_wall_thinner_than_tol_is_warned_of(
    tmp_path: Path, thickness: float, warned: bool
) -> None:
    """A plate of B-spline faces 1 µm thick at 0.01 mm: its two faces may
    cross (its volume changed by 88% in a trial) with the same counts and a
    valid BRepCheck; the report says so."""
    src = tmp_path / "plate.step"
    occ.write_shape(extreme.plate(thickness), src, "STEP")
    r = pipeline.compress_file(src, tmp_path / "plate.nzc", tol=0.01)
    thin = [w for w in r["warnings"] if "thin against the tolerance" in w]
    assert bool(thin) == warned, r["warnings"]


@pytest.mark.slow
def test_a_container_declares_only_what_the_defaults_refuse(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A container within the default limits declares nothing (no byte
    spent); one past them declares its measures, and the default reader then
    decodes it where an undeclared one is refused."""
    import dataclasses

    from nurbscomp import budget, container, serialize
    from nurbscomp.errors import LimitError

    from .conftest import SAMPLES

    def meta(p: Path) -> dict:
        return serialize.read_meta(container.unpack(p.read_bytes()).get("META"))

    src = SAMPLES / "bracket.step"
    plain = tmp_path / "plain.nzc"
    pipeline.compress_file(src, plain, tol=0.01)
    assert "decoded" not in meta(plain)
    e = budget.expansion(pipeline.decode(container.unpack(plain.read_bytes()))[0])
    # half of what it holds: past the default, within 16x it (the ceiling)
    small = dataclasses.replace(budget.DEFAULT, references=e.references // 2)
    monkeypatch.setattr(budget, "DEFAULT", small)
    big = tmp_path / "big.nzc"
    pipeline.compress_file(src, big, tol=0.01)  # verified under the small defaults
    assert meta(big)["decoded"] == {"references": e.references}
    pipeline.decode_file(big, budget.DEFAULT)
    with pytest.raises(LimitError, match="sub-shape references"):
        pipeline.decode_file(plain, budget.DEFAULT)
