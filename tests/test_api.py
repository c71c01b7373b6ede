"""The Python API (``nurbscomp.compress`` …): same bytes as the CLI, shapes in
and out, typed reports, one-line errors."""

from __future__ import annotations

import dataclasses
import json
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import nurbscomp
from nurbscomp import errors, pipeline

from .conftest import SAMPLES

GOLDEN = Path(__file__).resolve().parent / "golden"


@pytest.fixture(scope="module")
def cq():
    import cadquery

    return cadquery


def test_import_is_lazy() -> None:
    """``import nurbscomp`` loads neither OCP, cadquery nor numpy; the API's
    names load on first use."""
    code = (
        "import sys, nurbscomp; "
        "print(sorted(m for m in ('OCP', 'cadquery', 'numpy', 'nurbscomp.pipeline') "
        "if m in sys.modules)); "
        "nurbscomp.info; print('nurbscomp.pipeline' in sys.modules, 'OCP' in sys.modules)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split("\n")[:2] == ["[]", "True False"]


def test_filleted_box_round_trip(cq) -> None:
    """The issue's one-liner, with the box's true volume (5.8047: the fillets
    take 0.195 mm³ off the 6 of the box): every face within tol, so the
    volume within tol times the area (the fillets' radii may come back on
    the analytic grid, 0.2 -> 0.20020 mm)."""
    src = cq.Workplane().box(1, 2, 3).edges().fillet(0.2).val()
    data = nurbscomp.compress(src, tol=0.001)
    s = nurbscomp.decompress(data)
    assert isinstance(s, cq.Shape)
    assert s.isValid() and abs(s.Volume() - src.Volume()) <= 0.001 * src.Area()
    r = nurbscomp.evaluate(src, data)
    assert r.same_topology and r.within_tolerance
    raw = nurbscomp.decompress(data, raw=True)
    assert raw.ShapeType() == src.wrapped.ShapeType()
    assert nurbscomp.info(data)["shapes"]["face"] == len(src.Faces())


def test_path_gives_the_cli_bytes(tmp_path: Path) -> None:
    """``compress(path)`` runs the CLI's stages: the same container, bit for bit."""
    src = SAMPLES / "loft.step"
    pipeline.compress_file(src, tmp_path / "loft.nzc", tol=0.01)
    assert nurbscomp.compress(src, tol=0.01) == (tmp_path / "loft.nzc").read_bytes()
    assert nurbscomp.compress(str(src), lossless=True)[:4] == b"\x89NZC"


def test_bytes_in_and_out(tmp_path: Path) -> None:
    data = nurbscomp.compress((SAMPLES / "loft.step").read_bytes(), tol=0.01)
    (tmp_path / "x.nzc").write_bytes(data)
    by_bytes, by_path = nurbscomp.info(data), nurbscomp.info(tmp_path / "x.nzc")
    assert by_bytes["input"] == "<bytes>" and by_path["input"] == str(tmp_path / "x.nzc")
    assert isinstance(by_bytes, nurbscomp.InfoReport)
    assert dataclasses.replace(by_bytes, input="") == dataclasses.replace(by_path, input="")
    assert {**by_bytes, "input": ""} == {**by_path, "input": ""}  # read as a dict still
    assert json.loads(by_bytes.to_json())["shapes"] == by_bytes.shapes
    assert by_bytes["source_name"] == "data.step" and by_bytes["mode"] == "tolerance"
    a = nurbscomp.decompress(data, raw=True)
    b = nurbscomp.decompress(tmp_path / "x.nzc", raw=True)
    from nurbscomp import occ

    assert occ.counts(a) == occ.counts(b)


@pytest.mark.slow
def test_workplane_and_topods(cq) -> None:
    wp = cq.Workplane().box(2, 2, 2).faces(">Z").workplane().hole(0.5)
    s = nurbscomp.decompress(nurbscomp.compress(wp, lossless=True))
    assert abs(s.Volume() - wp.val().Volume()) < 1e-12
    two = cq.Workplane().pushPoints([(0, 0), (5, 0)]).box(1, 1, 1)
    s = nurbscomp.decompress(nurbscomp.compress(two))
    assert len(s.Solids()) == 2  # a Workplane's shapes go in as one compound
    s = nurbscomp.decompress(nurbscomp.compress(wp.val().wrapped))
    assert len(s.Faces()) == len(wp.val().Faces())


def test_assembly_round_trip(cq) -> None:
    assy = cq.Assembly(name="top")
    assy.add(cq.Workplane().box(1, 1, 1), name="cube", color=cq.Color("red"))
    assy.add(
        cq.Workplane().sphere(0.5),
        name="ball",
        loc=cq.Location((3, 0, 0)),
        color=cq.Color("blue"),
    )
    back = nurbscomp.decompress(nurbscomp.compress(assy, tol=0.001))
    assert isinstance(back, cq.Assembly)
    leaves = [obj for _, obj in back.traverse() if obj.obj is not None]
    assert len(leaves) == 2
    total = sum(o.obj.Volume() for o in leaves)
    assert abs(total - (1 + 4 / 3 * np.pi * 0.125)) < 1e-3
    solids = back.toCompound().Solids()
    assert max(s.Center().x for s in solids) == pytest.approx(3, abs=1e-6)


def test_sample_assembly_decodes_to_an_assembly(cq) -> None:
    back = nurbscomp.decompress(nurbscomp.compress(SAMPLES / "assembly.step", lossless=True))
    assert isinstance(back, cq.Assembly)
    plain = nurbscomp.decompress(nurbscomp.compress(SAMPLES / "loft.step", lossless=True))
    assert isinstance(plain, cq.Shape)


@pytest.mark.slow
def test_evaluate_report(cq, tmp_path: Path, one_coding: None) -> None:
    part = cq.Workplane().box(1, 2, 3).edges().fillet(0.2).val()
    r = nurbscomp.evaluate(part, nurbscomp.compress(part, tol=0.001))
    assert isinstance(r, nurbscomp.Report)
    assert r.same_topology and r.valid_reconstructed and r.within_tolerance
    assert r.tolerance_mm == 0.001 and r.reconstructed == "<bytes>"
    assert r.counts_original == r.counts_reconstructed and r.counts_original.faces == 26
    assert len(r.face_max_mm) == 26 and r.max_deviation_mm == r.face_max_mm.max()
    assert r.worst_faces[0].max_mm == r.max_deviation_mm
    nzc = tmp_path / "blob.nzc"
    pipeline.compress_file(SAMPLES / "blob.step", nzc, tol=0.01)
    r = nurbscomp.evaluate(SAMPLES / "blob.step", nzc, tol=0.001)
    assert r.tolerance_mm == 0.001 and r.within_tolerance is False  # coded at 0.01
    assert 0 < r.max_deviation_mm <= 0.01
    assert nurbscomp.evaluate(SAMPLES / "blob.step", nzc).within_tolerance


def test_errors_are_nurbscomp_errors(tmp_path: Path) -> None:
    with pytest.raises(errors.ArgumentError, match="cannot compress a builtins.list"):
        nurbscomp.compress([1, 2])
    with pytest.raises(ValueError, match="positive"):
        nurbscomp.compress(SAMPLES / "loft.step", tol=-1)
    with pytest.raises(errors.InputError, match="no such file"):
        nurbscomp.compress(tmp_path / "missing.step")
    with pytest.raises(errors.InputError, match="not a STEP or IGES"):
        nurbscomp.compress(b"hello")
    with pytest.raises(errors.BadMagicError):
        nurbscomp.decompress(b"not a container at all")
    with pytest.raises(errors.ArgumentError):
        nurbscomp.decompress(42)  # type: ignore[arg-type]
    verbatim = GOLDEN / "passthrough" / "tessellated.step.nzc"
    with pytest.raises(errors.InputError, match="verbatim"):
        nurbscomp.decompress(verbatim)
    assert nurbscomp.info(verbatim.read_bytes())["passthrough"]


def test_no_brep_bytes_are_stored_verbatim() -> None:
    src = (GOLDEN / "passthrough" / "tessellated.step").read_bytes()
    data = nurbscomp.compress(src)
    r = nurbscomp.info(data)
    assert r["passthrough"] and r["source_bytes"] == len(src)


@pytest.mark.slow
@pytest.mark.parametrize("name", ["assembly.step", "blob.step", "bracket.step", "teapot.step"])
def test_every_sample_gives_the_cli_bytes(name: str, tmp_path: Path) -> None:
    """``compress(path)`` and ``compress_file`` write the same container, in every mode."""
    src = SAMPLES / name
    modes: list[tuple[dict[str, Any], dict[str, Any]]] = [
        ({"tol": 0.01}, {"tol": 0.01}),
        ({"lossless": "brep"}, {"lossless": True}),
        ({"lossless": True}, {"exact": True}),
    ]
    for api, cli in modes:
        out = tmp_path / f"{name}.nzc"
        pipeline.compress_file(src, out, force=True, **cli)
        assert nurbscomp.compress(src, **api) == out.read_bytes(), api


# ---------------------------------------------------------------- tol and force (issue 26)


@pytest.mark.parametrize(
    "tol, mm", [("5um", 0.005), ("0.01mm", 0.01), ("1mil", 0.0254), (" 2 um", 0.002), (1, 1.0)]
)
def test_tol_takes_lengths_with_units(cq, tol: Any, mm: float, one_coding: None) -> None:
    """``tol`` as ``--tol`` takes it: a length with a unit, or a number of mm
    (coded within that tolerance only: a small part is coded tighter too,
    and the smaller container, which names its own tolerance, kept)."""
    box = cq.Workplane().box(1, 2, 3).val()
    data = nurbscomp.compress(box, tol=tol)
    assert nurbscomp.info(data)["tolerance_mm"] == pytest.approx(mm, rel=1e-12)
    assert nurbscomp.evaluate(box, data, tol=tol).tolerance_mm == pytest.approx(mm, rel=1e-12)


@pytest.mark.slow
def test_tol_string_gives_the_cli_bytes(tmp_path: Path) -> None:
    """``compress(path, tol="1mil")`` is ``nurbscomp compress --tol 1mil``, bit for bit."""
    from click.testing import CliRunner

    from nurbscomp.cli import cli

    out = tmp_path / "loft.nzc"
    r = CliRunner().invoke(
        cli, ["compress", "-q", "--tol", "1mil", str(SAMPLES / "loft.step"), "-o", str(out)]
    )
    assert r.exit_code == 0, r.output
    assert nurbscomp.compress(SAMPLES / "loft.step", tol="1mil") == out.read_bytes()


BAD_TOLS = [
    (True, "not builtins.bool"),
    (False, "not builtins.bool"),
    (None, "not None"),
    ([0.01], "not builtins.list"),
    (b"5um", "not builtins.bytes"),
    (float("nan"), "positive, finite"),
    (float("inf"), "positive, finite"),
    (0, "positive, finite"),
    (-1, "positive, finite"),
    ("0um", "must be a positive length"),
    ("1e400", "must be a positive length"),
    ("5 parsecs", "is not a length"),
    ("nan", "is not a length"),
    ("", "is not a length"),
]


@pytest.mark.parametrize("tol, message", BAD_TOLS)
def test_bad_tol_is_refused_before_any_work(tmp_path: Path, tol: Any, message: str) -> None:
    """A tol that is no positive, finite length raises ``ArgumentError`` with a
    one-line message, before the input is looked at (the input is missing
    here: the error would otherwise be an ``InputError``); also with
    ``lossless``, which then ignores tol, and in ``evaluate`` (but for None,
    its default)."""
    missing = tmp_path / "missing.step"
    calls = [
        lambda: nurbscomp.compress(missing, tol=tol),
        lambda: nurbscomp.compress(missing, tol=tol, lossless=True),
    ]
    if tol is not None:
        calls.append(lambda: nurbscomp.evaluate(missing, missing, tol=tol))
    for call in calls:
        with pytest.raises(errors.ArgumentError) as e:
            call()
        assert message in str(e.value) and "tol" in str(e.value)
        assert "\n" not in str(e.value)


@pytest.mark.slow
def test_evaluate_heatmap_is_not_overwritten_without_force(cq, tmp_path: Path) -> None:
    """``evaluate(heatmap=)``, the API's one file written: an existing picture
    raises ``OutputError`` without ``force`` (before any work: the inputs are
    not read), and is replaced with it."""
    part = cq.Workplane().box(1, 2, 3).edges().fillet(0.2).val()
    data = nurbscomp.compress(part, tol=0.001)
    png = tmp_path / "error.png"
    nurbscomp.evaluate(part, data, heatmap=png)
    first = png.read_bytes()
    assert first[:4] == b"\x89PNG"
    with pytest.raises(errors.OutputError, match="already exists"):
        nurbscomp.evaluate(tmp_path / "missing.step", data, heatmap=png)
    assert png.read_bytes() == first
    png.write_bytes(b"old")
    nurbscomp.evaluate(part, data, heatmap=png, force=True)
    assert png.read_bytes()[:4] == b"\x89PNG"
    assert not [p for p in tmp_path.iterdir() if p.name.endswith(".tmp")]


@pytest.mark.slow
def test_compress_report(tmp_path: Path) -> None:
    """``compress(..., report=True)`` gives the same container and a typed report
    of what the CLI's ``--json`` says (sizes, mode, tolerance, counts)."""
    src = SAMPLES / "loft.step"
    data, r = nurbscomp.compress(src, tol=0.01, report=True)
    assert data == nurbscomp.compress(src, tol=0.01)
    assert isinstance(r, nurbscomp.CompressReport)
    assert (r.input_bytes, r.output_bytes) == (src.stat().st_size, len(data))
    assert r.ratio == pytest.approx(src.stat().st_size / len(data))
    assert (r.mode, r.tolerance_mm, r.source_format, r.verified) == (
        "tolerance",
        0.01,
        "STEP",
        True,
    )
    assert r.counts["faces"] == nurbscomp.info(data).shapes["face"]
    assert 0 < r.max_bound_mm <= 0.01 and r.certified_faces > 0
    assert json.loads(r.to_json())["faces_by_method"] == r.faces_by_method
    cli = pipeline.compress_file(src, tmp_path / "x.nzc", tol=0.01)
    assert {k: cli[k] for k in ("ratio", "mode", "counts", "max_bound_mm")} == {
        k: r[k] for k in ("ratio", "mode", "counts", "max_bound_mm")
    }

    exact, e = nurbscomp.compress(src, lossless=True, report=True)
    assert (e.mode, e.output_bytes, e.tolerance_mm) == ("exact", len(exact), None)
    assert e.sha256 == nurbscomp.info(exact).sha256 and e.model == "step"

    import cadquery as cq

    _, s = nurbscomp.compress(cq.Workplane().box(1, 2, 3).val(), report=True)
    assert (s.source_format, s.input_bytes, s.ratio) == ("BREP", 0, None)


def test_surface_trimmed_in_one_direction(cq) -> None:
    """A cylinder trimmed in u only keeps OCCT's infinite bounds in v,
    ±Precision::Infinite() itself (OCCT's booleans make such faces: a slot cut
    into a filleted, pocketed block was refused, "SURF params: a value is not
    finite or out of range").  Both modes take it; B-rep exact gives the
    bounds back bit for bit."""
    from OCP.BRep import BRep_Tool
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeFace
    from OCP.Geom import Geom_CylindricalSurface, Geom_RectangularTrimmedSurface
    from OCP.gp import gp_Ax3
    from OCP.Precision import Precision

    cyl = Geom_CylindricalSurface(gp_Ax3(), 5.0)
    trimmed = Geom_RectangularTrimmedSurface(cyl, np.pi, 3 * np.pi, True)
    assert trimmed.Bounds()[2:] == (-Precision.Infinite_s(), Precision.Infinite_s())
    face = cq.Face(BRepBuilderAPI_MakeFace(trimmed, np.pi, 2.5 * np.pi, 0.0, 8.0, 1e-7).Face())
    for kw in ({"tol": 0.01}, {"lossless": "brep"}):
        data = nurbscomp.compress(face, **kw)  # type: ignore[arg-type]
        back = nurbscomp.decompress(data)
        assert back.isValid() and nurbscomp.evaluate(face, data).within_tolerance is not False
    raw = nurbscomp.decompress(nurbscomp.compress(face, lossless="brep"), raw=True)
    got = BRep_Tool.Surface_s(cq.Shape.cast(raw).Faces()[0].wrapped)
    assert got.Bounds() == trimmed.Bounds()
