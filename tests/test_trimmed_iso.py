"""A boolean on a sweep or a loft trims its faces but not their surfaces: the
edges along the surface's sides keep the side as their curve, over a part of
its range.  Such a curve is copied from the decoded surface like a side used
whole (``encode.coincide.iso_sources``), not coded on its own: it costs no
bytes, and it lies on its surface, so the pcurves projected on both faces meet
(ec_turbine-A.stp's 31 such curves at 0.01 mm: 12,302 -> 10,628 bytes, and
its first candidate passes the STEP check)."""

from __future__ import annotations

import numpy as np
import pytest

import nurbscomp
from nurbscomp import container, occ, pipeline
from nurbscomp.encode import coincide
from nurbscomp.model import EC, BSplineCurve, BSplineSurface, RepKind
from nurbscomp.rules import joins


def _swept_and_cut() -> object:
    import cadquery as cq

    path = cq.Workplane("XZ").spline([(0, 0), (6, 10), (0, 22), (-5, 30)])
    body = cq.Workplane("XY").rect(5, 3).sweep(path)
    return body.cut(cq.Workplane("XY").box(20, 20, 6).translate((0, 0, 13)))


def _trimmed(m, iso: dict) -> list[int]:
    """Curve rows of ``iso`` that an edge uses over a part of their knot range only."""
    out = []
    for q in np.flatnonzero(m.edge_reps[:, EC.KIND] == RepKind.CURVE3D).tolist():
        c = int(m.edge_reps[q, EC.CURVE])
        g = m.curves3d[c]
        if c in iso and tuple(m.edge_rep_range[q]) != (g.knots[0], g.knots[-1]):
            out.append(c)
    return sorted(set(out))


@pytest.mark.parametrize("tol", [0.01, 0.1])
def test_a_trimmed_side_is_copied_from_its_decoded_surface(tol: float) -> None:
    part = _swept_and_cut()
    src, _ = occ.shape_to_model(part.val().wrapped)
    crows = {i for i, g in enumerate(src.curves3d) if isinstance(g, BSplineCurve)}
    srows = {i for i, g in enumerate(src.surfaces) if isinstance(g, BSplineSurface)}
    iso = coincide.iso_sources(src, crows, srows)
    trimmed = _trimmed(src, iso)
    assert trimmed, "no edge uses a part of a side: the test would prove nothing"

    data = nurbscomp.compress(part, tol=tol)
    m, _ = pipeline.decode(container.unpack(data))
    moved = [
        c
        for c in trimmed
        if not np.array_equal(m.surfaces[iso[c][0]].poles, src.surfaces[iso[c][0]].poles)
    ]
    assert moved, "no trimmed side's surface was coded: the test would prove nothing"
    for c in moved:
        r, side, rev, _ = iso[c]
        assert np.array_equal(
            m.curves3d[c].poles, joins.boundary(m.surfaces[r].poles, side, bool(rev))
        )
    assert pipeline.max_net_displacement(src, m) <= tol
    shape = nurbscomp.decompress(data)
    assert shape.isValid()
    assert len(shape.Faces()) == len(part.val().Faces())
    assert len(shape.Edges()) == len(part.val().Edges())


def test_a_side_within_iso_eps_is_a_near_copy() -> None:
    """A curve whose poles are its surface's side's up to rounding (within
    ``coincide.ISO_EPS``; boxed_sphere.step's 34 such curves) is a copy too,
    with its distance, which the surface's code leaves room for."""
    from dataclasses import replace

    src, _ = occ.shape_to_model(_swept_and_cut().val().wrapped)
    crows = {i for i, g in enumerate(src.curves3d) if isinstance(g, BSplineCurve)}
    srows = {i for i, g in enumerate(src.surfaces) if isinstance(g, BSplineSurface)}
    exact = coincide.iso_sources(src, crows, srows)
    c = min(exact)
    off = src.curves3d[c].poles.copy()
    off[1] += [4e-10, 0.0, 0.0]
    src.curves3d[c] = replace(src.curves3d[c], poles=off)
    assert c not in coincide.iso_sources(src, crows, srows)
    near = coincide.iso_sources(src, crows, srows, coincide.ISO_EPS)
    assert near[c][:3] == exact[c][:3]
    assert near[c].distance == pytest.approx(4e-10, rel=1e-3)
    off[1] += [1e-9, 0.0, 0.0]
    assert c not in coincide.iso_sources(src, crows, srows, coincide.ISO_EPS)
