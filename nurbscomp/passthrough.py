"""Passthrough containers (format 1.2): a STEP or IGES file stored verbatim.

A valid STEP or IGES file that holds no B-rep (tessellated-only AP242,
curves or points only, a product with no shape) cannot be coded as tables,
but an archive must still take it.  ``compress`` stores its bytes, entropy
coded like any body, in a container whose header has ``FLAG_PASSTHROUGH``
set, with two sections: ``META`` (JSON: ``mode`` ``"passthrough"``, the
source's format, name and size, the writer, and why it holds no B-rep) and
``FILE`` (the bytes).  ``decompress`` gives back the exact bytes.  Nothing
here imports OCP.  Layout: docs/format.md, §1.5.
"""

from __future__ import annotations

import json
import os
import time
import zlib
from pathlib import Path
from typing import Any

from . import __version__, container
from .errors import CorruptError, InputError, LimitError, SectionError
from .formats import BREP_SUFFIXES, IGES_SUFFIXES, STEP_SUFFIXES, output_format

#: The sections of a passthrough container, in order.
SECTIONS = ("META", "FILE")
#: ``source_format`` values a passthrough container may hold.
SOURCE_FORMATS = ("STEP", "IGES")
#: Largest META section a reader parses, in bytes (a writer's is ~300).
MAX_META_BYTES = 1 << 16
#: Longest string in META, in characters.
MAX_META_TEXT = 1024


def is_passthrough(path: Path) -> bool:
    """Whether ``path`` starts like a container whose header flags a passthrough.

    Only the 16 header bytes are looked at (and their checksum); the whole
    container is checked by :func:`read`.  A file that cannot be read is not
    a passthrough (its reader says why).
    """
    try:
        with open(path, "rb") as fh:
            head = fh.read(16)
    except OSError:
        return False
    if len(head) < 16 or head[:4] != container.MAGIC:
        return False
    if zlib.crc32(head[:12]) != int.from_bytes(head[12:16], "little"):
        return False
    flags = int.from_bytes(head[6:8], "little")
    return bool(flags & container.FLAG_PASSTHROUGH)


def well_formed(data: bytes, fmt: str) -> bool:
    """Whether ``data`` is laid out as a STEP or IGES file, beyond what OCCT's
    reader checked (its IGES reader takes noise): a STEP file starts with
    ``ISO-10303-21`` and has its end line; an IGES file has the section letter
    in column 73 of its first line (S, or F and C for the binary and compressed
    forms) and ends with its terminate line (T)."""
    if fmt == "STEP":
        return data.lstrip().startswith(b"ISO-10303-21") and b"END-ISO-10303-21" in data
    lines = [line.rstrip(b"\r") for line in data.splitlines() if line.strip()]
    return (
        len(lines) >= 2
        and len(lines[0]) >= 73
        and lines[0][72:73] in (b"S", b"F", b"C")
        and len(lines[-1]) >= 73
        and lines[-1][72:73] == b"T"
    )


def pack(data: bytes, source_format: str, source_name: str, reason: str) -> bytes:
    """Container bytes holding ``data`` verbatim.

    Raises
    ------
    InputError
        ``data`` is larger than a reader inflates (``container.MAX_RAW``).
    """
    from .serialize import meta_text

    if len(data) > container.MAX_RAW - MAX_META_BYTES:
        raise InputError(
            f"holds no B-rep, and at {len(data)} bytes is too large to store verbatim "
            f"(at most {container.MAX_RAW - MAX_META_BYTES})"
        )
    meta = {
        "mode": "passthrough",
        "source_format": source_format,
        "source_name": meta_text(source_name),
        "source_bytes": len(data),
        "writer": f"nurbscomp {__version__}",
        "reason": meta_text(reason),
    }
    raw_meta = json.dumps(meta, sort_keys=True, separators=(",", ":")).encode()
    return container.pack([("META", raw_meta), ("FILE", data)], container.FLAG_PASSTHROUGH)


def read(c: container.Container) -> tuple[dict[str, Any], bytes]:
    """The META fields and the stored file of a checked passthrough container.

    Raises
    ------
    CorruptError
        Other sections than ``META`` and ``FILE``, the lossless flag set too,
        or a stored file whose length is not META's ``source_bytes``.
    SectionError
        META is not a JSON object with the fields a writer writes.
    LimitError
        META is larger than ``MAX_META_BYTES``.
    """
    if not c.flags & container.FLAG_PASSTHROUGH:
        raise CorruptError("not a passthrough container (flag bit 1 at offset 6 is clear)")
    if c.flags & container.FLAG_LOSSLESS:
        raise CorruptError("a passthrough container has the lossless flag set (offset 6)")
    if tuple(c.tags()) != SECTIONS:
        raise CorruptError(f"a passthrough container holds sections {c.tags()}, not META, FILE")
    raw = c.get("META")
    if len(raw) > MAX_META_BYTES:
        raise LimitError(f"META: {len(raw)} bytes, more than the {MAX_META_BYTES} a reader parses")
    try:
        meta = json.loads(raw.decode("utf-8"))
    except (UnicodeDecodeError, ValueError, RecursionError):
        raise SectionError("META section is not valid JSON") from None
    if not isinstance(meta, dict) or meta.get("mode") != "passthrough":
        raise SectionError("META: a passthrough container's mode is not 'passthrough'")
    for key in ("source_format", "source_name", "writer", "reason"):
        v = meta.get(key, "")
        if not isinstance(v, str) or len(v) > MAX_META_TEXT or not v.isprintable():
            raise SectionError(f"META: {key} is not a short printable string")
    if meta.get("source_format") not in SOURCE_FORMATS:
        raise SectionError("META: source_format is not STEP or IGES")
    data = c.get("FILE")
    size = meta.get("source_bytes")
    if isinstance(size, bool) or not isinstance(size, int) or size != len(data):
        raise CorruptError(f"FILE holds {len(data)} bytes, META's source_bytes says {size!r}")
    return meta, data


def pack_file(data: bytes, name: str, reason: str) -> tuple[bytes, str]:
    """The passthrough container of a STEP/IGES file's bytes, and its format.

    Raises
    ------
    InputError
        ``data`` is not laid out as STEP or IGES (:func:`well_formed`), or is
        too large to store.
    """
    from .formats import sniff_format

    fmt = sniff_format(Path(name), data[: 1 << 16])
    if not well_formed(data, fmt):
        raise InputError(f"not a well-formed {fmt} file ({reason})")
    return pack(data, fmt, name, reason), fmt


def compress_file(
    src: Path, dst: Path, reason: str, *, force: bool, t0: float, verify: bool = True
) -> dict[str, Any]:
    """Store ``src`` verbatim in ``dst``; the report of ``pipeline.compress_file``'s shape.

    ``reason`` says why the file holds no B-rep (the ``NoBRepError``'s message);
    it is the report's warning.  With ``verify``, the written container is read
    back and must give the same bytes.

    Raises
    ------
    InputError
        ``src`` cannot be read, or is too large to store.
    OutputError
        ``dst`` cannot be written (see ``pipeline.atomic_output``).
    """
    from .pipeline import atomic_output, read_container

    try:
        data = src.read_bytes()
    except OSError as e:
        raise InputError(e.strerror or str(e)) from None
    blob, fmt = pack_file(data, src.name, reason)
    with atomic_output(dst, force, (src,)) as tmp:
        tmp.write_bytes(blob)
        if verify and read(read_container(tmp))[1] != data:
            raise CorruptError("the passthrough container does not give the file back")
    warning = f"stored verbatim (passthrough container, no geometry coding): {reason}"
    return {
        "command": "compress",
        "input": str(src),
        "output": str(dst),
        "input_bytes": len(data),
        "output_bytes": len(blob),
        "ratio": len(data) / len(blob),
        "mode": "passthrough",
        "passthrough": True,
        "reason": reason,
        "tolerance_mm": None,
        "source_format": fmt,
        "verified": verify,
        "seconds": time.perf_counter() - t0,
        "warnings": [warning],
    }


def decompress_file(src: Path, dst: Path, *, force: bool, fmt: str | None = None) -> dict[str, Any]:
    """Write back the file a passthrough container holds, byte for byte.

    ``fmt`` is the output format asked for (default: by ``dst``'s extension,
    where an unknown one means the stored file's own format).

    Raises
    ------
    InputError
        The stored file is STEP (IGES) and IGES or BREP (STEP) was asked for:
        there is no B-rep to convert.
    FormatError
        The container is damaged (see :func:`read`).
    OutputError
        ``dst`` cannot be written.
    """
    from .pipeline import atomic_output, check_output, read_container

    t0 = time.perf_counter()
    check_output(dst, force, (src,))
    meta, data = read(read_container(src))
    have = meta["source_format"]
    known = os.path.splitext(dst)[1].lower() in (*STEP_SUFFIXES, *IGES_SUFFIXES, *BREP_SUFFIXES)
    want = fmt or (output_format(dst) if known else have)
    if want != have:
        raise InputError(
            f"holds a {have} file stored verbatim (no B-rep): it cannot be written as {want}"
        )
    with atomic_output(dst, force, (src,)) as tmp:
        tmp.write_bytes(data)
    return {
        "command": "decompress",
        "input": str(src),
        "output": str(dst),
        "format": have,
        "passthrough": True,
        "output_bytes": len(data),
        "seconds": time.perf_counter() - t0,
    }


def info(src: Path) -> dict[str, Any]:
    """What a passthrough container holds (the fields of ``pipeline.info`` that apply)."""
    from .pipeline import read_container

    c = read_container(src)
    meta, data = read(c)
    return {
        "command": "info",
        "input": str(src),
        "format_version": f"{c.major}.{c.minor}",
        "lossless": False,
        "passthrough": True,
        "mode": "passthrough",
        "reason": meta.get("reason", ""),
        "tolerance_mm": None,
        "source_format": meta["source_format"],
        "source_name": meta.get("source_name"),
        "source_bytes": len(data),
        "writer": meta.get("writer"),
        "file_bytes": src.stat().st_size,
        "coder": container.entropy.Coder(c.coder).name.lower(),
        "body_stored_bytes": c.stored_length,
        "section_raw_bytes": {s.tag: len(s.raw) for s in c.sections},
    }
