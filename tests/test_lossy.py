"""Tolerance mode: every face within tol (measured independently), topology and validity kept."""

from __future__ import annotations

from pathlib import Path

import pytest

from nurbscomp import occ, pipeline

from .conftest import assert_step_keeps_floor, corpus_files, sample_files


def _check(path: Path, tmp_path: Path, tol: float, step: bool = False, **kw) -> dict:
    cad = occ.read_cad(path)
    nzc = tmp_path / "x.nzc"
    rep = pipeline.compress_file(path, nzc, tol=tol, **kw)
    assert rep["verified"] and rep["max_bound_mm"] <= tol
    shape, _, meta = pipeline.decode_file(nzc)
    assert meta["tolerance_mm"] == tol
    assert occ.counts(shape) == occ.counts(cad.shape)
    dev = occ.deviation(cad.shape, shape, n=5, tol=tol)
    assert dev.max() <= tol, f"face {dev.argmax()} deviates {dev.max()} > {tol}"
    if occ.is_valid(cad.shape):
        assert occ.is_valid(shape)
    if step:
        assert_step_keeps_floor(cad, nzc, tmp_path)
    return rep


@pytest.mark.parametrize("path", sample_files(), ids=lambda p: p.name)
@pytest.mark.parametrize("tol", [0.001, 0.1])
def test_samples_within_tol(path: Path, tmp_path: Path, tol: float) -> None:
    rep = _check(path, tmp_path, tol)
    if path.name in ("teapot.step", "blob.step"):
        # freeform models: (nearly) every face coded, far smaller than the text
        assert rep["faces_by_method"].get("exact", 0) <= len(rep["face_method_list"]) // 4
        assert rep["output_bytes"] < path.stat().st_size / 10


@pytest.mark.slow
@pytest.mark.parametrize("path", corpus_files(), ids=lambda p: p.name)
def test_corpus_within_tol(path: Path, tmp_path: Path) -> None:
    _check(path, tmp_path, 0.01, step=True)


@pytest.mark.parametrize("path", sample_files(), ids=lambda p: p.name)
def test_samples_without_step_safety(path: Path, tmp_path: Path) -> None:
    rep = _check(path, tmp_path, 0.05, step_safe=False)
    assert not rep["step_safe"]


def test_lossy_is_smaller_than_lossless(tmp_path: Path) -> None:
    from .conftest import SAMPLES

    p = SAMPLES / "blob.step"
    a = pipeline.compress_file(p, tmp_path / "a.nzc", lossless=True)
    b = pipeline.compress_file(p, tmp_path / "b.nzc", tol=0.01)
    assert b["output_bytes"] < a["output_bytes"]
