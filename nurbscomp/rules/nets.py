"""What a net's coding needs of its surface record (docs/format.md §2.4):
the normalised Greville abscissae of the Coons blend, eqs. (4)-(6), and the
basis of the D-map, eqs. (10)-(12).  Both sides take them from here."""

from __future__ import annotations

import numpy as np

from .. import coons, dmap
from ..model import BSplineSurface, Geometry
from . import joins


def net_basis(g: Geometry) -> dmap.Basis | None:
    """What the D-map needs of a surface record: clamped, non-periodic B-splines only."""
    if not joins.clamped_surface(g):
        return None
    assert isinstance(g, BSplineSurface)
    if g.bezier:
        nu, nv = g.poles.shape[:2]
        ends = np.array([0.0, 1.0])
        nus, nvs = np.array([nu, nu]), np.array([nv, nv])
        return dmap.Basis.of(ends, nus, ends, nvs, nu - 1, nv - 1, g.weights)
    return dmap.Basis.of(g.uknots, g.umults, g.vknots, g.vmults, g.udegree, g.vdegree, g.weights)


def net_abscissae(g: Geometry) -> tuple[np.ndarray | None, np.ndarray | None]:
    """Normalised Greville abscissae of a surface's net (Coons blending); None for curves."""
    if not isinstance(g, BSplineSurface):
        return None, None
    nu, nv = g.poles.shape[:2]
    s = coons.unit_abscissae(coons.greville(g.uknots, g.umults, g.udegree, nu))
    t = coons.unit_abscissae(coons.greville(g.vknots, g.vmults, g.vdegree, nv))
    return s, t
