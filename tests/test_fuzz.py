"""Fuzzing in ``make test``: mutated containers decode or fail with a FormatError.

The seeds are the golden containers (formats 1.0 to 1.2, made from the samples); the
mutations are those of ``tests/fuzz.py`` (``make fuzz`` runs ≥ 10,000 of
them).  Raw mutations are mostly caught by a CRC; section mutations are
packed again with valid CRCs, so they reach the section decoders and OCCT.
Each case has a time limit (``fuzz.check``).
"""

from __future__ import annotations

import random
from pathlib import Path

import pytest
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from nurbscomp import container, entropy, pipeline
from nurbscomp.cli import cli
from nurbscomp.errors import (
    EXIT_CONTAINER,
    CorruptError,
    FormatError,
    RebuildError,
    UndiagnosedError,
)

from . import fuzz
from .conftest import SAMPLES

GOLDEN = Path(__file__).resolve().parent / "golden"
SEEDS = [p.read_bytes() for p in sorted(GOLDEN.glob("*.nzc"))]
SECONDS = 10.0


def _settings(n: int) -> settings:
    return settings(
        max_examples=n,
        deadline=None,  # fuzz.check has its own time limit
        suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
    )


def test_seeds_decode() -> None:
    assert len(SEEDS) >= 4
    for data in SEEDS:
        assert fuzz.check(data, SECONDS) == "ok"


@_settings(1000)
@given(st.integers(0, 2**63), st.integers(0, len(SEEDS) - 1))
def test_raw_mutations(seed: int, which: int) -> None:
    data = fuzz.mutate_raw(SEEDS[which], random.Random(seed))
    # raises (and fails the test) on anything but a FormatError, or on a hang
    fuzz.check(data, SECONDS)


@pytest.mark.slow
@_settings(400)  # make fuzz runs 10,000 such cases
@given(st.integers(0, 2**63), st.integers(0, len(SEEDS) - 1))
def test_section_mutations_with_valid_crcs(seed: int, which: int) -> None:
    rng = random.Random(seed)
    data = fuzz.mutate_sections(SEEDS[which], rng, SEEDS)
    try:  # every CRC is valid: the damage is inside the sections (or a duplicated one)
        container.unpack(data)
    except CorruptError as e:
        assert "appears twice" in str(e)
    fuzz.check(data, SECONDS)


@pytest.mark.slow
def test_mutations_reach_the_section_decoders() -> None:
    """The section family is not all caught by the container layer: most cases
    get past ``container.unpack``, and some decode."""
    outcomes = [
        fuzz.check(fuzz.mutate_sections(SEEDS[i % len(SEEDS)], random.Random(i), SEEDS), SECONDS)
        for i in range(80)
    ]
    assert "SectionError" in outcomes and "ok" in outcomes
    assert not {"ChecksumError", "TruncatedError", "BadMagicError"} & set(outcomes)


@pytest.mark.slow
@_settings(100)
@given(st.integers(0, 2**63), st.integers(0, len(SEEDS) - 1), st.booleans())
def test_cli_decompress_on_mutations(
    tmp_path_factory: pytest.TempPathFactory, seed: int, which: int, raw: bool
) -> None:
    rng = random.Random(seed)
    data = (
        fuzz.mutate_raw(SEEDS[which], rng)
        if raw
        else fuzz.mutate_sections(SEEDS[which], rng, SEEDS)
    )
    d = tmp_path_factory.mktemp("fuzz")
    src, out = d / "case.nzc", d / "case.step"
    src.write_bytes(data)
    r = CliRunner().invoke(cli, ["decompress", str(src), "-o", str(out)])
    left = sorted(p.name for p in d.iterdir())
    if r.exit_code == 0:
        assert left == ["case.nzc", "case.step"]
        return
    assert r.exit_code == EXIT_CONTAINER, r.output
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"error: {src}: "), r.stderr
    assert "internal error" not in lines[0] and "Traceback" not in r.stderr
    assert left == ["case.nzc"]


def test_shape_the_step_writer_refuses(tmp_path: Path, monkeypatch) -> None:
    """Found by ``make fuzz`` (seed 1, case 3413): one stored edge range of the
    bracket set to -0.0 decodes and builds, but OCCT's STEP writer refuses the
    shape.  That is a RebuildError (a FormatError), not an OutputError.  (The
    bracket's ranges are now all rules from the vertices; they are stored as
    floats here, as the writer did when the fuzzer found this.)"""
    from nurbscomp.rules import joins

    from .golden.make_golden import _arrays, _replace, _write_arrays

    src = tmp_path / "bracket.nzc"
    with monkeypatch.context() as mp:
        mp.setattr(joins, "vertex_ranges", lambda m: {})
        pipeline.compress_file(SAMPLES / "bracket.step", src, lossless=True, verify=False)
    c = container.unpack(src.read_bytes())
    edge = _arrays(c.get("EDGE"), "EDGE")
    ranges = edge[-3][1].copy()  # the stored ranges: the last three arrays (range, uv, uv2)
    ranges[55] = -0.0
    edge[-3] = ("f", ranges)
    secs = _replace([(s.tag, s.raw) for s in c.sections], "EDGE", _write_arrays(edge))
    bad = tmp_path / "bad.nzc"
    bad.write_bytes(container.pack(secs, c.flags, (entropy.Coder.STORED,)))
    out = tmp_path / "bad.step"
    with pytest.raises(RebuildError, match="STEP writer refused"):
        pipeline.decompress_file(bad, out)
    r = CliRunner().invoke(cli, ["decompress", str(bad), "-o", str(out)])
    assert r.exit_code == EXIT_CONTAINER
    # the container holds product data (1.2): XDE's writer translates on Write,
    # which then has nothing to write
    assert r.stderr.strip() == f"error: {bad}: the STEP writer refused the shape (IFSelect_RetVoid)"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.nzc", "bracket.nzc"]


# ---------------------------------------------------------------- structure-aware (issue 11)


@pytest.mark.slow
@pytest.mark.parametrize("edit", fuzz.EDITS)
def test_each_structure_edit_builds_a_container(edit: str) -> None:
    """Each edit of ``fuzz.EDITS`` makes a container whose CRCs are valid and
    whose tables decode or fail with a FormatError (no OCCT here: the worker
    run below builds and writes)."""
    models = [fuzz.decoded(d) for d in SEEDS]
    for k in range(3):
        name, data = fuzz.build_case(models, random.Random(f"{edit}:{k}"), [edit])
        assert name == edit
        c = container.unpack(data)  # every CRC valid
        try:
            pipeline.decode(c)
        except FormatError as e:
            assert not isinstance(e, UndiagnosedError), e


@pytest.mark.slow
def test_structure_cases_in_workers(capsys: pytest.CaptureFixture[str]) -> None:
    """A fast, seeded subset of ``make fuzz``'s structure-aware run: each case
    in a worker process under a memory and a time limit, decoded and written
    (STEP, IGES or BREP); no crash, hang, memory excess or traceback."""
    status = fuzz.run(40, seed=7, jobs=1, timeout=60, mode="structure")
    out = capsys.readouterr().out
    assert "fuzz (structure): 40 cases" in out
    assert status == 0, out
    assert "LimitError" in out and "ok " in out  # both verdicts are reached
