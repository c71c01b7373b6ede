"""Imported by a worker pool's fork server in ``tests/test_batch.py``: the
workers then die (SIGKILL, as a crash in OCCT would end them) on any input
named ``crash.step``.

The environment orders events across the workers with marker files, so that
no timing decides what a test sees:

``NURBSCOMP_TEST_BARRIER``
    A folder for the markers: ``NAME.done`` once NAME's compress has
    returned, ``NAME.held`` once NAME's worker holds (below); and ``runs``,
    one line per compress begun (the file's name).
``NURBSCOMP_TEST_CRASH_AFTER``
    Names, comma-separated: the worker of ``crash.step`` dies only once each
    of them holds (``NAME.held``, for a name in ``NURBSCOMP_TEST_HOLD``) or
    is done (``NAME.done``).  Unset: it dies at once.
``NURBSCOMP_TEST_HOLD``
    ``NAME:POINT``, comma-separated: the first time NAME is done, its worker
    stops at POINT and waits there until it is told to stop (the pool broke):

    * ``start``: before NAME is compressed, so that it is in progress;
    * ``written``: once its output has been renamed into place, before its
      record is returned;
    * ``sending``: once its record is on its way back to the parent process
      (the pool has not read it).

A wait that lasts ``WAIT`` seconds raises ``RuntimeError``: the test then
fails on that file's record instead of hanging.
"""

from __future__ import annotations

import concurrent.futures.process as cfp
import os
import signal
import time
from pathlib import Path
from typing import Any

from nurbscomp import batch, pipeline

#: The longest a worker waits for a marker or to be told to stop (seconds).
WAIT = 120.0

_compress = pipeline.compress_file
_sendback = cfp._sendback_result  # type: ignore[attr-defined]


def _env_list(name: str) -> list[str]:
    return [x for x in os.environ.get(name, "").split(",") if x]


def _barrier() -> Path | None:
    folder = os.environ.get("NURBSCOMP_TEST_BARRIER")
    return Path(folder) if folder else None


def _holds() -> dict[str, str]:
    return dict(x.split(":", 1) for x in _env_list("NURBSCOMP_TEST_HOLD"))


def _wait_for(test: Any, what: str) -> None:
    deadline = time.monotonic() + WAIT
    while not test():
        if time.monotonic() > deadline:
            raise RuntimeError(f"crash_worker: waited {WAIT:g} s for {what}")
        time.sleep(0.01)


def _hold(name: str, point: str) -> None:
    """Wait at ``point`` until this worker is told to stop, if ``name`` is held
    there and was not held before (a file held once runs freely when re-run)."""
    folder = _barrier()
    if folder is None or _holds().get(name) != point:
        return
    try:
        (folder / f"{name}.held").open("x").close()
    except FileExistsError:
        return
    # the stop signal either raises KeyboardInterrupt here or, if batch lets
    # the file finish first, sets batch._stopping
    _wait_for(lambda: batch._stopping, f"{name} to be stopped at {point}")


def _crash() -> None:
    folder = _barrier()
    if folder is not None:
        holds = _holds()
        marks = [
            folder / f"{n}.{'held' if n in holds else 'done'}"
            for n in _env_list("NURBSCOMP_TEST_CRASH_AFTER")
        ]
        _wait_for(lambda: all(m.exists() for m in marks), ", ".join(m.name for m in marks))
    os.kill(os.getpid(), signal.SIGKILL)


def _compress_or_die(src: Any, *a: Any, **k: Any) -> Any:
    name = Path(src).name
    folder = _barrier()
    if folder is not None:
        with open(folder / "runs", "a") as f:
            f.write(name + "\n")
    if name == "crash.step":
        _crash()
    _hold(name, "start")
    r = _compress(src, *a, **k)
    if folder is not None:
        (folder / f"{name}.done").touch()
    _hold(name, "written")
    return r


def _sendback_or_hold(result_queue: Any, work_id: Any, result: Any = None, **k: Any) -> None:
    if isinstance(result, dict) and "input" in result:
        _hold(Path(result["input"]).name, "sending")
    _sendback(result_queue, work_id, result=result, **k)


pipeline.compress_file = _compress_or_die
cfp._sendback_result = _sendback_or_hold  # type: ignore[attr-defined]
