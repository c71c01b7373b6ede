"""Free edges per face (the STEP check's blame for new gaps)."""

from __future__ import annotations

import subprocess
import sys

import pytest


@pytest.mark.slow  # a fresh interpreter
def test_free_edges_per_face_imports_no_scipy_spatial() -> None:
    """An open box: its four free edges, each counted for its face, all traced
    through the sewing's history, so scipy.spatial (0.1 to 1 s to import) is
    not loaded."""
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
