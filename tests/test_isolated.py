"""STEP round trips in a forked child (``occ.isolated``): a crash of OCCT's
reader is reported, never shared."""

from __future__ import annotations

import os
import signal
import threading
import time
from pathlib import Path
from typing import Any, cast

import pytest

from nurbscomp import container, occ, pipeline
from nurbscomp.encode import nets, validity
from nurbscomp.errors import InputError
from nurbscomp.writer import model_to_sections

from .conftest import SAMPLES


def _crash() -> None:
    os.kill(os.getpid(), signal.SIGSEGV)


def _refuse() -> None:
    raise InputError("cannot parse STEP file (Fail)")


def _boom(shape: object) -> None:
    raise ValueError("no")


def _pid(shape: object) -> int:
    return os.getpid()


def test_answers_come_from_the_child() -> None:
    shape = occ.read_cad(SAMPLES / "loft.step").shape
    with occ.RoundTrip(lambda: shape) as r:
        assert r.ask(occ.counts) == occ.counts(shape)
        assert r.ask(_pid) != os.getpid()  # asked where the shape is
        with pytest.raises(RuntimeError, match="ValueError: no"):
            r.ask(_boom)
        assert r.ask(occ.is_valid)  # still serving after an error


def test_a_crash_is_reported_not_shared() -> None:
    assert occ.isolated.can_fork()  # Linux: in a child, or this test would crash
    with occ.RoundTrip(_crash) as r:
        with pytest.raises(occ.ReaderCrash, match="SIGSEGV"):
            r.ask(occ.counts)
        assert r.crashed
        with pytest.raises(occ.ReaderCrash):
            r.ask(occ.counts)
    with occ.RoundTrip(_refuse) as r, pytest.raises(InputError, match="cannot parse"):
        r.ask(occ.counts)


def test_other_threads_do_not_stop_the_fork() -> None:
    """A progress bar's thread is running (as ``compress`` in a terminal has):
    the round trip is still made, and crashes, in a child."""
    done = threading.Event()
    t = threading.Thread(target=done.wait, daemon=True)
    t.start()
    try:
        with occ.RoundTrip(lambda: None) as r:
            assert r.ask(_pid) != os.getpid()
        with occ.RoundTrip(_crash) as r, pytest.raises(occ.ReaderCrash):
            r.ask(occ.counts)
    finally:
        done.set()
        t.join()


def test_without_fork_it_runs_here(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(occ.isolated, "can_fork", lambda: False)
    with occ.RoundTrip(lambda: None) as r:
        assert r.ask(_pid) == os.getpid()


def test_compress_survives_a_reader_that_crashes(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Every candidate's STEP re-read crashes (as OCCT 7.9's did on a 685-face
    faces-mode IGES model: ShapeBuild_ReShape::Apply recursing without end):
    compress loses every face to the check, falls back, and still writes a
    container that decodes within tol."""
    real = occ.step_round_trip

    def crashing(
        shape: object, unit: str = "MM", product: object = None, folder: object = None
    ) -> object:
        if product is not None:  # candidates, written as decompress writes them
            _crash()
        return real(shape, unit, product, folder)

    monkeypatch.setattr(validity.occ, "step_round_trip", crashing)
    src = SAMPLES / "loft.step"
    report = pipeline.compress_file(src, tmp_path / "l.nzc", tol=0.01)
    assert report["validity"]["fallback"] == "exact"
    assert report["validity"]["step_round_trips"] >= 2
    shape = pipeline.decode_file(tmp_path / "l.nzc")[0]
    assert occ.counts(shape) == occ.counts(occ.read_cad(src).shape)


def test_leaving_the_block_stops_a_child_still_at_work() -> None:
    """A round trip begun beside other work and no longer wanted (its
    candidate failed BRepCheck) is not waited for: the child is killed."""
    t0 = time.perf_counter()
    with occ.RoundTrip(lambda: time.sleep(60)) as r:
        pid = r._pid
    assert time.perf_counter() - t0 < 10
    with pytest.raises(ChildProcessError):
        os.waitpid(pid, os.WNOHANG)  # reaped already


def test_a_reader_that_does_not_answer_in_time_is_stopped() -> None:
    """A round trip given a time limit is killed past it (OCCT's reader can
    loop: an offset of a surface of revolution), and says so from then on."""
    t0 = time.perf_counter()
    with occ.RoundTrip(lambda: time.sleep(60), limit=0.5) as r:
        pid = r._pid
        with pytest.raises(occ.ReaderTimeout, match="did not finish within 0.5 s"):
            r.ask(occ.counts)
        assert r.crashed
        with pytest.raises(occ.ReaderTimeout):
            r.ask(occ.counts)
        with pytest.raises(ChildProcessError):
            os.waitpid(pid, os.WNOHANG)  # killed and reaped at once
    assert time.perf_counter() - t0 < 10
    shape = occ.read_cad(SAMPLES / "loft.step").shape
    with occ.RoundTrip(lambda: shape, limit=30) as r:  # in time: as with no limit
        assert r.ask(occ.counts) == occ.counts(shape)


def _offset_of_revolution() -> Any:
    """One face on an offset of a surface of revolution of a B-spline profile,
    the kind ``validity.step_reader_hangs`` names."""
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeFace
    from OCP.Geom import Geom_OffsetSurface, Geom_SurfaceOfRevolution
    from OCP.GeomAPI import GeomAPI_PointsToBSpline
    from OCP.gp import gp_Ax1, gp_Dir, gp_Pnt
    from OCP.TColgp import TColgp_Array1OfPnt

    points = TColgp_Array1OfPnt(1, 4)
    for i, (x, z) in enumerate([(5, 0), (6, 3), (5.5, 6), (7, 9)], 1):
        points.SetValue(i, gp_Pnt(x, 0, z))
    profile = GeomAPI_PointsToBSpline(points).Curve()
    rev = Geom_SurfaceOfRevolution(profile, gp_Ax1(gp_Pnt(0, 0, 0), gp_Dir(0, 0, 1)))
    return BRepBuilderAPI_MakeFace(Geom_OffsetSurface(rev, 0.8), 0, 4.0, 0, 1, 1e-7).Face()


def test_a_model_the_reader_may_loop_on_is_still_checked(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Such a model's round trips only get a time limit: this one's come back,
    and its coded edges' tolerances (some 5e-3) would have had OCCT's reader
    add a degenerated edge (4 -> 5 edges) in the decompressed STEP, which the
    check keeps out.  Coded with the pole bound (``nets.SPREAD`` off), whose
    first candidate is the one that gains the edge: written with the
    tolerance the coding widened as its uncertainty, it keeps its 4 edges
    (``ValidityReport.uncertainty``; before, a second round held it).  Its
    edges keep their knots (``nets.CURVE_REMOVAL`` off): with fewer poles the
    first candidate keeps its 4 edges, and this check would not be reached."""
    monkeypatch.setattr(nets, "SPREAD", False)
    monkeypatch.setattr(nets, "CURVE_REMOVAL", False)
    src = tmp_path / "offrev.step"
    occ.write_shape(_offset_of_revolution(), src, "STEP")
    m = occ.shape_to_model(occ.read_cad(src).shape)[0]
    assert validity.step_reader_hangs(m) and validity.step_time_limit(m)
    report = pipeline.compress_file(src, tmp_path / "o.nzc", tol=0.01)
    assert not report["validity"]["step_skipped"]
    v = report["validity"]
    assert v["step_round_trips"] >= 3  # the floor, the first candidate's two
    assert v["uncertainty"] is not None  # the first candidate gained the edge
    pipeline.decompress_file(tmp_path / "o.nzc", tmp_path / "o.step")
    assert occ.counts(occ.read_cad(tmp_path / "o.step").shape) == occ.counts(
        occ.step_round_trip(occ.read_cad(src).shape)
    )


@pytest.mark.slow
def test_a_reader_that_loops_on_the_source_too_leaves_no_check(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """If every round trip loops, the source's own included, compress waits one
    time limit (the source's runs beside the candidate's), then goes on with
    no STEP check and says why."""
    src = tmp_path / "offrev.step"
    occ.write_shape(_offset_of_revolution(), src, "STEP")

    def looping(*a: object, **k: object) -> None:
        time.sleep(60)

    monkeypatch.setattr(validity.occ, "step_round_trip", looping)
    monkeypatch.setattr(validity, "HANG_SECONDS", 1.0)
    t0 = time.perf_counter()
    report = pipeline.compress_file(src, tmp_path / "o.nzc", tol=0.01)
    assert time.perf_counter() - t0 < 20
    assert "did not finish within" in report["validity"]["step_skipped"]
    assert any("no STEP check" in w for w in report["warnings"])
    assert occ.counts(pipeline.decode_file(tmp_path / "o.nzc")[0])["faces"] == 1


@pytest.mark.slow
def test_a_reader_that_loops_on_any_model_is_stopped(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A part no rule names (a lofted solid) whose every round trip loops is
    stopped after its time limit too (``validity.LIMIT_SECONDS``), not
    waited for forever: compress goes on with no STEP check and says why."""
    assert not validity.step_reader_hangs(
        occ.shape_to_model(occ.read_cad(SAMPLES / "loft.step").shape)[0]
    )

    def looping(*a: object, **k: object) -> None:
        time.sleep(600)

    monkeypatch.setattr(validity.occ, "step_round_trip", looping)
    monkeypatch.setattr(validity, "LIMIT_SECONDS", 1.0)
    monkeypatch.setattr(validity, "LIMIT_PER_FACE", 0.0)
    t0 = time.perf_counter()
    report = pipeline.compress_file(SAMPLES / "loft.step", tmp_path / "o.nzc", tol=0.01)
    assert time.perf_counter() - t0 < 60
    assert "did not finish within 1 s" in report["validity"]["step_skipped"]
    assert pipeline.evaluate(SAMPLES / "loft.step", tmp_path / "o.nzc")["verdict"] == "pass"


def _pack(
    model: object, codes: dict, step_pcurves: bool = True, uncertainty: float | None = None
) -> tuple[int, bytes]:
    meta: dict = {"mode": "tolerance", "tolerance_mm": 0.01}
    if not step_pcurves:
        meta["step_pcurves"] = False
    if uncertainty is not None:
        meta["uncertainty"] = uncertainty
    return id(model), container.pack(model_to_sections(model, meta, codes), 0, thorough=False)


@pytest.mark.parametrize("spare", [True, False])
def test_what_is_packed_meanwhile_is_the_target(
    spare: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``lossy_target(meanwhile=...)`` runs while a candidate's STEP round trip
    does: what it returns is kept for the model returned, which is still as
    it was then; the floor begun at once (a core to spare) or when needed
    changes nothing but time.  With no core to spare it does not run."""
    monkeypatch.setattr(validity.occ, "spare_core", lambda: spare)
    cad = occ.read_cad(SAMPLES / "loft.step")
    m, _ = occ.shape_to_model(cad.shape)
    t = validity.lossy_target(m, cad.shape, 0.01, meanwhile=_pack)
    assert t.validity.step_round_trips >= 1
    if not spare:
        assert t.early is None
        return
    assert t.early is not None and t.early[0] == id(t.model)
    assert t.early[1] == _pack(t.model, t.codes, t.validity.step_pcurves, t.validity.uncertainty)[1]


@pytest.mark.slow
def test_nothing_is_packed_meanwhile_for_a_fallback(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """When every candidate fails, the model returned (every record exact)
    was never checked: no early result comes with it."""
    monkeypatch.setattr(validity.occ, "step_round_trip", lambda *a: _crash())
    monkeypatch.setattr(validity.occ, "spare_core", lambda: True)
    cad = occ.read_cad(SAMPLES / "loft.step")
    m, _ = occ.shape_to_model(cad.shape)
    t = validity.lossy_target(m, cad.shape, 0.01, meanwhile=_pack)
    assert t.validity.fallback == "exact" and t.early is None


def test_a_busy_machine_makes_no_round_trip_for_a_faulty_candidate(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """With a core to spare a candidate's STEP round trip begins before its
    BRepCheck; without one it waits for BRepCheck to pass, so a candidate
    with a new fault costs no round trip at all."""
    from nurbscomp.encode import validity

    trips: list[object] = []

    class Floor:
        product = None
        broken = ""
        pcurves = True
        uncertainty = None

        def trip(
            self,
            shape: object,
            stack: object,
            product: object = None,
            pcurves: bool = True,
            uncertainty: float | None = None,
        ) -> object:
            trips.append(shape)
            return object()

    monkeypatch.setattr(validity.occ, "failures", lambda shape: ({1}, set()))
    for spare, made in ((True, 1), (False, 0)):
        monkeypatch.setattr(validity.occ, "spare_core", lambda spare=spare: spare)
        trips.clear()
        new_e, new_f, blamed, early = validity._check(
            "shape", set(), set(), cast(Any, Floor()), 0.01
        )
        assert (new_e, new_f, blamed, early) == ({1}, set(), None, None)
        assert len(trips) == made


def test_a_process_that_shares_the_cores_has_none_to_spare() -> None:
    """``occ.share_cores`` (what a batch's worker calls) makes ``spare_core``
    answer False whatever the machine's load, and can be undone."""
    from nurbscomp.occ import isolated

    try:
        isolated.share_cores()
        assert isolated.spare_core() is False
    finally:
        isolated.share_cores(False)
    assert not isolated._Cores.shared
