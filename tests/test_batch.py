"""Batches (issue 13): many files and folders, -d mirroring the tree, JSON
records for every file (failures included) and a summary, worker processes,
Ctrl-C and --skip-existing, streams, outputs that are not regular files,
--debug, and the same batch on a Dask LocalCluster."""

from __future__ import annotations

import builtins
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest
from click.testing import CliRunner

from nurbscomp import batch, container, pipeline
from nurbscomp.cli import cli
from nurbscomp.errors import EXIT_CONTAINER, EXIT_INPUT, EXIT_INTERNAL, EXIT_OUTPUT
from nurbscomp.occ import exchange as occ_exchange

from .conftest import SAMPLES, default_signals
from .test_cli import CURVE_ONLY, TESSELLATED

ROOT = Path(__file__).resolve().parent.parent


def run(*args: str) -> tuple[int, str, str]:
    r = CliRunner().invoke(cli, list(args))
    return r.exit_code, r.stdout, r.stderr


def lines(out: str) -> tuple[dict[str, dict[str, Any]], dict[str, Any]]:
    """The JSON records by input file name, and the summary."""
    recs = [json.loads(line) for line in out.splitlines()]
    *files, total = recs
    assert total["summary"] and all("summary" not in r for r in files)
    return {Path(r["input"]).name: r for r in files}, total


def mixed_folder(root: Path) -> Path:
    """A folder of mixed files: a part, tessellated-only and curve-only STEP, garbage."""
    src = root / "in"
    (src / "sub").mkdir(parents=True)
    shutil.copy(SAMPLES / "loft.step", src / "part.step")
    (src / "tess.step").write_bytes(TESSELLATED)
    (src / "sub" / "curve.stp").write_bytes(CURVE_ONLY)
    (src / "sub" / "garbage.step").write_bytes(b"garbage\n" * 10)
    (src / "sub" / "notes.txt").write_text("not CAD: not picked up by -r")
    return src


def no_temporary_files(root: Path) -> bool:
    return not [p for p in root.rglob("*") if p.name.endswith(".tmp")]


# ---------------------------------------------------------------- planning


def test_plan_mirrors_the_tree(tmp_path: Path) -> None:
    src = mixed_folder(tmp_path)
    opts = batch.Options("compress")
    tasks = batch.plan([str(src)], opts, recursive=True, output_dir=str(tmp_path / "out"))
    got = {Path(t.src).relative_to(src).as_posix(): t.dst for t in tasks}
    out = tmp_path / "out"
    assert got == {
        "part.step": str(out / "part.step.nzc"),
        "tess.step": str(out / "tess.step.nzc"),
        "sub/curve.stp": str(out / "sub" / "curve.stp.nzc"),
        "sub/garbage.step": str(out / "sub" / "garbage.step.nzc"),
    }
    assert all(t.make_parent for t in tasks)
    # default names beside the inputs; a folder without -r is one (failing) input
    tasks = batch.plan([str(src / "part.step"), str(src)], opts)
    assert [t.dst for t in tasks] == [str(src / "part.step.nzc"), str(src) + ".nzc"]
    # decompress: .nzc files; --format sets the extension
    (src / "sub" / "a.step.nzc").write_bytes(b"")
    d = batch.Options("decompress", fmt="IGES")
    tasks = batch.plan([str(src)], d, recursive=True, output_dir=str(out))
    assert [t.dst for t in tasks] == [str(out / "sub" / "a.igs")]


@pytest.mark.parametrize(
    "inputs, kw, opts, message",
    [
        (["a", "b"], {"output": "x"}, {}, "single input"),
        (["a", "b"], {"to_stdout": True}, {}, "single input"),
        (["a"], {"output": "x", "output_dir": "d"}, {}, "exclude"),
        (["-", "-"], {}, {}, "once"),
        (["-"], {"output_dir": "d"}, {}, "not -O"),
        (["a"], {}, {"force": True, "skip_existing": True}, "exclude"),
        (["a.nzc"], {"to_stdout": True}, {"command": "decompress", "remove_input": True}, "--rm"),
        (["a"], {}, {"verify": False, "remove_input": True}, "--rm needs"),
    ],
)
def test_plan_usage_errors(
    inputs: list[str], kw: dict[str, Any], opts: dict[str, Any], message: str
) -> None:
    o = batch.Options(**{"command": "compress", **opts})
    with pytest.raises(batch.UsageError, match=message):
        batch.plan(inputs, o, **kw)
    code, _, err = run(o.command, *inputs, *(["-o", kw["output"]] if "output" in kw else []))
    if "output" in kw and "output_dir" not in kw:
        assert code == 2 and "single input" in err


# ---------------------------------------------------------------- one process


def test_mixed_batch_json_and_back(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Every file gets a JSON line (failures with class, message, exit code),
    then the summary; the exit code is the worst; decompress rebuilds them all
    and the passthrough files come back byte-identical."""
    src = mixed_folder(tmp_path)
    locked = src / "sub" / "locked.step"
    shutil.copy(SAMPLES / "loft.step", locked)
    locked.chmod(0)
    real_open = builtins.open

    def refuse(file: Any, *a: Any, **k: Any) -> Any:  # root reads anything: the OS refusal
        if str(file) == str(locked):
            raise PermissionError(13, "Permission denied", str(file))
        return real_open(file, *a, **k)

    monkeypatch.setattr(occ_exchange, "open", refuse, raising=False)  # check_readable
    out, back = tmp_path / "out", tmp_path / "back"
    code, stdout, err = run("compress", "-r", str(src), "-O", str(out), "-j", "1", "--json")
    assert code == 1
    recs, total = lines(stdout)
    assert sorted(recs) == ["curve.stp", "garbage.step", "locked.step", "part.step", "tess.step"]
    assert not any(r.get("internal") for r in recs.values())
    assert recs["part.step"]["status"] == "ok" and recs["part.step"]["mode"] == "tolerance"
    for name in ("tess.step", "curve.stp"):
        r = recs[name]
        assert r["status"] == "ok" and r["passthrough"] and r["exit_code"] == 0
        assert "stored verbatim" in r["warnings"][0]
    g, lk = recs["garbage.step"], recs["locked.step"]
    assert (g["status"], g["error_class"], g["exit_code"]) == ("failed", "InputError", 1)
    assert "cannot parse STEP" in g["error"]
    assert lk["error_class"] == "InputError" and lk["error"] == "Permission denied"
    assert (total["files"], total["ok"], total["failed"], total["passthrough"]) == (5, 3, 2, 2)
    assert total["exit_code"] == 1 and total["bytes_out"] < total["bytes_in"]
    ok = [r for r in recs.values() if r["status"] == "ok"]
    assert total["bytes_in"] == sum(r["input_bytes"] for r in ok)
    assert total["ratio"] == pytest.approx(total["bytes_in"] / total["bytes_out"])
    errors = [line for line in err.splitlines() if line.startswith("error: ")]
    assert sorted(errors) == sorted(
        f"error: {src / 'sub' / n}: {recs[n]['error']}" for n in ("garbage.step", "locked.step")
    )
    assert sorted(p.relative_to(out).as_posix() for p in out.rglob("*.nzc")) == [
        "part.step.nzc",
        "sub/curve.stp.nzc",
        "tess.step.nzc",
    ]
    code, stdout, err = run("decompress", "-r", str(out), "-O", str(back), "-j", "1")
    assert code == 0, err
    assert "3 files: 3 ok (2 stored verbatim), 0 failed" in stdout
    assert (back / "tess.step").read_bytes() == TESSELLATED
    assert (back / "sub" / "curve.stp").read_bytes() == CURVE_ONLY
    assert (back / "part.step").read_bytes().startswith(b"ISO-10303-21;")
    # a second run skips what exists, --force redoes it
    code, stdout, _ = run("decompress", "-r", str(out), "-O", str(back), "--skip-existing")
    assert code == 0 and "3 skipped" in stdout
    code, stdout, err = run("decompress", "-r", str(out), "-O", str(back), "--json", "-j", "1")
    assert code == EXIT_OUTPUT and err.count("already exists") == 3
    code, stdout, _ = run("decompress", "-r", str(out), "-O", str(back), "--json", "-f", "-j", "1")
    assert code == 0 and lines(stdout)[1]["ok"] == 3
    assert no_temporary_files(tmp_path)


def test_internal_error_is_reported_with_its_class(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    shutil.copy(SAMPLES / "loft.step", tmp_path)

    def broken(*a: Any, **k: Any) -> Any:
        return 1 / 0

    monkeypatch.setattr(pipeline, "compress_file", broken)
    code, out, err = run("compress", "--json", str(tmp_path / "loft.step"))
    assert code == EXIT_INTERNAL
    rec = lines(out)[0]["loft.step"]
    assert rec["internal"] and rec["error_class"] == "ZeroDivisionError"
    assert err.strip().endswith("rerun with --debug for details")
    assert "Traceback" not in err
    code, out, err = run("--debug", "compress", str(tmp_path / "loft.step"))
    assert code == EXIT_INTERNAL and "Traceback (most recent call last)" in err and "1 / 0" in err


def test_debug_prints_the_real_traceback(tmp_path: Path) -> None:
    (tmp_path / "bad.step").write_bytes(b"garbage\n")
    (tmp_path / "bad.nzc").write_bytes(b"\x89NZC garbage")
    for args, want in (
        (["compress", str(tmp_path / "bad.step")], EXIT_INPUT),
        (["info", str(tmp_path / "bad.nzc")], EXIT_CONTAINER),
    ):
        code, _, err = run("--debug", *args)
        assert code == want
        assert "Traceback (most recent call last)" in err and "NoneType: None" not in err
        assert "Error: " in err  # the exception's class closes the traceback
        assert err.strip().splitlines()[-1].startswith("error: ")
        code, _, err = run(*args)
        assert "Traceback" not in err and len(err.strip().splitlines()) <= 2


# ---------------------------------------------------------------- outputs


@pytest.mark.parametrize("kind", ["symlink", "dangling", "fifo", "folder"])
def test_output_that_is_not_a_regular_file_is_refused(tmp_path: Path, kind: str) -> None:
    shutil.copy(SAMPLES / "loft.step", tmp_path)
    target = tmp_path / "target"
    target.write_bytes(b"keep me")
    out = tmp_path / "out.nzc"
    if kind == "symlink":
        out.symlink_to(target)
    elif kind == "dangling":
        out.symlink_to(tmp_path / "nowhere")
    elif kind == "fifo":
        os.mkfifo(out)
    else:
        out.mkdir()
    code, _, err = run("compress", "-f", "-q", str(tmp_path / "loft.step"), "-o", str(out))
    assert code == EXIT_OUTPUT
    assert len(err.strip().splitlines()) == 1
    if kind == "folder":
        assert "is a directory" in err
    else:
        assert "never replaced" in err and ("symbolic link" in err or "FIFO" in err)
    assert out.is_symlink() == (kind in ("symlink", "dangling"))
    assert target.read_bytes() == b"keep me"
    assert no_temporary_files(tmp_path)


# ---------------------------------------------------------------- real processes


def _cli(*args: str, **kw: Any) -> subprocess.CompletedProcess[bytes]:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    return subprocess.run(
        [sys.executable, "-m", "nurbscomp.cli", *args], env=env, capture_output=True, **kw
    )


@pytest.mark.slow
def test_streams(tmp_path: Path) -> None:
    """``cat part.step | nurbscomp compress - -c > part.nzc``, then
    ``nurbscomp decompress -c --format step part.nzc``."""
    step = (SAMPLES / "loft.step").read_bytes()
    r = _cli("compress", "-q", "-", "-c", input=step, timeout=300)
    assert r.returncode == 0, r.stderr
    nzc = tmp_path / "part.nzc"
    nzc.write_bytes(r.stdout)
    assert container.unpack(r.stdout).minor == container.MINOR
    r = _cli("decompress", "-c", "--format", "step", str(nzc), timeout=300)
    assert r.returncode == 0, r.stderr
    assert r.stdout.startswith(b"ISO-10303-21;") and b"END-ISO-10303-21;" in r.stdout
    r = _cli("decompress", "-", "-c", "--format", "iges", input=nzc.read_bytes(), timeout=300)
    assert r.returncode == 0 and r.stdout[72:73] == b"S"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["part.nzc"]
    # the passthrough of a stream: the same bytes back
    r = _cli("compress", "-q", "-", "-c", input=TESSELLATED, timeout=300)
    back = _cli("decompress", "-", "-c", "--format", "step", input=r.stdout, timeout=300)
    assert back.returncode == 0 and back.stdout == TESSELLATED


@pytest.mark.slow
def test_workers_interrupted_then_resumed(tmp_path: Path) -> None:
    """-j 2: Ctrl-C part-way exits 130 and leaves complete outputs only;
    --skip-existing then does only the files left."""
    src = tmp_path / "in"
    src.mkdir()
    # enough files that the batch is still busy when the first output appears
    # (a small file now takes well under a second)
    n = 4
    for i in range(n):
        shutil.copy(SAMPLES / "loft.step", src / f"loft{i}.step")
        shutil.copy(SAMPLES / "bracket.step", src / f"bracket{i}.step")
    out = tmp_path / "out"
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    cmd = [sys.executable, "-m", "nurbscomp.cli", "compress", "-q", "--no-verify"]
    cmd += ["-r", str(src), "-O", str(out)]
    p = subprocess.Popen(
        [*cmd, "-j", "2"],
        env=env,
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=default_signals,
    )
    deadline = time.time() + 300
    while not list(out.rglob("*.nzc")) and p.poll() is None and time.time() < deadline:
        time.sleep(0.01)
    assert p.poll() is None, "the batch ended before it could be interrupted"
    p.send_signal(signal.SIGINT)
    _, err = p.communicate(timeout=120)
    assert p.returncode == 130, err
    assert err.strip().splitlines()[-1].endswith("interrupted")
    assert no_temporary_files(tmp_path)
    done = sorted(f.name for f in out.glob("*.nzc"))
    assert 1 <= len(done) < 2 * n
    for f in out.glob("*.nzc"):
        container.unpack(f.read_bytes())  # complete containers only
    r = subprocess.run([*cmd, "-j", "2", "--skip-existing", "--json"], env=env, capture_output=True)
    assert r.returncode == 0, r.stderr
    recs, total = lines(r.stdout.decode())
    assert sorted(n + ".nzc" for n, x in recs.items() if x["status"] == "skipped") == done
    assert (total["files"], total["ok"] + total["skipped"], total["failed"]) == (2 * n, 2 * n, 0)
    assert len(list(out.glob("*.nzc"))) == 2 * n and no_temporary_files(tmp_path)


@pytest.mark.slow
def test_dask_local_cluster_gives_the_same_containers(tmp_path: Path) -> None:
    """The same batch through ``--scheduler`` on a LocalCluster of two workers:
    the same records and byte-identical containers."""
    distributed = pytest.importorskip("distributed")
    src = mixed_folder(tmp_path)
    code, out, _ = run(
        "compress", "-r", str(src), "-O", str(tmp_path / "local"), "-j", "1", "--json"
    )
    local, _ = lines(out)
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
    ) as cluster:
        args = [
            "-r",
            str(src),
            "-O",
            str(tmp_path / "dask"),
            "--scheduler",
            cluster.scheduler_address,
        ]
        code2, out, err = run("compress", *args, "--json")
    remote, total = lines(out)
    assert code2 == code == 1, err
    assert sorted(remote) == sorted(local)
    for name, r in remote.items():
        assert (r["status"], r.get("error_class")) == (
            local[name]["status"],
            local[name].get("error_class"),
        )
        assert r["input"] == local[name]["input"]
    assert total["ok"] == 3 and total["failed"] == 1
    a = sorted(p.relative_to(tmp_path / "local") for p in (tmp_path / "local").rglob("*.nzc"))
    b = sorted(p.relative_to(tmp_path / "dask") for p in (tmp_path / "dask").rglob("*.nzc"))
    assert a == b and len(a) == 3
    for rel in a:
        assert (tmp_path / "local" / rel).read_bytes() == (tmp_path / "dask" / rel).read_bytes()
    assert no_temporary_files(tmp_path)


def _batch_with_a_crash(
    src: Path, out: Path, barrier: Path, crash_after: str, hold: str = ""
) -> tuple[dict[str, dict[str, Any]], dict[str, Any], list[str]]:
    """``compress -r SRC -O OUT -j 2 --json`` with workers that die on
    ``crash.step`` once the files ``crash_after`` names hold or are done, and
    hold as ``hold`` says (``tests/crash_worker.py``); the records, the
    summary, and the files compressed, once per compress begun."""
    barrier.mkdir()
    code = (
        "import sys; from nurbscomp import batch, cli; "
        "batch.WORKER_PRELOAD += ('tests.crash_worker',); "
        "sys.argv = ['nurbscomp', *sys.argv[1:]]; cli.main()"
    )
    args = ["compress", "-r", str(src), "-O", str(out), "-j", "2", "--json"]
    env = {
        **os.environ,
        "PYTHONPATH": str(ROOT),
        "NURBSCOMP_TEST_BARRIER": str(barrier),
        "NURBSCOMP_TEST_CRASH_AFTER": crash_after,
        "NURBSCOMP_TEST_HOLD": hold,
    }
    r = subprocess.run(
        [sys.executable, "-c", code, *args], env=env, capture_output=True, cwd=ROOT, timeout=600
    )
    assert r.returncode == EXIT_INTERNAL, r.stderr
    recs, total = lines(r.stdout.decode())
    runs = (barrier / "runs").read_text().split()
    return recs, total, runs


@pytest.mark.slow
def test_a_worker_that_dies_fails_only_its_file(tmp_path: Path) -> None:
    """A worker killed on one file (as by a crash in OCCT) breaks the pool:
    the file in progress then is done again, the files finished are not, and
    only the file that killed its worker is reported failed.  Its worker dies
    once a.step and b.step are done and c.step has begun (and waits)."""
    src = tmp_path / "in"
    src.mkdir()
    for name in ("a.step", "crash.step", "b.step", "c.step"):
        shutil.copy(SAMPLES / "loft.step", src / name)
    out = tmp_path / "out"
    recs, total, runs = _batch_with_a_crash(
        src, out, tmp_path / "barrier", "a.step,b.step,c.step", "c.step:start"
    )
    assert recs["crash.step"]["error_class"] == "WorkerDied" and recs["crash.step"]["internal"]
    others = {n: x for n, x in recs.items() if n != "crash.step" and x["status"] != "ok"}
    assert not others, others  # a failure names its record (error class and message)
    assert sorted(recs) == ["a.step", "b.step", "c.step", "crash.step"]
    assert (total["ok"], total["failed"]) == (3, 1)
    assert sorted(p.name for p in out.iterdir()) == ["a.step.nzc", "b.step.nzc", "c.step.nzc"]
    # c.step was stopped in its first pool and done again; crash.step killed two
    assert sorted(runs) == ["a.step", "b.step", "c.step", "c.step", "crash.step", "crash.step"]
    assert no_temporary_files(tmp_path)


@pytest.mark.slow
@pytest.mark.parametrize("point", ["written", "sending"])
def test_a_file_its_dead_pool_finished_is_not_done_again(tmp_path: Path, point: str) -> None:
    """The race of issue 26: c.step's output is renamed into place, then the
    pool breaks (another worker dies) before c.step's record reaches this
    process, its worker stopped either before it returned the record
    (``written``) or as it sends it (``sending``).  The file is done: it
    keeps its record, and is not compressed again into "already exists".

    Three files for two workers: the pool watches a worker for its death
    from the next ``submit`` on (CPython 3.11 wakes its manager thread before
    it starts the worker), so with two files the death of the second worker
    could go unseen while c.step's worker holds."""
    src = tmp_path / "in"
    src.mkdir()
    for name in ("a.step", "c.step", "crash.step"):
        shutil.copy(SAMPLES / "loft.step", src / name)
    out = tmp_path / "out"
    recs, total, runs = _batch_with_a_crash(
        src, out, tmp_path / "barrier", "a.step,c.step", f"c.step:{point}"
    )
    c = recs["c.step"]
    assert c["status"] == "ok", c
    assert c["mode"] == "tolerance" and c["verified"] and c["output"] == str(out / "c.step.nzc")
    assert c["output_bytes"] == (out / "c.step.nzc").stat().st_size
    assert recs["crash.step"]["error_class"] == "WorkerDied"
    assert recs["a.step"]["status"] == "ok", recs["a.step"]
    assert (total["ok"], total["failed"], total["files"]) == (2, 1, 3)
    assert sorted(runs) == ["a.step", "c.step", "crash.step", "crash.step"]  # each once
    assert sorted(p.name for p in out.iterdir()) == ["a.step.nzc", "c.step.nzc"]
    container.unpack((out / "c.step.nzc").read_bytes())
    assert no_temporary_files(tmp_path)


def archive_round_trip(cad: Path, tmp_path: Path) -> dict[str, dict[str, Any]]:
    """``compress -r CAD MIXED -O OUT -j 2 --json`` over ``cad`` and a folder
    of generated and bad files, then ``decompress -r OUT -O BACK -j 2``; the
    compress records."""
    mixed = mixed_folder(tmp_path)
    out, back = tmp_path / "out", tmp_path / "back"
    r = _cli("compress", "-r", str(cad), str(mixed), "-O", str(out), "-j", "2", "--json")
    assert r.returncode == 1, r.stderr  # the garbage file
    recs, total = lines(r.stdout.decode())
    want = {p.name for p in batch.walk(cad, "compress")} | {
        p.name for p in batch.walk(mixed, "compress")
    }
    assert set(recs) == want
    failed = {n for n, x in recs.items() if x["status"] == "failed"}
    assert failed == {"garbage.step"}, {n: recs[n]["error"] for n in failed}
    assert not any(x.get("internal") for x in recs.values())
    assert total["failed"] == 1 and total["ok"] == len(want) - 1
    r = _cli("decompress", "-r", str(out), "-O", str(back), "-j", "2", "--json")
    assert r.returncode == 0, r.stderr
    assert lines(r.stdout.decode())[1]["ok"] == len(want) - 1
    assert (back / "tess.step").read_bytes() == TESSELLATED
    assert (back / "sub" / "curve.stp").read_bytes() == CURVE_ONLY
    for name, x in recs.items():
        if x["status"] == "ok" and not x.get("passthrough"):
            rel = Path(x["output"]).relative_to(out)
            cad_back = back / rel.parent / pipeline.default_decompressed_name(rel).name
            data = cad_back.read_bytes()  # STEP, or IGES for an IGES source (by its name)
            if cad_back.suffix.lower() in (".igs", ".iges"):
                assert data.splitlines()[0][72:73] == b"S", name
            else:
                assert data.startswith(b"ISO-10303-21;"), name
    assert no_temporary_files(tmp_path)
    return recs


@pytest.mark.corpus
@pytest.mark.slow
def test_corpus_archive_round_trip(tmp_path: Path) -> None:
    """The issue's "done when": corpus and generated files, -j 2, and back.
    The corpus files under 300 kB (three of the eleven, STEP and IGES, linked
    into a folder): the larger ones are compressed by the corpus tiers, and
    here they would only make the suite slower, not the batch runner surer."""
    from .conftest import CORPUS

    cad = tmp_path / "corpus"
    cad.mkdir()
    small = [p for p in sorted(CORPUS.iterdir()) if p.is_file() and p.stat().st_size < 300_000]
    small = [p for p in small if p.suffix.lower() in (".step", ".stp", ".igs", ".iges")]
    assert len({p.suffix.lower() for p in small} & {".igs", ".iges"}) and len(small) >= 3
    for p in small:
        (cad / p.name).symlink_to(p)
    archive_round_trip(cad, tmp_path / "work")


def _on_a_terminal(args: list[str], cwd: Path) -> tuple[int, str]:
    """Run the CLI with stderr on a pseudo-terminal (120 columns); its exit
    code and what the terminal showed."""
    import fcntl
    import pty
    import struct
    import termios

    master, slave = pty.openpty()
    fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", 40, 120, 0, 0))
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    p = subprocess.Popen(
        [sys.executable, "-m", "nurbscomp.cli", *args],
        env=env,
        cwd=cwd,
        stdout=subprocess.DEVNULL,
        stderr=slave,
    )
    os.close(slave)
    shown = b""
    while True:
        try:
            chunk = os.read(master, 4096)
        except OSError:  # the child closed the terminal
            break
        if not chunk:
            break
        shown += chunk
    os.close(master)
    return p.wait(timeout=300), shown.decode(errors="replace")


@pytest.mark.slow
def test_progress_bar_only_on_a_terminal(tmp_path: Path) -> None:
    """Files done, bytes and ratio so far, the file's stage: on a terminal
    once the batch has run a second; nothing with -q.  Four files, so that
    the batch outlasts the bar's one-second delay however fast it codes."""
    for copy in (1, 2, 3, 4):
        shutil.copy(SAMPLES / "loft.step", tmp_path / f"loft_{copy}.step")
    args = ["compress", "-r", ".", "-O", "out", "-j", "1", "--no-verify"]
    code, shown = _on_a_terminal(args, tmp_path)
    assert code == 0, shown
    # the rate: "1.2file/s, <bytes>, <ratio>]" or, below one file a second, "1.5s/file, ..."
    assert "file/s" in shown or "s/file" in shown, shown
    assert "/4 [" in shown and "x]" in shown  # files done of 4, and the ratio so far
    assert re.search(r"loft_\d\.step: (read|code|write|check)", shown), shown
    quiet = tmp_path / "quiet"  # one file is enough to show nothing
    quiet.mkdir()
    shutil.copy(SAMPLES / "loft.step", quiet / "loft.step")
    code, shown = _on_a_terminal([*args, "-q"], quiet)
    assert code == 0 and shown == "", shown
    assert (quiet / "out" / "loft.step.nzc").exists()


def test_largest_inputs_start_first(tmp_path: Path) -> None:
    """A pool gets the largest files first (ties and streams in their order), so
    that a long job does not start last and keep one worker busy alone."""
    sizes = {"a.step": 10, "b.step": 300, "c.step": 10, "d.step": 50}
    for name, n in sizes.items():
        (tmp_path / name).write_bytes(b"x" * n)
    tasks = [batch.Task(str(tmp_path / n), None) for n in sizes]
    tasks.insert(2, batch.Task(batch.STDIO, None))
    tasks.append(batch.Task(str(tmp_path / "missing.step"), None))
    order = [Path(t.src).name for t in batch.largest_first(tasks)]
    assert order == ["b.step", "d.step", "a.step", "c.step", "-", "missing.step"]
