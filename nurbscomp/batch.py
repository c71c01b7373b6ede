"""Batches: many files and folders, worker processes, a Dask cluster, one record per file.

The CLI (``cli.py``) is thin wiring over this module:

* :func:`plan` expands the inputs (files, folders with ``recursive``, ``-``
  for standard input) into :class:`Task` s, each with its output path (beside
  the input, under ``output_dir`` mirroring the folder walked, ``output``, or
  standard output);
* :func:`run_task` does one file in this process and returns its record, a
  plain dict: the pipeline's report with ``status`` ``"ok"``, or, for a file
  that failed, ``status`` ``"failed"`` with the error's class, message and
  exit code (an unexpected exception is an ``internal`` error with its class);
* :class:`Runner` runs the tasks serially, in a process pool (workers forked
  from a fork server that imported OCP once, each taking many files) or on a
  Dask cluster (files sent as bytes), and yields the records as files finish;
* :func:`summary` adds them up.

Nothing here prints: the caller does, from the records.
"""

from __future__ import annotations

import concurrent.futures as cf
import contextlib
import itertools
import multiprocessing
import os
import pickle
import shutil
import signal
import tempfile
import time
import traceback
from collections.abc import Callable, Generator, Iterable, Iterator
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from . import budget, pipeline, signals
from .errors import EXIT_INPUT, EXIT_INTERNAL, InputError, NurbscompError, OutputError
from .formats import (
    BREP_SUFFIXES,
    FORMAT_SUFFIX,
    IGES_SUFFIXES,
    STEP_SUFFIXES,
    output_format,
    sniff_format,
)

#: What ``-r`` picks up in a folder, by command (case-insensitive suffixes).
WALK_SUFFIXES = {
    "compress": (*STEP_SUFFIXES, *IGES_SUFFIXES),
    "decompress": (pipeline.SUFFIX,),
    "test": (pipeline.SUFFIX,),
    "info": (pipeline.SUFFIX,),
}
#: The commands that read files and write none (their tasks have no output).
CHECKS = ("test", "info")
#: What the fork server of the worker processes imports before forking them.
WORKER_PRELOAD = ("nurbscomp.pipeline", "nurbscomp.occ", "nurbscomp.encode.validity")
#: The name standing for standard input and standard output.
STDIO = "-"
#: How long a worker may take to clean up after it is told to stop (seconds).
STOP_GRACE = 30.0
#: How long to wait for a Dask scheduler to answer (seconds).
CONNECT_TIMEOUT = 30


class UsageError(ValueError):
    """The inputs and options do not go together (the CLI exits 2)."""


class WorkerDied(RuntimeError):
    """The worker process doing a file died (a crash in OCCT, say): an
    internal error of that file."""


class SchedulerError(RuntimeError):
    """The Dask scheduler cannot be reached (the CLI exits 1, no file is done)."""


@dataclass(frozen=True)
class Options:
    """What every file of a batch is done with."""

    command: str  # "compress", "decompress", or "test" (no output)
    force: bool = False
    skip_existing: bool = False
    tol: float | None = pipeline.DEFAULT_TOL_MM
    lossless: bool = False  # the B-rep's numbers bit for bit (--lossless-brep)
    exact: bool = False  # the file byte for byte (--lossless)
    verify: bool = True
    step_safe: bool = True
    fmt: str | None = None  # decompress: "STEP", "IGES" or "BREP"
    debug: bool = False  # failures carry their traceback
    limit_scale: float = 1.0  # decompress, test: the decoding budget times this (--limit-scale)
    remove_input: bool = False  # --rm: remove each input once its output is written (verified)


@dataclass(frozen=True)
class Task:
    """One file: its input (``"-"``: standard input) and output (None: standard output)."""

    src: str
    dst: str | None
    make_parent: bool = False  # under -d: the output's folder is created


# ---------------------------------------------------------------- planning


def default_output(src: Path, opts: Options) -> Path:
    """The output beside ``src``: ``part.step.nzc``, or ``part.step`` (``.igs``,
    ``.brep`` with ``opts.fmt``)."""
    if opts.command == "compress":
        return pipeline.default_compressed_name(src)
    out = pipeline.default_decompressed_name(src)
    if opts.fmt is not None and output_format(out) != opts.fmt:
        out = out.with_suffix(FORMAT_SUFFIX[opts.fmt])
    return out


def cores() -> int:
    """The cores this process may run on (the default ``-j``)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def walk(folder: Path, command: str) -> list[Path]:
    """The files under ``folder`` that ``command`` takes, sorted, links to folders not followed."""
    suffixes = WALK_SUFFIXES[command]
    found = []
    for root, dirs, files in os.walk(folder):
        dirs.sort()
        found += [Path(root, f) for f in sorted(files) if f.lower().endswith(suffixes)]
    return found


def plan(
    inputs: list[str],
    opts: Options,
    *,
    recursive: bool = False,
    output: str | None = None,
    output_dir: str | None = None,
    to_stdout: bool = False,
) -> list[Task]:
    """The tasks for ``inputs`` (files, folders, ``-``), each with its output.

    A command that writes no output (``test``, ``info``) gets tasks whose
    output is None.

    Raises
    ------
    UsageError
        ``output`` with several inputs or a folder, ``output`` with
        ``output_dir``, ``-`` twice, standard output with several files,
        ``force`` with ``skip_existing``, standard input with ``output_dir``,
        ``remove_input`` with standard output or without verification.
    """
    if opts.force and opts.skip_existing:
        raise UsageError("--force and --skip-existing exclude each other")
    if opts.remove_input and (to_stdout or output == STDIO):
        raise UsageError("--rm and -c/--stdout exclude each other (the input is kept)")
    if opts.remove_input and opts.command == "compress" and not opts.verify:
        raise UsageError("--rm needs the output verified (drop --no-verify)")
    if output == STDIO:
        output, to_stdout = None, True
    if output is not None and output_dir is not None:
        raise UsageError("-o/--output and -O/--output-dir exclude each other")
    if inputs.count(STDIO) > 1:
        raise UsageError("standard input (-) can be read once")
    tasks: list[Task] = []
    for name in inputs:
        if name == STDIO:
            if output_dir is not None:
                raise UsageError("standard input (-) goes to standard output or -o, not -O")
            tasks.append(Task(STDIO, output))  # to standard output unless -o
            continue
        p = Path(name)
        if recursive and p.is_dir():
            if output is not None:
                raise UsageError("-o/--output takes a single input file, not a folder")
            for f in walk(p, opts.command):
                tasks.append(_task(f, f.relative_to(p).parent, opts, output_dir))
        else:
            tasks.append(_task(p, Path(), opts, output_dir))
    if output is not None and len(tasks) != 1:
        raise UsageError("-o/--output takes a single input file")
    if output is not None and opts.fmt is not None:
        known = (*STEP_SUFFIXES, *IGES_SUFFIXES, *BREP_SUFFIXES)
        if Path(output).suffix.lower() in known and output_format(output) != opts.fmt:
            raise UsageError(f"--format {opts.fmt.lower()} and the extension of -o disagree")
    if output is not None:
        tasks = [replace(tasks[0], dst=output)]
    if to_stdout:
        if len(tasks) != 1:
            raise UsageError("-c/--stdout takes a single input file")
        tasks = [replace(tasks[0], dst=None, make_parent=False)]
    return tasks


def largest_first(tasks: list[Task]) -> list[Task]:
    """``tasks`` with the largest inputs first (ties, and streams, in their
    order): the longest jobs start first, so that no worker is left with one
    at the end.  The corpus at 0.01 mm took 29.5 s with ``-j 2`` in name order,
    its second-largest file (15 s of the 45 s) starting ninth of eleven."""

    def size(t: Task) -> int:
        try:
            return -1 if t.src == STDIO else os.stat(t.src).st_size
        except OSError:
            return -1

    return sorted(tasks, key=size, reverse=True)


def _task(src: Path, rel: Path, opts: Options, output_dir: str | None) -> Task:
    if opts.command in CHECKS:  # no output
        return Task(str(src), None)
    out = default_output(src, opts)
    if output_dir is None:
        return Task(str(src), str(out))
    return Task(str(src), str(Path(output_dir) / rel / out.name), make_parent=True)


# ---------------------------------------------------------------- one file


def failure(e: BaseException, debug: bool = False) -> dict[str, Any]:
    """The record fields of a file that failed with ``e`` (called in its
    ``except``), with the exit code of its kind (``errors.EXIT_*``).

    Raises
    ------
    signals.Interrupted
        A stop signal has come: the failure may be its doing (an import cut
        short by Ctrl-C fails with ``ImportError``), and is not reported.
    """
    signals.check()
    if isinstance(e, NurbscompError):
        rec = {"error_class": type(e).__name__, "error": str(e), "exit_code": e.exit_code}
    elif isinstance(e, MemoryError):
        rec = {"error_class": "MemoryError", "error": "out of memory", "exit_code": EXIT_INPUT}
    else:  # a bug or an OCCT failure no check caught: reported with its class
        rec = {
            "error_class": type(e).__name__,
            "error": f"internal error ({type(e).__name__}: {e}); rerun with --debug for details",
            "exit_code": EXIT_INTERNAL,
            "internal": True,
        }
    if debug:
        rec["traceback"] = traceback.format_exc()
    return {"status": "failed", **rec}


def run_task(
    task: Task, opts: Options, stage: Callable[[str], None] | None = None
) -> dict[str, Any]:
    """Do one file here and now; its record (``status`` ok, skipped or failed).

    ``task.dst`` must be a path (standard output goes through :func:`run_bytes`),
    or None for a command that writes no output (``test``, ``info``).
    ``stage`` is told each stage of the file as it starts (``pipeline.compress_file``).
    ``KeyboardInterrupt`` (and so SIGTERM, SIGHUP in the CLI and in workers)
    is not caught: the output being written is removed on the way out.
    """
    if _stopping:
        raise KeyboardInterrupt
    src = Path(task.src)
    base = {"command": opts.command, "input": task.src, "output": task.dst}
    try:
        if opts.command in CHECKS:
            r = _check(src, opts)
            return {**r, **base, "status": "ok", "exit_code": 0, "input_bytes": src.stat().st_size}
        assert task.dst is not None
        dst = Path(task.dst)
        if opts.skip_existing and (dst.exists() or dst.is_symlink()):
            return {**base, "status": "skipped", "exit_code": 0, "reason": "output exists"}
        if src.is_dir():
            raise InputError("is a directory (-r walks it)")
        if task.make_parent:
            try:
                dst.parent.mkdir(parents=True, exist_ok=True)
            except OSError as e:
                raise OutputError(f"cannot make folder {dst.parent}: {e.strerror or e}") from None
        if opts.command == "compress":
            r = pipeline.compress_file(
                src,
                dst,
                tol=None if opts.lossless else opts.tol,
                lossless=opts.lossless,
                exact=opts.exact,
                force=opts.force,
                verify=opts.verify,
                step_safe=opts.step_safe,
                stage=stage,
            )
        else:
            limits = budget.DEFAULT.scaled(opts.limit_scale)
            r = pipeline.decompress_file(src, dst, force=opts.force, limits=limits, stage=stage)
    except Exception as e:  # one file's failure, reported in its record (MemoryError too)
        return {**base, **failure(e, opts.debug)}
    if "input_bytes" not in r:
        r["input_bytes"] = src.stat().st_size
    r.setdefault("passthrough", False)
    return {**r, **base, "status": "ok", "exit_code": 0}


def _check(src: Path, opts: Options) -> dict[str, Any]:
    """``test`` or ``info`` of one container (no output)."""
    limits = budget.DEFAULT.scaled(opts.limit_scale)
    if opts.command == "test":
        return pipeline.test_file(src, limits)
    return pipeline.info(src, limits)


def run_bytes(
    name: str, data: bytes, opts: Options, out_name: str | None = None
) -> tuple[dict[str, Any], bytes | None]:
    """Do one file given as bytes, in a private scratch folder; its record and the
    output's bytes (None if it failed).

    The same work as :func:`run_task`, for inputs and outputs that are not
    files here: standard input and output, and Dask workers (no shared disk).
    ``name`` is the input's file name (it is stored in the container and
    tells the format); ``out_name`` the output's (its extension gives the
    format; default :func:`default_output`'s).  The record's paths are the
    scratch folder's, for the caller to replace.
    """
    with tempfile.TemporaryDirectory(prefix="nurbscomp.") as scratch:
        src = Path(scratch) / "in" / (Path(name).name or "stdin")
        src.parent.mkdir()
        src.write_bytes(data)
        scratch_opts = replace(opts, force=False, skip_existing=False, remove_input=False)
        if opts.command in CHECKS:
            return run_task(Task(str(src), None), scratch_opts), None
        out = Path(scratch) / (Path(out_name).name if out_name else _output_name(src, opts))
        rec = run_task(Task(str(src), str(out)), scratch_opts)
        return rec, out.read_bytes() if rec["status"] == "ok" else None


def _output_name(src: Path, opts: Options) -> str:
    """The name of an output with no name of its own (standard output): by
    :func:`default_output`, in the format of the container's source when
    ``decompress`` is given no format (``decompress -c``)."""
    out = default_output(src, opts)
    if opts.command == "decompress" and opts.fmt is None:
        try:
            fmt = pipeline.source_format(src)
        except NurbscompError:  # the decode fails on it again, with its own message
            return out.name
        out = out.with_suffix(FORMAT_SUFFIX[fmt])
    return out.name


def stdin_name(data: bytes, opts: Options) -> str:
    """A file name for standard input's bytes: ``stdin.step``, ``stdin.igs`` by
    content (``stdin.nzc`` to decompress; ``stdin`` when neither applies: the
    pipeline then refuses it as it refuses such a file)."""
    if opts.command == "decompress":
        return "stdin" + pipeline.SUFFIX
    try:
        fmt = sniff_format(Path("stdin"), data[: 1 << 16])
    except InputError:
        return "stdin"
    return "stdin" + FORMAT_SUFFIX[fmt]


def deliver(rec: dict[str, Any], blob: bytes, task: Task, opts: Options) -> dict[str, Any]:
    """Write ``blob`` (made elsewhere) to ``task.dst`` atomically; the record with
    the real paths, or a failure if the output cannot be written."""
    assert task.dst is not None
    dst = Path(task.dst)
    rec = {**rec, "input": task.src, "output": task.dst}
    try:
        if task.make_parent:
            dst.parent.mkdir(parents=True, exist_ok=True)
        inputs = (Path(task.src),) if task.src != STDIO else ()
        with pipeline.atomic_output(dst, opts.force, inputs) as tmp:
            tmp.write_bytes(blob)
    except (OSError, NurbscompError) as e:
        if isinstance(e, OSError):
            e = OutputError(f"cannot write {dst}: {e.strerror or e}")
        return {**rec, **failure(e, opts.debug)}
    return rec


# ---------------------------------------------------------------- workers

#: Set in a worker process once it has been told to stop: tasks not started are refused.
_stopping = False
#: In a worker, while :func:`_pool_task` does a file: its output's path, and
#: what was at that path when the file began (:func:`_identity`).
_doing: tuple[str, tuple[int, int] | None] | None = None


def _identity(path: str) -> tuple[int, int] | None:
    """What is at ``path`` (device and inode, the link itself), or None."""
    try:
        st = os.lstat(path)
    except OSError:
        return None
    return st.st_dev, st.st_ino


def _output_in_place() -> bool:
    """Whether the file being done has renamed its output into place: its
    output's path holds another file than when the file began.  (Another
    process putting a file there meanwhile would look the same; the file
    would then run on to its end before it stops.)"""
    if _doing is None:
        return False
    dst, before = _doing
    now = _identity(dst)
    return now is not None and now != before


def _stop_worker(signum: int, frame: Any) -> None:
    """SIGINT/SIGTERM/SIGHUP in a worker: the task running raises
    ``KeyboardInterrupt`` (its output's temporary file is removed on the way
    out) and no further task starts.  A second signal is ignored so that it
    cannot cut that clean-up short.

    A file whose output is already renamed into place is done: it is not
    interrupted but finishes (a few dictionaries), so that :func:`_pool_task`
    writes its record to the journal before the worker stops."""
    global _stopping
    if _stopping:
        return
    _stopping = True
    if _output_in_place():
        return
    raise KeyboardInterrupt


def _pool_task(task: Task, opts: Options, journal: str, key: str) -> dict[str, Any]:
    """:func:`run_task` in a pool worker; its record is also written to the
    journal (``journal/KEY.rec``) before it is returned.

    A pool that breaks (a worker died) fails every task whose result it has
    not read, also a task finished, or finished by a worker that the broken
    pool then stopped: the journal keeps their records for :class:`Runner`."""
    global _doing
    # a check (test) writes no output: nothing to be in place
    _doing = (task.dst, _identity(task.dst)) if task.dst is not None else None
    try:
        rec = run_task(task, opts)
        _write_journal(Path(journal), key, rec)
    finally:
        _doing = None
    if _stopping:  # told to stop once the output was in place (_stop_worker)
        raise KeyboardInterrupt
    return rec


def _write_journal(folder: Path, key: str, rec: dict[str, Any]) -> None:
    """Keep ``rec`` as ``folder/KEY.rec``, whole or not at all.  A journal that
    cannot be written only loses the record if the pool also breaks (the
    file is then done again)."""
    tmp = folder / f"{key}.tmp"
    try:
        tmp.write_bytes(pickle.dumps(rec))
        os.replace(tmp, folder / f"{key}.rec")
    except OSError:
        pass


def _read_journal(folder: Path, key: str) -> dict[str, Any] | None:
    """The record a worker kept as ``folder/KEY.rec``, or None."""
    try:
        data = (folder / f"{key}.rec").read_bytes()
    except FileNotFoundError:
        return None
    rec: dict[str, Any] = pickle.loads(data)  # written by this batch's workers
    return rec


def _init_worker() -> None:
    """A pool worker: handle the stop signals; OCP is imported already (the fork
    server preloads it, ``WORKER_PRELOAD``), or here, once for all its files.
    The workers keep the cores busy, so the process says so
    (``occ.share_cores``): the validity stage then begins no STEP round trip
    it may not need, and a build forks no child to share its projections."""
    for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
        signal.signal(sig, _stop_worker)
    from . import occ

    occ.read_cad  # noqa: B018 (the import itself: seconds, once per worker)
    occ.share_cores()


# ---------------------------------------------------------------- running


class Runner:
    """Run tasks and yield their records as they finish.

    Parameters
    ----------
    tasks : list of Task
    opts : Options
    jobs : int
        Worker processes; 1 (or a single task) runs here, in this process.
    scheduler : str, optional
        A Dask scheduler's address (``tcp://HOST:PORT``): the files are sent
        to its workers as bytes and the outputs written here.
    read_stdin : callable, optional
        Returns standard input's bytes (for a task whose input is ``-``).
    stage : callable, optional
        Told ``"NAME: STAGE"`` as each stage of a file done in this process
        starts (not in workers).

    Attributes
    ----------
    running : list of str
        The inputs being worked on (for the CLI to name on an interrupt).
    """

    def __init__(
        self,
        tasks: list[Task],
        opts: Options,
        jobs: int = 1,
        scheduler: str | None = None,
        read_stdin: Any = None,
        stage: Callable[[str], None] | None = None,
    ) -> None:
        self.tasks, self.opts, self.scheduler = tasks, opts, scheduler
        self.jobs = max(1, min(jobs, len(tasks)))
        self.read_stdin = read_stdin
        self.stage = stage
        self.running: list[str] = []
        self._reported: set[tuple[str, str]] = set()
        # what each output is before the batch: an output found replaced after
        # an interrupt was renamed into place complete (settled)
        self._before = {t.dst: _identity(t.dst) for t in tasks if t.dst is not None}
        # the folders -O will make: those left empty at the end are removed
        self._new_folders = _missing_folders(t.dst for t in tasks if t.make_parent and t.dst)
        self._keys = itertools.count()  # a journal entry per task submitted to a pool

    def records(self) -> Generator[tuple[dict[str, Any], bytes | None], None, None]:
        """``(record, output bytes)`` per task; the bytes only for a task whose
        output is standard output (the caller writes them).  With
        ``opts.remove_input`` (``--rm``), each input whose output is written
        (and verified, by ``compress``) is removed as its record is yielded."""
        if self.scheduler is not None:
            inner = self._dask()
        elif self.jobs == 1:
            inner = self._serial()
        else:
            inner = self._pool()
        try:
            for rec, blob in inner:
                if self.opts.remove_input and rec["status"] == "ok":
                    rec = remove_input(rec)
                yield rec, blob
                # reported once the caller asks for the next: an interrupt
                # while it reports this one leaves it to settled()
                self._reported.add((rec["input"], rec["output"] or STDIO))
        finally:
            inner.close()
            _remove_empty(self._new_folders)

    def settled(self) -> list[dict[str, Any]]:
        """After an interrupt: the records of the tasks not yet reported whose
        output was renamed into place before it (the file is complete and
        verified: the rename is the last step), as ``ok`` records with
        ``"interrupted": True``; their inputs are not removed."""
        out = []
        for t in self.tasks:
            if t.dst is None or (t.src, t.dst) in self._reported:
                continue
            now = _identity(t.dst)
            if now is None or now == self._before.get(t.dst):
                continue
            self._reported.add((t.src, t.dst))
            out.append(
                {
                    "command": self.opts.command,
                    "input": t.src,
                    "output": t.dst,
                    "status": "ok",
                    "exit_code": 0,
                    "interrupted": True,
                    "passthrough": False,
                    "input_bytes": _size(t.src),
                    "output_bytes": _size(t.dst),
                }
            )
        return out

    def _serial(self) -> Generator[tuple[dict[str, Any], bytes | None], None, None]:
        for t in self.tasks:
            self.running = [t.src]
            if t.src == STDIO or (t.dst is None and self.opts.command not in CHECKS):
                yield self._via_bytes(t)
            else:
                yield run_task(t, self.opts, self._stage_of(t)), None
            self.running = []

    def _stage_of(self, t: Task) -> Callable[[str], None] | None:
        """The stage callback for ``t``: ``stage("part.step: code")``."""
        tell = self.stage
        if tell is None:
            return None
        name = Path(t.src).name
        return lambda what: tell(f"{name}: {what}")

    def _via_bytes(self, t: Task) -> tuple[dict[str, Any], bytes | None]:
        """A task reading standard input or writing standard output, done here."""
        try:
            if t.src == STDIO:
                data = self.read_stdin()
                name = stdin_name(data, self.opts)
            else:
                data, name = _read_input(Path(t.src)), Path(t.src).name
        except NurbscompError as e:
            return self._failed(t, e), None
        if t.dst is not None:  # stdin to a file: refuse an output in the way first
            try:
                pipeline.check_output(Path(t.dst), self.opts.force)
            except NurbscompError as e:
                return self._failed(t, e), None
        rec, blob = run_bytes(name, data, self.opts, t.dst)
        rec = {**rec, "input": t.src, "output": t.dst or STDIO}
        if blob is None or t.dst is None:
            return rec, blob
        return deliver(rec, blob, t, self.opts), None

    def _failed(self, t: Task, e: Exception) -> dict[str, Any]:
        base = {"command": self.opts.command, "input": t.src, "output": t.dst or STDIO}
        return {**base, **failure(e, self.opts.debug)}

    def _pool(self) -> Generator[tuple[dict[str, Any], bytes | None], None, None]:
        """The tasks in ``jobs`` worker processes.  A worker that dies (a crash
        in OCCT, say) breaks the pool and every task whose result the pool has
        not read.  Those that a worker finished all the same (their output
        renamed into place, their record in the journal, :func:`_pool_task`)
        are done: their records are the journal's.  Each of the others is run
        again alone, in a pool of its own, so that only the file that kills its
        worker is reported failed, and no file is done twice."""
        journal = Path(tempfile.mkdtemp(prefix="nurbscomp.journal."))
        try:
            broken: list[Task] = []
            yield from self._in_pool(self.tasks, self.jobs, broken, journal)
            for t in list(broken):
                yield from self._in_pool([t], 1, None, journal)
        finally:
            shutil.rmtree(journal, ignore_errors=True)

    def _in_pool(
        self, tasks: list[Task], jobs: int, broken: list[Task] | None, journal: Path
    ) -> Iterator[tuple[dict[str, Any], bytes | None]]:
        """Run ``tasks`` in a pool of ``jobs`` workers; the tasks the pool
        breaks on that no worker finished are added to ``broken`` (None:
        reported failed)."""
        # Workers are forked from a fork server that has imported OCP and the
        # coder once (no fork of this process, which may have threads): N
        # workers cost one import, not N.
        ctx = multiprocessing.get_context("forkserver")
        ctx.set_forkserver_preload(list(WORKER_PRELOAD))
        ex = cf.ProcessPoolExecutor(jobs, mp_context=ctx, initializer=_init_worker)
        done = False
        futures: dict[cf.Future[dict[str, Any]], tuple[Task, str]] = {}
        lost: list[tuple[Task, str, str]] = []  # broken on: task, journal key, why
        try:
            for t in largest_first(tasks):
                key = str(next(self._keys))
                futures[ex.submit(_pool_task, t, self.opts, str(journal), key)] = (t, key)
            for f in cf.as_completed(futures):
                try:
                    rec = f.result()
                except BrokenProcessPool as e:
                    lost.append((*futures[f], str(e)))
                    continue
                yield rec, None
            done = True
        finally:
            if done:
                ex.shutdown(wait=True)
            else:  # interrupted: name the files started, stop the workers
                self.running = [futures[f][0].src for f in futures if f.running()]
                _stop_pool(ex)
        # Every worker has exited (a broken pool stops them all, and shutdown
        # waits for them): the journal holds every record they will ever write.
        for t, key, why in lost:
            kept = _read_journal(journal, key)
            if kept is not None:
                yield kept, None
            elif broken is not None:
                broken.append(t)
            else:
                yield self._failed(t, WorkerDied(why)), None

    def _dask(self) -> Generator[tuple[dict[str, Any], bytes | None], None, None]:
        from distributed import Client, as_completed

        try:
            client = Client(self.scheduler, set_as_default=False, timeout=CONNECT_TIMEOUT)
        except (OSError, TimeoutError, ValueError) as e:
            raise SchedulerError(f"cannot connect to the Dask scheduler: {e}") from None
        futures: dict[Any, Task] = {}
        try:
            for t in largest_first(self.tasks):
                if t.src == STDIO or t.dst is None:  # a stream: done here
                    yield self._via_bytes(t)
                    continue
                rec = self._client_side_checks(t)
                if rec is not None:
                    yield rec, None
                    continue
                try:
                    data = _read_input(Path(t.src))
                except NurbscompError as e:
                    yield self._failed(t, e), None
                    continue
                name = Path(t.src).name
                futures[client.submit(run_bytes, name, data, self.opts, t.dst, pure=False)] = t
            self.running = [t.src for t in futures.values()]
            for fut in as_completed(list(futures), loop=client.loop):
                t = futures.pop(fut)
                self.running.remove(t.src)
                try:
                    rec, blob = fut.result()
                except Exception as e:  # the task itself failed (a worker lost): report it
                    yield self._failed(t, e), None
                    continue
                rec = {**rec, "input": t.src, "output": t.dst}
                yield (deliver(rec, blob, t, self.opts) if blob is not None else rec), None
        finally:
            client.cancel(list(futures))
            client.close()

    def _client_side_checks(self, t: Task) -> dict[str, Any] | None:
        """What this machine decides before a file is sent: skip it, or refuse its output."""
        assert t.dst is not None
        dst = Path(t.dst)
        base = {"command": self.opts.command, "input": t.src, "output": t.dst}
        if self.opts.skip_existing and (dst.exists() or dst.is_symlink()):
            return {**base, "status": "skipped", "exit_code": 0, "reason": "output exists"}
        try:
            pipeline.check_output(dst, self.opts.force, (Path(t.src),))
        except NurbscompError as e:
            return self._failed(t, e)
        return None


def _size(path: str) -> int:
    """The size of a file, 0 if it is not there (or is standard input)."""
    try:
        return os.stat(path).st_size if path != STDIO else 0
    except OSError:
        return 0


def _missing_folders(outputs: Iterable[str]) -> list[Path]:
    """The folders above ``outputs`` that do not exist yet, deepest first."""
    missing: set[Path] = set()
    for out in outputs:
        p = Path(out).parent
        while p != p.parent and p not in missing and not p.exists():
            missing.add(p)
            p = p.parent
    return sorted(missing, key=lambda p: len(p.parts), reverse=True)


def _remove_empty(folders: list[Path]) -> None:
    """Remove those of ``folders`` (deepest first) that are empty: the mirrored
    folders of files that failed or were interrupted (``rmdir`` refuses the others)."""
    for f in folders:
        with contextlib.suppress(OSError):
            f.rmdir()


def remove_input(rec: dict[str, Any]) -> dict[str, Any]:
    """``--rm``: remove the input of a file done (``rec``, status ok) once its
    output is written, and, by ``compress``, verified; a warning in the record
    where it is not (standard input, an unverified output, an OS refusal)."""
    src = rec["input"]
    why = None
    if src == STDIO or rec["output"] in (None, STDIO):
        why = "standard input or output"
    elif rec["command"] == "compress" and not rec.get("verified"):
        why = "the output was not verified"
    else:
        try:
            os.unlink(src)
        except OSError as e:
            why = e.strerror or str(e)
        else:
            return {**rec, "input_removed": True}
    return {
        **rec,
        "input_removed": False,
        "warnings": [*rec.get("warnings", []), f"input kept: {why}"],
    }


def _read_input(p: Path) -> bytes:
    """The bytes of an input file sent elsewhere (the errors ``read_cad`` gives)."""
    if not p.exists():
        raise InputError("no such file")
    if p.is_dir():
        raise InputError("is a directory")
    try:
        return p.read_bytes()
    except OSError as e:
        raise InputError(e.strerror or str(e)) from None


def _stop_pool(ex: cf.ProcessPoolExecutor) -> None:
    """Stop a pool on an interrupt: each worker is told to stop (SIGTERM) and
    removes the output it was writing; waits for them (``STOP_GRACE``), and
    kills one that does not stop."""
    procs = list(getattr(ex, "_processes", {}).values())  # the stdlib has no public handle
    for p in procs:
        if p.is_alive():
            os.kill(p.pid, signal.SIGTERM)
    ex.shutdown(wait=False, cancel_futures=True)
    deadline = time.monotonic() + STOP_GRACE
    for p in procs:
        p.join(max(0.0, deadline - time.monotonic()))
        if p.is_alive():
            p.kill()
            p.join()


# ---------------------------------------------------------------- summary


def summary(records: list[dict[str, Any]], seconds: float) -> dict[str, Any]:
    """The batch in one record: files ok, failed, skipped, stored verbatim;
    bytes in and out; the total ratio (uncoded ÷ coded bytes); wall time;
    the worst exit code."""
    ok = [r for r in records if r["status"] == "ok"]
    bytes_in = sum(r.get("input_bytes", 0) for r in ok)
    bytes_out = sum(r.get("output_bytes", 0) for r in ok)
    command = records[0]["command"] if records else ""
    big, small = (bytes_out, bytes_in) if command == "decompress" else (bytes_in, bytes_out)
    return {
        "summary": True,
        "command": command,
        "files": len(records),
        "ok": len(ok),
        "failed": sum(r["status"] == "failed" for r in records),
        "skipped": sum(r["status"] == "skipped" for r in records),
        "passthrough": sum(bool(r.get("passthrough")) for r in ok),
        "bytes_in": bytes_in,
        "bytes_out": bytes_out,
        "ratio": big / small if small else None,
        "seconds": seconds,
        "exit_code": max((r["exit_code"] for r in records), default=0),
    }
