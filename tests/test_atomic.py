"""Atomic output: a failure or Ctrl-C at any point of a write leaves nothing behind,
and an existing output is never touched without --force (nor by a failed --force)."""

from __future__ import annotations

import os
import shutil
from pathlib import Path
from typing import Any

import pytest
from click.testing import CliRunner

from nurbscomp import occ, paths, pipeline
from nurbscomp.cli import cli
from nurbscomp.errors import EXIT_OUTPUT, OutputError, RebuildError

from .conftest import default_signals

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

    from nurbscomp.stages import compress

    monkeypatch.setattr(compress, "decode", interrupted)  # what verify_encoded decodes with
    with pytest.raises(KeyboardInterrupt):
        pipeline.compress_file(tmp_path / "loft.step", lossless=True)
    assert _names(tmp_path) == ["loft.step"]


def test_decompress_never_overwrites_without_force(work: Path) -> None:
    (work / "part.step").write_bytes(b"keep me")
    r = CliRunner().invoke(cli, ["decompress", str(work / "part.step.nzc")])
    assert r.exit_code == EXIT_OUTPUT and "--force" in r.stderr
    assert (work / "part.step").read_bytes() == b"keep me"
    r = CliRunner().invoke(cli, ["decompress", "-f", str(work / "part.step.nzc")])
    assert r.exit_code == 0, r.stderr
    assert (work / "part.step").read_bytes().startswith(b"ISO-10303-21;")
    assert _names(work) == ["part.step", "part.step.nzc"]


def test_decompress_into_missing_folder(work: Path) -> None:
    out = work / "no" / "such" / "x.step"
    r = CliRunner().invoke(cli, ["decompress", str(work / "part.step.nzc"), "-o", str(out)])
    assert r.exit_code == EXIT_OUTPUT
    assert "output folder" in r.stderr and "does not exist" in r.stderr
    assert _names(work) == ["part.step.nzc"]


# ---------------------------------------------------------------- issue 11: outputs


def test_output_on_its_input_is_refused_even_with_force(work: Path) -> None:
    src = work / "part.step.nzc"
    before = src.read_bytes()
    for args in (["decompress", "-f", str(src), "-o", str(src)], ["compress", "-f", str(src)]):
        if args[0] == "compress":  # a CAD input as its own output
            cad = work / "loft.step"
            shutil.copy(Path(__file__).resolve().parent.parent / "samples" / "loft.step", cad)
            before_cad = cad.read_bytes()
            args = ["compress", "-f", "--lossless", str(cad), "-o", str(cad)]
        r = CliRunner().invoke(cli, args)
        assert r.exit_code == EXIT_OUTPUT, r.output
        lines = r.stderr.strip().splitlines()
        assert len(lines) == 1 and "is the input file" in lines[0], r.stderr
    assert src.read_bytes() == before
    assert cad.read_bytes() == before_cad
    assert _names(work) == ["loft.step", "part.step.nzc"]


def test_output_through_a_link_to_the_input_is_refused(work: Path) -> None:
    src = work / "part.step.nzc"
    (work / "link.step").symlink_to(src)
    with pytest.raises(OutputError, match="is the input file"):
        pipeline.decompress_file(src, work / "link.step", force=True)
    assert (work / "link.step").is_symlink()
    assert (GOLDEN / "loft.tol0.01.nzc").read_bytes() == src.read_bytes()


def test_os_errors_on_output_are_output_errors(work: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A folder that cannot be written (the test runs as root, so the OS's
    refusal is simulated where it happens), and a full disk mid-write."""
    import errno

    real_open = os.open

    def refuse(path: Any, flags: int, *a: Any, **k: Any) -> Any:
        if flags & os.O_CREAT and str(path).endswith(".tmp"):  # the temporary output
            raise PermissionError(errno.EACCES, "Permission denied")
        return real_open(path, flags, *a, **k)

    with monkeypatch.context() as mp:
        mp.setattr(os, "open", refuse)
        r = CliRunner().invoke(cli, ["decompress", str(work / "part.step.nzc")])
    assert r.exit_code == EXIT_OUTPUT
    assert r.stderr.strip().endswith("Permission denied"), r.stderr
    assert "internal error" not in r.stderr
    monkeypatch.setattr(occ, "write_shape", _half_write(OSError(errno.ENOSPC, "No space left")))
    with pytest.raises(OutputError, match="No space left"):
        pipeline.decompress_file(work / "part.step.nzc")
    assert _names(work) == ["part.step.nzc"]


def test_long_output_names(work: Path) -> None:
    """249 characters: the temporary name is shortened to fit 255 bytes.  300:
    the OS's own refusal, as an OutputError."""
    src = work / "part.step.nzc"
    out = work / ("x" * 244 + ".step")
    assert len(out.name) == 249
    pipeline.decompress_file(src, out)
    assert out.read_bytes().startswith(b"ISO-10303-21;")
    uni = work / ("é" * 100 + "y" * 40 + ".step")  # 145 characters, 245 bytes
    pipeline.decompress_file(src, uni)
    assert _names(work) == sorted(["part.step.nzc", out.name, uni.name])
    assert paths._tmp_prefix("é" * 200).encode() == b"." + "é".encode() * 100 + b"."
    with pytest.raises(OutputError, match="File name too long"):
        pipeline.decompress_file(src, work / ("z" * 300 + ".step"))
    r = CliRunner().invoke(cli, ["decompress", str(src), "-o", str(work / ("z" * 300))])
    assert r.exit_code == EXIT_OUTPUT and "File name too long" in r.stderr
    assert len(_names(work)) == 3


@pytest.mark.slow
@pytest.mark.parametrize(("sig", "code"), [("SIGTERM", 143), ("SIGHUP", 129)])
def test_signal_mid_write_leaves_nothing(work: Path, sig: str, code: int) -> None:
    """A real process, killed while its temporary file exists: the signal is
    handled like Ctrl-C (the temporary file is removed), with exit 128 + signal."""
    import os
    import signal
    import subprocess
    import sys
    import time

    root = Path(__file__).resolve().parent.parent
    src = work / "loft.step"
    shutil.copy(root / "samples" / "blob.step", src)
    # compress verifies the container while its temporary file exists; the
    # process is stopped (SIGSTOP) as soon as the file is seen, so that the
    # signal surely lands while it exists, however fast or loaded the run
    cmd = [sys.executable, "-m", "nurbscomp.cli", "compress", "--tol", "0.01", str(src)]
    env = {**os.environ, "PYTHONPATH": str(root)}
    for _ in range(5):
        p = subprocess.Popen(
            cmd,
            cwd=root,
            env=env,
            stderr=subprocess.PIPE,
            text=True,
            preexec_fn=default_signals,
        )
        deadline = time.time() + 120
        while not list(work.glob(".*.tmp")) and p.poll() is None and time.time() < deadline:
            time.sleep(0.002)
        assert p.poll() is None, "the process ended before its temporary file was seen"
        p.send_signal(signal.SIGSTOP)
        if list(work.glob(".*.tmp")):
            break  # stopped inside the window
        p.send_signal(signal.SIGCONT)  # it got past the window: run it again
        p.communicate(timeout=120)
        (work / "loft.step.nzc").unlink(missing_ok=True)
    else:
        pytest.fail("the process never stopped while its temporary file existed")
    p.send_signal(getattr(signal, sig))
    p.send_signal(signal.SIGCONT)
    _, err = p.communicate(timeout=120)
    assert p.returncode == code, err
    assert err.strip().splitlines()[-1] == f"error: {src}: interrupted ({sig})"
    left = {p.name: p.stat().st_size for p in work.iterdir()}
    assert _names(work) == ["loft.step", "part.step.nzc"], (left, err)


def test_an_interrupt_before_the_cleanup_removes_the_temporary(work: Path) -> None:
    """The signal mask holds the thread that makes the temporary file only: a
    stop signal taken by another thread (a thread pool's, OCCT's) runs its
    handler in the main thread, perhaps before the ``try`` that would remove
    the file.  The file is listed before it exists, and the command line's
    interrupt removes what is listed (a SIGHUP left one under load)."""
    from nurbscomp import cli as cli_module

    tmp = Path(paths._make_temporary(work, ".part.step.nzc."))
    assert tmp.exists() and str(tmp) in paths._LIVE
    with pytest.raises(SystemExit) as stop:
        cli_module._interrupted(KeyboardInterrupt(), [str(work / "part.step")])
    assert stop.value.code == 128 + 2
    assert not tmp.exists() and str(tmp) not in paths._LIVE
    assert _names(work) == ["part.step.nzc"]


def test_an_interrupt_right_after_the_file_is_made_removes_it(
    work: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """An interrupt whose handler runs once ``os.open`` has made the file,
    before ``_make_temporary`` returns (a signal another thread took: the
    mask does not hold it; the test of a killed process left the file so
    under load): the file is removed and no longer listed."""
    real_close = paths.os.close

    def close_then_interrupt(fd: int) -> None:
        real_close(fd)
        raise KeyboardInterrupt

    monkeypatch.setattr(paths.os, "close", close_then_interrupt)
    with pytest.raises(KeyboardInterrupt):
        paths._make_temporary(work, ".part.step.nzc.")
    monkeypatch.undo()
    assert _names(work) == ["part.step.nzc"] and not paths._LIVE
    with pytest.raises(KeyboardInterrupt):  # through atomic_output too
        monkeypatch.setattr(paths.os, "close", close_then_interrupt)
        with paths.atomic_output(work / "x.step", False):
            pass
    monkeypatch.undo()
    assert _names(work) == ["part.step.nzc"] and not paths._LIVE
