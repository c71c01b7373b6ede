"""Run fuzz cases in worker processes that may hang or die (``tests.fuzz``,
``tests.fuzz_text``): a case that runs past its time or kills its worker is a
failure, and the rest of its chunk goes on in a new worker."""

from __future__ import annotations

import signal
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


class Hang(BaseException):
    """A worker's case ran past its time (raised by the alarm)."""


def supervise(
    cases: int,
    jobs: int,
    timeout: float,
    chunk: int,
    command: Callable[[int, int], list[str]],
    title: str,
    seed: int,
    whole: bool = False,
) -> int:
    """Run ``cases`` cases in chunks, ``jobs`` worker processes at a time
    (``command(first, count)``: a worker printing ``start K`` and ``done K
    OUTCOME`` lines); a case that hangs past ``timeout`` or kills its worker is a
    failure, and its chunk resumes after it.  Print a summary, outcomes counted
    by their first word (``whole``: by the whole outcome); 1 if any failed."""
    t0 = time.time()
    results: dict[int, str] = {}
    todo = [(a, min(chunk, cases - a)) for a in range(0, cases, chunk)]
    running: list[tuple[subprocess.Popen[str], int, int]] = []
    while todo or running:
        while todo and len(running) < jobs:
            first, n = todo.pop(0)
            p = subprocess.Popen(command(first, n), cwd=ROOT, stdout=subprocess.PIPE, text=True)
            running.append((p, first, n))
        p, first, n = running.pop(0)
        last = _collect(p, results, timeout)
        end = first + n
        if last is not None and last + 1 < end:  # died or hung in case `last`
            todo.insert(0, (last + 1, end - last - 1))
        print(f"{len(results)} cases, {time.time() - t0:.0f} s", file=sys.stderr, flush=True)
    fails = {k: v for k, v in sorted(results.items()) if v.startswith("FAIL")}
    kinds: dict[str, int] = {}
    for v in results.values():
        key = "FAIL" if v.startswith("FAIL") else v if whole else v.split(" ")[0]
        kinds[key] = kinds.get(key, 0) + 1
    print(f"{title}: {len(results)} cases, seed {seed}, {time.time() - t0:.0f} s")
    print("outcomes: " + ", ".join(f"{k} {v}" for k, v in sorted(kinds.items())))
    print(f"failures: {len(fails)}")
    for k, v in fails.items():
        print(f"  case {k}: {v}")
    return 1 if fails else 0


def _collect(p: subprocess.Popen[str], results: dict[int, str], timeout: float) -> int | None:
    """Read a worker's lines; on a hang or crash, record its case as failed and
    return it (the caller resumes after it)."""
    assert p.stdout is not None
    current = None

    def on_alarm(signum: int, frame: object) -> None:
        raise Hang

    old = signal.signal(signal.SIGALRM, on_alarm)
    try:
        signal.setitimer(signal.ITIMER_REAL, timeout)
        for line in p.stdout:
            word, case, *rest = line.rstrip("\n").split(" ", 2)
            if word == "start":
                current = int(case)
                signal.setitimer(signal.ITIMER_REAL, timeout)
            elif word == "done":
                results[int(case)] = rest[0] if rest else ""
                current = None
        p.wait()
    except Hang:
        p.kill()
        p.wait()
        if current is not None:
            results[current] = f"FAIL timeout after {timeout:g} s"
        return current
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)
    if current is not None:  # the worker died inside a case
        results[current] = f"FAIL worker died (exit {p.returncode})"
        return current
    return None
