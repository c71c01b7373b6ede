"""Fast start (issue 13): ``--help`` and ``--version`` import neither OCP nor
numpy; ``info``, and ``test`` on a damaged container, import neither OCP nor
scipy.  Checked by what the process imports (``python -X importtime``), not by
the clock, which a loaded machine makes unreliable; ``make bench`` times them."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
GOLDEN = ROOT / "tests" / "golden"


def imported(*args: str) -> set[str]:
    """The top-level packages ``nurbscomp ARGS`` imports."""
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    r = subprocess.run(
        [sys.executable, "-X", "importtime", "-m", "nurbscomp.cli", *args],
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
    )
    names = set()
    for line in r.stderr.splitlines():
        if line.startswith("import time:") and "|" in line:
            names.add(line.rsplit("|", 1)[1].strip().split(".")[0])
    assert "nurbscomp" in names, r.stderr[-2000:]
    return names


@pytest.mark.parametrize("args", [["--help"], ["--version"], ["compress", "--help"]])
def test_help_and_version_import_no_ocp_nor_numpy(args: list[str]) -> None:
    names = imported(*args)
    assert not names & {"OCP", "numpy", "scipy", "tqdm", "distributed"}


@pytest.mark.parametrize(
    "args",
    [
        ["info", str(GOLDEN / "blob.tol0.01.nzc")],
        ["info", str(GOLDEN / "passthrough" / "tessellated.step.nzc")],
        ["test", str(GOLDEN / "errors" / "body_crc.nzc")],
        ["test", str(GOLDEN / "passthrough" / "tessellated.step.nzc")],
    ],
)
def test_info_and_test_on_damaged_import_no_ocp(args: list[str]) -> None:
    names = imported(*args)
    assert "OCP" not in names and "scipy" not in names


@pytest.mark.slow
def test_compress_of_a_small_part_imports_no_scipy(tmp_path: Path) -> None:
    """Compress finds close points, clusters and nearest faces with numpy
    (``nearby.close_pairs``, ``first_of_components``, ``nearest``): importing
    scipy.spatial cost 0.2 s a process, more than OCCT's whole read of a
    small file.  Faces-mode IGES (its faces' corners are separate vertices
    at one place, which must be clustered) and STEP, with the STEP check."""
    import cadquery as cq

    from tests.stress import files

    shape = cq.Workplane().box(4, 3, 2).edges().fillet(0.5).val().wrapped
    for name, write in (
        ("part.igs", lambda p: files.write_iges(shape, p, 0)),
        ("part.step", lambda p: files.write_step(shape, p, "part")),
    ):
        src = tmp_path / name
        write(src)
        names = imported("compress", "-q", "--tol", "0.01", str(src), "-o", str(src) + ".nzc")
        assert "OCP" in names and "scipy" not in names, name
