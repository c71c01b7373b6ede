"""The ``nurbscomp`` script, and ``python -m nurbscomp``: the command line.

The stop signals are handled first (``signals.install``), before the command
line's own imports: Ctrl-C or SIGTERM in the first tenth of a second is an
interrupt too (exit 130 or 143), not a traceback.
"""

from __future__ import annotations

import sys


def main() -> None:
    """Console-script entry point."""
    from . import signals

    signals.install()
    try:
        from .cli import main as cli_main
    except KeyboardInterrupt as e:  # while the command line loads
        print(f"error: nurbscomp: {signals.describe(signals.signum_of(e))}", file=sys.stderr)
        sys.exit(128 + signals.signum_of(e))
    cli_main()


if __name__ == "__main__":
    main()
