"""Lossless round trips through the model and the container, on samples and corpus.

The deviation check is independent of the codec: it samples points inside each
original face and measures their distance to the decoded face of the same index.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from nurbscomp import container, decode, occ, pipeline, serialize, writer
from nurbscomp.errors import CorruptError
from nurbscomp.model import differences
from nurbscomp.rules import ranges

from .conftest import assert_step_keeps_floor, corpus_files, sample_files


def _model(path: Path):
    cad = occ.read_cad(path)
    m, _ = occ.shape_to_model(cad.shape)
    m.unit, m.source_format = cad.unit, cad.source_format
    return cad, m


@pytest.mark.parametrize("path", sample_files(), ids=lambda p: p.name)
def test_model_round_trip_is_exact(path: Path) -> None:
    cad, m = _model(path)
    rebuilt = occ.model_to_shape(m)
    again, _ = occ.shape_to_model(rebuilt)
    again.unit, again.source_format = m.unit, m.source_format
    assert differences(m, again) == [] or all(
        d.startswith(("surfaces", "curves")) for d in differences(m, again)
    )
    assert occ.counts(rebuilt) == occ.counts(cad.shape)
    assert occ.is_valid(rebuilt)


@pytest.mark.parametrize("path", sample_files(), ids=lambda p: p.name)
def test_container_round_trip_of_model_is_exact(path: Path) -> None:
    _, m = _model(path)
    data = container.pack(writer.model_to_sections(m, {"x": 1, "mode": "lossless"}))
    back, meta = decode.sections_to_model(container.unpack(data).get)
    assert differences(m, back) == []
    assert meta["x"] == 1


def _check_lossless(path: Path, tmp_path: Path) -> dict:
    """Compress losslessly, decode in memory and to .brep; compare with the input."""
    cad = occ.read_cad(path)
    nzc = tmp_path / (path.name + ".nzc")
    report = pipeline.compress_file(path, nzc, lossless=True)
    assert report["verified"]
    shape, m, _ = pipeline.decode_file(nzc)
    src_model, _ = occ.shape_to_model(cad.shape)
    # same numbers, bit for bit, except analytic frames that OCCT's gp
    # constructors re-normalise (at most a few ulp: see docs/format.md)
    diff = [d for d in differences(src_model, m) if d not in ("unit", "source_format")]
    assert diff == [] or all(d.startswith(("surfaces", "curves3d", "curves2d")) for d in diff), diff
    assert occ.counts(shape) == occ.counts(cad.shape)
    assert [f.TShape() is not None for f in occ.faces(shape)]
    dev = occ.deviation(cad.shape, shape, n=4)
    assert dev.max() <= 1e-9, f"max deviation {dev.max()}"
    if occ.is_valid(cad.shape):
        assert occ.is_valid(shape)
    brep = tmp_path / "out.brep"
    pipeline.decompress_file(nzc, brep)
    from OCP.BRep import BRep_Builder
    from OCP.BRepTools import BRepTools
    from OCP.TopoDS import TopoDS_Shape

    back = TopoDS_Shape()
    assert BRepTools.Read_s(back, str(brep), BRep_Builder())
    assert occ.counts(back) == occ.counts(cad.shape)
    return report


@pytest.mark.parametrize("path", sample_files(), ids=lambda p: p.name)
def test_lossless_samples(path: Path, tmp_path: Path) -> None:
    _check_lossless(path, tmp_path)


@pytest.mark.slow
@pytest.mark.parametrize("path", corpus_files(), ids=lambda p: p.name)
def test_lossless_corpus(path: Path, tmp_path: Path) -> None:
    _check_lossless(path, tmp_path)


@pytest.mark.slow
@pytest.mark.parametrize("path", corpus_files(), ids=lambda p: p.name)
def test_step_output_keeps_what_occt_keeps(path: Path, tmp_path: Path) -> None:
    """Decompressed to STEP and read back, the file keeps what OCCT's own round trip keeps."""
    cad = occ.read_cad(path)
    nzc = tmp_path / "x.nzc"
    pipeline.compress_file(path, nzc, lossless=True)
    ours = assert_step_keeps_floor(cad, nzc, tmp_path)
    if occ.counts(ours) == occ.counts(cad.shape):
        dev = occ.deviation(cad.shape, ours, n=4, tol=1e-9)
        assert dev.max() <= 1e-9, f"max deviation {dev.max()}"


def test_ranges_from_vertices_are_exact_and_checked() -> None:
    """Edges on lines and circles whose ranges are what their vertices give, bit
    for bit, store no floats (RANGE_VERTICES); the rule is refused elsewhere."""
    cad, m = _model(next(p for p in sample_files() if p.name == "bracket.step"))
    how = ranges.range_kinds(m)
    assert (how == serialize.RANGE_VERTICES).sum() > 0
    sections = dict(writer.model_to_sections(m, {"mode": "lossless"}))
    back, _ = decode.sections_to_model(sections.__getitem__)
    assert not differences(m, back)
    # a "from vertices" range on a curve that is no line does not decode
    assert (how == serialize.RANGE_NATURAL).any() or (how == serialize.RANGE_STORED).any()
    with pytest.raises(CorruptError, match="no line or circle"):
        ranges.resolve_ranges(back, np.full(len(how), serialize.RANGE_VERTICES))
