"""Shared fixtures: the corpus (read in place) and the samples.

The corpus is the folder ``NURBSCOMP_CORPUS`` names, else ``../shared/corpus``
beside the repository.  Without it the suite still runs: every test that needs
it is skipped (a test marked ``corpus``, a parameter made by :func:`in_corpus`,
or an empty :func:`corpus_files` parametrisation), and the run ends with one
line saying how to get it.  With it, nothing is skipped."""

from __future__ import annotations

import json
import os
import signal
from pathlib import Path

import pytest

from . import part21

ROOT = Path(__file__).resolve().parent.parent
CORPUS = Path(os.environ.get("NURBSCOMP_CORPUS") or ROOT.parent / "shared" / "corpus")
SAMPLES = ROOT / "samples"
CAD_SUFFIXES = (".step", ".stp", ".igs", ".iges")
NO_CORPUS = (
    f"corpus not found at {CORPUS}: set NURBSCOMP_CORPUS to the folder of the shared "
    "corpus (the 11 CAD files and their MANIFEST) to run the corpus tests"
)


def have_corpus() -> bool:
    return CORPUS.is_dir() and any(p.suffix.lower() in CAD_SUFFIXES for p in CORPUS.iterdir())


def corpus_files() -> list[Path]:
    """Every CAD file of the corpus (teapot.bpt is raw data, not CAD); none
    when the corpus is absent, so that a test parametrised on them is skipped."""
    if not have_corpus():
        return []
    return sorted(p for p in CORPUS.iterdir() if p.suffix.lower() in CAD_SUFFIXES)


#: The corpus file whose checks take longest (some 40 s a compress and
#: check on 2 loaded cores): in the corpus tests that name it, left to make stress.
SLOWEST = "occt__trj7_b1-ec-214.stp"


def corpus_params() -> list:
    """:func:`corpus_files` as test parameters, :data:`SLOWEST` marked long."""
    return [
        pytest.param(p, marks=pytest.mark.long, id=p.name) if p.name == SLOWEST else p
        for p in corpus_files()
    ]


def in_corpus(name: str):
    """A test parameter: the corpus file ``name``, skipped without the corpus."""
    return pytest.param(CORPUS / name, marks=pytest.mark.corpus, id=name)


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """The tests marked long first, then the ones marked slow (each worker
    starts on a long one and the run ends on short ones, not with one worker
    alone on a long test); without the corpus, skip what needs it."""
    items.sort(  # stable
        key=lambda item: (
            item.get_closest_marker("long") is None,
            item.get_closest_marker("slow") is None,
        )
    )
    if have_corpus():
        return
    skip = pytest.mark.skip(reason="needs the corpus (NURBSCOMP_CORPUS; see the last line)")
    for item in items:
        if item.get_closest_marker("corpus") is not None:
            item.add_marker(skip)


@pytest.fixture(scope="session")
def made(tmp_path_factory: pytest.TempPathFactory):
    """``made(src, tol)``: the container of ``src`` at ``tol`` (defaults
    otherwise; ``tol`` None: lossless-brep), made once for the whole run, by
    whichever worker asks first: a folder that every pytest-xdist worker
    shares, a lock file per container; ``compress_file``'s report is beside
    it (``.json``)."""
    import fcntl

    from nurbscomp import pipeline

    root = tmp_path_factory.getbasetemp()
    if os.environ.get("PYTEST_XDIST_WORKER"):
        root = root.parent  # the run's folder, above each worker's own
    folder = root / "made"
    folder.mkdir(exist_ok=True)

    def get(src: Path, tol: float | None) -> Path:
        out = folder / f"{src.name}.{tol}.nzc"
        with open(folder / f"{src.name}.{tol}.lock", "w") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)
            if not out.exists():
                # written whole or not at all; tol None: lossless-brep
                rep = pipeline.compress_file(src, out, tol=tol, lossless=tol is None)
                out.with_suffix(".json").write_text(json.dumps(rep, default=str))
        return out

    return get


def pytest_terminal_summary(terminalreporter, exitstatus: int, config: pytest.Config) -> None:
    if not have_corpus():
        terminalreporter.write_line(NO_CORPUS)


def brep_bytes(shape: object) -> bytes:
    """The ``.brep`` text OCCT writes of ``shape`` (``BRepTools.Write``):
    two shapes built alike give the same bytes."""
    import tempfile

    from OCP.BRepTools import BRepTools

    with tempfile.TemporaryDirectory() as d:
        f = os.path.join(d, "s.brep")
        BRepTools.Write_s(shape, f)
        return Path(f).read_bytes()


def sample_files() -> list[Path]:
    files = sorted(SAMPLES.glob("*.step"))
    assert len(files) >= 4, "samples/*.step missing: run `make samples`"
    return files


def assert_comes_back(src: Path, nzc: Path, tol: float, n: int = 5):
    """Decode ``nzc``: the source's counts, within ``tol`` of it (``n``×``n``
    samples per face), valid.  Returns the decoded shape."""
    from nurbscomp import occ, pipeline

    shape = pipeline.decode_file(nzc)[0]
    cad = occ.read_cad(src)
    assert occ.counts(shape) == occ.counts(cad.shape)
    assert occ.deviation(cad.shape, shape, n=n, tol=tol).max() <= tol
    assert occ.is_valid(shape)
    return shape


def compressed_part(
    tmp_path_factory: pytest.TempPathFactory, make, name: str, tol: float = 0.01
) -> tuple[Path, Path, dict]:
    """``make(path)`` writes a part's STEP; it compressed at ``tol``:
    (source, container, report)."""
    from nurbscomp import pipeline

    d = tmp_path_factory.mktemp(name)
    src = make(d / f"{name}.step")
    nzc = d / f"{name}.nzc"
    return src, nzc, pipeline.compress_file(src, nzc, tol=tol)


def through_curves(m, kind) -> list[int]:
    """The ``CRV3`` rows of ``m`` of analytic ``kind`` (a line, a circle) that
    go through vertices."""
    from nurbscomp.model import Analytic

    return [
        i
        for i, g in enumerate(m.curves3d)
        if isinstance(g, Analytic) and g.kind == kind and g.through
    ]


def through_rows(nzc: Path, revision: int, kind) -> tuple:
    """The tables of container ``nzc`` (of ``revision`` or later) and the
    ``CRV3`` rows of ``kind`` that go through vertices, with that kind's rows
    all told: (tables, model as read, through rows, every row of the kind)."""
    from nurbscomp import container, serialize
    from nurbscomp.model import Analytic

    c = container.unpack(nzc.read_bytes())
    assert c.revision >= revision
    m, _, tables = serialize.read_sections(c.get, c.revision)
    every = [i for i, g in enumerate(m.curves3d) if isinstance(g, Analytic) and g.kind == kind]
    return tables, m, through_curves(m, kind), every


def tag_step_trips(monkeypatch: pytest.MonkeyPatch, which: str, lose) -> list:  # type: ignore[no-untyped-def]
    """Tag each STEP round trip the STEP check makes (``validity._Floor.trip``)
    with the value of its argument ``which`` (``"pcurves"`` or
    ``"uncertainty"``), and add face 0 to the faces a candidate's re-read
    loses (``_Floor.candidate_losses``) where ``lose(value, asked)`` is true;
    ``asked``, the values of the re-reads checked so far (this one last), is
    returned and kept up to date."""
    from nurbscomp.encode import validity

    asked: list = []
    losses, trip = validity._Floor.candidate_losses, validity._Floor.trip
    made: dict = {}  # id of a round trip: its value

    def tagged(self, shape, stack, product=None, nice=0, pcurves=True, uncertainty=None):  # type: ignore[no-untyped-def]
        back = trip(self, shape, stack, product, nice, pcurves, uncertainty)
        made[id(back)] = {"pcurves": pcurves, "uncertainty": uncertainty}[which]
        return back

    def lost(self, back, tol):  # type: ignore[no-untyped-def]
        value = made[id(back)]
        asked.append(value)
        got = losses(self, back, tol)
        return {0} | (got or set()) if lose(value, asked) else got

    monkeypatch.setattr(validity._Floor, "trip", tagged)
    monkeypatch.setattr(validity._Floor, "candidate_losses", lost)
    return asked


def assert_step_keeps_floor(cad, nzc: Path, tmp_path: Path):
    """Decompress ``nzc`` to STEP, read it back, and compare with OCCT's own
    STEP round trip of the source (the floor): each topology count between
    the source's and the floor's (``validity.step_keeps``), valid where the floor is, and
    no more free edges (sewn at 1e-7) than the source or the floor; and the
    STEP is well formed by a Part 21 reader other than OCCT's (``part21``).
    Returns the re-read shape."""
    from nurbscomp import occ, pipeline

    floor = occ.step_round_trip(cad.shape, cad.unit, cad.product)  # as decompress writes
    out = tmp_path / "out.step"
    pipeline.decompress_file(nzc, out, force=True)
    part21.read_file(out)  # a second reader, not OCCT's, finds it well formed
    back = occ.read_cad(out).shape
    src, lo, got = occ.counts(cad.shape), occ.counts(floor), occ.counts(back)
    worse = {
        k: (src[k], lo[k], got[k])
        for k in src
        if not min(src[k], lo[k]) <= got[k] <= max(src[k], lo[k])
    }
    assert not worse, f"(source, floor, ours) {worse}"
    if occ.is_valid(floor):
        assert occ.is_valid(back)
    free = [occ.free_edges_sewn(x) for x in (cad.shape, floor, back)]
    assert free[2] <= max(free[:2]), f"free edges (source, floor, ours) {free}"
    return back


@pytest.fixture(scope="session")
def thick_step(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A shelled loft written by OCCT's STEP writer (the stress corpus's
    ``feature_thick_00``): its inner face is an offset of a B-spline no face
    lies on, and its pcurves there are dense (1,992 and 307 poles); they are
    stored under format 2.15's rule, not under 2.16's."""
    from tests.stress.files import write_step
    from tests.stress.shapes import entries

    entry = {e.name: e for e in entries(0)}["feature_thick_00"]
    path = tmp_path_factory.mktemp("thick") / "thick.step"
    write_step(entry.build(), path, "thick")
    return path


@pytest.fixture(scope="session")
def small_step() -> Path:
    return SAMPLES / "bracket.step"


def default_signals() -> None:
    """``preexec_fn`` of a child whose signal handling a test checks: SIGINT,
    SIGTERM and SIGHUP at their defaults, whatever the test run inherited
    (``nohup`` ignores SIGHUP, a shell's background job SIGINT, and the CLI
    keeps an ignored signal ignored)."""
    for s in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
        signal.signal(s, signal.SIG_DFL)


@pytest.fixture
def one_coding(monkeypatch: pytest.MonkeyPatch) -> None:
    """Compress codes a part within the tolerance asked only, never a tenth
    of it (``stages.compress._coded``): for tests of what the validity
    stage does at one tolerance."""
    from nurbscomp.stages import compress

    monkeypatch.setattr(compress, "RETRY_SHARE", float("inf"))
    monkeypatch.setattr(compress, "RETRY_SMALL", 0)
    monkeypatch.setattr(compress, "RETRY_MEDIUM", 0)
    monkeypatch.setattr(compress, "FINE_SHARE", float("inf"))


def wavy_plate(
    path: Path,
    n: int,
    size: tuple[float, float],
    wave: tuple[float, float, float],
    fit: float,
    degree: int,
) -> Path:
    """A wavy plate written to STEP at ``path``: a face fitted by
    ``makeSplineApprox`` (within ``fit`` mm, at ``degree``) through an
    ``n`` x ``n`` grid of points over ``size`` (x, y), z = a·sin(x/px)·cos(y/py)
    with ``wave`` = (a, px, py)."""
    import cadquery as cq
    import numpy as np

    x = np.linspace(0.0, size[0], n)
    y = np.linspace(0.0, size[1], n)
    a, px, py = wave
    pts = [[cq.Vector(u, v, a * np.sin(u / px) * np.cos(v / py)) for v in y.tolist()] for u in x]
    face = cq.Face.makeSplineApprox(pts, tol=fit, minDeg=degree, maxDeg=degree)
    cq.exporters.export(cq.Workplane().add(face), str(path))
    return path
