"""nurbscomp: compress STEP/IGES B-reps by re-encoding their NURBS faces within a tolerance."""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("nurbscomp")
except PackageNotFoundError:  # running from a source tree without install
    __version__ = "0.0.0"
