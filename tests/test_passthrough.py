"""Passthrough containers (format 1.2): valid STEP/IGES files without a B-rep,
stored verbatim; the golden file decodes to the exact bytes forever."""

from __future__ import annotations

import struct
import zlib
from pathlib import Path

import pytest

from nurbscomp import container, passthrough, pipeline
from nurbscomp.errors import (
    CorruptError,
    InputError,
    ReservedBitsError,
    SectionError,
)

HERE = Path(__file__).resolve().parent / "golden" / "passthrough"


def test_golden_passthrough_gives_the_exact_bytes(tmp_path: Path) -> None:
    src, nzc = HERE / "tessellated.step", HERE / "tessellated.step.nzc"
    assert passthrough.is_verbatim(nzc)
    assert not passthrough.is_verbatim(HERE.parent / "loft.tol0.01.nzc")
    c = container.unpack(nzc.read_bytes())
    assert (c.major, c.minor, c.flags) == (1, 2, container.FLAG_PASSTHROUGH)
    meta, data = passthrough.read(c)
    assert data == src.read_bytes()
    assert meta["source_format"] == "STEP" and meta["source_name"] == "tessellated.step"
    r = pipeline.decompress_file(nzc, tmp_path / "back.step")
    assert r["passthrough"] and (tmp_path / "back.step").read_bytes() == src.read_bytes()
    assert pipeline.info(nzc)["reason"] == "nothing in the STEP file transfers to a B-rep"
    assert pipeline.test_file(nzc)["ok"]
    with pytest.raises(InputError, match="verbatim, not a B-rep"):
        pipeline.decode(c)


def _repack(data: bytes, minor: int, flags: int) -> bytes:
    """``data`` with another minor version and flags, its header CRC fixed."""
    b = bytearray(data)
    b[5] = minor
    b[6:8] = struct.pack("<H", flags)
    b[12:16] = struct.pack("<I", zlib.crc32(bytes(b[:12])))
    return bytes(b)


def test_damaged_passthrough_containers() -> None:
    data = (HERE / "tessellated.step.nzc").read_bytes()
    # the flag is reserved before 1.2: a 1.1 reader's view
    with pytest.raises(ReservedBitsError, match="offset 6"):
        container.unpack(_repack(data, 1, container.FLAG_PASSTHROUGH))
    both = container.FLAG_PASSTHROUGH | container.FLAG_LOSSLESS
    with pytest.raises(CorruptError, match="lossless flag"):
        passthrough.read(container.unpack(_repack(data, 2, both)))
    meta = b'{"mode":"passthrough","source_format":"STEP","source_bytes":5}'
    wrong = [
        ([("META", meta), ("FILE", b"abcd")], CorruptError, "META's source_bytes"),
        ([("META", meta)], CorruptError, "not META, FILE"),
        ([("META", b"[1]"), ("FILE", b"abcde")], SectionError, "mode|neither"),
        ([("META", meta.replace(b"STEP", b"BREP")), ("FILE", b"abcde")], SectionError, "STEP"),
    ]
    for secs, cls, msg in wrong:
        c = container.unpack(container.pack(secs, container.FLAG_PASSTHROUGH))
        with pytest.raises(cls, match=msg):
            passthrough.read(c)
    # a regular container with the flag set: a FormatError, never a B-rep
    loft = (HERE.parent / "loft.tol0.01.nzc").read_bytes()
    with pytest.raises(CorruptError):
        pipeline.decode(container.unpack(_repack(loft, 2, container.FLAG_PASSTHROUGH)))


def test_garbage_is_not_stored(tmp_path: Path) -> None:
    """OCCT's IGES reader takes noise; the passthrough does not."""
    assert passthrough.well_formed((HERE / "tessellated.step").read_bytes(), "STEP")
    assert not passthrough.well_formed(b"ISO-10303-21;\nHEADER;\n", "STEP")
    assert not passthrough.well_formed(bytes(range(256)) * 8, "IGES")
    (tmp_path / "noise.igs").write_bytes(bytes(range(256)) * 8)
    with pytest.raises(InputError, match="not a well-formed IGES file"):
        pipeline.compress_file(tmp_path / "noise.igs")
    assert [p.name for p in tmp_path.iterdir()] == ["noise.igs"]
