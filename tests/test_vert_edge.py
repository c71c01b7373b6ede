"""Format 2.0 EDGE surfaces by prediction (issue 28 item 2, docs/format.md §2.7):
a representation's surface is picked among the surfaces of its edge's faces,
or escaped; 1.x files keep their layout."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from nurbscomp import container, pipeline, serialize
from nurbscomp.errors import BadReferenceError, FormatError, LimitError, SectionError
from nurbscomp.model import RepKind

from . import fuzz

GOLDEN = Path(__file__).resolve().parent / "golden"
NAMES = (
    "bracket.lossless.nzc",
    "loft.tol0.01.nzc",
    "teapot.faces.tol0.01.nzc",
    "assembly.lossless.nzc",
)


def _repacked(name: str) -> tuple[object, bytes]:
    """A golden file (1.x) decoded, and its model as a 2.0 lossless container."""
    m, meta = fuzz.decoded((GOLDEN / name).read_bytes())
    return m, fuzz.pack_model(m, meta)


def _decode(data: bytes):  # type: ignore[no-untyped-def]
    c = container.unpack(data)
    assert c.revision == container.REVISION == 3
    return pipeline.decode(c)[0]


@pytest.mark.parametrize("name", NAMES)
def test_picked_surfaces_round_trip(name: str) -> None:
    m, data = _repacked(name)
    back = _decode(data)
    np.testing.assert_array_equal(back.edge_reps, m.edge_reps)


def test_every_pcurve_surface_is_a_face_surface_of_its_edge() -> None:
    """On the golden models every surface of a representation is one of its
    edge's candidates: nothing is escaped, and most picks are 0."""
    for name in NAMES:
        m, _ = _repacked(name)
        cands = serialize.edge_candidates(m)
        reps = m.edge_reps
        on = reps[:, 1] != RepKind.CURVE3D
        picks = serialize._picks(reps[on, 4], reps[on, 0], cands)
        assert (picks >= 0).all(), name
        assert (picks == 0).mean() > 0.4, name


@pytest.mark.parametrize(
    ("pick", "error", "match"),
    [(7, BadReferenceError, "picks surface"), (-2, SectionError, "below -1")],
)
def test_hostile_picks_are_refused(monkeypatch, pick: int, error: type, match: str) -> None:
    m, meta = fuzz.decoded((GOLDEN / "bracket.lossless.nzc").read_bytes())
    monkeypatch.setattr(serialize, "_picks", lambda v, e, c: np.full(len(v), pick, np.int64))
    data = fuzz.pack_model(m, meta)
    with pytest.raises(error, match=match):
        _decode(data)
    assert issubclass(error, FormatError)


def test_escaped_surfaces_round_trip(monkeypatch) -> None:
    """Every surface escaped (a writer that predicts nothing) decodes the same."""
    m, meta = fuzz.decoded((GOLDEN / "loft.lossless.nzc").read_bytes())
    monkeypatch.setattr(serialize, "_picks", lambda v, e, c: np.full(len(v), -1, np.int64))
    back = _decode(fuzz.pack_model(m, meta))
    np.testing.assert_array_equal(back.edge_reps, m.edge_reps)


def test_candidate_walks_are_bounded() -> None:
    m, _ = fuzz.decoded((GOLDEN / "bracket.lossless.nzc").read_bytes())
    serialize.edge_candidates(m)
    with pytest.raises(LimitError):
        serialize.edge_candidates(m, cap=3)


def test_tolerance_codes_are_exact() -> None:
    """Quarter powers (what the lossy writer widens to) are coded as integers
    and read back bit for bit; other values, 0 and 1.0 stay floats."""
    k = np.arange(-200, 40)
    tols = np.concatenate([np.exp2(k / 4), [1e-7, 0.0, 1.0, 3.3e-3, 5e-324]])
    w = serialize.BlockWriter()
    serialize._write_tolerances(w, tols)
    r = serialize.BlockReader(bytes(w), "VERT")
    back = serialize._read_tolerances(r, len(tols), "VERT")
    r.done()
    assert back.view(np.int64).tolist() == tols.view(np.int64).tolist()
    codes = serialize.BlockReader(bytes(w), "VERT").ints()
    assert (codes[: len(k)] == np.where(k == 0, 0, k)).all()


def test_tolerance_code_out_of_range_is_refused() -> None:
    w = serialize.BlockWriter()
    w.ints([5000])
    w.floats(np.zeros(0))
    with pytest.raises(SectionError, match="tolerance code"):
        serialize._read_tolerances(serialize.BlockReader(bytes(w), "EDGE"), None, "EDGE")


@pytest.mark.parametrize("name", ["loft.tol0.01.nzc", "teapot.tol0.01.nzc"])
def test_lossy_tolerances_round_trip(name: str) -> None:
    m, data = _repacked(name)
    back = _decode(data)
    assert back.vertex_tol.view(np.int64).tolist() == m.vertex_tol.view(np.int64).tolist()
    assert back.edge_tol.view(np.int64).tolist() == m.edge_tol.view(np.int64).tolist()
