"""Interrupts: SIGINT, SIGTERM and SIGHUP stop the command line at any moment.

``install`` (called by ``cli.main`` only: a library does not take over a
program's signals) makes each of them raise :class:`Interrupted`, a
``KeyboardInterrupt``, so that the output being written is removed on the way
out (``paths.atomic_output``), and remembers that it came.

Why remember: a signal can arrive inside code that turns exceptions into
reports.  While OCP loads, the ``KeyboardInterrupt`` raised in an extension
module's initialisation comes out as ``ImportError: initialization failed``,
which a reader wrapping every failure of OCCT would report as a bad input.
:func:`check`, called wherever a failure is about to be reported, raises the
interrupt instead.

Why deliver again: Python swallows an exception raised where nothing can
catch it (a weakref callback such as the import system's module-lock
cleanup, a ``__del__``, a garbage-collector callback) and only prints
``Exception ignored in ...``.  A signal whose handler runs there would be lost,
and the command would go on to finish and exit 0.  ``install`` therefore also
wraps ``sys.unraisablehook``: an :class:`Interrupted` that reaches it is
delivered to the main thread again a moment later (``REDELIVER_S``), out of
the context that swallowed it.
"""

from __future__ import annotations

import _thread
import signal
import sys
import threading
from typing import Any

#: The signals handled, with the exit status each gives (128 + its number).
HANDLED = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)

#: The first signal received since :func:`install` (None: none).
received: int | None = None

#: Delay before a swallowed interrupt is delivered again, in seconds: long
#: enough for the main thread to leave the callback that swallowed it.
REDELIVER_S = 0.05


class Interrupted(KeyboardInterrupt):
    """A stop signal, raised like Ctrl-C's ``KeyboardInterrupt``."""

    def __init__(self, signum: int) -> None:
        super().__init__(signum)
        self.signum = signum


def _handler(signum: int, frame: Any) -> None:
    global received
    if received is None:
        received = signum
    raise Interrupted(signum)


def _redeliver(signum: int) -> None:
    """Deliver ``signum`` to the main thread again, as if it came once more
    (the handler installed for it runs there)."""
    _thread.interrupt_main(signal.Signals(signum))


class _UnraisableHook:
    """``sys.unraisablehook`` that delivers a swallowed :class:`Interrupted`
    again instead of printing it, and hands anything else to the hook it
    replaced."""

    def __init__(self, previous: Any) -> None:
        self.previous = previous

    def __call__(self, args: Any) -> None:
        if isinstance(args.exc_value, Interrupted):
            timer = threading.Timer(REDELIVER_S, _redeliver, (args.exc_value.signum,))
            timer.daemon = True
            try:
                timer.start()
                return
            except RuntimeError:  # no new thread at interpreter shutdown: exiting anyway
                pass
        self.previous(args)


def install() -> None:
    """Handle SIGINT, SIGTERM and SIGHUP, unless they are ignored (a
    background job's SIGINT, ``nohup``'s SIGHUP stay ignored); deliver again an
    interrupt that Python swallowed (:class:`_UnraisableHook`)."""
    for sig in HANDLED:
        if signal.getsignal(sig) is not signal.SIG_IGN:
            signal.signal(sig, _handler)
    if not isinstance(sys.unraisablehook, _UnraisableHook):
        sys.unraisablehook = _UnraisableHook(sys.unraisablehook)


def signum_of(e: KeyboardInterrupt) -> int:
    """The signal a ``KeyboardInterrupt`` stands for: the first signal received
    since :func:`install`, whatever became of its exception on the way (one
    raised in a worker thread or an extension module comes back as a plain
    ``KeyboardInterrupt``, or as the interrupt of a later signal); SIGINT for
    a plain one with no signal received (Ctrl-C without :func:`install`)."""
    if received is not None:
        return received
    return e.signum if isinstance(e, Interrupted) else signal.SIGINT


def describe(signum: int) -> str:
    """How an interrupt is reported: ``interrupted``, ``interrupted (SIGTERM)``."""
    if signum == signal.SIGINT:
        return "interrupted"
    return f"interrupted ({signal.Signals(signum).name})"


def check() -> None:
    """Raise :class:`Interrupted` if a stop signal has come: call it before
    reporting a failure, which may be the signal's doing."""
    if received is not None:
        raise Interrupted(received)
