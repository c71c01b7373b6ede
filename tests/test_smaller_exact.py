"""A coded container larger than the file stored byte for byte is not
written (``pipeline.smaller_exact``): the file itself is, which is within
any tolerance.  A thickened loft as an IGES surface model came out 48,597
bytes within 0.1 mm (one face of 120 edges kept exact, with its pcurves,
for OCCT's STEP reader) and 28,870 byte for byte."""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

import pytest

import nurbscomp
from nurbscomp import pipeline

SAMPLES = Path(__file__).resolve().parent.parent / "samples"


def _bloated(monkeypatch: pytest.MonkeyPatch, extra: int) -> None:
    """``encode_cad`` gives a container ``extra`` bytes larger (a coding that
    went badly), as the CLI's and the API's paths call it."""
    real = pipeline.encode_cad

    def encode(*a: Any, **k: Any) -> Any:
        enc = real(*a, **k)
        return dataclasses.replace(enc, data=enc.data + b"\0" * extra)

    monkeypatch.setattr(pipeline, "encode_cad", encode)


@pytest.mark.parametrize("extra", [0, 200_000])
def test_the_smaller_of_the_coded_and_the_byte_exact_container(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, extra: int
) -> None:
    src = SAMPLES / "loft.step"
    _bloated(monkeypatch, extra)
    out = tmp_path / "loft.nzc"
    r = pipeline.compress_file(src, out, tol=0.01)
    data = out.read_bytes()
    via_api, made = nurbscomp.compress(src, tol=0.01, report=True)
    if not extra:  # the coded container is far smaller: no byte-exact one is made
        assert r["mode"] == "tolerance" and made.mode == "tolerance"
        return
    assert r["mode"] == "exact" and r["tolerance_mm"] is None
    assert any("stored byte for byte" in w for w in r["warnings"])
    assert r["output_bytes"] == len(data) < src.stat().st_size
    assert nurbscomp.original(data) == src.read_bytes()
    assert via_api == data and made.mode == "exact"


def test_a_file_the_text_model_refuses_keeps_its_coded_container(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from nurbscomp import passthrough
    from nurbscomp.errors import InputError

    def refuse(*a: Any, **k: Any) -> Any:
        raise InputError("too large to store")

    monkeypatch.setattr(passthrough, "pack_file", refuse)
    enc = dataclasses.make_dataclass("E", ["lossless", "data"])(False, b"x" * 1000)
    src = tmp_path / "a.step"
    src.write_bytes(b"y" * 2000)
    assert pipeline.smaller_exact(src, "a.step", enc) is None
