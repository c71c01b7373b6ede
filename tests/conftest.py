"""Shared fixtures: the corpus (read in place from ../shared/corpus) and the samples."""

from __future__ import annotations

import signal
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
CORPUS = ROOT.parent / "shared" / "corpus"
SAMPLES = ROOT / "samples"
CAD_SUFFIXES = (".step", ".stp", ".igs", ".iges")


def corpus_files() -> list[Path]:
    """Every CAD file of the corpus (teapot.bpt is raw data, not CAD)."""
    assert CORPUS.is_dir(), f"corpus folder missing: {CORPUS}"
    files = sorted(p for p in CORPUS.iterdir() if p.suffix.lower() in CAD_SUFFIXES)
    assert files, "no CAD files in the corpus"
    return files


def sample_files() -> list[Path]:
    files = sorted(SAMPLES.glob("*.step"))
    assert len(files) >= 4, "samples/*.step missing: run `make samples`"
    return files


def assert_step_keeps_floor(cad, nzc: Path, tmp_path: Path):
    """Decompress ``nzc`` to STEP, read it back, and compare with OCCT's own
    STEP round trip of the source (the floor): each topology count between
    the source's and the floor's (``validity.step_keeps``), valid where the floor is, and
    no more free edges (sewn at 1e-7) than the source or the floor.
    Returns the re-read shape."""
    from nurbscomp import occ, pipeline

    floor = occ.step_round_trip(cad.shape, cad.unit, cad.product)  # as decompress writes
    out = tmp_path / "out.step"
    pipeline.decompress_file(nzc, out, force=True)
    back = occ.read_cad(out).shape
    src, lo, got = occ.counts(cad.shape), occ.counts(floor), occ.counts(back)
    worse = {
        k: (src[k], lo[k], got[k])
        for k in src
        if not min(src[k], lo[k]) <= got[k] <= max(src[k], lo[k])
    }
    assert not worse, f"(source, floor, ours) {worse}"
    if occ.is_valid(floor):
        assert occ.is_valid(back)
    free = [occ.free_edges_sewn(x) for x in (cad.shape, floor, back)]
    assert free[2] <= max(free[:2]), f"free edges (source, floor, ours) {free}"
    return back


@pytest.fixture(scope="session")
def small_step() -> Path:
    return SAMPLES / "bracket.step"


def default_signals() -> None:
    """``preexec_fn`` of a child whose signal handling a test checks: SIGINT,
    SIGTERM and SIGHUP at their defaults, whatever the test run inherited
    (``nohup`` ignores SIGHUP, a shell's background job SIGINT, and the CLI
    keeps an ignored signal ignored)."""
    for s in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
        signal.signal(s, signal.SIG_DFL)
