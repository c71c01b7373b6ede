"""What the stages share: output names, the source format of a container,
faces by type, and BLAS held to one thread for the codec's small matrices."""

from __future__ import annotations

import collections
import functools
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar, cast

from threadpoolctl import threadpool_limits

from .. import passthrough, serialize, units
from ..errors import InputError, NoBRepError, NurbscompError
from ..formats import FORMAT_SUFFIX
from ..lazy import lazy_module
from ..model import (
    BRepModel,
    Derived,
    Kind,
)
from ..paths import read_container

if TYPE_CHECKING:
    from .. import occ
else:  # OCP takes seconds to import: only what builds or reads shapes pays for it
    occ = lazy_module("nurbscomp.occ")


DEFAULT_TOL_MM = units.DEFAULT_TOL_MM


#: A tolerance above this fraction of the part's bounding-box diagonal is warned of.
TOL_WARN_FRACTION = 0.1


SUFFIX = ".nzc"


_F = TypeVar("_F", bound=Any)


def one_blas_thread(fn: _F) -> _F:
    """Run ``fn`` with BLAS held to one thread.

    The codec's linear algebra works on tiny matrices (the D-map's least
    squares, eq. 18-24), where OpenBLAS's thread start-up and spinning cost
    far more than the arithmetic, and on a busy machine 100x more (measured).
    """

    @functools.wraps(fn)
    def run(*args: Any, **kwargs: Any) -> Any:
        with threadpool_limits(limits=1, user_api="blas"):
            return fn(*args, **kwargs)

    return cast(_F, run)


def default_compressed_name(src: Path) -> Path:
    """``part.step`` -> ``part.step.nzc``."""
    return src.with_name(src.name + SUFFIX)


def default_decompressed_name(src: Path) -> Path:
    """``part.step.nzc`` -> ``part.step``; ``part.nzc`` -> ``part.step``."""
    if src.name.endswith(SUFFIX):
        stem = Path(src.name[: -len(SUFFIX)])
        if stem.suffix.lower() in (".step", ".stp", ".igs", ".iges", ".brep", ".p21"):
            return src.with_name(stem.name)
        return src.with_name(stem.name + ".step")
    return src.with_name(src.name + ".step")


def source_format(path: Path) -> str:
    """The format of the file a container was made from (``"STEP"``, ``"IGES"``,
    or ``"BREP"`` for a shape given in memory), from its META alone: what
    ``decompress -c`` writes when no ``--format`` is given.

    Raises
    ------
    InputError, FormatError
        As :func:`read_container`; a META that does not read.
    """
    c = read_container(path)
    if c.flags & passthrough.VERBATIM:
        return str(passthrough.read(c)[0]["source_format"])
    fmt = str(serialize.read_meta(c.get("META"), c.revision).get("source_format", "STEP"))
    return fmt if fmt in FORMAT_SUFFIX else "STEP"


def _no_stage(name: str) -> None:
    """The default ``stage`` callback: no progress display."""


def faces_by_type(m: BRepModel) -> dict[str, int]:
    """Faces counted by the kind of their surface (a trimmed surface by its basis)."""
    out: collections.Counter[str] = collections.Counter()
    for s in m.face_surface.tolist():
        g = m.surfaces[s]
        while isinstance(g, Derived) and g.kind in (Kind.TRIMMED_SURFACE, Kind.OFFSET_SURFACE):
            g = m.surfaces[g.basis]
        out[g.kind.name.lower()] += 1
    return dict(sorted(out.items()))


def read_source(src: Path) -> Any:
    """The ``occ.CadFile`` of a STEP/IGES file, product data included.

    Raises
    ------
    NoBRepError
        A valid file that holds no B-rep faces (stored verbatim by the callers).
    InputError
        The file cannot be read (OCCT's failures included, in one line).
    """
    try:
        cad = occ.read_cad(src, product=True)
        if occ.counts(cad.shape)["faces"] == 0:
            raise NoBRepError(
                f"the {cad.source_format} file holds no B-rep faces (only curves or points)"
            )
    except NurbscompError:
        raise
    except Exception as e:
        raise InputError(f"OCCT failed to read the file ({type(e).__name__}: {e})") from None
    return cad
