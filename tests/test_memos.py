"""The encoder's memos answer as the computations they stand for, and tell
apart what those read (issue 30: the validity stage packs a part once or
more a round, and asks again of the same rows)."""

from __future__ import annotations

import numpy as np

from nurbscomp import codec, coons, writer
from nurbscomp.encode import nets
from nurbscomp.model import BSplineSurface


def _surface(seed: int) -> BSplineSurface:
    rng = np.random.default_rng(seed)
    u, v = np.meshgrid(np.linspace(0, 1, 6), np.linspace(0, 1, 5), indexing="ij")
    poles = np.stack([40 * u, 30 * v, 4 * np.sin(3 * u) * np.cos(2 * v)], -1)
    poles = poles + rng.uniform(-200, 200, 3) + rng.normal(0, 0.05, poles.shape)
    uk, vk = np.array([0.0, 0.5, 1.0]), np.array([0.0, 1.0])
    um, vm = np.array([4, 2, 4]), np.array([5, 5])
    return BSplineSurface(poles, None, uk, vk, um, vm, 3, 4, False, False)


def _code(g: BSplineSurface, tol: float, method: codec.Method) -> codec.NetCode:
    s = coons.unit_abscissae(coons.greville(g.uknots, g.umults, g.udegree, g.poles.shape[0]))
    t = coons.unit_abscissae(coons.greville(g.vknots, g.vmults, g.vdegree, g.poles.shape[1]))
    return codec.encode_net(g.poles, s, t, tol, methods=(method,), origin=g.poles[0, 0] + 1.0)


def _fresh(*args: object) -> tuple[codec.NetCode, int, list[int]]:
    writer._CHOSEN.clear()
    return writer._chosen(*args)  # type: ignore[arg-type]


def test_a_rows_rebasing_is_remembered_by_all_it_reads() -> None:
    tol = 0.01
    for seed, method in enumerate((codec.Method.SPATIAL2, codec.Method.DDMAP)):
        g = _surface(seed)
        code = _code(g, tol, method)
        rng = np.random.default_rng(seed)
        points = g.poles[[0, -1, -1], [-1, 0, -1]] + rng.normal(0, 0.003, (3, 3))
        origins = [None, g.poles[0, 0] + 0.37, g.poles[0, 0] - 5.0]
        answers = []
        for origin in origins:
            for pts in (points, points[::-1] + 0.01):
                want = _fresh(code, g, origin, pts, tol)
                got = writer._chosen(code, g, origin, pts, tol)  # from the memo
                assert np.array_equal(got[0].ints, want[0].ints) and got[1:] == want[1:]
                answers.append(want[0].ints.tobytes())
        # each answer asked of a memo the other rows' answers filled first
        combos = [(o, pts) for o in origins for pts in (points, points[::-1] + 0.01)]
        for target in combos:
            writer._CHOSEN.clear()
            for other in combos:
                if other is not target:
                    writer._chosen(code, g, *other, tol)
            hot = writer._chosen(code, g, *target, tol)
            cold = _fresh(code, g, *target, tol)
            assert np.array_equal(hot[0].ints, cold[0].ints) and hot[1:] == cold[1:]
        assert len(set(answers)) > 1  # the origin and the points change the integers


def test_feature_limits_are_remembered_by_poles_and_tol() -> None:
    g = _surface(3)
    small = g.poles * 1e-4  # a feature smaller than tol
    cases = [(p, tol) for p in (g.poles, small, small[::-1], g.poles[:, 0]) for tol in (1e-3, 0.01)]
    for poles, tol in cases:
        nets._LIMITS.clear()
        for other, t in cases:  # the others' answers first
            if other is not poles or t != tol:
                nets.feature_limit(other, t)
        hot = nets.feature_limit(poles, tol)
        nets._LIMITS.clear()
        assert hot == nets.feature_limit(poles, tol)
    assert nets.feature_limit(small, 0.1) < nets.feature_limit(small, 0.001) * 101
    assert nets.feature_limit(small, 0.1) != nets.feature_limit(g.poles, 0.1)


def test_a_digest_tells_apart_what_its_parts_hold() -> None:
    """``memo.digest``: the same values give the same key whatever the
    arrays' identity or memory layout; the dtype, the shape, where one part
    ends and the next begins, and an array changed in place give others."""
    from nurbscomp.memo import digest

    a = np.arange(12.0).reshape(3, 4)
    key = digest(a, 3, None, (1.0, 2.0))
    assert digest(a.copy(), 3, None, (1.0, 2.0)) == key
    assert digest(np.asfortranarray(a), 3, None, (1.0, 2.0)) == key  # values, not layout
    others = [
        digest(a.reshape(4, 3), 3, None, (1.0, 2.0)),
        digest(a.view(np.int64), 3, None, (1.0, 2.0)),  # the same bytes, another dtype
        digest(a, 3.0, None, (1.0, 2.0)),
        digest(a, 3, (1.0, 2.0)),
        digest(a[:1], a[1:], 3, None, (1.0, 2.0)),  # the same bytes, split in two
        digest(a, "3", None, (1.0, 2.0)),
    ]
    assert len({key, *others}) == 1 + len(others)
    a[1, 1] += 1e-12
    assert digest(a, 3, None, (1.0, 2.0)) != key
