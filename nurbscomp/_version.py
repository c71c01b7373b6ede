"""The package's version, looked up once and only when asked for
(``importlib.metadata`` costs 25 ms: the script starts without it)."""

from __future__ import annotations

import functools


@functools.cache
def version() -> str:
    from importlib.metadata import PackageNotFoundError
    from importlib.metadata import version as installed

    try:
        return installed("nurbscomp")
    except PackageNotFoundError:  # running from a source tree without install
        return "0.0.0"
