"""Format 2.17's mapped knot vectors (docs/format.md §2.3, form 3 and 11):
a knot vector that is an earlier one of as many knots, mirrored or not,
mapped affinely onto its own ends, is stored as a reference, a flag and
its ends.  Written and read back bit for bit, by ``nurbscomp`` and by the
independent reader; hostile references refused; older revisions neither
write nor read it."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from nurbscomp import container, pipeline
from nurbscomp.errors import SectionError
from nurbscomp.model import BSplineCurve
from nurbscomp.serialize import geometry as G
from nurbscomp.streams import BlockWriter

from .golden.make_golden import _arrays
from .independent import reader
from .test_independent_reader import same_floats

GOLDEN = Path(__file__).resolve().parent / "golden"
REV = container.REVISION
OLD = container.VERSIONS.index((2, 16))


def _curve(knots: np.ndarray, mults: np.ndarray, degree: int = 3) -> BSplineCurve:
    n = int(np.sum(mults)) - degree - 1
    poles = np.random.default_rng(n).normal(size=(n, 3))
    return BSplineCurve(poles, None, np.asarray(knots, float), np.asarray(mults), degree, False)


def _table() -> list[BSplineCurve]:
    """A leader with uneven knots; its mirror and its forward copy mapped onto
    other ends; its mirror on [0, 1]; and one with a knot moved by 1e-6."""
    rng = np.random.default_rng(5)
    k = np.r_[0.0, np.sort(rng.uniform(0, 1, 9)), 1.0] * 2.7 + 0.4
    mu = np.r_[4, [1] * 9, 4]
    mu[3] = 2
    lead = _curve(k, mu)
    mirror = _curve(G.mapped_knots(k, 1.5, 9.25, True), mu[::-1])
    forward = _curve(G.mapped_knots(k, -3.0, 0.125, False), mu)
    unit = _curve(G.mapped_knots(k, 0.0, 1.0, True), mu[::-1])
    off = G.mapped_knots(k, 1.0, 2.0, False)
    off[5] += 1e-6
    return [lead, mirror, forward, unit, _curve(off, mu)]


def _forms(raw: bytes) -> list[int]:
    return [int(x) for x in _arrays(raw, "CRV3")[2][1]]


def test_mapped_vectors_round_trip_bit_for_bit() -> None:
    table = _table()
    raw = G._write_geometry(table, 3, frozenset(), REV)
    back = G._read_geometry(raw, "CRV3", 3, REV)
    for a, b in zip(table, back, strict=True):
        assert b.knots.tobytes() == a.knots.tobytes()
        assert b.mults.tobytes() == a.mults.tobytes()
    assert _vector_forms(_forms(raw)) == [
        (G.K_EXPLICIT,),
        (G.K_MAPPED, 1, 1),
        (G.K_MAPPED, 2, 0),
        (G.K_MAPPED | G.K_UNIT, 3, 1),
        (G.K_EXPLICIT,),
    ]
    # the same table in 2.16 stores every knot
    old = G._write_geometry(table, 3, frozenset(), OLD)
    assert {f[0] & ~G.K_UNIT for f in _vector_forms(_forms(old))} == {G.K_EXPLICIT}
    assert len(_arrays(old, "CRV3")[-1][1]) > len(_arrays(raw, "CRV3")[-1][1]) + 20


def _vector_forms(hdr: list[int]) -> list[tuple[int, ...]]:
    """Per row of a table of non-rational B-spline curves, its vector's form
    (and, for a mapped one, its reference and flag)."""
    out, i = [], 0
    while i < len(hdr):
        form = hdr[i + 4]
        take = 3 if form & ~G.K_UNIT == G.K_MAPPED else 1
        out.append(tuple(hdr[i + 4 : i + 4 + take]))
        i += 4 + take
    return out


def _with_header(raw: bytes, change) -> bytes:  # type: ignore[no-untyped-def]
    arrays = _arrays(raw, "CRV3")
    hdr = change(arrays[2][1].copy())
    w = BlockWriter()
    for i, (k, a) in enumerate(arrays):
        (w.floats if k == "f" else w.ints)(hdr if i == 2 else a)
    return bytes(w)


def test_hostile_mapped_vectors_are_refused() -> None:
    table = _table()[:2]
    raw = G._write_geometry(table, 3, frozenset(), REV)
    with pytest.raises(SectionError, match="form"):
        G._read_geometry(raw, "CRV3", 3, OLD)
    at = 5 + 4  # the second row's form, after the first row's five values
    assert _forms(raw)[at] == G.K_MAPPED

    def far(h: np.ndarray) -> np.ndarray:
        h[at + 1] = 2  # a vector before the first
        return h

    def flag(h: np.ndarray) -> np.ndarray:
        h[at + 2] = 2  # neither forward nor mirrored
        return h

    for change in (far, flag):
        with pytest.raises(SectionError, match="refers to none"):
            G._read_geometry(_with_header(raw, change), "CRV3", 3, REV)
    # the mapped vector's ends (the last two knots stored) swapped, or infinite
    for ends, match in (([9.25, 1.5], "do not increase"), ([1.5, np.inf], "not finite")):
        arrays = _arrays(raw, "CRV3")
        knots = arrays[-1][1].copy()
        knots[-2:] = ends
        w = BlockWriter()
        for i, (k, a) in enumerate(arrays):
            (w.floats if k == "f" else w.ints)(knots if i == len(arrays) - 1 else a)
        with pytest.raises(SectionError, match=match):
            G._read_geometry(bytes(w), "CRV3", 3, REV)


def test_the_golden_surface_model_maps_its_twins() -> None:
    """The 2.17 golden file (crossed cylinders as an IGES surface model)
    holds mapped vectors; the independent reader decodes it as ``nurbscomp``."""
    data = (GOLDEN / "crossed.v2_17.faces.tol0.01.nzc").read_bytes()
    c = container.unpack(data)
    assert G.K_MAPPED | G.K_UNIT in _forms(c.get("CRV3"))
    got = reader.read(data).floats()
    assert same_floats(data, got) == []
    m, _ = pipeline.decode(c)
    assert len(m.face_surface) == 7
