"""Byte-exact containers (format 2.0, issue 29): ``compress --lossless`` keeps
the file itself, through the text model, and every reader gives it back bit
for bit with its SHA-256 checked."""

from __future__ import annotations

import hashlib
import json
import struct
import subprocess
import sys
import zlib
from pathlib import Path

import pytest

import nurbscomp
from nurbscomp import container, errors, occ, passthrough, pipeline, serialize, text

from .conftest import CORPUS, SAMPLES, in_corpus


def _cli(*args: str, stdin: bytes | None = None) -> subprocess.CompletedProcess[bytes]:
    return subprocess.run(
        [sys.executable, "-m", "nurbscomp", *args], input=stdin, capture_output=True
    )


@pytest.mark.slow
@pytest.mark.parametrize(
    "src",
    [
        in_corpus("occt__occ22470.igs"),
        in_corpus("trimesh__featuretype.STEP"),
        SAMPLES / "bracket.step",
    ],
    ids=lambda p: p.name,
)
def test_lossless_gives_the_file_back(tmp_path: Path, src: Path) -> None:
    nzc = tmp_path / "x.nzc"
    r = _cli("compress", "--lossless", "--json", str(src), "-o", str(nzc))
    assert r.returncode == 0, r.stderr
    rep = json.loads(r.stdout.splitlines()[0])
    want = hashlib.sha256(src.read_bytes()).hexdigest()
    assert rep["mode"] == "exact" and rep["sha256"] == want and rep["verified"]
    assert not rep["passthrough"] and rep["warnings"] == []
    c = container.unpack(nzc.read_bytes())
    assert (c.major, c.minor, c.flags) == (2, container.MINOR, container.FLAG_EXACT)
    assert c.tags() == ["META", "TEXT"]
    back = tmp_path / ("back" + src.suffix)
    assert _cli("decompress", str(nzc), "-o", str(back)).returncode == 0
    assert back.read_bytes() == src.read_bytes()
    # -c writes the source's own format, and the same bytes
    assert _cli("decompress", "-c", str(nzc)).stdout == src.read_bytes()
    info = json.loads(_cli("info", "--json", str(nzc)).stdout)
    assert info["sha256"] == want and info["mode"] == "exact"
    assert info["source_bytes"] == src.stat().st_size
    r = _cli("test", str(nzc))
    assert r.returncode == 0 and f"sha256 {want[:16]}" in r.stdout.decode()


@pytest.mark.slow
def test_lossless_needs_no_reader_and_takes_broken_files(tmp_path: Path) -> None:
    """A STEP file OCCT cannot read (cut in the middle of DATA) is kept byte for byte."""
    src = tmp_path / "cut.step"
    whole = (SAMPLES / "loft.step").read_bytes()
    src.write_bytes(whole[: len(whole) // 2])
    r = _cli("compress", "--lossless", str(src))
    assert r.returncode == 0, r.stderr
    assert nurbscomp.original(tmp_path / "cut.step.nzc") == src.read_bytes()
    # tolerance mode needs a B-rep, and says the file does not read
    r = _cli("compress", str(src), "-o", str(tmp_path / "tol.nzc"))
    assert r.returncode == 1 and r.stderr.decode().startswith(f"error: {src}: ")
    # a file that is neither STEP nor IGES is refused in every mode
    junk = tmp_path / "notes.txt"
    junk.write_bytes(b"hello")
    r = _cli("compress", "--lossless", str(junk))
    assert r.returncode == 1 and b"not a STEP or IGES file" in r.stderr
    assert not (tmp_path / "notes.txt.nzc").exists()


def test_byte_exact_converts_to_another_format(tmp_path: Path) -> None:
    """decompress -o x.igs of a STEP kept byte for byte: OCCT reads the text and
    writes IGES, as it writes a decoded shape."""
    src = SAMPLES / "bracket.step"
    nzc = tmp_path / "b.nzc"
    pipeline.compress_file(src, nzc, exact=True)
    r = pipeline.decompress_file(nzc, tmp_path / "b.igs")
    assert r["format"] == "IGES" and not r["exact"]
    assert occ.counts(occ.read_cad(tmp_path / "b.igs").shape) == occ.counts(occ.read_cad(src).shape)
    shape, _ = pipeline.load_shape(nzc)  # a shape, as decompress() gives it
    assert occ.counts(shape) == occ.counts(occ.read_cad(src).shape)


@pytest.mark.slow
def test_api_lossless_modes() -> None:
    import cadquery as cq

    data = (SAMPLES / "blob.step").read_bytes()
    exact = nurbscomp.compress(data, lossless=True)
    assert nurbscomp.original(exact) == data
    assert nurbscomp.compress(data, lossless="exact") == exact
    assert nurbscomp.info(nurbscomp.compress(data, lossless="brep"))["mode"] == "lossless"
    box = cq.Workplane().box(1, 2, 3).val()  # no file to keep: True is the B-rep
    assert nurbscomp.info(nurbscomp.compress(box, lossless=True))["mode"] == "lossless"
    with pytest.raises(errors.ArgumentError, match="give a path or bytes"):
        nurbscomp.compress(box, lossless="exact")
    with pytest.raises(errors.ArgumentError, match="lossless must be"):
        nurbscomp.compress(data, lossless="yes")  # type: ignore[arg-type]
    with pytest.raises(errors.InputError, match="holds a B-rep"):
        nurbscomp.original(nurbscomp.compress(box, tol=0.01))


def _repack(sections: list[tuple[str, bytes]], flags: int = container.FLAG_EXACT) -> bytes:
    return container.pack(sections, flags, coders=(container.entropy.Coder.STORED,))


def test_damaged_byte_exact_containers() -> None:
    src = (SAMPLES / "loft.step").read_bytes()
    good = passthrough.pack(src, "STEP", "loft.step")
    c = container.unpack(good)
    meta, blob = serialize.parse_meta(c.get("META")), c.get("TEXT")

    def meta_with(**kw: object) -> bytes:
        return json.dumps({**meta, **kw}).encode()

    bad_byte = bytearray(blob)
    bad_byte[len(blob) // 2] ^= 0x55
    cases = [
        ([("META", meta_with(sha256="0" * 64)), ("TEXT", blob)], errors.ChecksumError),
        ([("META", meta_with(source_bytes=len(src) - 1)), ("TEXT", blob)], errors.FormatError),
        ([("META", meta_with(source_bytes=2**40)), ("TEXT", blob)], errors.SectionError),
        ([("META", meta_with(model="zip")), ("TEXT", blob)], errors.SectionError),
        ([("META", meta_with(mode="tolerance")), ("TEXT", blob)], errors.SectionError),
        ([("META", c.get("META")), ("TEXT", bytes(bad_byte))], errors.FormatError),
        ([("META", c.get("META")), ("TEXT", blob[:-5])], errors.FormatError),
        ([("META", c.get("META")), ("TEXT", b"\x07" + blob[1:])], errors.CorruptError),
        ([("META", c.get("META")), ("FILE", src)], errors.CorruptError),
        ([("META", c.get("META"))], errors.CorruptError),
    ]
    for sections, error in cases:
        with pytest.raises(error):
            passthrough.read(container.unpack(_repack(sections)))
    # the flag is reserved before 2.0; lossless and byte-exact exclude each other
    b = bytearray(good)
    b[4], b[5] = 1, 2
    b[12:16] = struct.pack("<I", zlib.crc32(bytes(b[:12])))
    with pytest.raises(errors.ReservedBitsError, match="offset 6"):
        container.unpack(bytes(b))
    both = container.FLAG_EXACT | container.FLAG_LOSSLESS
    with pytest.raises(errors.CorruptError, match="lossless flag"):
        passthrough.read(container.unpack(_repack([(s.tag, s.raw) for s in c.sections], both)))


def test_no_brep_file_is_kept_byte_exact_in_tolerance_mode(tmp_path: Path) -> None:
    """A valid STEP file with no B-rep, in tolerance mode: a byte-exact container
    whose META says why (1.2 wrote a passthrough container)."""
    src = Path(__file__).parent / "golden" / "passthrough" / "tessellated.step"
    nzc = tmp_path / "t.nzc"
    r = pipeline.compress_file(src, nzc, tol=0.01)
    assert r["passthrough"] and r["mode"] == "passthrough"
    meta, data = passthrough.read(container.unpack(nzc.read_bytes()))
    assert data == src.read_bytes() and "B-rep" in meta["reason"]
    with pytest.raises(errors.InputError, match="verbatim, not a B-rep"):
        pipeline.decode_file(nzc)


@pytest.mark.corpus
def test_text_blob_is_never_larger_than_its_plain_stream() -> None:
    """The model is kept only where it is smaller than raw LZMA2 at 9e (xz -9e's coding)."""
    for src in (SAMPLES / "teapot.step", CORPUS / "pythonocc-core__sunglasses_lens.igs"):
        data = src.read_bytes()
        blob = text.encode(data)
        assert text.decode(blob, len(data)) == data
        assert len(blob) <= len(text._plain(data))
    with pytest.raises(errors.LimitError):
        data = (SAMPLES / "teapot.step").read_bytes()
        text.decode(text.encode(data), len(data) - 1)
