"""A larger tolerance never gives a larger container, on small analytic parts
too (issue 28): parts whose sections are the same at every tolerance, where
only META's tolerance differs (format 2.13 writes it as a short decimal, and
coder 7's dictionary was trained at 0.01 and 0.1 mm; with format 2.12 a
filleted box came out 994 bytes at 0.01 mm and 999 at 0.1 mm)."""

from __future__ import annotations

import pytest

import nurbscomp


def _parts() -> dict[str, object]:
    import cadquery as cq

    return {
        "filleted box": cq.Workplane().box(20, 10, 5).edges("|Z").fillet(2).faces(">Z").hole(3),
        "cylinder": cq.Workplane().circle(4).extrude(12),
        "chamfered plate": cq.Workplane().box(30, 20, 3).edges(">Z").chamfer(1).faces(">Z").hole(5),
        "revolved spline": cq.Workplane("XZ")
        .spline([(1, 0), (3, 2), (2, 5), (1, 7)])
        .lineTo(0, 7)
        .lineTo(0, 0)
        .close()
        .revolve(),
    }


#: Parts that grow, and why: each a strict xfail, so that a fix shows.
GROWS = {
    "chamfered plate": "made in memory and baked (encode.placed): every section is the same "
    "at 0.01 and 0.1 mm but META (the tolerance), which the body's coder packs one byte "
    "larger (630 -> 631 bytes)",
}


@pytest.mark.parametrize(
    "name",
    [
        pytest.param(n, marks=pytest.mark.xfail(strict=True, reason=GROWS[n])) if n in GROWS else n
        for n in _parts()
    ],
)
def test_no_growth_with_the_tolerance(name: str) -> None:
    part = _parts()[name]
    sizes = [len(nurbscomp.compress(part, tol=t)) for t in (0.001, 0.01, 0.1)]
    assert sizes == sorted(sizes, reverse=True), f"bytes at 0.001, 0.01, 0.1 mm: {sizes}"
