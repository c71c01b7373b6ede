"""OCCT's STEP round trip in a forked child, so that a crash of OCCT's cannot
take the process down.

OCCT's STEP reader heals what it reads (``ShapeFix_Shape``), and its healing
can recurse without end: a faces-mode IGES model of 685 faces, coded at
0.01 mm and written as one STEP part, sent ``ShapeFix_Face::FixOrientation``
into a cycle of ``ShapeBuild_ReShape::Apply`` calls (a segmentation fault
once the stack is spent; with no stack limit, all memory).  The STEP check of
the encoder (``encode.validity``) writes and re-reads many such candidates,
so it makes each round trip in a child process forked for it
(:class:`RoundTrip`): the child writes the file, reads it back, keeps the
shape, and answers what the check asks of it (counts, validity, faulty faces,
face signatures).  If the child dies, :class:`ReaderCrash` says so, and the
check counts the candidate as one OCCT's reader cannot take.

The child is forked even when other threads run (a progress bar's, a
thread pool's): a fork copies only the calling thread, and a lock another
thread holds stays held in the child, but the child takes none of theirs.
It runs OCCT, pickle and a socket; OCP holds the GIL through every OCCT call,
so no other thread is inside OCCT (holding its mutexes) when this one forks;
the GIL, the import lock and malloc's are reset in a child by Python and
glibc.  Where there is no ``fork`` (Windows) or it is unsafe (macOS), the
round trip runs in this process, unguarded.
"""

from __future__ import annotations

import contextlib
import faulthandler
import gc
import math
import os
import pickle
import signal
import socket
import struct
import sys
import time
import warnings
from collections.abc import Callable
from typing import Any

from ..errors import InputError

_LEN = struct.Struct("<Q")
#: Seconds a child past its time limit still gets to answer (it may have made
#: its shape long ago, while its parent was busy).
GRACE = 2.0


class ReaderCrash(InputError):
    """OCCT's STEP round trip killed the process it ran in."""


class ReaderTimeout(ReaderCrash):
    """OCCT's STEP round trip did not answer within its time limit (its
    child is killed: OCCT's reader loops on some shapes)."""


def _send(sock: socket.socket, obj: Any) -> None:
    data = pickle.dumps(obj, protocol=pickle.HIGHEST_PROTOCOL)
    sock.sendall(_LEN.pack(len(data)) + data)


def _recv(sock: socket.socket) -> Any:
    head = _recv_exactly(sock, _LEN.size)
    return pickle.loads(_recv_exactly(sock, _LEN.unpack(head)[0]))


def _recv_exactly(sock: socket.socket, n: int) -> bytes:
    parts, got = [], 0
    while got < n:
        chunk = sock.recv(min(n - got, 1 << 20))
        if not chunk:
            raise EOFError
        parts.append(chunk)
        got += len(chunk)
    return b"".join(parts)


def can_fork() -> bool:
    """Whether a round trip runs in a forked child here (POSIX but macOS)."""
    return hasattr(os, "fork") and sys.platform != "darwin"


class _Cores:
    """Whether this process shares the cores with others that keep them busy
    (:func:`share_cores`)."""

    shared = False


def share_cores(shared: bool = True) -> None:
    """Say that this process is one of a pool that keeps every core busy (a
    batch's worker): :func:`spare_core` then answers False, so neither the
    validity stage's speculative STEP round trip nor a split build starts
    work that would cost the other files' time."""
    _Cores.shared = shared


def spare_core() -> bool:
    """Whether another core looks idle: none while the process shares the
    cores (:func:`share_cores`); else more than one usable, no other
    process's thread running right now on all the others (:func:`_others_running`),
    and a load average over the last minute at least half a core below
    their number.  With the other core busy a split build is some 5 % slower
    than a serial one (``topology.rebuild_pcurves``; the corpus's decode beside a CPU-bound process:
    3.31 s against 3.15 s), idle some 15 % faster (2.6 s against 3.0 s)."""
    if _Cores.shared:
        return False
    try:
        cores = len(os.sched_getaffinity(0))
        load = os.getloadavg()[0]
    except (AttributeError, OSError):  # no affinity or load average here
        return False
    return cores > 1 and load <= cores - 0.5 and _others_running() < cores - 1


#: Seconds a count of :func:`_others_running` stands: :func:`spare_core` is
#: asked at every validity round and split build, and a count read 4 ms of
#: ``/proc`` on a machine of 70 processes (126 counts, 0.5 s, over 38
#: compresses of small parts).
RUNNING_FOR = 0.5
_counted: list[float] = [-math.inf, 0.0]  # when, and what


def _others_running() -> int:
    """Threads of other processes running or runnable now (state ``R`` in
    Linux's ``/proc/PID/task/TID/stat``; 0 where there is no ``/proc``, which
    leaves the load average to say), but for niced ones, which yield the
    core (the validity stage's speculative round trip); a count made less
    than :data:`RUNNING_FOR` seconds ago stands."""
    now = time.monotonic()
    if now - _counted[0] < RUNNING_FOR:
        return int(_counted[1])
    me = os.getpid()
    try:
        pids = [int(p) for p in os.listdir("/proc") if p.isdigit() and int(p) != me]
    except OSError:
        return 0
    n = sum(_running(pid) for pid in pids)
    _counted[:] = [now, float(n)]
    return n


def _running(pid: int) -> int:
    """Threads of process ``pid`` running or runnable now and not niced (0 for
    a process gone meanwhile)."""
    n = 0
    try:
        for tid in os.listdir(f"/proc/{pid}/task"):
            with open(f"/proc/{pid}/task/{tid}/stat", "rb") as f:
                st = f.read()
            f3 = st[st.rindex(b")") + 2 :].split()  # fields 3 (state) on
            n += f3[0] == b"R" and int(f3[16]) <= 0  # field 19: niceness
    except (OSError, ValueError, IndexError):  # gone meanwhile
        return n
    return n


class RoundTrip:
    """The shape ``make()`` returns (OCCT's re-read of a STEP file), kept in a
    child process; :meth:`ask` runs a function of it there and returns its
    (picklable) result.

    Use as a context manager.  The child starts on ``make`` as the block is
    entered, so the caller may do other work before it asks; it is killed
    when the block ends, done or not (files it writes belong in a folder the
    caller removes afterwards).

    Raises
    ------
    ReaderCrash
        From :meth:`ask`, when the child died (a signal, or any exit) before
        it answered: the first question is answered once ``make`` returned.
    InputError
        From :meth:`ask`, when ``make`` raised one in the child (OCCT's
        reader refused the file): re-raised with its message.
    """

    def __init__(self, make: Callable[[], Any], nice: int = 0, limit: float | None = None) -> None:
        self._make = make
        self._nice = nice  # the child's niceness increment: work only a spare core should do
        #: Seconds the child may take to make its shape, from its start, and
        #: then to answer each question (None: no limit); past them, it is
        #: killed and :meth:`ask` raises ReaderTimeout.
        self.limit = limit
        self._started = 0.0
        self._answered = False
        self._local: Any = None
        self._pid = 0
        self._sock: socket.socket | None = None
        self._dead = ""
        self._timed_out = False

    def __enter__(self) -> RoundTrip:
        if not can_fork():
            self._local = self._make()
            return self
        parent, child = socket.socketpair()
        gc.freeze()  # the child's collections leave the parent's objects (and pages) alone
        pid = -1
        try:
            with warnings.catch_warnings():  # 3.12+: "multi-threaded, fork() may deadlock"
                warnings.simplefilter("ignore", DeprecationWarning)
                pid = os.fork()
        finally:
            if pid != 0:
                gc.unfreeze()
        if pid == 0:  # the child: never returns into the caller's code
            status = 1
            try:
                parent.close()
                faulthandler.disable()  # a crash here is reported by the parent, once
                for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
                    signal.signal(sig, signal.SIG_DFL)
                if self._nice:
                    os.nice(self._nice)
                status = _serve(child, self._make)
            finally:
                os._exit(status)
        child.close()
        self._pid, self._sock = pid, parent
        self._started = time.monotonic()
        return self

    @property
    def crashed(self) -> bool:
        """Whether the child died before answering."""
        return bool(self._dead)

    def ask(self, fn: Callable[[Any], Any]) -> Any:
        """``fn(shape)`` computed where the shape is."""
        if self._dead:
            raise (ReaderTimeout if self._timed_out else ReaderCrash)(self._dead)
        if self._sock is None:
            return fn(self._local)
        self._sock.settimeout(self._wait())
        try:
            _send(self._sock, fn)
            kind, value = _recv(self._sock)
            self._answered = True
        except TimeoutError:
            self._kill()
            self._timed_out = True
            self._dead = f"OCCT's STEP reader did not finish within {self.limit:g} s"
            raise ReaderTimeout(self._dead) from None
        except (EOFError, OSError):
            self._dead = self._reap()
            raise ReaderCrash(self._dead) from None
        if kind == "error":
            cls, msg = value
            raise (InputError if cls == "InputError" else RuntimeError)(msg)
        return value

    def _wait(self) -> float | None:
        """How long the next answer may take: what is left of :attr:`limit`
        since the child began, until it has answered once (with a grace of
        :data:`GRACE` seconds for an answer already made), then the limit."""
        if self.limit is None or self._answered:
            return self.limit
        return max(GRACE, self._started + self.limit - time.monotonic())

    def _reap(self) -> str:
        """Why the child is gone (it is waited for)."""
        _, status = os.waitpid(self._pid, 0)
        self._pid = 0
        if os.WIFSIGNALED(status):
            name = signal.Signals(os.WTERMSIG(status)).name
            return f"OCCT's STEP reader crashed ({name}) on the file it had written"
        return f"OCCT's STEP round trip ended early (exit status {os.WEXITSTATUS(status)})"

    def __exit__(self, *exc: object) -> None:
        """End the child at once, whatever it is doing: a round trip begun
        beside other work (the encoder's BRepCheck, say) may no longer be
        wanted, and its answers are never waited for here."""
        self._kill()
        self._local = None

    def _kill(self) -> None:
        if self._sock is not None:
            self._sock.close()
            self._sock = None
        if self._pid:
            with contextlib.suppress(ProcessLookupError):
                os.kill(self._pid, signal.SIGKILL)
            os.waitpid(self._pid, 0)
            self._pid = 0


def _serve(sock: socket.socket, make: Callable[[], Any]) -> int:
    """The child's loop: make the shape, then answer each function sent until None."""
    failure: tuple[str, str] | None = None
    shape: Any = None
    try:
        shape = make()
    except InputError as e:
        failure = ("InputError", str(e))
    while True:
        try:
            fn = _recv(sock)
        except EOFError:
            return 0
        if fn is None:
            return 0
        if failure is not None:
            _send(sock, ("error", failure))
            continue
        try:
            _send(sock, ("ok", fn(shape)))
        except Exception as e:  # reported to the parent, raised there
            _send(sock, ("error", (type(e).__name__, f"{type(e).__name__}: {e}")))
