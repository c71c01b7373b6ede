"""IGES output keeps what OCCT's own IGES round trip keeps (issue 26).

A container decompressed to ``.igs`` is written in BRep mode (solids, shells,
shared edges) on every path, with product data and without.  Each case is held
to OCCT's own XDE read -> BRep-mode IGES write -> read of the source: the same
solids, shells, faces, edges, vertices and free edges (sewing at 1e-7); in
tolerance mode no more free edges (coincident coded boundaries are joined).  In
faces mode, OCCT's default, a solid came back as loose faces with every edge
free (occ22470: 0 solids and 88 free edges where the source has 1 and 0).
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from nurbscomp import occ, pipeline
from nurbscomp.occ import xcaf

from .conftest import CORPUS

MODES = {"lossless": {"lossless": True, "tol": None}, "0.01": {"tol": 0.01}}


def _seen(path: Path) -> dict[str, int]:
    """What a reader sees of an IGES or STEP file: topology counts and free edges."""
    shape = occ.read_cad(path).shape
    return {**occ.counts(shape), "free_edges": occ.free_edges_sewn(shape, 1e-7)}


def _assert_iges_keeps(src: Path, tmp_path: Path, mode: str, made=None) -> dict[str, int]:
    ref = tmp_path / "occt.igs"
    xcaf.round_trip(src, ref)
    nzc = tmp_path / f"{src.name}.nzc"
    if made is not None and mode == "0.01":
        nzc = made(src, 0.01)  # the corpus container the other tests use too
    else:
        pipeline.compress_file(src, nzc, force=True, **MODES[mode])  # type: ignore[arg-type]
    out = tmp_path / "out.igs"
    pipeline.decompress_file(nzc, out, force=True)
    want, got = _seen(ref), _seen(out)
    said = f"{src.name} {mode}: OCCT's round trip {want}, ours {got}"
    if mode == "lossless":
        assert got == want, said
    else:
        # coded boundaries that coincide are joined (coincide.twin_sides): a
        # surface model's gaps may close (bearing at 0.01 mm: 25 free edges
        # where the source and OCCT's round trip have 29), never open
        assert {**got, "free_edges": 0} == {**want, "free_edges": 0}, said
        assert got["free_edges"] <= want["free_edges"], said
    return got


def _solid(tmp: Path, suffix: str) -> Path:
    """A filleted solid with a lofted B-spline side, written by OCCT (BRep-mode
    IGES, or STEP)."""
    import cadquery as cq

    lofted = cq.Workplane("XY").rect(20, 12).workplane(offset=15).circle(5).loft()
    box = cq.Workplane("XY").box(30, 20, 4).edges("|Z").fillet(2.0)
    shape = lofted.union(box).val().wrapped
    path = tmp / f"solid{suffix}"
    occ.write_shape(shape, path, "IGES" if suffix == ".igs" else "STEP")
    return path


@pytest.mark.parametrize("mode", sorted(MODES))
def test_generated_iges_solid(tmp_path: Path, mode: str) -> None:
    got = _assert_iges_keeps(_solid(tmp_path, ".igs"), tmp_path, mode)
    assert got["solids"] == 1 and got["free_edges"] == 0


@pytest.mark.parametrize("mode", sorted(MODES))
def test_step_source_to_iges(tmp_path: Path, mode: str) -> None:
    got = _assert_iges_keeps(_solid(tmp_path, ".step"), tmp_path, mode)
    assert got["solids"] == 1 and got["free_edges"] == 0


@pytest.mark.corpus
@pytest.mark.parametrize("mode", sorted(MODES))
def test_occ22470_keeps_its_solid(tmp_path: Path, mode: str) -> None:
    got = _assert_iges_keeps(CORPUS / "occt__occ22470.igs", tmp_path, mode)
    assert (got["solids"], got["shells"], got["edges"], got["free_edges"]) == (1, 1, 44, 0)


@pytest.mark.corpus
@pytest.mark.slow
@pytest.mark.parametrize("mode", sorted(MODES))
@pytest.mark.parametrize(
    "name",
    [
        "occt__bearing.iges",
        "pythonocc-core__sunglasses_lens.igs",
        "occt__bug32596_abc_0_13.step",
        "trimesh__featuretype.STEP",
    ],
)
def test_corpus_to_iges(tmp_path: Path, name: str, mode: str, made) -> None:
    _assert_iges_keeps(CORPUS / name, tmp_path, mode, made)


@pytest.mark.slow
@pytest.mark.corpus
def test_eval_fails_the_faces_mode_output(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """``nurbscomp eval SRC OUT.igs`` on occ22470 at 0.01 mm: exit 6 (topology
    differs, 88 free edges) for the faces-mode output the writer made before,
    0 for the BRep-mode one."""
    from click.testing import CliRunner

    from nurbscomp.cli import cli
    from nurbscomp.errors import EXIT_DIFFERS

    src = CORPUS / "occt__occ22470.igs"
    nzc = tmp_path / "occ.nzc"
    pipeline.compress_file(src, nzc, tol=0.01)
    faces, brep = tmp_path / "faces.igs", tmp_path / "brep.igs"
    with monkeypatch.context() as mp:
        mp.setattr(xcaf, "IGES_BREP_MODE", ("write.iges.brep.mode", "Faces"))
        pipeline.decompress_file(nzc, faces)
    pipeline.decompress_file(nzc, brep)
    r = CliRunner().invoke(cli, ["eval", str(src), str(faces), "--tol", "0.01"])
    assert r.exit_code == EXIT_DIFFERS, r.output
    assert "verdict:     FAIL: within 0.01 mm, topology differs, " in r.stdout
    assert "88 free edges where the original has 0" in r.stdout
    r = CliRunner().invoke(cli, ["eval", str(src), str(brep), "--tol", "0.01"])
    assert r.exit_code == 0, r.output
    assert r.stdout.strip().endswith(
        "verdict:     pass: within 0.01 mm, same topology, valid, no new free edges"
    )
    r = CliRunner().invoke(cli, ["eval", str(src), str(nzc), "--tol", "0.001", "--json"])
    rep = json.loads(r.stdout)
    assert r.exit_code == EXIT_DIFFERS and rep["exit_code"] == EXIT_DIFFERS
    assert rep["within_tolerance"] is False and rep["failed"] == ["within_tolerance"]
    assert rep["topology_same"] and rep["valid_kept"] and rep["free_edges_kept"]
