"""Format 2.12's geometry tables (docs/format.md §2.3, marked *(2.12)*):
unit knot vectors store no ends, end multiplicities are stored less
degree + 1, and a table's weights may be integers on a grid 2^-b, each
predicted from the weights before it.  Written and read back bit for bit,
by ``nurbscomp`` and by the independent reader; hostile values refused."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from nurbscomp import container, pipeline, writer
from nurbscomp.errors import SectionError
from nurbscomp.model import BSplineCurve, BSplineSurface
from nurbscomp.serialize import geometry as G
from nurbscomp.streams import BlockWriter

from .golden.make_golden import _arrays
from .independent import reader
from .test_independent_reader import same_floats

GOLDEN = Path(__file__).resolve().parent / "golden"
REV = container.REVISION
OLD = container.VERSIONS.index((2, 11))


def _curve(knots, mults, degree: int, periodic: bool = False, weights=None) -> BSplineCurve:
    n = int(np.sum(mults)) - (int(mults[0]) if periodic else degree + 1)
    poles = np.random.default_rng(n).normal(size=(n, 3))
    return BSplineCurve(
        poles, weights, np.asarray(knots, float), np.asarray(mults), degree, periodic
    )


def _same(a, b) -> None:  # type: ignore[no-untyped-def]
    assert type(a) is type(b)
    for f in ("poles", "weights", "knots", "mults", "uknots", "vknots", "umults", "vmults"):
        x, y = getattr(a, f, None), getattr(b, f, None)
        if x is None:
            assert y is None, f
        else:
            assert np.asarray(x).tobytes() == np.asarray(y).tobytes(), f


CURVES = [
    _curve([0.0, 1.0], [4, 4], 3),  # a unit vector of two knots: nothing stored
    _curve([0.0, 0.25, 0.5, 1.0], [3, 1, 2, 3], 2),  # unit, explicit multiplicities
    _curve([0.0, 0.5, 1.0], [3, 1, 3], 2),  # unit and evenly spaced
    _curve([-0.0, 0.3, 1.0], [3, 1, 3], 2),  # -0.0 is not a unit vector's end
    _curve([2.0, 3.5, 7.0], [4, 1, 4], 3),  # not a unit vector
    _curve([0.0, 0.2, 0.6, 1.0], [1, 1, 1, 1], 2, periodic=True),  # ends far below degree + 1
]


@pytest.mark.parametrize("revision", [OLD, REV])
def test_knot_vectors_round_trip(revision: int) -> None:
    raw = G._write_geometry(CURVES, 3, frozenset(), revision)
    back = G._read_geometry(raw, "CRV3", 3, revision)
    for a, b in zip(CURVES, back, strict=True):
        _same(a, b)


def test_unit_vectors_store_no_ends() -> None:
    """The four unit vectors of ``CURVES`` (two knots; explicit; evenly
    spaced; periodic) hold two knots fewer each in 2.12; -0.0 ... 1.0 and
    2 ... 7 as many."""
    counts = {}
    for rev in (OLD, REV):
        arrays = _arrays(G._write_geometry(CURVES, 3, frozenset(), rev), "CRV3")
        counts[rev] = len(arrays[-1][1])  # the knots array comes last
    assert counts[OLD] - counts[REV] == 4 * 2


def _rounded(shape: tuple[int, ...], b: int, seed: int) -> np.ndarray:
    """Weights on the grid 2^-b that vary smoothly along rows, ends at 1."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0, 1, shape[-1])
    w = 0.7 + 0.2 * np.sin(3 * t + rng.uniform(0, 1, (shape[0], 1)))
    w[0] = w[-1] = 1.0
    return np.ldexp(np.rint(np.ldexp(w, b)), -b)


@pytest.mark.parametrize("b", [0, 12, 17, 52])
def test_weight_grid_residuals_are_inverted(b: int) -> None:
    w = _rounded((3, 40), b, b) if b else np.array([[1.0, 2.0, 3.0, 5.0]])
    assert G.weight_grid([w]) == b
    r = G.grid_residuals(w, b)
    assert G.grid_weights(r, b, "test").tobytes() == w.tobytes()
    if b == 17:  # smooth rows: small residuals
        assert np.abs(r[:, 2:]).max() < np.abs(np.ldexp(w, b)).max() / 100


def test_weights_that_are_no_grid_stay_floats() -> None:
    """Exact weights need every bit: 1/sqrt(2) alone is on 2^-53, but 1.0
    on that grid is 2^53, out of range; a subnormal needs a grid past 2^-1074."""
    assert G.weight_grid([np.array([[np.sqrt(0.5)]])]) == 53
    assert G.weight_grid([np.array([[1.0, np.sqrt(0.5), 1.0]])]) is None
    assert G.weight_grid([np.array([[1.0, 0.5, 1.0]]), np.array([[2.0**-1060 * 3]])]) is None
    rows = [_curve([0.0, 1.0], [3, 3], 2, weights=np.array([1.0, np.sqrt(0.5), 1.0]))]
    arrays = _arrays(G._write_geometry(rows, 3, frozenset(), REV), "CRV3")
    assert arrays[-2][0] == "f"


def _surface(b: int, seed: int) -> BSplineSurface:
    nu, nv = 3, 30
    rng = np.random.default_rng(seed)
    poles = rng.normal(size=(nu, nv, 3)) * 10
    uk, um = np.array([0.0, 1.0]), np.array([3, 3])
    vk = np.linspace(0, 1, nv - 1)
    vm = np.r_[3, np.ones(nv - 3, int), 3]
    return BSplineSurface(poles, _rounded((nu, nv), b, seed), uk, vk, um, vm, 2, 2, False, False)


def test_rounded_weights_go_on_the_grid_and_back() -> None:
    rows = [_surface(16, 1), _surface(16, 2)]
    raw = G._write_geometry(rows, 3, frozenset(), REV)
    arrays = _arrays(raw, "SURF")
    kinds = [k for k, _ in arrays]
    assert kinds[-2] == "i" and arrays[-2][1][0] == 16  # weights on the grid 2^-16
    back = G._read_geometry(raw, "SURF", 3, REV)
    for a, b in zip(rows, back, strict=True):
        _same(a, b)
    floats = G._write_geometry(rows, 3, frozenset(), OLD)
    assert _arrays(floats, "SURF")[-2][0] == "f"  # 2.11 keeps floats


def _with_weights(arrays, values) -> bytes:  # type: ignore[no-untyped-def]
    w = BlockWriter()
    for i, (k, a) in enumerate(arrays):
        if i == len(arrays) - 2:
            w.ints(values)
        else:
            (w.floats if k == "f" else w.ints)(a)
    return bytes(w)


def test_hostile_weight_grids_are_refused() -> None:
    rows = [_surface(16, 1)]
    arrays = _arrays(G._write_geometry(rows, 3, frozenset(), REV), "SURF")
    grid = arrays[-2][1]
    for bad, match in (
        (np.zeros(0, np.int64), "weight grid"),
        (np.r_[1075, grid[1:]], "weight grid"),
        (np.r_[-1, grid[1:]], "weight grid"),
        (np.r_[grid[:2], 1 << 62, grid[3:]], "out of range"),
        (grid[:-1], "too short"),
    ):
        with pytest.raises(SectionError, match=match):
            G._read_geometry(_with_weights(arrays, bad), "SURF", 3, REV)
    # an integer weights array in a 2.11 table is not read as a grid
    with pytest.raises(SectionError):
        G._read_geometry(_with_weights(arrays, grid), "SURF", 3, OLD)


def test_unit_form_is_refused_before_2_12_and_with_a_repeat() -> None:
    raw = G._write_geometry(CURVES[:1], 3, frozenset(), REV)
    with pytest.raises(SectionError, match="form"):
        G._read_geometry(raw, "CRV3", 3, OLD)
    arrays = _arrays(raw, "CRV3")
    hdr = arrays[2][1].copy()
    assert hdr[-1] == G.K_UNIT | G.K_SIMPLE
    hdr[-1] = G.K_UNIT | G.K_REPEAT
    w = BlockWriter()
    for i, (k, a) in enumerate(arrays):
        (w.floats if k == "f" else w.ints)(hdr if i == 2 else a)
    with pytest.raises(SectionError, match="form"):
        G._read_geometry(bytes(w), "CRV3", 3, REV)


def test_independent_reader_reads_a_weight_grid() -> None:
    """A container whose surfaces have weights on a grid: the independent
    reader, written from the spec, decodes it as ``nurbscomp`` does."""
    data = (GOLDEN / "loft.lossless.nzc").read_bytes()
    m, meta = pipeline.decode(container.unpack(data))
    surfaces = list(m.surfaces)
    for i, s in enumerate(surfaces):
        if isinstance(s, BSplineSurface):
            nu, nv = s.poles.shape[:2]
            w = _rounded((nu, nv), 14, i)
            surfaces[i] = replace(s, weights=w)
    m2 = replace(m, surfaces=surfaces)
    secs = writer.model_to_sections(m2, meta)
    packed = container.pack(secs, container.FLAG_LOSSLESS)
    surf = dict(secs)["SURF"]
    assert _arrays(surf, "SURF")[-2][0] == "i"  # the grid was chosen
    got = reader.read(packed).floats()
    assert same_floats(packed, got) == []
    back, _ = pipeline.decode(container.unpack(packed))
    for a, b in zip(surfaces, back.surfaces, strict=True):
        if isinstance(a, BSplineSurface):
            assert np.asarray(b.weights).tobytes() == a.weights.tobytes()
