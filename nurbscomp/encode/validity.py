"""The validity stage: the cheapest decodable model that is as valid as the source.

Every B-spline net and curve is coded (:func:`encode.nets.code_model`),
and the pcurves OCCT can compute are left for the decoder (docs/design.md §4a).  The
B-rep the decoder will build is then checked, and remedies are applied where
it falls short, cheapest first.  Two checks:

1. **BRepCheck** on the candidate.  The faces of every face or edge with a
   fault the source does not have are coded ``TIGHTER``² times tighter (their
   surfaces and edge curves); where they were already, the faulty faces and
   edges get their stored pcurves back; where those were already there, its
   record (an edge's curve, a face's surface) stays exact, then its
   neighbours' (the faces of a curve, the curves of a surface).
2. **The STEP reader** (``step_check``): the candidate is written to STEP as
   ``decompress`` writes it (through OCCT's XDE writer when the model has
   product data; without pcurves while the source STEP had none and that
   keeps what is kept, ``ValidityReport.step_pcurves``; with the largest
   tolerance the coding widened as its length uncertainty where that keeps
   more, ``ValidityReport.uncertainty``) and read back once
   per round, and must keep what OCCT's own round trip of the
   source keeps (:func:`step_keeps`), and have no more free edges (sewn at
   1e-7) than the source or that round trip.  OCCT's round trip of the source (the
   *floor*) is only made when the candidate's re-read differs from the source
   at all.  A source face that comes back otherwise (:func:`step_losses`)
   climbs one rung of :class:`Rung` per round; a face whose rungs are all
   spent passes the blame to its edge neighbours, then to its vertex
   neighbours.  At the :data:`STALLED`-th round of a plan that passes the
   blame on, the rounds of that plan stop: its candidates are not the cause
   there (a lofted solid whose fillets OCCT's reader merges with their
   neighbours made 13 more round trips with every face around at its last
   rung, and passed at once with nets coded to the pole bound).
   Faces that come back split with no face to blame get the
   deliberate rule of :func:`encode.nets.kinked_records`.

Faces and edges are always indices of the *source* model (``m``): a re-read
shape's faces are mapped onto the source's by :func:`step_losses` before
anything is done with them.

When a round changes nothing, or after ``MAX_ROUNDS``, two fallbacks follow:
the coded geometry with every pcurve stored, then every record exact.  Each
face kept exact is counted in :class:`ValidityReport` with its reason.
"""

from __future__ import annotations

import collections
import contextlib
import functools
import logging
import tempfile
from collections.abc import Callable, Iterable, Sequence, Set
from dataclasses import dataclass, field, replace
from enum import IntEnum
from pathlib import Path
from typing import Any, cast

import numpy as np

from .. import entropy, occ, writer
from ..errors import InputError, NurbscompError, RebuildError
from ..model import (
    EC,
    REBUILD,
    BRepModel,
    Derived,
    Kind,
    Rec,
    ShapeType,
    Table,
    faces_around,
    records,
)
from . import assembly, coincide, nets, pcurves

log = logging.getLogger(__name__)

#: Rounds of remedies before the fallbacks.
MAX_ROUNDS = 20
#: Rounds of a plan whose blame passed on to the neighbours of lost faces
#: all at their last rung before the plan's rounds stop.  On the corpus and
#: on 200 generated parts (seed 7, 0.1 mm) no round passes the blame on; on
#: two lofts filleted at both ends, no plan passed after it did (13 and 6
#: more rounds), one passed with the pole bound.
STALLED = 2

#: OCCT's own STEP round trip of the source (the floor) is begun at the
#: start, in a child beside the net search, in case a candidate needs it,
#: where a core is spare (``occ.spare_core``; never in a batch's worker,
#: which keeps every core busy: ``occ.share_cores``).
#: The niceness the floor's round trip gets when begun that way.
SPECULATIVE_NICE = 10

#: What :func:`lossy_target` may run on a candidate while its STEP round trip
#: runs: called with the model, its codes, whether its STEP output gets
#: pcurves and the length uncertainty it is written with
#: (``ValidityReport.step_pcurves`` and ``uncertainty`` if it passes).
Meanwhile = Callable[[BRepModel, dict[Rec, Any], bool, float | None], Any]


class Rung(IntEnum):
    """What a face the STEP reader mends gets, one rung a round."""

    STILL = 1  # its vertices stay where they are
    TIGHT = 2  # it and its edges' curves are coded TIGHTER times tighter
    TIGHTER = 3  # ... TIGHTER² times tighter (near what a tenth of tol codes)
    EXACT = 4  # its surface and its edges' curves stay exact
    PCURVES = 5  # ... and its pcurves are stored


@dataclass
class ValidityReport:
    """What the validity stage did.

    Attributes
    ----------
    rounds : int
        Candidates built and checked.
    step_round_trips : int
        STEP writes and re-reads (the floor included).
    exact_faces : dict
        Reason -> number of faces whose coded record was *not* used because
        of it: ``"brepcheck"`` (a BRepCheck fault), ``"step"`` (the STEP
        reader mended it), ``"kinked"`` (C0 knots, split by the reader),
        ``"precision"`` (no code within tol: doubles too coarse for its steps,
        far from the origin or at a tol near the source's own precision),
        ``"fallback"`` (the last resort: every record exact).
    pcurves_kept : int
        Faces whose pcurves were stored because of a fault.
    tightened : int
        Faces whose surface and edge curves were coded tighter than tol
        because of a fault (BRepCheck, or a rung of the STEP check).
    fallback : str
        ``""``, ``"pcurves"`` (every pcurve stored) or ``"exact"``.
    step_skipped : str
        Why the STEP check was not made (:func:`step_reader_hangs`), or ``""``.
    step_pcurves : bool
        Whether the STEP output is written with pcurves.  False only where the
        source STEP had none and the STEP check passed on the model kept with
        the candidate written without them (``occ.write_shape``'s ``pcurves``).
    uncertainty : float or None
        The length uncertainty (mm) STEP and IGES output are written with
        (``occ.write_shape``'s ``uncertainty``), or None for OCCT's default
        (the shape's average tolerance): set where the STEP check read the
        first candidate it found lossy back with fewer faces lost when
        written with the largest tolerance the coding widened
        (:func:`widened_tolerance`), and the kept candidate so.
    """

    rounds: int = 0
    step_round_trips: int = 0
    exact_faces: dict[str, int] = field(default_factory=dict)
    pcurves_kept: int = 0
    tightened: int = 0
    fallback: str = ""
    step_skipped: str = ""
    step_pcurves: bool = True
    uncertainty: float | None = None


#: What one validity round's remedies add to a candidate's container, at
#: most, as a share of it: a round packs its candidate against the ceiling
#: only where the rounds since the last packing could have reached it
#: (bearing.iges, coded within 0.01 and 0.001 mm: +3.1 % at most a round).
#: Too low a guess costs time (a later packing finds the ceiling), never bytes.
CEILING_STEP = 0.03


class Costlier(Exception):
    """A round's candidate packs to at least the ``ceiling`` given to
    :func:`lossy_target`: every later round only adds remedies to it (records
    exact, pcurves kept, vertices held, codes tightened), each of which costs
    bytes, so none comes out under the ceiling either (bearing.iges at 0.1 mm,
    coded within 0.01 mm: 9,519 bytes at its first round, growing to 10,083
    at its sixth, against the 9,350 already in hand).

    ``fell_back``: raised where no coded candidate passed and the last
    resort, every record exact, came to the ceiling or more (so a coding
    within a smaller tolerance may still pass where this one did not)."""

    def __init__(self, fell_back: bool = False) -> None:
        super().__init__()
        self.fell_back = fell_back


@dataclass
class Target:
    """The model to store, its codes, and the shape it builds."""

    model: BRepModel
    codes: dict[Rec, Any]
    report: assembly.LossyReport
    shape: Any
    validity: ValidityReport
    pcurves_rebuilt: int
    #: What ``meanwhile`` made of this model (:func:`lossy_target`), or None.
    early: Any = None


def step_reader_hangs(m: BRepModel) -> str:
    """Why OCCT's STEP reader may not come back from this model, or ``""``.

    An offset of a surface of revolution: OCCT 7.9's reader can loop forever
    in ``ShapeFix_Wire::FixShifted`` (``ShapeAnalysis_Surface::ComputeSingularities``
    evaluating the offset's derivatives), on the source's own round trip as on
    ours (seen on a faces-mode IGES offset of a partial cylinder, which IGES
    holds as a surface of revolution; others of the kind read back at once).
    Such a model's round trips get a time limit (:func:`step_time_limit`).
    """
    for g in m.surfaces:
        if isinstance(g, Derived) and g.kind == Kind.OFFSET_SURFACE:
            b = m.surfaces[g.basis]
            while isinstance(b, Derived) and b.kind in (Kind.OFFSET_SURFACE, Kind.TRIMMED_SURFACE):
                b = m.surfaces[b.basis]
            if isinstance(b, Derived) and b.kind == Kind.REVOLUTION:
                return "an offset surface of revolution (OCCT's STEP reader loops on it)"
    return ""


#: A round trip of a model :func:`step_reader_hangs` names may take this many
#: seconds, plus :data:`HANG_PER_FACE` a face, before it is taken for a loop
#: (a round trip takes some 2.5 ms a face: NIST_MBE_PMI_2's 597 in 1.5 s).
HANG_SECONDS = 10.0
HANG_PER_FACE = 0.02
#: Any other model's round trip may take this many seconds, plus
#: :data:`LIMIT_PER_FACE` a face (some 100 times what it takes): a loop of
#: OCCT's reader that no rule foresaw costs that much, not the whole compress.
LIMIT_SECONDS = 120.0
LIMIT_PER_FACE = 0.25


def step_time_limit(m: BRepModel) -> float:
    """Seconds a STEP round trip of ``m`` may take before it is taken for a
    loop of OCCT's reader (``occ.ReaderTimeout``): short where
    :func:`step_reader_hangs` names a cause, generous elsewhere."""
    if step_reader_hangs(m):
        return HANG_SECONDS + HANG_PER_FACE * len(m.face_surface)
    return LIMIT_SECONDS + LIMIT_PER_FACE * len(m.face_surface)


def build(m: BRepModel, cache: occ.PcurveCache | None = None, pcurves: bool = True) -> Any:
    """The OCCT shape of a model, turning any OCCT failure into a ``RebuildError``.

    ``cache``: pcurves projected by earlier builds, reused where unchanged
    (:class:`occ.PcurveCache`; the shape is the same without it).  Without
    ``pcurves``, those the model leaves to compute are not (a shape only
    written to STEP without pcurves: ``occ.model_to_shape``)."""
    try:
        return occ.model_to_shape(m, cache, pcurves)
    except NurbscompError:
        raise
    except Exception as e:  # OCCT raises Standard_Failure subclasses on bad data
        raise RebuildError(
            f"container does not rebuild into a shape ({type(e).__name__}: {e})"
        ) from None


class _Floor:
    """The source as the STEP reader gives it back, made only when needed.

    Every STEP round trip (the floor's and each candidate's) runs in a child
    process (:class:`occ.RoundTrip`), which keeps the re-read shape and
    answers what is asked of it: OCCT's reader can crash on a file it is
    given (a candidate, or even the source's own round trip), and that must
    not take compress down.  Close it (:meth:`close`) when done.

    A child works beside this process until it is asked: with a core to
    spare, a candidate's round trip is begun before its BRepCheck
    (:func:`_check`), and the floor's is begun at once (:meth:`begin`), beside
    the net search, and stopped unused if no candidate needs it.  Only the round
    trips whose answers are used count in the report.
    """

    def __init__(
        self,
        source: Any,
        unit: str,
        report: ValidityReport,
        product: Any = None,
        limit: float | None = None,
        pcurves: bool = True,
    ) -> None:
        self.source, self.unit, self.report = source, unit, report
        #: Whether the candidates are written with pcurves (the floor always is:
        #: OCCT's own round trip is made with its defaults); see :func:`_check`.
        self.pcurves = pcurves
        #: Whether a candidate written without pcurves has been compared with
        #: itself written with them (once: the mode is settled then).
        self.compared = False
        #: The length uncertainty the candidates are written with (None: OCCT's
        #: default), and whether the first lossy candidate has been compared
        #: with itself written with its widened tolerance (:func:`_check`).
        self.uncertainty: float | None = None
        self.uncertainty_compared = False
        self.limit = limit  # seconds a round trip may take (step_time_limit)
        self.product = product  # the candidates are written as decompress writes them
        self.counts = occ.counts(source)
        self._children = contextlib.ExitStack()  # the floor's round trip, once made
        self._floor: occ.RoundTrip | None = None
        self._floor_used = False
        self._signatures: dict[str, np.ndarray] = {}  # the source's and the floor's
        #: Why the floor cannot be had (OCCT's reader crashed on the source's
        #: own round trip), or "": then no candidate is held to it.
        self.broken = ""

    def trip(
        self,
        shape: Any,
        stack: contextlib.ExitStack,
        product: Any = None,
        nice: int = 0,
        pcurves: bool = True,
        uncertainty: float | None = None,
    ) -> occ.RoundTrip:
        """A round trip of ``shape``, begun now in a child (``nice``: its
        niceness increment) and held by ``stack`` (with the folder its STEP
        file is written to), written with or without ``pcurves``, with
        ``uncertainty`` (``occ.write_shape``'s)."""
        folder = Path(stack.enter_context(tempfile.TemporaryDirectory(prefix="nurbscomp-")))
        make = functools.partial(
            occ.step_round_trip, shape, self.unit, product, folder, pcurves, uncertainty
        )
        return stack.enter_context(occ.RoundTrip(make, nice, self.limit))

    def unsettle(self) -> None:
        """Let the next lossy candidate settle again how candidates are
        written (:func:`_check`: without pcurves, with OCCT's default
        uncertainty), where what settled it was not the coding: a candidate
        whose re-approximated pcurves lost a face (``_Plan.whole``)."""
        self.uncertainty_compared &= self.uncertainty is not None
        self.compared &= self.pcurves

    def begin(self, speculative: bool = False) -> None:
        """Begin the floor's round trip now (it is counted once asked); a
        ``speculative`` one runs at a lower priority (:data:`SPECULATIVE_NICE`),
        on what the candidates' work leaves of the cores."""
        if self._floor is None:
            nice = SPECULATIVE_NICE if speculative else 0
            # written as decompress writes the source, product data and all:
            # the round trip the candidates are held to is OCCT's own through
            # the path theirs take (written plainly it kept less on an
            # assembly, and the candidates were held to that)
            self._floor = self.trip(self.source, self._children, self.product, nice=nice)

    def _ask_floor(self, fn: Any) -> Any:
        self.begin()
        assert self._floor is not None
        if not self._floor_used:
            self._floor_used = True
            self.report.step_round_trips += 1
        return self._floor.ask(fn)

    def close(self) -> None:
        self._children.close()
        self._floor = None

    @functools.cached_property
    def floor_counts(self) -> dict[str, int]:
        return cast(dict[str, int], self._ask_floor(occ.counts))

    @functools.cached_property
    def floor_valid(self) -> bool:
        return bool(self._ask_floor(occ.is_valid))

    @functools.cached_property
    def free(self) -> int:
        """The source's free edges (``occ.free_edges_sewn``): a re-read may
        have no more than these or the floor's."""
        return int(occ.free_edges_sewn(self.source))

    @functools.cached_property
    def floor_free(self) -> int:
        return int(self._ask_floor(occ.free_edges_sewn))

    def _per_face(self, measure: Callable[[Any], np.ndarray], which: str) -> np.ndarray:
        """``measure`` of the ``"source"`` (here) or the ``"floor"`` (in its
        child), made once each."""
        key = f"{measure.__name__} {which}"
        if key not in self._signatures:
            if which == "source":
                self._signatures[key] = measure(self.source)
            else:
                self._signatures[key] = self._ask_floor(measure)
        return self._signatures[key]

    def signatures(self, which: str) -> np.ndarray:
        """:func:`occ.face_signatures` of the ``"source"`` or the ``"floor"``, made once."""
        return self._per_face(occ.face_signatures, which)

    def candidate_losses(self, back: occ.RoundTrip, tol: float) -> set[int] | None:
        """:meth:`losses` of a candidate's round trip ``back`` (:meth:`trip`,
        with the product data).

        A STEP file of the candidate that OCCT's reader takes nothing from (an
        ``InputError`` of the re-read; seen on a face periodic in u and v whose
        seams had widened tolerances) or that crashes it (``occ.ReaderCrash``)
        loses every face.
        """
        self.report.step_round_trips += 1
        try:
            return self.losses(back, tol)
        except InputError as e:
            if isinstance(e, occ.ReaderTimeout) and self._floor_fails():
                return None  # the source's own round trip loops too: nothing to hold to
            log.debug("STEP round trip of the candidate fails: %s", e)
            return {int(f) for f in self.model_face}

    def _floor_fails(self) -> bool:
        """Whether the source's own round trip cannot be had (then ``broken``
        says why)."""
        try:
            self.floor_counts  # noqa: B018 (asks the floor)
        except occ.ReaderCrash as e:
            self.broken = f"{e} (the source's own round trip)"
            return True
        return False

    def losses(self, back: occ.RoundTrip, tol: float) -> set[int] | None:
        """None if the re-read ``back`` keeps what the floor keeps; else the
        source faces to blame (possibly none)."""
        got = back.ask(occ.counts)
        free = back.ask(occ.free_edges_sewn)
        valid = back.ask(occ.is_valid)
        if got == self.counts and free <= self.free and valid:
            return None  # as the source: whatever the floor is, this keeps it
        try:
            floor = self.floor_counts
            # an invalid re-read fails where the floor is valid, also when no
            # face or edge carries the fault (occ.faulty_faces then names the
            # faces of the shells and solids BRepCheck rejects)
            faulty = back.ask(occ.faulty_faces) if self.floor_valid and not valid else set()
            loose = free > max(self.free, self.floor_free)
            if not faulty and not loose and step_keeps(self.counts, floor, got):
                return None
            log.debug(
                "STEP round trip %s, %d free edges != %s, %d",
                got,
                free,
                floor,
                self.floor_free,
            )
            floor_sig = self.signatures("floor")
        except occ.ReaderCrash as e:
            if self._floor is not None and self._floor.crashed:
                # the source's own round trip crashes OCCT: nothing to hold to
                self.broken = f"{e} (the source's own round trip)"
                return None
            raise
        free_faces = None
        if loose:  # the faces along new free edges are blamed too
            free_faces = (
                self.free_per_face("source"),
                self.free_per_face("floor"),
                back.ask(occ.free_edges_per_face),
            )
        lost = step_losses(
            self.signatures("source"),
            floor_sig,
            back.ask(occ.face_signatures),
            tol,
            faulty,
            free_faces,
        )
        return {int(self.model_face[f]) for f in lost}

    def free_per_face(self, which: str) -> np.ndarray:
        """:func:`occ.free_edges_per_face` of the ``"source"`` or the ``"floor"``, made once."""
        return self._per_face(occ.free_edges_per_face, which)

    @functools.cached_property
    def model_face(self) -> np.ndarray:
        """Per source face in signature order, its model face (:func:`occ.model_order`)."""
        return occ.model_order(self.source, "face")


#: The grid must save more than this many bytes of those tables to be used:
#: moving every analytic record for less is not worth it (a filleted box at
#: 0.001 mm: 4 bytes, for faces moved by 2.4e-4 mm).
GRID_GAIN = 16


def _source_edges(m: BRepModel, source: Any) -> tuple[Any, list[tuple[int, int]]]:
    """What ``nets.code_model`` needs of the source's shape: its edges sampled
    (``occ.edge_points``) and the pairs its sewing joins (``occ.sewn_edge_pairs``)."""
    return occ.edge_points(source, list(range(len(m.edge_tol)))), occ.sewn_edge_pairs(source)


class _Plan:
    """Which records stay exact, which pcurves are kept, which vertices stay."""

    def __init__(
        self,
        m: BRepModel,
        tol: float,
        source: Any,
        spread: bool = True,
        edges: tuple[Any, Sequence[tuple[int, int]]] | None = None,
        offsets_coded: bool = True,
    ) -> None:
        """``edges``: :func:`_source_edges` of ``source``, when already measured;
        ``offsets_coded``: :func:`nets.code_model`'s."""
        self.m, self.tol = m, tol
        self.knot_memo: dict[tuple[Any, ...], bool] = {}  # pcurves.unit_curves's answers
        points, sewn = edges if edges is not None else _source_edges(m, source)
        self.coded = nets.code_model(
            m, tol, points=points, sewn=sewn, spread=spread, offsets_coded=offsets_coded
        )
        self.faces_rec, self.edges_rec = nets.face_records(m), nets.edge_records(m)
        self.faces_of = faces_around(m, ShapeType.EDGE)
        self.edges_of: list[list[int]] = [[] for _ in self.faces_rec]
        for e, fs in enumerate(self.faces_of):
            for f in fs:
                self.edges_of[f].append(e)
        self.verts_of: list[list[int]] = [[] for _ in self.faces_rec]
        for v, fs in enumerate(faces_around(m, ShapeType.VERTEX)):
            for f in fs:
                self.verts_of[f].append(v)
        self.near_faces = vertex_neighbours(m, tol)
        self.srec = records(m.surfaces, Table.SURFACE)
        self.crec = records(m.curves3d, Table.CURVE3D)
        # records, and None (an edge with no 3-D curve: see nets.edge_records)
        self.exact: set[Rec | None] = set()
        self.keep_e: set[int] = set()
        self.keep_f: set[int] = set()
        self.still_v: set[int] = set()
        self.as_read_e: set[int] = set()  # edges whose ranges stay as read
        self.whole_e: set[int] = set()  # edges whose stored pcurves stay as read
        self.compacted: frozenset[int] = frozenset()  # the last candidate's (LossyReport)
        self.rung: dict[int, Rung] = {}  # source face -> highest rung taken
        self.tight_f: set[int] = set()  # faces tightened for a BRepCheck fault
        self.plain_f: set[int] = set()  # faces whose nets around lost SPATIAL2 (nets.plain)
        self.reason: dict[Rec | None, str] = {}  # record -> why it is exact
        self.loose_v: frozenset[int] = frozenset()  # the last candidate's (LossyReport)
        self.make_exact(set(self.coded.uncodable), "precision")
        self.grid = True  # analytic records on their grids (encode.analytic)
        self.gridded: frozenset[Rec] = frozenset()  # those of the last candidate
        self.through_s: frozenset[Rec] = frozenset()  # its planes, cylinders through a vertex
        self.plain_s: set[Rec] = set()  # records taken off a vertex, straightened still
        self._made: tuple[Any, ...] | None = None  # (state, grid, what _candidate made)
        # per codes weighed by _keep_removal: (codes, rows made rigid, its candidate)
        self._early: dict[int, tuple[nets.Coded, int, Any]] = {}
        if self.coded.spares:
            self._keep_removal(self.coded.with_every_knot())
        self.grid = self._grid_pays()

    def _keep_removal(self, without: nets.Coded) -> None:
        """Keep the nets coded with inner knots removed (:mod:`.removal`) only
        where they make the tables that change (SURF, SNET, CRV3, CNET)
        smaller than ``without`` (:meth:`_packed`): a net the DCT codes for
        little (a sphere's dense rational patches, at 0.01 mm) can cost more
        with fewer poles and weights of its own."""
        sizes = []
        with_removal = self.coded
        for coded in (with_removal, without):
            self._use(coded)
            made = self._candidate()
            self._early[id(coded)] = (coded, len(coded.rigid), made)
            sizes.append(self._packed(made, ("SURF", "SNET", "CRV3", "CNET")))
        log.debug("knots removed: %d -> %d bytes", sizes[1], sizes[0])
        if sizes[0] < sizes[1]:
            self._use(with_removal)

    def _use(self, coded: nets.Coded) -> None:
        """Plan with ``coded``: only the records it cannot code exact."""
        self.coded, self.exact, self.reason = coded, set(), {}
        self.make_exact(set(coded.uncodable), "precision")

    def _packed(self, made: tuple[BRepModel, dict[Rec, Any], Any], tags: tuple[str, ...]) -> int:
        """Bytes of the sections ``tags`` of a candidate (:meth:`_candidate`'s
        model and codes), compressed together as the container compresses them."""
        cand, codes, _ = made
        secs = dict(writer.model_to_sections(cand, {"tolerance_mm": self.tol}, codes, tags))
        return entropy.xz_size(b"".join(secs[t] for t in tags))

    def _grid_pays(self) -> bool:
        """Whether analytic records on their grids make the tables that
        change (SURF, CRV3, VERT, EDGE: the widened tolerances) smaller
        (:meth:`_packed`): a part whose
        frames share their coordinates with its vertices gains nothing from
        the grid and pays for the widening (featuretype at 0.01 mm: 218
        bytes more; NIST_MBE_PMI_2: 1.1 KB less)."""
        sizes = []
        made = {}
        for grid in (False, True):
            self.grid = grid
            made[grid] = self._made_early() if grid else self._candidate()
            sizes.append(self._packed(made[grid], ("SURF", "CRV3", "VERT", "EDGE")))
        log.debug("analytic grid: %d -> %d bytes", *sizes)
        self._early.clear()
        pays = sizes[1] < sizes[0] - GRID_GAIN
        self._made = (self.state(), pays, made[pays])  # the first round's candidate
        return pays

    def _made_early(self) -> tuple[BRepModel, dict[Rec, Any], assembly.LossyReport]:
        """The candidate :meth:`_keep_removal` made on the grid from the codes
        the plan uses now, where no assembly has coded a row of them again
        since (:func:`nets.rigid`, the only change an assembly makes to
        them); else one made now.  Nothing else of the plan changes between
        the two, so it is the candidate :meth:`_candidate` would make."""
        early = self._early.get(id(self.coded))
        if early is not None and early[0] is self.coded and early[1] == len(self.coded.rigid):
            return early[2]
        return self._candidate()

    def state(self) -> tuple[int, ...]:
        return (
            len(self.exact),
            len(self.keep_e),
            len(self.keep_f),
            len(self.still_v),
            len(self.as_read_e),
            sum(self.rung.values()),
            len(self.tight_f),
            len(self.plain_f),
            len(self.plain_s),
            len(self.whole_e),
        )

    def candidate(self) -> tuple[BRepModel, dict[Rec, Any], assembly.LossyReport]:
        """The model the plan makes now, its codes and its report.

        The first round's is the one :meth:`_grid_pays` made for the grid it
        chose, when nothing has changed since (the plan's state and grid)."""
        made, self._made = self._made, None
        fresh = made is None or made[:2] != (self.state(), self.grid)
        out = self._candidate() if fresh else made[2]  # type: ignore[index]
        self.gridded, self.loose_v = out[2].gridded, out[2].loose_v
        self.through_s = out[2].through_s
        self.compacted = out[2].compacted
        return out

    def _candidate(self) -> tuple[BRepModel, dict[Rec, Any], assembly.LossyReport]:
        """:meth:`candidate` made now (``gridded`` and ``loose_v`` left as they are)."""
        target, codes, report = assembly.assemble(
            self.m, self.coded, self.exact, self.still_v, self.grid, self.plain_s
        )
        kept = pcurves.stretch_short(pcurves.drop_pcurves(target, self.keep_e, self.keep_f))
        cand = assembly.unthread(kept, self.m)
        cand = pcurves.unit_curves(
            pcurves.unit_surfaces(cand, codes, self.knot_memo), self.knot_memo
        )
        ranged = pcurves.vertex_ranges(cand, self.tol, self.as_read_e, self.m.vertex_point)
        rounded = pcurves.rounded_ranges(ranged, self.tol, self.as_read_e)
        out, compacted = pcurves.compact_kept(rounded, self.tol, self.whole_e, occ.compact_pcurve)
        return out, codes, replace(report, compacted=compacted)

    def with_leaders(self, recs: set[Rec | None]) -> set[Rec | None]:
        """``recs`` with the records their copies follow: a copied curve's leader
        (``Coded.twins``) and the leaders of a surface's joined sides
        (``Coded.sides``): a copy moves only as what it copies does.  (An
        iso-boundary's surface is not added: tightening a neighbour's whole
        surface cost 514 bytes on ec_turbine at 0.001 and mended nothing.)"""
        out = set(recs)
        for k, (row, _) in self.coded.twins.items():
            if k in recs:
                out.add(self.crec[row])
        for (b, _), ((a, _), _) in self.coded.sides.items():
            if self.srec[b] in out:
                out.add(self.srec[a])
        return out

    def edge_recs(self, f: int) -> list[Rec | None]:
        """Records of face ``f``'s edges' curves (None: an edge with no 3-D curve)."""
        return [self.edges_rec[e] for e in self.edges_of[f]]

    def make_exact(self, recs: Set[Rec | None], why: str) -> None:
        for i in recs - self.exact:
            self.reason.setdefault(i, why)
        self.exact |= recs

    def brepcheck(self, new_e: set[int], new_f: set[int]) -> None:
        """A fault's edges (or its faces' edges) whose stored pcurves were
        re-approximated (:meth:`whole`) keep them as read, and nothing else
        this round.  A fault's faces whose vertices were snapped beside a
        curve kept exact (``LossyReport.loose_v``) get those vertices back
        where they were first, and nothing else this round.  Other faults' faces are
        coded ``TIGHTER``² times tighter first (a code
        that is valid at a smaller tolerance is valid at this one, and costs
        far less than stored pcurves: ec_turbine at 0.1 mm grew by 2 KB
        otherwise); then stored pcurves; where they are stored already, exact
        records; where those are exact already, the faces' vertices stay
        where they are, and their edges keep the ranges they were read with
        (``pcurves.vertex_ranges`` moves an end along a line or circle by up
        to 1e-3 tol, past a 1e-7 tolerance: a surface of revolution in a
        faces-mode IGES file)."""
        if self.whole({*new_e, *(e for f in new_f for e in self.edges_of[f])}):
            return  # first, pcurves re-approximated go back to the source's
        faces = set(new_f) | {f for e in new_e for f in self.faces_of[e]}
        loose = {f for f in faces if set(self.verts_of[f]) & self.loose_v}
        if loose:  # first, vertices snapped beside a curve kept exact stay
            self.still_v |= {v for f in loose for v in self.verts_of[f]} & self.loose_v
            faces -= loose
            new_e = {e for e in new_e if not set(self.faces_of[e]) & loose}
            new_f = new_f - loose
        if self.ungrid(faces, "grid-brepcheck"):  # then analytic records leave their grids
            return
        eased = self.ease(faces)  # then nets around lose SPATIAL2
        new_e = {e for e in new_e if not set(self.faces_of[e]) & eased}
        new_f = new_f - eased
        faces -= eased
        fresh = faces - self.tight_f
        if fresh:
            self.tight_f |= fresh
            recs = self.with_leaders(
                {i for f in fresh for i in (self.faces_rec[f], *self.edge_recs(f))}
            )
            nets.tighten(self.coded, self.m, [i for i in recs if i is not None], 2)
            new_e = {e for e in new_e if not set(self.faces_of[e]) & fresh}
            new_f = new_f - fresh
        for e in new_e & self.keep_e:  # its curve, then its faces' surfaces, then vertices
            around = {self.faces_rec[f] for f in self.faces_of[e]}
            if self.edges_rec[e] in self.exact and around <= self.exact:
                self.as_read(self.faces_of[e])
            if self.edges_rec[e] in self.exact:
                self.make_exact(around, "brepcheck")
            self.make_exact({self.edges_rec[e]}, "brepcheck")
        for f in new_f & self.keep_f:  # its surface, then its edges' curves, then vertices
            curves = {self.edges_rec[e] for e in self.edges_of[f]}
            if self.faces_rec[f] in self.exact and curves <= self.exact:
                self.as_read([f])
            if self.faces_rec[f] in self.exact:
                self.make_exact(curves, "brepcheck")
            self.make_exact({self.faces_rec[f]}, "brepcheck")
        self.keep_e |= new_e
        self.keep_f |= new_f

    def whole(self, edges: Iterable[int]) -> bool:
        """The first rung for a fault on ``edges`` (or on their faces), or for
        a STEP loss of their faces (:func:`_rounds`), where the last candidate
        stored re-approximated pcurves (``pcurves.compact_kept``): those edges
        keep their pcurves as read; whether there were any."""
        hit = set(edges) & self.compacted - self.whole_e
        self.whole_e |= hit
        return bool(hit)

    def ungrid(self, faces: Iterable[int], why: str) -> bool:
        """The first rung for a fault: the analytic records of ``faces`` and
        of their edges that are on a grid are left as they are (exact), but
        a plane or cylinder through a vertex first goes back to its own
        origin, its directions straightened still (a filleted plate turned by
        1e-12 rad kept its fillets' noise otherwise); whether there were any."""
        recs = {r for f in faces for r in (self.faces_rec[f], *self.edge_recs(f))}
        hit = (recs & self.gridded) - self.exact
        back = {r for r in hit & self.through_s if r is not None} - self.plain_s
        self.plain_s |= back
        self.make_exact(set(hit - back), why)
        return bool(hit)

    def ease(self, faces: Iterable[int]) -> set[int]:
        """The first remedy for a fault on ``faces`` (not taken before): the
        ``SPATIAL2`` nets of each face and of the faces across its edges are
        coded without it (:func:`nets.plain`); the faces where some net was
        are returned, their fault left for the next round to judge."""
        out = set()
        for f in sorted(set(faces) - self.plain_f):
            self.plain_f.add(f)
            around = {f} | {g for e in self.edges_of[f] for g in self.faces_of[e]}
            recs = self.with_leaders({self.faces_rec[g] for g in around})
            if nets.plain(self.coded, self.m, [i for i in recs if i is not None]):
                out.add(f)
        return out

    def as_read(self, faces: Iterable[int]) -> None:
        """The vertices of ``faces`` stay where they are, and their edges keep
        the ranges they were read with (the BRepCheck ladder's last rung)."""
        for f in faces:
            self.still_v |= set(self.verts_of[f])
            self.as_read_e |= set(self.edges_of[f])

    def step(self, blamed: set[int]) -> frozenset[int] | None:
        """One rung up for each blamed source face whose rungs are not all
        spent; when all are, for their neighbours (by edge, then by vertex),
        and the faces blamed are returned (else None).
        (A blame of spent and unspent faces at once used to climb the spent
        ones past the last rung: compress crashed on an assembly of blended
        bodies, with "6 is not a valid Rung".)"""
        if self.ungrid(blamed, "grid-step"):
            return None
        spent = {f for f, r in self.rung.items() if r == Rung.PCURVES}
        widened = frozenset(blamed) if blamed <= spent else None
        if blamed <= spent:
            wider = {g for f in blamed for e in self.edges_of[f] for g in self.faces_of[e]}
            if wider <= spent:
                wider = {g for f in blamed for g in self.near_faces[f]}
            blamed = wider
        blamed = blamed - spent
        blamed -= self.ease(blamed)
        for f in sorted(blamed):
            r = Rung(self.rung.get(f, 0) + 1)
            self.rung[f] = r
            log.debug("STEP check: face %d climbs to %s", f, r.name)
            recs = self.with_leaders({self.faces_rec[f], *self.edge_recs(f)})
            if r == Rung.STILL:
                self.still_v |= set(self.verts_of[f])
            elif r in (Rung.TIGHT, Rung.TIGHTER):
                level = 1 if r == Rung.TIGHT else 2
                nets.tighten(self.coded, self.m, [i for i in recs if i is not None], level)
            elif r == Rung.EXACT:
                self.make_exact(recs, "step")
            else:
                self.keep_f.add(f)
                self.keep_e |= set(self.edges_of[f])
        return widened

    def tightened(self) -> int:
        """Faces coded tighter than tol for a fault."""
        return len(self.tight_f | {f for f, r in self.rung.items() if r >= Rung.TIGHT})

    def exact_faces(self, report: assembly.LossyReport) -> dict[str, int]:
        """Faces whose coded record the plan left exact, by reason."""
        out: collections.Counter[str] = collections.Counter()
        for f, rec in enumerate(self.faces_rec):
            if rec in self.exact and report.face_method[f] == "exact":
                out[self.reason.get(rec, "other")] += 1
        return dict(sorted(out.items()))


def lossy_target(
    m: BRepModel,
    source: Any,
    tol: float,
    step_check: bool = True,
    meanwhile: Meanwhile | None = None,
    step_pcurves: bool = True,
    ceiling: int | None = None,
    offsets_coded: bool = True,
) -> Target:
    """The cheapest decodable model that is as valid as the source (module docstring).

    Parameters
    ----------
    m : BRepModel
        The source's model (exact).
    source : TopoDS_Shape
        The shape ``m`` was read from.
    tol : float
    step_check : bool
        Also hold the candidate to OCCT's STEP round trip.
    meanwhile : callable, optional
        Called with a candidate model and its codes while its STEP round trip
        runs in a child (the container is packed then, in case the candidate
        passes); the result for the model returned is ``Target.early``.
    step_pcurves : bool
        False: write the candidates to STEP without pcurves (a source STEP
        file that had none, ``occ.CadFile.pcurves``) for as long as that keeps
        what OCCT's own round trip of the source keeps; the report's
        ``step_pcurves`` says whether it did.
    ceiling : int, optional
        The size of a container already in hand (a coding within a larger
        tolerance, ``stages.compress``): with ``meanwhile``, a round's
        candidate is packed before it is built (where the rounds since the
        last packing could have reached the ceiling, :data:`CEILING_STEP`),
        and one that comes to ``ceiling`` bytes or more ends the search
        (:class:`Costlier`); a fallback that does is not built.
    offsets_coded : bool
        Code the bases of offset surfaces (``nets.code_model``).

    Raises
    ------
    Costlier
        A round's candidate packed to ``ceiling`` bytes or more.
    """
    vr = ValidityReport()
    floor = None
    if step_check:
        floor = _Floor(source, m.unit, vr, m.product, step_time_limit(m), step_pcurves)
    try:
        if floor is not None and step_reader_hangs(m):
            floor.begin()  # beside the candidates': a loop costs one limit, not two
        elif floor is not None and occ.spare_core():
            floor.begin(speculative=True)
        return _search(m, source, tol, vr, floor, meanwhile, ceiling, offsets_coded)
    finally:
        if floor is not None:
            floor.close()
            vr.step_skipped = vr.step_skipped or floor.broken
            # only a candidate checked as written without them goes without
            vr.step_pcurves = floor.pcurves or bool(floor.broken) or vr.fallback == "exact"
            if not floor.broken and vr.fallback != "exact":
                vr.uncertainty = floor.uncertainty


def _search(
    m: BRepModel,
    source: Any,
    tol: float,
    vr: ValidityReport,
    floor: _Floor | None,
    meanwhile: Meanwhile | None,
    ceiling: int | None = None,
    offsets_coded: bool = True,
) -> Target:
    """The rounds and the fallbacks of :func:`lossy_target`.

    The nets are first coded to the refined bound (``nets.code_model``'s
    ``spread``); where no round passes with them, the rounds start again
    from nets coded to the pole bound, before the fallbacks (trj7 at 0.1 mm:
    a face BRepCheck rejected in every round, its records exact or not).
    What comes from the source is measured once for both."""
    start = pcurves.natural_ends(m, tol)
    edges = _source_edges(m, source)
    old_e, old_f = occ.failures(source)
    cache = occ.PcurveCache()  # the candidates differ from round to round in a few records
    if ceiling is not None and meanwhile is not None:
        meanwhile = _last_packed(meanwhile)  # the check's packing of a candidate that passes
    for spread in (True, False):
        plan = _Plan(start, tol, source, spread, edges, offsets_coded)
        done = _rounds(plan, (old_e, old_f), floor, vr, meanwhile, cache, ceiling)
        if done is not None:
            return done
        log.debug("no candidate passed with the %s bound", "refined" if spread else "pole")
    # coded geometry with every pcurve stored, if that passes (and is under the ceiling)
    target, codes, report = assembly.assemble(
        plan.m, plan.coded, plan.exact, plan.still_v, plan.grid
    )
    target = pcurves.stretch_short(target)
    if not _over(ceiling, meanwhile, floor, target, codes):
        shape = build(target, cache)
        vr.rounds += 1
        new_e, new_f, blamed, early = _check_candidate(
            plan, target, codes, shape, (old_e, old_f), floor, meanwhile
        )
        log.debug(
            "fallback with every pcurve stored: new faults on %d edges, %d faces; STEP losses %s",
            len(new_e),
            len(new_f),
            blamed,
        )
        if not new_e and not new_f and blamed is None:
            vr.fallback = "pcurves"
            vr.exact_faces = plan.exact_faces(report)
            vr.pcurves_kept = len(m.face_surface)
            vr.tightened = plan.tightened()
            return Target(target, codes, report, shape, vr, 0, early)
    # every record: coded ones, and analytic ones (straightened otherwise)
    everything: set[Rec | None] = {
        *records(m.surfaces, Table.SURFACE),
        *records(m.curves3d, Table.CURVE3D),
    }
    target, codes, report = assembly.assemble(m, plan.coded, everything, grid=False)
    if _over(ceiling, meanwhile, floor, target, codes):
        raise Costlier(fell_back=True)
    vr.fallback = "exact"
    vr.exact_faces = {"fallback": sum(1 for x in report.face_method if x == "exact")}
    return Target(target, codes, report, build(target, cache), vr, 0)


def _rounds(
    plan: _Plan,
    old: tuple[Any, Any],
    floor: _Floor | None,
    vr: ValidityReport,
    meanwhile: Meanwhile | None,
    cache: Any,
    ceiling: int | None = None,
) -> Target | None:
    """The rounds of remedies of :func:`_search` on ``plan``: the first
    candidate that passes, or None where a round changes nothing, after
    ``MAX_ROUNDS``, or at the :data:`STALLED`-th round whose blame passed on
    to the lost faces' neighbours.  ``old``: the source's own faults
    (``occ.failures``)."""
    old_e, old_f = old
    passed_on = 0  # rounds whose lost faces were all at their last rung
    reach: float | None = None  # the most the rounds since the last packing can have reached
    for _ in range(MAX_ROUNDS):
        before = plan.state()
        cand, codes, report = plan.candidate()
        if ceiling is not None and meanwhile is not None and (reach is None or reach >= ceiling):
            reach = _packed_size(meanwhile, floor, cand, codes)
            if reach >= ceiling:
                log.debug("validity round %d: the candidate packs to the ceiling", vr.rounds + 1)
                raise Costlier
        reach = None if reach is None else reach * (1 + CEILING_STEP)
        shape = build(cand, cache)
        vr.rounds += 1
        new_e, new_f, blamed, early = _check_candidate(
            plan, cand, codes, shape, old, floor, meanwhile
        )
        log.debug(
            "validity round %d: %d exact records, pcurves kept on %d faces; "
            "new faults: %d edges, %d faces",
            vr.rounds,
            len(plan.exact),
            len(plan.keep_f),
            len(new_e),
            len(new_f),
        )
        if new_e or new_f:
            plan.brepcheck(new_e, new_f)
        elif blamed is None:
            return _done(plan, cand, codes, report, shape, vr, early)
        elif blamed:
            if plan.whole(e for f in blamed for e in plan.edges_of[f]):
                if floor is not None:  # the re-approximated pcurves go back first
                    floor.unsettle()
            elif plan.step(blamed) is not None:
                passed_on += 1
                if passed_on >= STALLED:
                    log.debug("STEP check: faces %s lost, their rungs spent: plan stops", blamed)
                    break
        else:  # split or merged with no face to blame: C0 knots stay exact
            plan.make_exact(nets.kinked_records(plan.m), "kinked")
        if plan.state() == before:
            break  # nothing left to try here
    return None


def _packed_size(pack: Meanwhile, floor: _Floor | None, cand: BRepModel, codes: Any) -> int:
    """Bytes of the container of ``cand`` as the STEP check would pack it now."""
    written = (True, None) if floor is None else (floor.pcurves, floor.uncertainty)
    return len(pack(cand, codes, *written))


def _over(
    ceiling: int | None,
    pack: Meanwhile | None,
    floor: _Floor | None,
    cand: BRepModel,
    codes: Any,
) -> bool:
    """Whether a fallback's ``cand`` packs to ``ceiling`` bytes or more (never
    without a ceiling and a packer): it need not be built or checked."""
    if ceiling is None or pack is None:
        return False
    return _packed_size(pack, floor, cand, codes) >= ceiling


def _last_packed(pack: Meanwhile) -> Meanwhile:
    """``pack`` remembering its last answer: the ceiling's packing of a
    round's candidate (:func:`_rounds`) serves the check's of the same
    candidate written the same way."""
    last: list[Any] = []  # [model, step_pcurves, uncertainty, bytes]: the model kept alive

    def packed(cand: BRepModel, codes: dict[Rec, Any], pcurves: bool, unc: float | None) -> Any:
        if not (last and last[0] is cand and last[1:3] == [pcurves, unc]):
            last[:] = [cand, pcurves, unc, pack(cand, codes, pcurves, unc)]
        return last[3]

    return packed


def _done(
    plan: _Plan,
    cand: BRepModel,
    codes: dict[Rec, Any],
    report: assembly.LossyReport,
    shape: Any,
    vr: ValidityReport,
    early: Any,
) -> Target:
    vr.exact_faces = plan.exact_faces(report)
    vr.pcurves_kept = len(plan.keep_f)
    vr.tightened = plan.tightened()
    rebuilt = int((cand.edge_reps[:, EC.CURVE] == REBUILD).sum())
    return Target(cand, codes, report, shape, vr, rebuilt, early)


def _check_candidate(
    plan: _Plan,
    cand: BRepModel,
    codes: dict[Rec, Any],
    shape: Any,
    old: tuple[set[int], set[int]],
    floor: _Floor | None,
    meanwhile: Meanwhile | None,
) -> tuple[set[int], set[int], set[int] | None, Any]:
    """:func:`_check` of the candidate ``cand`` of ``plan`` (its ``codes``,
    built into ``shape``); ``old``: the source's own faults."""
    bound = None if meanwhile is None else functools.partial(meanwhile, cand, codes)
    widened = widened_tolerance(plan.m, cand)
    return _check(shape, old[0], old[1], floor, plan.tol, bound, widened)


def _check(
    shape: Any,
    old_e: set[int],
    old_f: set[int],
    floor: _Floor | None,
    tol: float,
    meanwhile: Callable[[bool, float | None], Any] | None = None,
    widened: float | None = None,
) -> tuple[set[int], set[int], set[int] | None, Any]:
    """A candidate's BRepCheck faults the source lacks (edges, faces) and, when
    it has none and there is a floor, the faces its STEP re-read loses
    (:meth:`_Floor.candidate_losses`; None: it keeps what the floor keeps);
    last, what ``meanwhile()`` returned (None if it was not called).

    With a core to spare (``occ.spare_core``) the STEP round trip is begun
    first, in its child, and BRepCheck runs here meanwhile (a candidate with
    new faults stops the round trip unused); else, not to take a busy core's
    time for a round trip that may be thrown away, only once BRepCheck has
    passed.  Then, with that core to spare, ``meanwhile`` runs, on a
    candidate BRepCheck passes, before the round trip's answers are waited
    for (on a busy machine the work it would do for candidates the round trip
    then fails is other jobs' time: trj7 makes seven round trips).

    ``meanwhile`` is given whether the candidate's STEP output gets pcurves
    (:attr:`_Floor.pcurves`).  The first candidate written without them whose
    re-read loses a face is checked again written with them (one more round
    trip).  If that keeps a face the first lost, the missing pcurves lost it:
    this and every later candidate are written with pcurves.  Else (the same
    faces or more lost: the coding lost them) they stay without, and the
    faces lost without pcurves are the ones blamed.  What ``meanwhile`` made
    of such a candidate is dropped.

    In the same way, the first candidate whose re-read loses faces (or
    splits one) is checked again written with ``widened`` (the largest
    tolerance the coding widened, :func:`widened_tolerance`) as its length
    uncertainty, OCCT's reader's healing precision.  If that loses fewer
    faces, this and every later candidate are written so."""
    spare = occ.spare_core()
    if floor is not None and floor.broken:
        floor = None  # the source's own round trip cannot be had: nothing to hold to
    with contextlib.ExitStack() as stack:
        back = None
        if floor is not None and spare:
            back = floor.trip(
                shape, stack, floor.product, pcurves=floor.pcurves, uncertainty=floor.uncertainty
            )
        bad_e, bad_f = occ.failures(shape)
        new_e, new_f = bad_e - old_e, bad_f - old_f
        if new_e or new_f:
            return new_e, new_f, None, None
        if floor is None:
            return new_e, new_f, None, meanwhile(True, None) if meanwhile is not None else None
        if back is None:
            back = floor.trip(
                shape, stack, floor.product, pcurves=floor.pcurves, uncertainty=floor.uncertainty
            )
        early = (
            meanwhile(floor.pcurves, floor.uncertainty) if meanwhile is not None and spare else None
        )
        losses = floor.candidate_losses(back, tol)
        if not floor.pcurves and floor.broken:
            floor.pcurves, early = True, None  # nothing to hold to: as OCCT writes
        elif not floor.pcurves and losses is not None and not floor.compared:
            floor.compared, early = True, None
            back = floor.trip(shape, stack, floor.product, uncertainty=floor.uncertainty)
            kept = floor.candidate_losses(back, tol)
            if kept is None or not losses <= kept:
                # without pcurves the reader makes another shape of it (OCCT's
                # own round trip of bug32596 written so gets 101 faces of 99)
                log.debug("STEP check: candidates are written with pcurves from now on")
                floor.pcurves, losses = True, kept
        if losses is not None and widened is not None and not floor.uncertainty_compared:
            floor.uncertainty_compared, early = True, None
            back = floor.trip(
                shape, stack, floor.product, pcurves=floor.pcurves, uncertainty=widened
            )
            kept = floor.candidate_losses(back, tol)
            log.debug(
                "STEP check: faces lost written with uncertainty %g: %s, with OCCT's default: %s",
                widened,
                kept,
                losses,
            )
            if kept is None or len(kept) < len(losses):
                log.debug("STEP check: candidates are written with uncertainty %g", widened)
                floor.uncertainty, losses = widened, kept
        return new_e, new_f, losses, early


def widened_tolerance(m: BRepModel, cand: BRepModel) -> float | None:
    """The largest vertex or edge tolerance of a candidate above the one the
    source model ``m`` gives the same vertex or edge (the coding widens
    tolerances to cover what it moves: ``assembly``), or None if none is.
    Tolerances the source had stay out: a source vertex of 8 mm (trj3) is
    no measure of the gaps the coding opened."""
    out = 0.0
    for a, b in ((m.vertex_tol, cand.vertex_tol), (m.edge_tol, cand.edge_tol)):
        if len(a) == len(b) and len(a):
            up = b > a
            if up.any():
                out = max(out, float(b[up].max()))
    return out or None


def vertex_neighbours(m: BRepModel, tol: float) -> list[set[int]]:
    """Per face, the faces that share a vertex with it, or have one within tol
    of one of its vertices (itself included).

    A STEP reader re-projecting the edges at a tiny edge (trj7: 23 nm long,
    between four faces) mends all four: two of them touch the others only
    through a vertex of their own.  Pairs of vertices within tol merge their
    faces in order (sorted pairs; a chain a-b, b-c gives a and c each other's
    faces only as far as the order carries them).
    """
    around = faces_around(m, ShapeType.VERTEX)
    for a, b in coincide.pairs_within(m.vertex_point, tol).tolist():  # pairs to merge, in order
        around[a] = around[b] = sorted({*around[a], *around[b]})
    out: list[set[int]] = [set() for _ in range(len(m.face_surface))]
    for fs in around:
        for f in fs:
            out[f].update(fs)
    return out


def step_keeps(source: dict[str, int], floor: dict[str, int], back: dict[str, int]) -> bool:
    """Whether a STEP re-read keeps at least what OCCT's own round trip keeps:
    each count lies between the source's and the floor's (both included).
    (As close to the source's on the other side is not kept: a blended part
    of 81 edges whose own round trip has 79 came back with 83.)"""
    return all(min(source[k], floor[k]) <= back[k] <= max(source[k], floor[k]) for k in source)


def step_losses(
    src: np.ndarray,
    floor: np.ndarray,
    back: np.ndarray,
    tol: float,
    faulty: set[int] = frozenset(),  # type: ignore[assignment]
    free: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
) -> set[int]:
    """Source faces that come back from a candidate's STEP round trip like
    neither the source face nor OCCT's own round trip of it (``floor``).

    Arguments are face signatures (:func:`occ.face_signatures`); a face is
    compared by its numbers of edges, shared edges and vertices (its outline
    may move by more than tol where a coded neighbour trims it).  Each source
    face's version in ``back`` and ``floor`` is the face at the same index when
    the reader kept the order (for nine faces in ten the centroid at the same
    index is within 3·tol of being the nearest), else the face with the
    nearest centroid.  A face of ``back`` that is no source face's version and
    is not like an extra face of the floor (a split piece, a new sliver), or
    that is in ``faulty`` (BRepCheck faults, indices of ``back``), blames its
    source face.  With ``free`` (per face of the source, the floor and
    ``back``: free edges, :func:`occ.free_edges_per_face`), a source face
    whose version in ``back`` has more free edges than it and than its
    version in the floor is lost too.  Every index returned is a source
    face's, in signature order (:meth:`_Floor.losses` maps it to the model's
    face).
    """
    if not len(src):
        return set()
    if not len(back):
        return set(range(len(src)))
    topo = slice(4, None)
    idx = np.arange(len(src))
    same_order = False
    # per face of back, the nearest source face (and how near)
    near, back_src = coincide.nearest(src[:, 1:4], back[:, 1:4])
    if len(back) == len(src):
        # in order where face i of back is (one of) the nearest to source face i
        here = np.sqrt(((back[:, 1:4] - src[:, 1:4]) ** 2).sum(-1))
        same_order = bool((here <= near + 3 * tol).mean() >= 0.9)
    in_back = idx if same_order else coincide.nearest(back[:, 1:4], src[:, 1:4])[1]
    ok = (back[in_back, topo] == src[:, topo]).all(-1)
    floor_extra = np.zeros((0, back.shape[1]))
    loose = free[2][in_back] > free[0] if free is not None else np.zeros(len(src), bool)
    if len(floor):
        if len(floor) == len(src) and same_order:  # the order holds there too
            in_floor = idx
        else:
            in_floor = coincide.nearest(floor[:, 1:4], src[:, 1:4])[1]
        ok |= (back[in_back, topo] == floor[in_floor, topo]).all(-1)
        floor_extra = floor[np.setdiff1d(np.arange(len(floor)), in_floor)]
        if free is not None:
            loose &= free[2][in_back] > free[1][in_floor]
    lost = {int(i) for i in np.flatnonzero(~ok | loose)}
    source_of = {int(j): i for i, j in enumerate(in_back.tolist())}

    def source_face(j: int) -> int:
        return source_of[j] if j in source_of else int(back_src[j])

    lost |= {source_face(j) for j in faulty if 0 <= j < len(back)}
    extra = np.setdiff1d(np.arange(len(back)), in_back)
    like = np.zeros(len(extra), bool)  # like an extra face of the floor
    if len(extra) and len(floor_extra):
        k = coincide.nearest(floor_extra[:, 1:4], back[extra, 1:4])[1]
        like = (floor_extra[k, topo] == back[extra, topo]).all(-1)
    lost |= {source_face(j) for j in extra[~like].tolist()}
    return lost
