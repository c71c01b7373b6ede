"""Lines through twin vertices (``encode.assembly.TWIN_LINES``; docs/format.md
§2.3, *Lines through their vertices*).

An IGES surface model (OCCT's faces mode) gives every face its own edges and
corners: the corners of neighbouring faces are twins at one point, and each
face's edge has a line of its own.  Where every twin of a cluster is at one
point (to 2**-33 mm), those lines go through their vertices too: the
container holds a kind code for each, not its frame.
"""

from __future__ import annotations

from pathlib import Path

import cadquery as cq
import numpy as np
import pytest

from nurbscomp import container, occ, pipeline
from nurbscomp.encode import assembly, coincide
from nurbscomp.model import Analytic, Kind
from tests.golden.make_golden import faces_iges


def _box_faces(tmp_path: Path) -> Path:
    """A chamfered box, turned off the axes, as an IGES surface model."""
    box = cq.Workplane("XY").box(24.0, 26.0, 21.0).edges("|Z").chamfer(0.8)
    box = box.rotate((0, 0, 0), (1, 2, 3), 17.0)
    step = tmp_path / "box.step"
    cq.exporters.export(box, str(step))
    return faces_iges(step, tmp_path / "box.igs")


def _through_lines(nzc: Path) -> tuple[int, int]:
    """(lines made through their vertices, lines) of a container's model."""
    m, _ = pipeline.decode(container.unpack(nzc.read_bytes()))
    lines = [g for g in m.curves3d if isinstance(g, Analytic) and g.kind == Kind.LINE]
    return sum(bool(g.through) for g in lines), len(lines)


def test_apart_twins_splits_clusters_by_their_spread() -> None:
    p = np.array(
        [[1.0, 2.0, 3.0], [1.0, 2.0, 3.0 + 1e-15], [5.0, 5.0, 5.0], [5.0 + 1e-9, 5.0, 5.0]]
    )
    lead = np.array([0, 0, 2, 2])
    twin = np.ones(4, bool)
    assert assembly._apart_twins(p, lead, twin).tolist() == [False, False, True, True]
    assert not assembly._apart_twins(p, lead, np.zeros(4, bool)).any()


@pytest.mark.slow
def test_a_surface_models_lines_go_through_their_twin_vertices(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    src = _box_faces(tmp_path)
    m, _ = occ.shape_to_model(occ.read_cad(src).shape)
    lead = coincide.vertex_clusters(m.vertex_point, 1e-7)
    assert (np.bincount(lead)[lead] > 1).all()  # every corner is a twin
    sizes = {}
    for on in (True, False):
        monkeypatch.setattr(assembly, "TWIN_LINES", on)
        out = tmp_path / f"{on}.nzc"
        report = pipeline.compress_file(src, out, tol=0.1, force=True)
        sizes[on] = report["output_bytes"]
        through, lines = _through_lines(out)
        assert lines == 48
        if on:
            assert through == lines
        else:
            assert through == 0
        r = pipeline.evaluate(src, out)
        assert r["verdict"] == "pass", r["failed"]
        assert r["free_edges"]["reconstructed"] == r["free_edges"]["original"]
    assert sizes[True] < 0.8 * sizes[False]
