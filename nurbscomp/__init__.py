"""nurbscomp: compress STEP/IGES B-reps by re-encoding their NURBS faces within a tolerance.

The Python API (docs/api.md)::

    import nurbscomp
    data = nurbscomp.compress("part.step", tol=0.01)   # or a cadquery / OCP shape, or bytes
    shape = nurbscomp.decompress(data)                  # a cadquery.Shape (or Assembly)
    nurbscomp.info(data)                                # an InfoReport: what it holds
    nurbscomp.evaluate("part.step", data)               # an EvalReport of the deviation
    data, r = nurbscomp.compress("part.step", report=True)  # and a CompressReport
    data = nurbscomp.compress("part.step", lossless=True)  # the same file back:
    nurbscomp.original(data)                            # its bytes, SHA-256 checked

Importing ``nurbscomp`` is fast: the functions are loaded on first use, and
OCP (OpenCASCADE) when a function needs it.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    __version__: str
    from ._api import compress, decompress, evaluate, info, original
    from .report import CompressReport, Counts, EvalReport, FaceDeviation, InfoReport, Report

__all__ = [
    "CompressReport",
    "Counts",
    "EvalReport",
    "FaceDeviation",
    "InfoReport",
    "Report",
    "__version__",
    "compress",
    "decompress",
    "evaluate",
    "info",
    "original",
]

_API = {"compress", "decompress", "evaluate", "info", "original"}
_REPORT = {"CompressReport", "Counts", "EvalReport", "FaceDeviation", "InfoReport", "Report"}


def __getattr__(name: str) -> Any:
    """The API's names, imported on first use (PEP 562): ``import nurbscomp``
    loads neither numpy's users nor OCP."""
    if name == "__version__":
        from ._version import version

        globals()["__version__"] = v = version()
        return v
    if name in _API:
        from . import _api

        return getattr(_api, name)
    if name in _REPORT:
        from . import report

        return getattr(report, name)
    raise AttributeError(f"module 'nurbscomp' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted({*globals(), *__all__})
