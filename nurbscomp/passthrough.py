"""Containers that hold the source file itself, byte for byte.

Two kinds (docs/format.md §1.4, §1.5), both read here:

* **byte-exact** (format 2.0, header flag ``FLAG_EXACT``): what ``compress
  --lossless`` writes, and what a valid STEP/IGES file that holds no B-rep
  becomes in any mode.  Sections ``META`` (JSON: ``mode`` ``"exact"``, the
  source's format, name, size and SHA-256, the writer, the text model used,
  and, for a file with no B-rep, why) and ``TEXT`` (the file through the text
  model, :mod:`nurbscomp.text`).  Writing one needs no OpenCASCADE: the file is
  read as text.
* **passthrough** (format 1.2, ``FLAG_PASSTHROUGH``): the file's bytes in a
  ``FILE`` section, entropy coded with the body.  Read, no longer written.

``decompress`` gives back the exact bytes; the SHA-256 is checked on every
read.  Nothing here imports OCP.
"""

from __future__ import annotations

import hashlib
import os
import time
from pathlib import Path
from typing import Any

from . import container, text
from ._version import version
from .entropy import Coder
from .errors import ChecksumError, CorruptError, InputError, LimitError, SectionError
from .formats import BREP_SUFFIXES, IGES_SUFFIXES, STEP_SUFFIXES, output_format
from .paths import atomic_output, check_output, read_container

#: The sections of a passthrough container (1.2), in order.
SECTIONS = ("META", "FILE")
#: The sections of a byte-exact container (2.0), in order.
EXACT_SECTIONS = ("META", "TEXT")
#: Header flags of a container that holds its source file.
VERBATIM = container.FLAG_PASSTHROUGH | container.FLAG_EXACT
#: ``META["model"]``: the text model's name by its id (the TEXT blob's first byte).
MODELS = {text.PLAIN: "plain", text.STEP: "step", text.IGES: "iges"}
#: ``source_format`` values a passthrough container may hold.
SOURCE_FORMATS = ("STEP", "IGES")
#: Largest META section a reader parses, in bytes (a writer's is ~300).
MAX_META_BYTES = 1 << 16
#: Longest string in META, in characters.
MAX_META_TEXT = 1024


def is_verbatim(path: Path) -> bool:
    """Whether ``path`` starts like a container that holds its source file
    (header flag passthrough or byte-exact).

    Only the header's bytes are looked at (and their checksum where the
    version has one: ``container.header_flags``); the whole container is
    checked by :func:`read`.  A file that cannot be read is not a passthrough
    (its reader says why).
    """
    try:
        with open(path, "rb") as fh:
            head = fh.read(container.HEAD_BYTES)
    except OSError:
        return False
    return bool((container.header_flags(head) or 0) & VERBATIM)


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


def pack(data: bytes, source_format: str, source_name: str, reason: str | None = None) -> bytes:
    """The byte-exact container of ``data``; ``reason`` says why a file that
    holds no B-rep is stored this way in a tolerance mode (None: asked for).

    The body is stored (coder 0): ``TEXT`` is already entropy coded.

    Raises
    ------
    InputError
        ``data`` is larger than a reader inflates (``container.MAX_RAW``).
    """
    return _pack(data, source_format, source_name, reason)[0]


def _pack(
    data: bytes, source_format: str, source_name: str, reason: str | None
) -> tuple[bytes, dict[str, Any]]:
    """:func:`pack`, and the META it wrote.

    Raises
    ------
    InputError
        ``data`` is larger than a reader inflates (``container.MAX_RAW``).
    """
    from .serialize import meta_text, write_meta

    if len(data) > container.MAX_RAW - MAX_META_BYTES:
        raise InputError(
            f"at {len(data)} bytes, too large to store (at most "
            f"{container.MAX_RAW - MAX_META_BYTES})"
        )
    blob = text.encode(data)
    meta: dict[str, Any] = {
        "mode": "exact",
        "source_format": source_format,
        "source_name": meta_text(source_name),
        "source_bytes": len(data),
        "sha256": hashlib.sha256(data).hexdigest(),
        "model": MODELS[blob[0]],
        "writer": f"nurbscomp {version()}",
    }
    if reason is not None:
        meta["reason"] = meta_text(reason)
    raw_meta = write_meta(meta)
    sections = [("META", raw_meta), ("TEXT", blob)]
    return container.pack(sections, container.FLAG_EXACT, coders=(Coder.STORED,)), meta


def _meta(c: container.Container, mode: str) -> dict[str, Any]:
    """META of a verbatim container, its fields checked (:func:`read`)."""
    from .serialize import parse_meta

    raw = c.get("META")
    if len(raw) > MAX_META_BYTES:
        raise LimitError(f"META: {len(raw)} bytes, more than the {MAX_META_BYTES} a reader parses")
    meta = parse_meta(raw, c.revision)
    if not isinstance(meta, dict) or meta.get("mode") != mode:
        raise SectionError(f"META: a {mode} container's mode is not {mode!r}")
    for key in ("source_format", "source_name", "writer", "reason", "model", "sha256"):
        v = meta.get(key, "")
        if not isinstance(v, str) or len(v) > MAX_META_TEXT or not v.isprintable():
            raise SectionError(f"META: {key} is not a short printable string")
    if meta.get("source_format") not in SOURCE_FORMATS:
        raise SectionError("META: source_format is not STEP or IGES")
    size = meta.get("source_bytes")
    if isinstance(size, bool) or not isinstance(size, int) or not 0 <= size <= container.MAX_RAW:
        raise SectionError(f"META: source_bytes is not a length a reader inflates: {size!r}")
    return meta


def read(c: container.Container) -> tuple[dict[str, Any], bytes]:
    """The META fields and the source file of a checked verbatim container.

    Raises
    ------
    CorruptError
        Neither flag is set, or both, or the lossless flag is; other sections
        than the kind's; a file whose length is not META's ``source_bytes``.
    ChecksumError
        A byte-exact container's file whose SHA-256 is not META's.
    SectionError
        META is not a JSON object with the fields a writer writes.
    LimitError
        META is larger than ``MAX_META_BYTES``.
    FormatError
        A ``TEXT`` section the text model does not decode (``text.decode``).
    """
    kind = c.flags & VERBATIM
    if kind not in (container.FLAG_PASSTHROUGH, container.FLAG_EXACT):
        raise CorruptError(
            f"not a container that holds its file (flag bits 1 and 2 at offset 6: {kind >> 1:02b})"
        )
    exact = kind == container.FLAG_EXACT
    what = "byte-exact" if exact else "passthrough"
    if c.flags & container.FLAG_LOSSLESS:
        raise CorruptError(f"a {what} container has the lossless flag set (offset 6)")
    want = EXACT_SECTIONS if exact else SECTIONS
    if tuple(c.tags()) != want:
        raise CorruptError(f"a {what} container holds sections {c.tags()}, not {', '.join(want)}")
    meta = _meta(c, "exact" if exact else "passthrough")
    size = meta["source_bytes"]
    if exact:
        if meta.get("model") not in MODELS.values():
            raise SectionError(f"META: unknown text model {meta.get('model')!r}")
        data = text.decode(c.get("TEXT"), size)
    else:
        data = c.get("FILE")
    if size != len(data):
        raise CorruptError(
            f"the stored file holds {len(data)} bytes, META's source_bytes says {size!r}"
        )
    if exact and hashlib.sha256(data).hexdigest() != meta.get("sha256"):
        raise ChecksumError("the decoded file's SHA-256 is not META's sha256")
    return meta, data


def pack_file(data: bytes, name: str, reason: str | None = None) -> tuple[bytes, dict[str, Any]]:
    """The byte-exact container of a STEP/IGES file's bytes, and its META
    (format, SHA-256, text model).

    ``reason`` (why the file holds no B-rep, when that is why it is stored so)
    asks for a well-formed file; asked for (``--lossless``), any file whose
    content or name says STEP or IGES is taken, even one OCCT cannot read.

    Raises
    ------
    InputError
        Not STEP or IGES; with ``reason``, not laid out as one
        (:func:`well_formed`); too large to store.
    """
    from .formats import sniff_format

    fmt = sniff_format(Path(name), data[: 1 << 16])
    if reason is not None and not well_formed(data, fmt):
        raise InputError(f"not a well-formed {fmt} file ({reason})")
    return _pack(data, fmt, name, reason)


def compress_file(
    src: Path, dst: Path, reason: str | None, *, force: bool, t0: float, verify: bool = True
) -> dict[str, Any]:
    """Store ``src`` byte for byte in ``dst``; the report of ``pipeline.compress_file``'s shape.

    ``reason`` says why the file holds no B-rep (the ``NoBRepError``'s message;
    the report's warning), or is None where byte-exact mode was asked for.  With
    ``verify``, the written container is read back and must give the same bytes.

    Raises
    ------
    InputError
        ``src`` cannot be read, is not STEP/IGES, or is too large to store.
    OutputError
        ``dst`` cannot be written (see ``paths.atomic_output``).
    """

    try:
        data = src.read_bytes()
    except OSError as e:
        raise InputError(e.strerror or str(e)) from None
    blob, meta = pack_file(data, src.name, reason)
    with atomic_output(dst, force, (src,)) as tmp:
        tmp.write_bytes(blob)
        if verify:
            check_gives_back(read_container(tmp), data)
    return {
        "command": "compress",
        "input": str(src),
        "output": str(dst),
        **report(data, blob, meta, reason, verify),
        "seconds": time.perf_counter() - t0,
    }


def check_gives_back(c: container.Container, data: bytes) -> None:
    """Raise ``CorruptError`` unless the byte-exact container ``c`` gives
    ``data`` back (the check of ``verify``)."""
    if read(c)[1] != data:
        raise CorruptError("the byte-exact container does not give the file back")


def report(
    data: bytes, blob: bytes, meta: dict[str, Any], reason: str | None, verified: bool
) -> dict[str, Any]:
    """The compress report of a verbatim container ``blob`` of ``data`` (its
    META ``meta``; ``reason`` as :func:`compress_file` takes it), less
    ``command``, ``input``, ``output`` and times."""
    warnings = []
    if reason is not None:
        warnings.append(f"stored verbatim, byte for byte (no geometry coding): {reason}")
    return {
        "input_bytes": len(data),
        "output_bytes": len(blob),
        "ratio": len(data) / len(blob),
        "mode": "exact" if reason is None else "passthrough",
        "passthrough": reason is not None,
        "reason": reason,
        "tolerance_mm": None,
        "source_format": meta["source_format"],
        "sha256": meta["sha256"],
        "model": meta["model"],
        "verified": verified,
        "warnings": warnings,
    }


def decompress_file(
    src: Path,
    dst: Path,
    *,
    force: bool,
    fmt: str | None = None,
    convert: Any = None,
) -> dict[str, Any]:
    """Write back the file a verbatim container holds, byte for byte, or,
    where another format is asked for, the file through ``convert(data,
    source_format, tmp_path, fmt, meta)`` (``pipeline``'s: OCCT reads the text
    and writes the other format; it returns the report's ``unit`` and ``counts``).

    ``fmt`` is the output format asked for (default: by ``dst``'s extension,
    where an unknown one means the stored file's own format).

    Raises
    ------
    InputError
        Another format is asked for and the file holds no B-rep (or there is
        no ``convert``).
    FormatError
        The container is damaged (see :func:`read`).
    OutputError
        ``dst`` cannot be written.
    """

    t0 = time.perf_counter()
    check_output(dst, force, (src,))
    meta, data = read(read_container(src))
    have = meta["source_format"]
    known = os.path.splitext(dst)[1].lower() in (*STEP_SUFFIXES, *IGES_SUFFIXES, *BREP_SUFFIXES)
    want = fmt or (output_format(dst) if known else have)
    if want != have and ("reason" in meta or convert is None):
        raise InputError(
            f"holds a {have} file stored verbatim (no B-rep): it cannot be written as {want}"
        )
    extra: dict[str, Any] = {}
    with atomic_output(dst, force, (src,)) as tmp:
        if want == have:
            tmp.write_bytes(data)
        else:
            extra = convert(data, have, tmp, want, meta)
        size = tmp.stat().st_size
    return {
        **extra,
        "command": "decompress",
        "input": str(src),
        "output": str(dst),
        "format": want,
        "passthrough": "reason" in meta,
        "exact": want == have,
        "output_bytes": size,
        "seconds": time.perf_counter() - t0,
    }


def info(c: container.Container, name: str, file_bytes: int) -> dict[str, Any]:
    """What a verbatim container holds (the fields of ``pipeline.info_data``
    that apply); ``name`` is the ``input`` reported, ``file_bytes`` the
    container's size."""
    meta, data = read(c)
    exact = bool(c.flags & container.FLAG_EXACT)
    return {
        "command": "info",
        "input": name,
        "format_version": f"{c.major}.{c.minor}",
        "lossless": False,
        "passthrough": "reason" in meta,
        "mode": "exact" if exact and "reason" not in meta else "passthrough",
        "reason": meta.get("reason", ""),
        "tolerance_mm": None,
        "source_format": meta["source_format"],
        "source_name": meta.get("source_name"),
        "source_bytes": len(data),
        "sha256": hashlib.sha256(data).hexdigest(),
        "model": meta.get("model", "verbatim"),
        "writer": meta.get("writer"),
        "file_bytes": file_bytes,
        "coder": container.entropy.Coder(c.coder).name.lower(),
        "body_stored_bytes": c.stored_length,
        "section_raw_bytes": {s.tag: len(s.raw) for s in c.sections},
    }
