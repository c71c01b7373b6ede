"""Free edges per face (the STEP check's blame for new gaps) without scipy.spatial."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from nurbscomp.occ import measure


@settings(max_examples=50, deadline=None)
@given(
    arrays(np.float64, (30, 9), elements=st.floats(-10, 10)),
    arrays(np.float64, (7, 9), elements=st.floats(-10, 10)),
    st.integers(1, 400),
)
def test_nearest_is_the_first_of_the_nearest(
    points: np.ndarray, queries: np.ndarray, chunk: int
) -> None:
    got = measure._nearest(points, queries, chunk)
    for q, k in zip(queries, got):
        d = ((points - q) ** 2).sum(axis=1)
        assert k == int(np.flatnonzero(d == d.min())[0])


def test_ties_go_to_the_first_edge() -> None:
    """Coincident edges (an IGES surface model's faces each have their own)
    tie exactly: the first in the shape's edge order is named, every time."""
    points = np.array([[1.0] * 9, [0.0] * 9, [0.0] * 9, [2.0] * 9])
    assert measure._nearest(points, np.zeros((3, 9)), chunk=4).tolist() == [1, 1, 1]


def test_free_edges_per_face_imports_no_scipy_spatial() -> None:
    """An open box: its four free edges, each counted for its face; and
    scipy.spatial (0.1 to 1 s to import) is not loaded."""
    code = (
        "import sys, cadquery as cq\n"
        "from OCP.BRep import BRep_Builder\n"
        "from OCP.TopoDS import TopoDS_Shell\n"
        "from nurbscomp.occ import measure\n"
        "b, shell = BRep_Builder(), TopoDS_Shell()\n"
        "b.MakeShell(shell)\n"
        "for f in measure.faces(cq.Workplane().box(2, 2, 2).val().wrapped)[:5]:\n"
        "    b.Add(shell, f)\n"
        "n = measure.free_edges_per_face(shell)\n"
        "print(sorted(n.tolist()), 'scipy.spatial' in sys.modules)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    counts, imported = out.stdout.split("]")
    assert imported.strip() == "False"
    assert sorted(int(x) for x in counts.strip("[ ").split(",")) == [0, 1, 1, 1, 1]
