"""Format 2.0 geometry tables (docs/format.md §2.3): knot vectors and weight
sets coded as what they are, bit for bit; analytic rows on a grid within
their bound; hostile SURF/CRV3 bytes refused with a ``FormatError``."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from nurbscomp import container, serialize
from nurbscomp.encode import analytic
from nurbscomp.errors import FormatError
from nurbscomp.model import Analytic, BRepModel, BSplineCurve, BSplineSurface, Kind, differences
from nurbscomp.streams import BlockReader, BlockWriter


def _curve(
    knots: list[float],
    mults: list[int],
    degree: int,
    periodic: bool = False,
    weights: np.ndarray | None = None,
) -> BSplineCurve:
    n = sum(mults) - (mults[-1] if periodic else degree + 1)
    poles = np.arange(3 * n, dtype=np.float64).reshape(n, 3)
    k = np.array(knots, np.float64)
    return BSplineCurve(poles, weights, k, np.array(mults, np.int64), degree, periodic)


def _same_tables(a: list, b: list, name: str = "curves3d") -> None:
    x, y = BRepModel(), BRepModel()
    setattr(x, name, a)
    setattr(y, name, b)
    assert differences(x, y) == []


def _round_trip(table: list, dim: int = 3, revision: int = 3, tag: str = "CRV3") -> list:
    raw = serialize._write_geometry(table, dim, frozenset(), revision)
    back = serialize._read_geometry(raw, tag, dim, revision)
    name = {"SURF": "surfaces", "CRV3": "curves3d", "CRV2": "curves2d"}[tag]
    _same_tables(table, back, name)
    # the rows that shared a record still do
    assert [id(g) for g in back].count(id(back[0])) == [id(g) for g in table].count(id(table[0]))
    return back


UNIFORM = np.linspace(0.0, 0.7, 8).tolist()  # evenly spaced within a few ulps
NON_UNIFORM = [0.0, 0.1, 0.35, 0.36, 1.0]


@pytest.mark.parametrize(
    "knots, mults, degree, periodic",
    [
        ([0.0, 1.0], [4, 4], 3, False),  # one span
        (UNIFORM, [4, 1, 1, 1, 1, 1, 1, 4], 3, False),  # clamped uniform
        (UNIFORM, [1] * 8, 3, False),  # uniform, unclamped
        ([0.0, 1.0, 2.0, 3.0, 4.0], [1, 1, 1, 1, 1], 3, True),  # periodic
        ([0.0, 0.5, 1.0], [3, 2, 3], 2, False),  # a repeated inner knot
        (NON_UNIFORM, [3, 1, 1, 1, 3], 2, False),
        ([-2.5, -1.25, -0.0, 1.25, 2.5], [2, 1, 1, 1, 2], 1, False),  # negative knots, -0.0
        ((np.arange(9) * 0.1 + 1e6).tolist(), [3] + [1] * 7 + [3], 2, False),
    ],
)
@pytest.mark.parametrize("revision", [2, 3])
def test_knots_round_trip_bit_for_bit(knots, mults, degree, periodic, revision) -> None:
    c = _curve(knots, mults, degree, periodic)
    d = _curve(knots, mults, degree, periodic)  # equal, another record: a repeat
    w = np.linspace(0.5, 2.0, len(c.poles)) ** 1.5
    e = _curve(knots, mults, degree, periodic, w)
    f = _curve(knots, mults, degree, periodic, w.copy())  # the same weights: a reference
    back = _round_trip([c, d, e, c, f], revision=revision)
    assert back[1] is not back[0] and back[3] is back[0]
    assert back[4].weights.tobytes() == w.tobytes()
    assert back[0].knots.tobytes() == np.array(knots).tobytes()


@pytest.mark.parametrize("revision", [container.VERSIONS.index((2, 11)), container.REVISION])
def test_forms_chosen(revision: int) -> None:
    """Evenly spaced vectors are coded as two ends and residuals, repeats by
    distance; from 2.12 a vector from 0 to 1 stores no ends, and end
    multiplicities are stored less degree + 1."""
    hdr: list[int] = []
    kw = serialize._KnotWriter(hdr, revision)
    knots: list[np.ndarray] = []
    mults: list[int] = []
    k = np.array(UNIFORM)
    mu = np.array([4, 1, 1, 1, 1, 1, 1, 4])
    kw.vector(k, mu, knots, mults, 3)
    kw.vector(k.copy(), mu.copy(), knots, mults, 3)
    kw.vector(np.array(NON_UNIFORM), np.array([3, 1, 2, 1, 3]), knots, mults, 2)
    even, rep, exp = serialize.K_EVEN | serialize.K_SIMPLE, serialize.K_REPEAT, serialize.K_EXPLICIT
    if revision < container.REVISION:
        assert hdr == [even, rep, 1, exp]
        assert [len(x) for x in knots] == [2, 5] and mults == [4, 3, 1, 2, 1, 3]
    else:  # NON_UNIFORM runs from 0 to 1
        assert hdr == [even, rep, 1, exp | serialize.K_UNIT]
        assert [len(x) for x in knots] == [2, 3] and mults == [0, 0, 1, 2, 1, 0]


def test_surface_knots_and_weights() -> None:
    rng = np.random.default_rng(1)
    uk, vk = np.array(UNIFORM[:5]), np.array(NON_UNIFORM)
    um, vm = np.array([3, 1, 1, 1, 3]), np.array([3, 1, 1, 1, 3])
    nu, nv = 6, 6
    w = rng.uniform(0.5, 2, (nu, nv))
    s1 = BSplineSurface(rng.normal(size=(nu, nv, 3)), w, uk, vk, um, vm, 2, 2, False, False)
    s2 = BSplineSurface(
        rng.normal(size=(nu, nv, 3)), w.copy(), uk.copy(), vk.copy(), um, vm, 2, 2, False, False
    )
    s3 = BSplineSurface(rng.normal(size=(nu, nv, 3)), None, vk, uk, vm, um, 2, 2, False, False)
    _round_trip([s1, s2, s3, s1], tag="SURF")


def _gridded(kind: Kind, frame: list[list[float]], params: list[float], tol: float):
    g = Analytic(kind, np.array(frame), np.array(params, np.float64))
    hit = analytic.quantize(g, tol)
    assert hit is not None
    q, bound = hit
    moved = np.linalg.norm(q.frame[0] - g.frame[0]) + np.abs(q.params - g.params).sum()
    assert moved <= bound <= tol
    assert (q.frame[1:] == g.frame[1:]).all()  # directions as they are
    return g, q


AX3 = [[12.345678, -7.654321, 100.0000001], [0, 0, 1.0], [1.0, 0, 0], [0, 1.0, 0]]


@pytest.mark.parametrize("tol", [0.001, 0.01, 0.1])
def test_analytic_rows_within_their_bound(tol: float) -> None:
    rows = [
        _gridded(Kind.PLANE, AX3, [], tol),
        _gridded(Kind.CYLINDER, AX3, [5.0000003], tol),
        _gridded(Kind.CONE, AX3, [2.5000001, 0.3], tol),
        _gridded(Kind.SPHERE, AX3, [7.77777], tol),
        _gridded(Kind.TORUS, AX3, [20.123, 3.21], tol),
    ]
    surfaces = [q for _, q in rows]
    back = _round_trip(surfaces, tag="SURF")
    assert [g.grid for g in back] == [g.grid for g in surfaces]
    assert back[2].params[1] == 0.3  # the semi-angle is not a length
    curves = [
        _gridded(Kind.LINE, AX3[:2], [], tol)[1],
        _gridded(Kind.CIRCLE, AX3[:3], [4.44444], tol)[1],
        _gridded(Kind.ELLIPSE, AX3[:3], [9.87654, 1.2345], tol)[1],
    ]
    _round_trip(curves)


def test_vertex_coordinates_stay() -> None:
    g = Analytic(Kind.CIRCLE, np.array(AX3[:3]), np.array([4.44444]))
    q, bound = analytic.quantize(g, 0.01, frozenset([AX3[0][1]]))
    assert q.mask == 0b101 and q.frame[0, 1] == AX3[0][1]
    assert bound == analytic.grid_bound(q) and bound < analytic.grid_bound(replace(q, mask=7))
    back = _round_trip([q])
    assert back[0].mask == 0b101


def test_small_features_get_a_finer_grid() -> None:
    _, q = _gridded(Kind.CYLINDER, AX3, [0.003], 0.01)
    assert 2.0 ** (q.grid - 64) <= 0.003 / 64
    assert abs(q.params[0] - 0.003) <= 0.003 / 128


def test_lossless_rows_stay_off_the_grid() -> None:
    g = Analytic(Kind.CYLINDER, np.array(AX3), np.array([5.0000003]))
    back = _round_trip([g], tag="SURF")
    assert back[0].grid == 0 and back[0].frame.tobytes() == g.frame.tobytes()


def _table(
    kinds, hdr=(), mults=(), res=(), aval=(), frames=(), params=(), poles=(), weights=(), knots=()
) -> bytes:
    w = BlockWriter()
    for a in (kinds, [], list(hdr), [], list(mults), list(res), list(aval)):
        w.ints(a)
    for a in (frames, params, poles, weights, knots):
        w.floats(np.array(a, np.float64))
    return bytes(w)


_POLES = [0.0] * 12  # 4 poles of a 3-D curve


@pytest.mark.parametrize(
    "data",
    [
        # a repeat of a vector that does not exist
        _table([22], hdr=[4, 0, 3, 2, 1, 1], mults=[], poles=_POLES),
        # an unknown knot form
        _table([22], hdr=[4, 0, 3, 2, 3], mults=[4, 4], poles=_POLES, knots=[0, 1]),
        # evenly spaced with two knots
        _table([22], hdr=[4, 0, 3, 2, 6], mults=[4], poles=_POLES, knots=[0, 1]),
        # a residual out of range
        _table([22], hdr=[4, 0, 2, 3, 6], mults=[3], res=[1 << 40], poles=_POLES, knots=[0, 1]),
        # residuals that make knots decrease
        _table(
            [22],
            hdr=[4, 0, 2, 3, 6],
            mults=[3],
            res=[-(1 << 20)],
            poles=_POLES,
            knots=[1.0, 1.0 + 4.440892098500626e-16],
        ),
        # evenly spaced ends that overflow
        _table(
            [22],
            hdr=[4, 0, 1, 5, 6],
            mults=[2],
            res=[0, 0, 0],
            poles=_POLES,
            knots=[-1.7e308, 1.7e308],
        ),
        # weights that repeat a set that does not exist
        _table([22], hdr=[4, 1, 3, 2, 4, 2], mults=[4], poles=_POLES, knots=[0, 1]),
        # a line on a grid out of range, a bad mask, a value missing, too large an integer
        _table([128 + 16], aval=[0, 7, 1, 2, 3], frames=[0, 0, 1]),
        _table([128 + 16], aval=[60, 8, 1, 2, 3], frames=[0, 0, 1]),
        _table([128 + 16], aval=[60, 7, 1, 2], frames=[0, 0, 1]),
        _table([128 + 16], aval=[60, 7, 1 << 53, 2, 3], frames=[0, 0, 1]),
        # a mask that leaves a coordinate to frames, which lacks it
        _table([128 + 16], aval=[60, 3, 1, 2], frames=[0, 0, 1]),
        # a B-spline kind cannot be on a grid
        _table([128 + 22], hdr=[4, 0], poles=_POLES),
    ],
)
def test_hostile_tables_are_refused(data: bytes) -> None:
    with pytest.raises(FormatError):
        serialize._read_geometry(data, "CRV3", 3, 3)


def test_old_layout_still_reads() -> None:
    """A 1.x table (no residuals, no grid values) reads as before."""
    c = _curve(UNIFORM, [4, 1, 1, 1, 1, 1, 1, 4], 3)
    raw = serialize._write_geometry([c], 3, frozenset(), 2)
    assert isinstance(BlockReader(raw, "CRV3"), BlockReader)
    back = serialize._read_geometry(raw, "CRV3", 3, 2)
    assert back[0].knots.tobytes() == c.knots.tobytes()
    with pytest.raises(FormatError):
        serialize._read_geometry(raw, "CRV3", 3, 3)
