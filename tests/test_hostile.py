"""Hostile containers (issue 11): built, not damaged.  A valid container is
decoded, its model or META edited, and packed again with valid CRCs.  Each
must end fast with one ``FormatError`` line, or decode within the budget."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from click.testing import CliRunner

from nurbscomp import container, entropy, pipeline, serialize
from nurbscomp.cli import cli, show
from nurbscomp.errors import FormatError, LimitError, SectionError

GOLDEN = Path(__file__).resolve().parent / "golden"
BASE = GOLDEN / "bracket.lossless.nzc"


def with_meta(raw: bytes, base: Path = BASE) -> bytes:
    """``base`` with its META section replaced by ``raw`` (every CRC valid)."""
    c = container.unpack(base.read_bytes())
    secs = [(s.tag, raw if s.tag == "META" else s.raw) for s in c.sections]
    return container.pack(secs, c.flags, (entropy.Coder.STORED,))


def _meta(**edits: object) -> dict[str, object]:
    c = container.unpack(BASE.read_bytes())
    return {**json.loads(c.get("META")), **edits}


def _cli_one_line(tmp_path: Path, data: bytes, *args: str) -> str:
    """Run ``nurbscomp ARGS FILE`` on ``data``: exit 1, one error line, nothing left."""
    src = tmp_path / "case.nzc"
    src.write_bytes(data)
    r = CliRunner().invoke(cli, [*args, str(src)])
    assert r.exit_code == 1, r.output
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"error: {src}: "), r.stderr
    assert "internal error" not in r.stderr and "Undiagnosed" not in r.stderr
    assert "no specific check" not in r.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["case.nzc"]
    return lines[0]


META_CASES = {
    "5000-digit integer": b'{"mode": "lossless", "source_bytes": ' + b"7" * 5000 + b"}",
    "10^400 source_bytes": json.dumps(_meta(source_bytes=10**400)).encode(),
    "1e400 source_bytes": json.dumps(_meta()).encode().replace(b'"source_bytes"', b'"x"')[:-1]
    + b', "source_bytes": 1e400}',
    "negative source_bytes": json.dumps(_meta(source_bytes=-1)).encode(),
    "lone surrogate": json.dumps(_meta(source_name="a\ud800b")).encode(),
    "CR and BEL": json.dumps(_meta(source_name="a\r\x07b")).encode(),
    "C1 control": json.dumps(_meta(writer="x\x9bx")).encode(),
    "long name": json.dumps(_meta(source_name="n" * 5000)).encode(),
    "NaN tolerance": json.dumps(_meta(mode="tolerance", tolerance_mm=float("nan"))).encode(),
    "unit as a number": json.dumps(_meta(unit=10**30)).encode(),
}


@pytest.mark.parametrize("case", sorted(META_CASES))
def test_meta_abuse_is_one_line(tmp_path: Path, case: str) -> None:
    data = with_meta(META_CASES[case])
    with pytest.raises(SectionError, match="META"):
        pipeline.decode(container.unpack(data))
    for cmd in ("info", "test", "decompress"):
        line = _cli_one_line(tmp_path, data, cmd)
        assert "META" in line


def test_meta_size_is_bounded(tmp_path: Path) -> None:
    """A 5 MB name: refused by the section's size, before JSON is parsed."""
    data = with_meta(json.dumps(_meta(source_name="n" * 5_000_000)).encode())
    with pytest.raises(LimitError, match="META: 5000"):
        pipeline.decode(container.unpack(data))
    _cli_one_line(tmp_path, data, "decompress")


def test_meta_text_for_writers() -> None:
    """What compress stores of a file name: control characters and undecodable
    bytes replaced, length cut; the reader accepts the result."""
    name = "a\rb\x07c\udcff" + "x" * 3000
    clean = serialize.meta_text(name)
    assert clean.startswith("a\ufffdb\ufffdc\ufffdxx") and len(clean) == serialize.MAX_META_TEXT
    raw = json.dumps(_meta(source_name=clean, writer=serialize.meta_text("w"))).encode()
    meta = serialize.read_meta(raw)
    assert meta["source_name"] == clean


def test_printed_text_is_escaped(tmp_path: Path) -> None:
    assert show("a\rb\x07c\u202ed\ud800") == "a\\rb\\x07c\\u202ed\\ud800"
    assert show("é ok") == "é ok"
    src = tmp_path / "x\r\x07y.nzc"
    src.write_bytes(BASE.read_bytes())
    r = CliRunner().invoke(cli, ["info", str(src)])
    assert r.exit_code == 0, r.output
    assert "\r" not in r.output and "\x07" not in r.output
    assert "x\\r\\x07y.nzc" in r.output
    bad = tmp_path / "z\x1b[31m.nzc"
    bad.write_bytes(b"junk")
    r = CliRunner().invoke(cli, ["info", str(bad)])
    assert r.exit_code == 1 and "\x1b" not in r.stderr and "z\\x1b[31m.nzc" in r.stderr


def test_goldens_meta_still_reads() -> None:
    for p in sorted(GOLDEN.glob("*.nzc")):
        meta = serialize.read_meta(container.unpack(p.read_bytes()).get("META"))
        assert isinstance(meta["source_name"], str)


def test_all_meta_errors_are_format_errors() -> None:
    for raw in META_CASES.values():
        with pytest.raises(FormatError):
            serialize.read_meta(raw)
