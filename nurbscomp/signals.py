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
"""

from __future__ import annotations

import signal
from typing import Any

#: The signals handled, with the exit status each gives (128 + its number).
HANDLED = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)

#: The first signal received since :func:`install` (None: none).
received: int | None = None


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


def install() -> None:
    """Handle SIGINT, SIGTERM and SIGHUP, unless they are ignored (a
    background job's SIGINT, ``nohup``'s SIGHUP stay ignored)."""
    for sig in HANDLED:
        if signal.getsignal(sig) is not signal.SIG_IGN:
            signal.signal(sig, _handler)


def signum_of(e: KeyboardInterrupt) -> int:
    """The signal a ``KeyboardInterrupt`` stands for (SIGINT for a plain one)."""
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
