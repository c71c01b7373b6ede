"""STEP output without pcurves where the source STEP had none (issue 30 item 3).

A STEP file without ``PCURVE`` entities (NIST's, many CAD systems') is read by
OCCT, which computes the pcurves; writing them back doubles the file and costs
the decoder every projection.  The encoder's STEP check writes its candidates
without pcurves while that keeps what OCCT's own round trip keeps, and META's
``step_pcurves`` tells ``decompress`` to do the same.
"""

from __future__ import annotations

import json
from pathlib import Path

import cadquery as cq
import pytest

import nurbscomp
from nurbscomp import container, occ, pipeline, serialize
from nurbscomp.errors import SectionError
from nurbscomp.occ import topology

from .conftest import assert_step_keeps_floor, tag_step_trips


def _shape():  # type: ignore[no-untyped-def]
    """Fillets, a hole and a boss: cylinders, tori and planes, seams included."""
    return (
        cq.Workplane()
        .box(20, 14, 8)
        .edges("|Z")
        .fillet(2)
        .faces(">Z")
        .workplane()
        .hole(5)
        .faces("<Z")
        .workplane()
        .circle(3)
        .extrude(4)
        .edges(">Z")
        .fillet(1)
        .val()
        .wrapped
    )


@pytest.fixture(scope="module")
def sources(tmp_path_factory: pytest.TempPathFactory) -> dict[bool, Path]:
    """The same part written to STEP with and without pcurves."""
    d = tmp_path_factory.mktemp("pcurves")
    out = {}
    for pcurves in (True, False):
        out[pcurves] = d / f"part_{pcurves}.step"
        occ.write_shape(_shape(), out[pcurves], "STEP", pcurves=pcurves)
    return out


def _meta(nzc: Path) -> dict:
    c = container.unpack(nzc.read_bytes())
    return serialize.read_meta(c.get("META"))


@pytest.mark.parametrize(
    "text, has",
    [
        (b"#5=PCURVE('',#6,#7);", True),
        (b"#5 = pcurve ( '',#6,#7);", True),
        (b"#5=BOUNDED_PCURVE('',#6,#7);", True),
        (b"#5=SURFACE_CURVE('',#6,(#7),.PCURVE_S1.);", False),
        (b"#5=SURFACE_CURVE('',#6,(),.PCURVE_S1.);\n#7=LINE('',#8,#9);", False),
    ],
)
def test_step_has_pcurves(text: bytes, has: bool) -> None:
    assert occ.files.step_has_pcurves(text) is has


def test_a_step_file_without_pcurves_is_read_as_such(sources: dict[bool, Path]) -> None:
    assert not occ.files.step_has_pcurves(sources[False].read_bytes())
    assert occ.read_cad(sources[False]).pcurves is False
    assert occ.read_cad(sources[True]).pcurves is True
    assert occ.read_cad(sources[False], product=True).pcurves is False


@pytest.mark.parametrize("pcurves", [True, False])
def test_decompressed_step_has_pcurves_where_the_source_had(
    sources: dict[bool, Path], pcurves: bool, tmp_path: Path
) -> None:
    src = sources[pcurves]
    nzc = tmp_path / "x.nzc"
    rep = pipeline.compress_file(src, nzc, tol=0.01)
    assert rep["validity"]["step_pcurves"] is pcurves
    assert ("step_pcurves" in _meta(nzc)) is not pcurves
    assert pipeline.info(nzc)["step_pcurves"] is pcurves
    assert nurbscomp.info(nzc).step_pcurves is pcurves
    back = assert_step_keeps_floor(occ.read_cad(src, product=True), nzc, tmp_path)
    out = (tmp_path / "out.step").read_bytes()
    assert occ.files.step_has_pcurves(out) is pcurves
    assert occ.counts(back) == occ.counts(_shape())
    # the in-memory shape is whole either way (every pcurve computed)
    shape, _, _ = pipeline.decode_file(nzc)
    assert occ.is_valid(shape)


def test_a_shape_without_its_computed_pcurves_writes_the_same_step(
    sources: dict[bool, Path], tmp_path: Path
) -> None:
    """What the STEP check writes (the whole candidate) is what decompress
    writes (the shape built without the pcurves the container leaves out)."""
    nzc = tmp_path / "x.nzc"
    pipeline.compress_file(sources[False], nzc, tol=0.01)
    m, meta = pipeline.decode(pipeline.read_container(nzc))
    whole, bare = topology.model_to_shape(m), topology.model_to_shape(m, pcurves=False)
    texts = []
    for shape, name in ((whole, "a.step"), (bare, "b.step")):
        pipeline.write(shape, tmp_path / name, "STEP", m.unit, meta, m.product)
        texts.append((tmp_path / name).read_bytes())
    assert texts[0] == texts[1]
    assert occ.counts(bare) == occ.counts(whole)


def _losing(monkeypatch: pytest.MonkeyPatch, bare: int, whole: int) -> list[bool]:
    """Make the first ``bare`` checks of candidates written without pcurves,
    and the first ``whole`` of those written with them, lose face 0; the
    modes asked, in order."""
    return tag_step_trips(
        monkeypatch,
        "pcurves",
        lambda pcurves, asked: asked.count(pcurves) <= (whole if pcurves else bare),
    )


def test_a_candidate_that_loses_a_face_only_without_pcurves_is_written_with_them(
    sources: dict[bool, Path], tmp_path: Path, monkeypatch: pytest.MonkeyPatch, one_coding: None
) -> None:
    """The check falls back to writing pcurves (one more round trip) rather
    than climbing the ladder for a loss that only the missing pcurves make."""
    asked = _losing(monkeypatch, bare=1, whole=0)
    nzc = tmp_path / "x.nzc"
    rep = pipeline.compress_file(sources[False], nzc, tol=0.01)
    assert asked == [False, True]
    assert rep["validity"]["step_pcurves"] is True
    assert rep["validity"]["exact_faces"] == {}  # nothing climbed
    assert "step_pcurves" not in _meta(nzc)
    out = tmp_path / "out.step"
    pipeline.decompress_file(nzc, out)
    assert occ.files.step_has_pcurves(out.read_bytes())


def test_a_loss_with_and_without_pcurves_keeps_them_out(
    sources: dict[bool, Path], tmp_path: Path, monkeypatch: pytest.MonkeyPatch, one_coding: None
) -> None:
    """A face lost either way is the coding's doing: the ladder climbs, and
    the candidates are still written without pcurves (compared once only)."""
    asked = _losing(monkeypatch, bare=2, whole=1)
    nzc = tmp_path / "x.nzc"
    rep = pipeline.compress_file(sources[False], nzc, tol=0.01)
    assert asked[:4] == [False, True, False, False]
    assert asked.count(True) == 1
    assert rep["validity"]["step_pcurves"] is False
    assert _meta(nzc)["step_pcurves"] is False


def test_without_the_step_check_pcurves_are_written(
    sources: dict[bool, Path], tmp_path: Path
) -> None:
    nzc = tmp_path / "x.nzc"
    rep = pipeline.compress_file(sources[False], nzc, tol=0.01, step_safe=False)
    assert rep["validity"]["step_pcurves"] is True
    assert "step_pcurves" not in _meta(nzc)


@pytest.mark.parametrize("value", ["no", 0, None, [False]])
def test_meta_step_pcurves_is_a_boolean(value: object) -> None:
    raw = json.dumps({"mode": "lossless", "step_pcurves": value}).encode()
    with pytest.raises(SectionError, match="step_pcurves"):
        serialize.read_meta(raw)
    assert serialize.read_meta(json.dumps({"mode": "lossless", "step_pcurves": False}).encode())
