"""The command line, through click's CliRunner: outputs, errors, exit codes."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from nurbscomp import container
from nurbscomp.cli import cli
from nurbscomp.errors import EXIT_CONTAINER, EXIT_OUTPUT

from .conftest import CORPUS, ROOT, SAMPLES


@pytest.fixture()
def work(tmp_path: Path) -> Path:
    shutil.copy(SAMPLES / "loft.step", tmp_path / "part.step")
    return tmp_path


def run(*args: str) -> tuple[int, str, str]:
    r = CliRunner().invoke(cli, list(args))
    return r.exit_code, r.stdout, r.stderr


def test_compress_decompress_default_names(work: Path) -> None:
    code, out, err = run("compress", str(work / "part.step"))
    assert code == 0, err
    assert "tolerance 0.01 mm (default" in err
    assert (work / "part.step.nzc").exists()
    assert (work / "part.step").exists()  # the input is kept
    (work / "part.step").rename(work / "orig.step")
    code, out, err = run("decompress", str(work / "part.step.nzc"))
    assert code == 0, err
    assert (work / "part.step").read_bytes().startswith(b"ISO-10303-21;")
    assert sorted(p.name for p in work.iterdir()) == ["orig.step", "part.step", "part.step.nzc"]


def test_existing_output_needs_force(work: Path) -> None:
    out = work / "x.nzc"
    out.write_bytes(b"keep me")
    code, _, err = run("compress", str(work / "part.step"), "-o", str(out))
    assert code == EXIT_OUTPUT
    last = err.strip().splitlines()[-1]
    assert last.startswith(f"error: {work / 'part.step'}: ") and "--force" in last
    assert out.read_bytes() == b"keep me"
    code, _, err = run("compress", str(work / "part.step"), "-o", str(out), "--force", "-q")
    assert code == 0, err
    assert out.read_bytes()[:4] == b"\x89NZC"


def test_json_info_and_test(work: Path) -> None:
    code, out, err = run("compress", "--lossless-brep", "--json", str(work / "part.step"))
    assert code == 0, err
    line, total = out.splitlines()  # one line per file, then the summary
    rep = json.loads(line)
    assert rep["mode"] == "lossless" and rep["verified"] and rep["counts"]["faces"] == 3
    assert rep["status"] == "ok" and rep["exit_code"] == 0
    s = json.loads(total)
    assert s["summary"] and (s["files"], s["ok"], s["failed"]) == (1, 1, 0)
    assert s["bytes_in"] == rep["input_bytes"] and s["bytes_out"] == rep["output_bytes"]
    code, out, _ = run("info", "--json", str(work / "part.step.nzc"))
    assert code == 0
    info = json.loads(out)
    assert info["lossless"] and info["unit"] == "MM" and info["shapes"]["face"] == 3
    assert info["passthrough"] is False and rep["passthrough"] is False
    assert set(info["section_raw_bytes"]) >= {"META", "SURF", "SHAP", "EDGE"}
    code, out, _ = run("info", str(work / "part.step.nzc"))
    assert code == 0 and f"format:      .nzc {container.MAJOR}.{container.MINOR}," in out
    code, out, _ = run("test", str(work / "part.step.nzc"))
    assert code == 0 and "OK" in out


def test_tol_with_unit_suffix(work: Path) -> None:
    code, out, err = run("compress", "--tol", "5um", "--json", str(work / "part.step"))
    assert code == 0, err
    assert json.loads(out.splitlines()[0])["tolerance_mm"] == pytest.approx(0.005)


@pytest.mark.parametrize(
    "args",
    [
        ["compress"],
        ["compress", "--tol", "fast", "x"],
        ["compress", "--lossless", "--tol", "1", "x"],
        ["frobnicate"],
    ],
)
def test_usage_errors_exit_2(args: list[str]) -> None:
    assert run(*args)[0] == 2


def test_output_with_several_inputs_is_usage_error(work: Path) -> None:
    p = str(work / "part.step")
    assert run("compress", p, p, "-o", str(work / "a.nzc"))[0] == 2


def _assert_clean_failure(work: Path, code: int, err: str, name: str, want: int = 1) -> None:
    assert code == want
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"error: {name}: "), err
    assert "Traceback" not in err
    assert not list(work.glob("*.tmp")) and not list(work.glob(".*.tmp"))


@pytest.mark.parametrize(
    "content, name",
    [
        (b"", "empty.step"),
        (b"garbage\n" * 10, "garbage.step"),
        (bytes(range(256)) * 8, "noise.igs"),
        (b"ISO-10303-21;\nHEADER;\nFILE_DESCRIPTION((''),'2;1');\n", "truncated.step"),
    ],
)
def test_bad_cad_input(work: Path, content: bytes, name: str) -> None:
    (work / name).write_bytes(content)
    code, _, err = run("compress", "-q", str(work / name))
    _assert_clean_failure(work, code, err, str(work / name))
    assert not (work / (name + ".nzc")).exists()


def _step(data: str) -> bytes:
    """A STEP file around ``data`` (the entities of its DATA section)."""
    return (
        "ISO-10303-21;\nHEADER;\nFILE_DESCRIPTION((''),'2;1');\n"
        "FILE_NAME('t.step','2026-01-01T00:00:00',(''),(''),'','','');\n"
        "FILE_SCHEMA(('AP242_MANAGED_MODEL_BASED_3D_ENGINEERING_MIM_LF "
        "{ 1 0 10303 442 1 1 4 }'));\n"
        f"ENDSEC;\nDATA;\n{data}ENDSEC;\nEND-ISO-10303-21;\n"
    ).encode()


_PRODUCT = """#1=APPLICATION_PROTOCOL_DEFINITION('international standard','ap242',2014,#2);
#2=APPLICATION_CONTEXT('managed model based 3d engineering');
#3=PRODUCT_CONTEXT('',#2,'mechanical');
#4=PRODUCT('p','p','',(#3));
#5=PRODUCT_DEFINITION_FORMATION('','',#4);
#6=PRODUCT_DEFINITION_CONTEXT('part definition',#2,'design');
#7=PRODUCT_DEFINITION('design','',#5,#6);
#8=PRODUCT_DEFINITION_SHAPE('','',#7);
"""
_CONTEXT = """#11=(GEOMETRIC_REPRESENTATION_CONTEXT(3) GLOBAL_UNCERTAINTY_ASSIGNED_CONTEXT((#15))
GLOBAL_UNIT_ASSIGNED_CONTEXT((#12,#13,#14)) REPRESENTATION_CONTEXT('',''));
#12=(LENGTH_UNIT() NAMED_UNIT(*) SI_UNIT(.MILLI.,.METRE.));
#13=(NAMED_UNIT(*) PLANE_ANGLE_UNIT() SI_UNIT($,.RADIAN.));
#14=(NAMED_UNIT(*) SI_UNIT($,.STERADIAN.) SOLID_ANGLE_UNIT());
#15=UNCERTAINTY_MEASURE_WITH_UNIT(LENGTH_MEASURE(1.E-07),#12,'distance_accuracy_value','');
"""
#: Only a triangle (AP242 tessellated geometry): no B-rep.
TESSELLATED = _step(
    _PRODUCT
    + _CONTEXT
    + """#9=SHAPE_DEFINITION_REPRESENTATION(#8,#10);
#10=TESSELLATED_SHAPE_REPRESENTATION('',(#20),#11);
#16=COORDINATES_LIST('',3,((0.,0.,0.),(10.,0.,0.),(0.,10.,0.)));
#20=TRIANGULATED_FACE('',#16,0,(),$,((1,2,3)));
"""
)
#: Only a line segment (a wireframe): it transfers, but holds no face.
CURVE_ONLY = _step(
    _PRODUCT
    + _CONTEXT
    + """#9=SHAPE_DEFINITION_REPRESENTATION(#8,#10);
#10=GEOMETRICALLY_BOUNDED_WIREFRAME_SHAPE_REPRESENTATION('',(#30),#11);
#30=GEOMETRIC_CURVE_SET('',(#31));
#31=TRIMMED_CURVE('',#32,(#36,PARAMETER_VALUE(0.)),(#37,PARAMETER_VALUE(1.)),.T.,.PARAMETER.);
#32=LINE('',#33,#34);
#33=CARTESIAN_POINT('',(0.,0.,0.));
#34=VECTOR('',#35,1.);
#35=DIRECTION('',(1.,0.,0.));
#36=CARTESIAN_POINT('',(0.,0.,0.));
#37=CARTESIAN_POINT('',(1.,0.,0.));
"""
)
#: A product with no shape at all: nothing transfers.
NO_SHAPE = _step(_PRODUCT)


@pytest.mark.parametrize(
    "content, name, fragment",
    [
        (TESSELLATED, "tessellated.step", "nothing in the STEP file transfers"),
        (CURVE_ONLY, "curve.step", "no B-rep faces"),
        (NO_SHAPE, "product.step", "in the STEP file"),
    ],
)
def test_step_without_brep_is_stored_verbatim(
    work: Path, content: bytes, name: str, fragment: str
) -> None:
    """A valid STEP file with no B-rep: a passthrough container, exit 0, a
    warning saying why; decompress gives the exact bytes back (issue 13)."""
    (work / name).write_bytes(content)
    code, out, err = run("compress", str(work / name))
    assert code == 0, err
    warning = [line for line in err.splitlines() if line.startswith("warning: ")]
    assert len(warning) == 1 and "stored verbatim" in warning[0] and fragment in warning[0]
    assert "stored verbatim" in out
    nzc = work / (name + ".nzc")
    code, out, _ = run("info", "--json", str(nzc))
    rep = json.loads(out)
    assert code == 0 and rep["passthrough"] and rep["mode"] == "passthrough"
    assert (
        rep["format_version"] == f"{container.MAJOR}.{container.MINOR}"
        and fragment in rep["reason"]
    )
    assert rep["source_bytes"] == len(content)
    code, out, _ = run("info", str(nzc))
    assert code == 0 and "passthrough" in out
    assert run("test", str(nzc))[0] == 0
    code, _, err = run("decompress", str(nzc), "-o", str(work / "back.step"))
    assert code == 0, err
    assert (work / "back.step").read_bytes() == content
    code, _, err = run("decompress", str(nzc), "-o", str(work / "back.igs"))
    assert code == 1 and "cannot be written as IGES" in err
    assert not (work / "back.igs").exists()


def test_sample_cut_in_half(work: Path) -> None:
    for sample in ("loft.step", "bracket.step"):
        data = (SAMPLES / sample).read_bytes()
        (work / "half.step").write_bytes(data[: len(data) // 2])
        code, _, err = run("compress", "-q", "-f", str(work / "half.step"))
        _assert_clean_failure(work, code, err, str(work / "half.step"))
        assert not (work / "half.step.nzc").exists()


def test_missing_file_and_directory(work: Path) -> None:
    code, _, err = run("compress", "-q", str(work / "nope.step"))
    _assert_clean_failure(work, code, err, str(work / "nope.step"))
    code, _, err = run("compress", "-q", str(work))
    _assert_clean_failure(work, code, err, str(work))


def test_damaged_container(work: Path) -> None:
    assert run("compress", "-q", str(work / "part.step"))[0] == 0
    data = bytearray((work / "part.step.nzc").read_bytes())
    for name, bad in [
        ("trunc.nzc", data[: len(data) // 2]),
        ("flip.nzc", data[:40] + bytes([data[40] ^ 4]) + data[41:]),
    ]:
        (work / name).write_bytes(bytes(bad))
        for cmd in ("decompress", "test", "info"):
            code, _, err = run(cmd, str(work / name))
            _assert_clean_failure(work, code, err, str(work / name), EXIT_CONTAINER)
        assert not (work / name.replace(".nzc", ".step")).exists()


def test_missing_output_folder(work: Path) -> None:
    code, _, err = run("compress", "-q", str(work / "part.step"), "-o", str(work / "no" / "x.nzc"))
    _assert_clean_failure(work, code, err, str(work / "part.step"), EXIT_OUTPUT)


def test_decompress_to_iges_and_brep(work: Path) -> None:
    assert run("compress", "-q", str(work / "part.step"))[0] == 0
    for ext in ("igs", "brep"):
        code, out, err = run(
            "decompress", str(work / "part.step.nzc"), "-o", str(work / f"o.{ext}")
        )
        assert code == 0, err
        assert (work / f"o.{ext}").stat().st_size > 0


def test_version_and_help() -> None:
    code, out, _ = run("--version")
    assert code == 0 and "nurbscomp" in out
    code, out, _ = run("--help")
    assert code == 0 and "Exit codes" in out


def test_python_dash_m() -> None:
    """``python -m nurbscomp`` is the same command line as the script."""
    import subprocess
    import sys

    r = subprocess.run(
        [sys.executable, "-m", "nurbscomp", "--help"], capture_output=True, text=True, timeout=60
    )
    assert r.returncode == 0 and "Usage: nurbscomp" in r.stdout and "Exit codes" in r.stdout


@pytest.mark.slow
def test_eval_reports_deviation_and_topology(work: Path) -> None:
    shutil.copy(SAMPLES / "teapot.step", work / "part.step")
    assert run("compress", "-q", "-f", "--tol", "0.05", str(work / "part.step"))[0] == 0
    code, out, err = run("eval", "--json", str(work / "part.step"), str(work / "part.step.nzc"))
    assert code == 0, err
    r = json.loads(out)
    assert r["same_topology"] and r["valid"]["reconstructed"]
    assert 0 < r["max_deviation_mm"] <= 0.05
    assert r["mean_deviation_mm"] <= r["max_deviation_mm"]
    code, out, _ = run("eval", str(work / "part.step"), str(work / "part.step.nzc"))
    assert code == 0 and "deviation:" in out and "worst faces:" in out
    code, _, err = run("eval", str(work / "part.step"), str(work / "missing.step"))
    assert code == 1 and err.startswith("error: ")


def test_readme_lists_every_error_class() -> None:
    """README's "Exit codes and errors" names every error class and exit code."""
    import inspect

    from nurbscomp import errors

    readme = (SAMPLES.parent / "README.md").read_text()
    section = readme.split("## Exit codes and errors")[1].split("\n## ")[0]
    classes = [
        n
        for n, c in inspect.getmembers(errors, inspect.isclass)
        if issubclass(c, errors.NurbscompError) and c is not errors.NurbscompError
    ]
    assert len(classes) >= 16
    for name in classes:
        assert f"`{name}`" in section, name
    for code in ("| 0 |", "| 1 |", "| 2 |", "| 130 |", "| 143 |", "| 129 |"):
        assert code in section


@pytest.mark.slow
def test_eval_heatmap_writes_a_readable_png(work: Path) -> None:
    """``eval --heatmap``: a PNG of the expected size, not blank (many colours,
    the model drawn over a good part of it), never over a file without -f."""
    import vtk
    from vtkmodules.util.numpy_support import vtk_to_numpy

    from nurbscomp import heatmap

    shutil.copy(SAMPLES / "blob.step", work / "blob.step")
    assert run("compress", "-q", str(work / "blob.step"))[0] == 0
    png = work / "heat.png"
    args = ["eval", str(work / "blob.step"), str(work / "blob.step.nzc"), "--heatmap", str(png)]
    code, out, err = run(*args)
    assert code == 0, err
    assert f"heatmap:     {png}" in out
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    reader = vtk.vtkPNGReader()
    reader.SetFileName(str(png))
    reader.Update()
    img = reader.GetOutput()
    w, h, _ = img.GetDimensions()
    assert (w, h) == heatmap.SIZE
    px = vtk_to_numpy(img.GetPointData().GetScalars())[:, :3].astype(int)
    assert len(np.unique(px, axis=0)) > 200  # a colour map and shading, not a flat fill
    assert (px.sum(1) < 600).mean() > 0.05  # not a white page
    code, _, err = run(*args)
    assert code == EXIT_OUTPUT and "--force" in err
    code, out, err = run(*args, "--force", "--json")
    assert code == 0, err
    rep = json.loads(out)
    assert rep["tolerance_mm"] == 0.01 and len(rep["face_max_mm"]) == 63


# ---------------------------------------------------------------- gzip's habits (issue 26)


def _script(*args: str, cwd: Path, stdin: bytes | None = None) -> subprocess.CompletedProcess:
    """The real script (``python -m nurbscomp``), for what CliRunner skips:
    ``main``'s usage errors under --json, pipes."""
    return subprocess.run(
        [sys.executable, "-m", "nurbscomp", *args],
        cwd=cwd,
        input=stdin,
        capture_output=True,
        timeout=300,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
    )


@pytest.mark.slow
def test_mode_flags_run_their_commands(work: Path) -> None:
    assert run("compress", "-q", str(work / "part.step"))[0] == 0
    nzc = str(work / "part.step.nzc")
    code, out, err = run("-k", "-t", nzc)
    assert code == 0 and out.strip() == f"{nzc}: OK (3 faces)", err
    code, out, _ = run("-tk", nzc)
    assert code == 0 and "OK" in out
    code, out, _ = run("-l", nzc)
    assert code == 0 and "mode:        tolerance 0.01 mm" in out
    (work / "part.step").rename(work / "orig.step")
    code, _, err = run("-d", nzc)
    assert code == 0, err
    assert (work / "part.step").read_bytes().startswith(b"ISO-10303-21;")
    code, _, err = run("--decompress", "-kf", nzc)  # grouped, and the long form
    assert code == 0, err
    code, _, err = run("-z", "-q", "-f", str(work / "orig.step"))
    assert code == 0 and (work / "orig.step.nzc").exists(), err


def test_mode_flags_refuse_another_command(work: Path) -> None:
    code, _, err = run("compress", "-d", str(work / "out"), str(work / "part.step"))
    assert code == 2 and "-O/--output-dir" in err
    code, _, err = run("-d", "-t", str(work / "x.nzc"))
    assert code == 2 and "exclude each other" in err
    assert not (work / "out").exists()


def test_rm_removes_inputs_once_done(work: Path) -> None:
    src = work / "part.step"
    code, out, err = run("compress", "--rm", "--json", str(src))
    assert code == 0, err
    assert json.loads(out.splitlines()[0])["input_removed"] and not src.exists()
    code, _, err = run("decompress", "--rm", "-q", str(work / "part.step.nzc"))
    assert code == 0, err
    assert src.exists() and not (work / "part.step.nzc").exists()
    code, _, err = run("compress", "--rm", "--no-verify", str(src))
    assert code == 2 and "--rm needs" in err and src.exists()
    # a failed file keeps its input
    (work / "bad.step").write_bytes(b"garbage\n")
    code, _, _ = run("compress", "--rm", "-q", str(work / "bad.step"))
    assert code == 1 and (work / "bad.step").exists()


@pytest.mark.slow
@pytest.mark.corpus
def test_decompress_to_stdout_in_the_source_format(work: Path, made) -> None:
    assert run("compress", "-q", str(work / "part.step"))[0] == 0
    # no format in the name: the container's META tells (the run's container
    # of occ22470 at the default 0.01 mm, as `compress` makes it)
    shutil.copy(made(CORPUS / "occt__occ22470.igs", 0.01), work / "occ.nzc")
    r = _script("decompress", "-c", "part.step.nzc", cwd=work)
    assert r.returncode == 0 and r.stdout.startswith(b"ISO-10303-21;"), r.stderr
    r = _script("-dc", "occ.nzc", cwd=work)
    assert r.returncode == 0, r.stderr
    assert r.stdout[72:80] == b"S0000001"  # an IGES start record
    r = _script("decompress", "-c", "--format", "step", "occ.nzc", cwd=work)
    assert r.stdout.startswith(b"ISO-10303-21;")
    data = (work / "part.step.nzc").read_bytes()
    r = _script("decompress", "-", cwd=work, stdin=data)
    assert r.returncode == 0 and r.stdout.startswith(b"ISO-10303-21;"), r.stderr


@pytest.mark.slow
def test_info_and_test_take_many_files(work: Path) -> None:
    part = str(work / "part.step")
    assert run("compress", "-q", "-O", str(work / "arc" / "sub"), part)[0] == 0
    assert run("compress", "-q", "--lossless", "-O", str(work / "arc"), part)[0] == 0
    a, b = work / "arc" / "part.step.nzc", work / "arc" / "sub" / "part.step.nzc"
    code, out, _ = run("info", str(a), str(b), "--json")
    assert code == 0
    recs = [json.loads(line) for line in out.splitlines()]
    assert [r["mode"] for r in recs] == ["exact", "tolerance"]
    code, out, _ = run("info", "-r", str(work / "arc"))
    assert code == 0 and out.count("file:        ") == 2
    code, out, err = run("test", "-r", str(work / "arc"), "-j", "2")
    assert code == 0 and out.count(": OK (3 faces)") == 1, err
    assert out.count(": OK (the exact file, sha256 ") == 1, out
    assert "2 files: 2 ok, 0 failed" in out
    (work / "arc" / "bad.nzc").write_bytes(b"\x89NZC junk")
    (work / "arc" / "gone.nzc").symlink_to(work / "nowhere.nzc")
    code, out, _ = run("test", "-r", str(work / "arc"), "--json", "-j", "1")
    recs = [json.loads(line) for line in out.splitlines()]
    by_name = {Path(r["input"]).name: r["exit_code"] for r in recs if not r.get("summary")}
    assert by_name == {"bad.nzc": EXIT_CONTAINER, "gone.nzc": 1, "part.step.nzc": 0}
    assert code == EXIT_CONTAINER and recs[-1]["exit_code"] == EXIT_CONTAINER


def test_usage_errors_under_json_are_json(work: Path) -> None:
    r = _script("compress", "--json", "--tol", "-1", "part.step", cwd=work)
    assert r.returncode == 2
    (line,) = r.stdout.decode().splitlines()
    rec = json.loads(line)
    assert rec["status"] == "failed" and rec["exit_code"] == 2 and "--tol" in rec["error"]
    assert "--tol" in r.stderr.decode()
    r = _script("compress", "--tol", "-1", "part.step", cwd=work)
    assert r.returncode == 2 and r.stdout == b""


def test_words_and_units(work: Path) -> None:
    code, _, err = run("compress", str(work))  # a folder: no tolerance notice before the error
    assert code == 1
    assert err.strip().splitlines() == [f"error: {work}: is a directory (-r walks it)"]
    assert run("compress", "-q", str(work / "part.step"))[0] == 0
    code, out, _ = run("info", str(work / "part.step.nzc"))
    assert "1 solid, 1 shell, 3 faces, 3 wires, 3 edges, 2 vertices" in out
    assert "product:     1 part, 0 assemblies, 0 instances, depth 1, 1 name" in out
    code, _, err = run("compress", str(work / "part.step.nzc"))
    assert code == 1 and "already a .nzc container" in err


def test_sizes_share_a_unit() -> None:
    from nurbscomp.cli import _sizes

    assert _sizes(862_000, 21_909) == "862 kB -> 21.9 kB"
    assert _sizes(1_963_123, 49_418) == "1.96 MB -> 0.0494 MB"
    assert _sizes(31_175, 1_787) == "31.2 kB -> 1.79 kB"
    assert _sizes(950, 120) == "950 bytes -> 120 bytes"
    assert _sizes(12_345_678, 1_234_567) == "12.3 MB -> 1.23 MB"


def test_no_empty_mirrored_folders(work: Path) -> None:
    """-O makes the folders it mirrors; one whose only file failed is removed again."""
    (work / "src" / "sub").mkdir(parents=True)
    (work / "src" / "sub" / "bad.step").write_bytes(b"garbage\n")
    shutil.copy(work / "part.step", work / "src" / "part.step")
    code, _, _ = run("compress", "-q", "-r", str(work / "src"), "-O", str(work / "out"), "-j", "1")
    assert code == 1
    assert sorted(p.name for p in (work / "out").rglob("*")) == ["part.step.nzc"]


def test_a_tolerance_larger_than_the_part_is_warned_of(work: Path) -> None:
    # (a tolerance near the part's size codes slowly: 10 m took 14 s here,
    # 11 of them within 100 mm)
    code, _, err = run("compress", "--tol", "2cm", str(work / "part.step"))
    assert code == 0
    assert "tolerance 20 mm is more than 10% of the part's size" in err
    code, _, err = run("compress", "-f", "--tol", "0.1", str(work / "part.step"))
    assert code == 0 and "warning" not in err
