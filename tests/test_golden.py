"""Golden files: format 1.0 containers decode forever, damaged ones fail exactly.

``tests/golden/make_golden.py`` wrote them; it is rerun only when the format's
major version changes.  Nothing here regenerates anything.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from nurbscomp import container, errors, occ, pipeline
from nurbscomp.cli import cli
from nurbscomp.errors import EXIT_CONTAINER

from .conftest import SAMPLES
from .golden.make_golden import GOLDEN, VERSION, describe, golden_name, model_floats

GOLDEN_DIR = Path(__file__).resolve().parent / "golden"
EXPECTED = json.loads((GOLDEN_DIR / "expected.json").read_text())
ERRORS = json.loads((GOLDEN_DIR / "errors" / "expected.json").read_text())
NAMES = [golden_name(s, m) for s, m, _ in GOLDEN]


def test_every_golden_file_is_listed() -> None:
    assert sorted(EXPECTED) == sorted(NAMES)
    assert sorted(ERRORS) == sorted(p.name for p in (GOLDEN_DIR / "errors").glob("*.nzc"))
    assert len(ERRORS) >= 20


@pytest.mark.parametrize("name", NAMES)
def test_golden_file_decodes_as_recorded(name: str) -> None:
    data = (GOLDEN_DIR / f"{name}.nzc").read_bytes()
    assert len(data) < 8000  # kept small
    want = EXPECTED[name]
    got = describe(data)
    assert got["format_version"] == want["format_version"] == VERSION[name]
    assert got["mode"] == want["mode"]
    if want["mode"] == "exact":  # byte-exact (2.0): the sample itself, bit for bit
        sample = next(s for s, m, _ in GOLDEN if golden_name(s, m) == name)
        assert got == want
        assert want["sha256"] == hashlib.sha256((SAMPLES / sample).read_bytes()).hexdigest()
        return
    assert got["counts"] == want["counts"]
    assert got["geometry"] == want["geometry"]
    assert got["int_digest"] == want["int_digest"]
    # product data (1.2) decodes as recorded; an older file yields none
    assert got.get("product_digest") == want.get("product_digest")
    assert ("product_digest" in want) == (VERSION[name] >= "1.2")
    # every decoded float within 1e-12 of the stored one (relative above 1)
    m, _ = pipeline.decode(container.unpack(data))
    stored = np.load(GOLDEN_DIR / f"{name}.npz")
    floats = model_floats(m)
    assert sorted(stored.files) == sorted(floats)
    for k, a in floats.items():
        b = stored[k]
        assert a.shape == b.shape, k
        assert (np.abs(a - b) <= 1e-12 * np.maximum(1.0, np.abs(b))).all(), k
    # and the shape builds, with the recorded topology
    shape = pipeline.build(m)
    assert occ.counts(shape)["faces"] == want.get("placed_faces", want["counts"]["face"])


@pytest.mark.parametrize("name", sorted(ERRORS))
def test_damaged_file_raises_its_error(name: str) -> None:
    data = (GOLDEN_DIR / "errors" / name).read_bytes()
    want = ERRORS[name]
    if want["error"] is None:
        m, _ = pipeline.decode(container.unpack(data))
        pipeline.build(m)
        return
    cls = getattr(errors, want["error"])
    assert issubclass(cls, errors.FormatError)
    with pytest.raises(errors.FormatError) as info:
        m, _ = pipeline.decode(container.unpack(data))
        pipeline.build(m)
    assert type(info.value) is cls, f"{type(info.value).__name__}: {info.value}"
    assert want["message"] in str(info.value)


def test_damaged_files_through_the_cli(tmp_path: Path) -> None:
    for name, want in sorted(ERRORS.items()):
        src = GOLDEN_DIR / "errors" / name
        out = tmp_path / f"{name}.step"
        r = CliRunner().invoke(cli, ["decompress", str(src), "-o", str(out)])
        if want["error"] is None:
            assert r.exit_code == 0, r.stderr
            continue
        assert r.exit_code == EXIT_CONTAINER, name
        lines = r.stderr.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith(f"error: {src}: "), r.stderr
        assert want["message"] in lines[0]
        assert not out.exists()
    assert sorted(p.suffix for p in tmp_path.iterdir()) == [".step"]  # nothing else left
