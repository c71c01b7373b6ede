"""A fast slice of the stress corpus (issue 10; ``make stress`` runs all of it).

Seventeen generated shapes (one of them long: ``LONG_CASES``) spread over the categories of
:mod:`tests.stress.shapes`, each written in one of the three file kinds
(STEP, IGES BRep, IGES faces), compressed at 0.01 mm (four of them at
0.1 mm) and checked as ``tests.stress.run`` checks every file: no crash and no
error, the same topology counts, every face within tol by independent
sampling, valid where OCCT's own STEP round trip is, no more free edges
(sewn at 1e-7) than the source.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from .stress import files, run, shapes

ENTRIES = {e.name: e for e in shapes.entries(seed=0)}

#: (shape, file kind, tolerances)
CASES = [
    ("fillet_box_03", "step", (0.01,)),
    ("chamfer_cyl_01", "brep", (0.01,)),
    ("shell_hollow_04", "step", (0.01,)),
    ("loft_closed_03", "step", (0.01, 0.1)),
    ("sweep_spline_01", "faces", (0.01,)),
    ("revolve_axis_01", "brep", (0.01,)),
    ("periodic_built_uv_d33_02", "step", (0.01, 0.1)),
    ("periodic_interp_uv_02", "step", (0.01,)),
    ("periodic_setper_u_d44_03", "faces", (0.01,)),
    ("net_degen_04", "step", (0.01,)),
    ("trimmed_polygon_3h_02", "faces", (0.01,)),
    ("instance_bspline_4x_02", "step", (0.01,)),
    # a BRepCheck fault on a located instance's face is the model's one face
    ("instance_sphere_3x_01", "step", (0.1,)),
    ("sewn_patches8_00", "brep", (0.01,)),
    ("feature_nurbs_fillet_box", "step", (0.01,)),
    # a loft cut by a box and a hole: sides used over a part of their range
    ("boolean_loft_01", "step", (0.1,)),
]
#: Cases over half a minute on 2 cores: run by ``make stress`` (long).
#: feature_thick_00 as a surface model: faces meeting along edges cut at
#: other points (free edges grew 171 -> 188); a small part whose every
#: tighter coding climbs to its one face OCCT's reader splits (45 s).
LONG_CASES = [("feature_thick_00", "faces", (0.01,))]


def test_the_corpus_is_large_varied_and_named_uniquely() -> None:
    assert len(ENTRIES) >= 200
    assert {e.category for e in ENTRIES.values()} == set(shapes.CATEGORIES)
    # the same seed gives the same list; another seed other parameters
    again = shapes.entries(seed=0)
    assert [e.name for e in again] == list(ENTRIES)
    assert {name for name, _, _ in CASES + LONG_CASES} <= set(ENTRIES)


@pytest.mark.slow
@pytest.mark.parametrize(
    "name, fmt, tol",
    [(n, f, t) for n, f, tols in CASES for t in tols]
    + [pytest.param(n, f, t, marks=pytest.mark.long) for n, f, tols in LONG_CASES for t in tols],
    ids=lambda x: str(x),
)
def test_stress_file(name: str, fmt: str, tol: float, tmp_path: Path) -> None:
    (path,) = files.write_entry(ENTRIES[name], tmp_path, [fmt])
    (result,) = run.check_file(path, [tol], tmp_path)
    assert result.ok, result.line()


def _kinds(ref: run.Reference, shape, tol: float) -> set[str]:
    r = run.Result("x", tol)
    run.compare(r, ref, shape, tol)
    return {k for k, _ in r.failures}


def test_the_checks_can_fail(tmp_path: Path) -> None:
    """The checker itself: a moved shape, loose faces (their STEP file read
    back too: a shell for each face) and a gap are caught."""
    from OCP.BRepBuilderAPI import BRepBuilderAPI_Transform
    from OCP.gp import gp_Trsf, gp_Vec

    from nurbscomp import occ

    def moved(shape, dz: float):
        t = gp_Trsf()
        t.SetTranslation(gp_Vec(0, 0, dz))
        return BRepBuilderAPI_Transform(shape, t, True).Shape()

    (path,) = files.write_entry(ENTRIES["sewn_patches8_00"], tmp_path, ["step"])
    ref = run.reference(path)
    assert _kinds(ref, ref.shape, 0.01) == set()
    assert _kinds(ref, moved(ref.shape, 0.02), 0.01) == {"deviation"}
    faces = occ.faces(ref.shape)
    loose = shapes.compound(faces)  # no shell: the same faces, unshared edges
    assert _kinds(ref, loose, 0.01) == {"counts", "step"}
    gap = shapes.compound([moved(faces[0], 0.005), *faces[1:]])
    assert {"counts", "free_edges"} <= _kinds(ref, gap, 0.01)
