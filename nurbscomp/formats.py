"""CAD file formats by name and by content, without OCCT.

Kept apart from :mod:`nurbscomp.occ.files` so that the commands that never
build a shape (``info``, ``--help``, passthrough containers, walking folders)
do not import OCP.
"""

from __future__ import annotations

import os
from pathlib import Path

from .errors import InputError

STEP_SUFFIXES = (".step", ".stp", ".p21")
IGES_SUFFIXES = (".iges", ".igs")
BREP_SUFFIXES = (".brep",)
#: The first bytes of a ``.nzc`` container (``container.MAGIC``).
CONTAINER_MAGIC = b"\x89NZC"
#: The output formats of ``decompress --format`` and the suffix each gets.
FORMAT_SUFFIX = {"STEP": ".step", "IGES": ".igs", "BREP": ".brep"}


def sniff_format(path: Path, head: bytes) -> str:
    """``"STEP"`` or ``"IGES"`` by content, falling back to the file name.

    Raises
    ------
    InputError
        Neither the content nor the name says STEP or IGES (or the content
        is a ``.nzc`` container's, which the message says).
    """
    if head.startswith(CONTAINER_MAGIC):
        raise InputError("already a .nzc container (nurbscomp -d decompresses it)")
    if head.lstrip().startswith(b"ISO-10303-21"):
        return "STEP"
    lines = head.splitlines()
    if lines and len(lines[0]) >= 73 and lines[0][72:73] in (b"S", b"F"):
        return "IGES"
    suffix = path.suffix.lower()
    if suffix in IGES_SUFFIXES:
        return "IGES"
    if suffix in STEP_SUFFIXES:
        return "STEP"
    raise InputError("not a STEP or IGES file")


def output_format(path: str | os.PathLike[str]) -> str:
    """``"STEP"`` (the default), ``"IGES"`` or ``"BREP"``, by the file's extension."""
    suffix = Path(path).suffix.lower()
    if suffix in BREP_SUFFIXES:
        return "BREP"
    if suffix in IGES_SUFFIXES:
        return "IGES"
    return "STEP"
