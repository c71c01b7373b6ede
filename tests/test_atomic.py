"""Atomic output: a failure or Ctrl-C at any point of a write leaves nothing behind,
and an existing output is never touched without --force (nor by a failed --force)."""

from __future__ import annotations

import shutil
from pathlib import Path
from typing import Any

import pytest
from click.testing import CliRunner

from nurbscomp import occ, pipeline
from nurbscomp.cli import cli
from nurbscomp.errors import OutputError, RebuildError

GOLDEN = Path(__file__).resolve().parent / "golden"


@pytest.fixture()
def work(tmp_path: Path) -> Path:
    shutil.copy(GOLDEN / "loft.tol0.01.nzc", tmp_path / "part.step.nzc")
    return tmp_path


def _names(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir())


def _half_write(exc: BaseException) -> Any:
    """A writer that writes half a file, then fails with ``exc``."""

    def write(shape: Any, path: Any, fmt: str, unit: str = "MM", **kw: Any) -> None:
        Path(path).write_bytes(b"ISO-10303-21;\nHEADER;\n")
        raise exc

    return write


@pytest.mark.parametrize("exc", [RuntimeError("disk on fire"), OSError(28, "No space left")])
def test_failure_mid_write_leaves_nothing(
    work: Path, monkeypatch: pytest.MonkeyPatch, exc: BaseException
) -> None:
    monkeypatch.setattr(occ, "write_shape", _half_write(exc))
    with pytest.raises((RebuildError, OutputError)):
        pipeline.decompress_file(work / "part.step.nzc")
    assert _names(work) == ["part.step.nzc"]


def test_ctrl_c_mid_write_leaves_nothing(work: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(occ, "write_shape", _half_write(KeyboardInterrupt()))
    with pytest.raises(KeyboardInterrupt):
        pipeline.decompress_file(work / "part.step.nzc")
    assert _names(work) == ["part.step.nzc"]
    # through the CLI: exit 130, one line, nothing left
    r = CliRunner().invoke(cli, ["decompress", str(work / "part.step.nzc")])
    assert r.exit_code == 130
    assert r.stderr.strip() == f"error: {work / 'part.step.nzc'}: interrupted"
    assert _names(work) == ["part.step.nzc"]


def test_failed_force_keeps_the_old_output(work: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    (work / "part.step").write_bytes(b"old")
    monkeypatch.setattr(occ, "write_shape", _half_write(KeyboardInterrupt()))
    with pytest.raises(KeyboardInterrupt):
        pipeline.decompress_file(work / "part.step.nzc", force=True)
    assert (work / "part.step").read_bytes() == b"old"
    assert _names(work) == ["part.step", "part.step.nzc"]


def test_ctrl_c_during_compress_verification(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The container is written, then Ctrl-C comes while it is being verified."""
    shutil.copy(Path(__file__).resolve().parent.parent / "samples" / "loft.step", tmp_path)

    def interrupted(*a: Any, **k: Any) -> Any:
        raise KeyboardInterrupt

    monkeypatch.setattr(pipeline, "decode", interrupted)
    with pytest.raises(KeyboardInterrupt):
        pipeline.compress_file(tmp_path / "loft.step", lossless=True)
    assert _names(tmp_path) == ["loft.step"]


def test_decompress_never_overwrites_without_force(work: Path) -> None:
    (work / "part.step").write_bytes(b"keep me")
    r = CliRunner().invoke(cli, ["decompress", str(work / "part.step.nzc")])
    assert r.exit_code == 1 and "--force" in r.stderr
    assert (work / "part.step").read_bytes() == b"keep me"
    r = CliRunner().invoke(cli, ["decompress", "-f", str(work / "part.step.nzc")])
    assert r.exit_code == 0, r.stderr
    assert (work / "part.step").read_bytes().startswith(b"ISO-10303-21;")
    assert _names(work) == ["part.step", "part.step.nzc"]


def test_decompress_into_missing_folder(work: Path) -> None:
    out = work / "no" / "such" / "x.step"
    r = CliRunner().invoke(cli, ["decompress", str(work / "part.step.nzc"), "-o", str(out)])
    assert r.exit_code == 1
    assert "output folder" in r.stderr and "does not exist" in r.stderr
    assert _names(work) == ["part.step.nzc"]
