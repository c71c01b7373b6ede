"""Format 2.10 (docs/format.md §2.4, "Corners"): a surface net's corners P0m,
Pn0 and Pnm may be coded against vertices of its face (``SNET``'s
``corners``).  The code is only re-expressed (``codec.recorner``): the net
decoded is the same, bit for bit."""

from __future__ import annotations

import numpy as np
import pytest

from nurbscomp import codec, container, serialize
from nurbscomp.codec.coder import corner_at

METHODS = (
    codec.Method.SPATIAL,
    codec.Method.SPATIAL2,
    codec.Method.BOUNDARY,
    codec.Method.DDMAP,
    codec.Method.BOUNDARY3,
    codec.Method.DDMAP3,
    codec.Method.ARCS_V,
    codec.Method.ARCS_U,
    codec.Method.ORDERS_11,
    codec.Method.ORDERS_23,
    codec.Method.ORDERS_33,
)


def _net(nu: int, nv: int, rng: np.random.Generator) -> np.ndarray:
    u = np.linspace(0.0, 1.0, nu)[:, None] + 0 * np.linspace(0.0, 1.0, nv)[None]
    v = 0 * u + np.linspace(0.0, 1.0, nv)[None]
    p = np.stack([10 * u, 7 * v, 0.3 * u * v], -1)
    return p + rng.normal(0, 1e-4, (nu, nv, 3)) + rng.normal(0, 20, 3)


@pytest.mark.parametrize("method", METHODS, ids=lambda m: m.name)
def test_corners_against_vertices_decode_the_same_net(method: codec.Method) -> None:
    rng = np.random.default_rng(int(method))
    for nu, nv in ((2, 2), (3, 5), (6, 4), (7, 9)):
        p = _net(nu, nv, rng)
        s, t = np.linspace(0, 1, nu), np.linspace(0, 1, nv)
        o = p[0, 0] + rng.normal(0, 3, 3)
        if min(nu, nv) <= 2 and method not in (*METHODS[:3],):
            continue  # no interior: the encoder tries the boundary method alone
        code = codec.encode_net(p, s, t, 0.01, methods=(method,), origin=o)
        net, _ = codec.decode_net(code, p.shape, s, t, 0.01, o)
        for picked in ({1}, {2}, {3}, {1, 3}, {1, 2, 3}):
            # vertices near the corners, as snapped onto the vertex grid
            corners = {k: p[corner_at(k, nu, nv)] + rng.normal(0, 3e-3, 3) for k in picked}
            again = codec.recorner(code, p.shape, corners, 0.01, s=s, t=t)
            for k in picked:
                assert np.abs(codec.corner_ints(again, p.shape, k)).max() <= 2
            back, _ = codec.decode_net(again, p.shape, s, t, 0.01, o, corners=corners)
            assert np.array_equal(back, net), (nu, nv, picked)
            if not np.array_equal(again.ints, code.ints):
                # read without its corners, the re-expressed code is another net
                other, _ = codec.decode_net(again, p.shape, s, t, 0.01, o)
                assert not np.array_equal(other, net)


def test_corners_only_on_surfaces() -> None:
    p = np.cumsum(np.ones((4, 3)), axis=0)
    code = codec.encode_net(p, None, None, 0.01, methods=codec.CURVE_METHODS)
    with pytest.raises(ValueError, match="corners 1-3"):
        codec.decode_net(code, p.shape, None, None, 0.01, corners={1: p[0]})
    q = _net(3, 3, np.random.default_rng(0))
    s = np.linspace(0, 1, 3)
    code = codec.encode_net(q, s, s, 0.01, methods=(codec.Method.SPATIAL,))
    with pytest.raises(ValueError, match="corners 1-3"):
        codec.decode_net(code, q.shape, s, s, 0.01, corners={0: q[0, 0]})


def test_corners_column_from_2_10_only(tmp_path) -> None:
    """A 2.10 ``SNET`` has the corners column (its golden file picks two), and
    its table written without it reads back as 2.9 does: no corners."""
    from nurbscomp.serialize.nets import _read_nets, _write_nets

    from .golden.make_golden import HERE

    c = container.unpack((HERE / "loft.v2_10.tol0.01.nzc").read_bytes())
    m, _, t = serialize.read_sections(c.get, c.revision, None)
    assert t.snet.corners is not None and (t.snet.corners > 0).sum() == 2
    shapes = [m.surfaces[r].poles.shape for r in serialize.coded_rows(m.surfaces)]  # type: ignore[union-attr]
    old = container.VERSIONS.index((2, 9))
    raw = _write_nets(t.snet, shapes, True, old)
    assert len(raw) < len(c.get("SNET"))
    back = _read_nets(raw, len(shapes), "SNET", shapes, old)
    assert back.corners is None and back.anchor is not None
    assert all(np.array_equal(a, b) for a, b in zip(back.ints, t.snet.ints, strict=True))
