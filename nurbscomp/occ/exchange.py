"""What the plain and the XDE (``xcaf``) readers and writers share: the check
that a file can be read, and the fixed dates and ids that make the same shape
give the same bytes."""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

from OCP.Interface import Interface_Static
from OCP.StepBasic import StepBasic_CalendarDate, StepBasic_LocalTime
from OCP.StepRepr import StepRepr_NextAssemblyUsageOccurrence
from OCP.TCollection import TCollection_HAsciiString

from ..errors import InputError, OutputError, RebuildError

#: The STEP header's time stamp: fixed, so that the same shape gives the same bytes.
STEP_TIME_STAMP = "1970-01-01T00:00:00"
#: The IGES global section's dates, for the same reason.
IGES_DATE = "19700101.000000"


@contextlib.contextmanager
def static(name: str, value: str) -> Iterator[None]:
    """Set one of OCCT's ``Interface_Static`` parameters for the duration.

    Set it once the reader or writer that reads it exists: a data exchange
    controller's first set-up (in the first reader's or writer's constructor of
    a process) resets them to their defaults."""
    old = Interface_Static.CVal_s(name)
    Interface_Static.SetCVal_s(name, value)
    try:
        yield
    finally:
        Interface_Static.SetCVal_s(name, old)


@contextlib.contextmanager
def precision(uncertainty: float | None) -> Iterator[None]:
    """The length uncertainty a STEP or IGES writer writes (a STEP file's
    ``UNCERTAINTY_MEASURE_WITH_UNIT``, an IGES file's resolution), set once
    the writer exists (docs/format.md §3.1, META's ``uncertainty``).

    None leaves OCCT's default, the average tolerance of the shape's
    sub-shapes (``write.precision.mode`` 0); a number (mm) is written as it
    is (mode 2, ``write.precision.val``), converted to the file's unit.  A
    reader takes that value as the precision it heals the shape to: a decoded
    shape whose widened tolerances reach past their average can come back
    with edges the reader split or added."""
    if uncertainty is None:
        yield
        return
    value = repr(float(uncertainty))  # a numpy float's repr is not a number
    with static("write.precision.mode", "2"), static("write.precision.val", value):
        yield


def write_iges(
    w: Any, transfer: Callable[[], bool], path: Path, uncertainty: float | None, what: str
) -> None:
    """What the plain and the XDE IGES writers ``w`` share: ``transfer()``
    (the shape or the document into ``w``; false: ``what`` is refused), the
    model computed, its dates fixed (:func:`fix_iges_dates`) and the file
    written, all with ``uncertainty`` (:func:`precision`).

    Raises
    ------
    RebuildError
        The writer refuses ``what``.
    OutputError
        The file cannot be written.
    """
    with precision(uncertainty):
        if not transfer():
            raise RebuildError(f"the IGES writer refused the {what}")
        w.ComputeModel()
        fix_iges_dates(w.Model())
        if not w.Write(str(path)):
            raise OutputError("cannot write IGES")


@contextlib.contextmanager
def step_settings(pcurves: bool, uncertainty: float | None) -> Iterator[None]:
    """The STEP writer's settings that a container's META chooses, set once
    the writer exists: pcurves or not (``write.surfacecurve.mode``), and the
    file's length uncertainty (:func:`precision`)."""
    with static("write.surfacecurve.mode", SURFACE_CURVES[pcurves]), precision(uncertainty):
        yield


#: ``write.surfacecurve.mode``'s values: pcurves written or not (the latter:
#: each edge's 3-D curve alone, as a STEP file that held no pcurve had it).
SURFACE_CURVES = {True: "1", False: "0"}


def check_readable(path: Path) -> bytes:
    """The first 64 KiB of ``path``; an ``InputError`` if it is missing, a
    folder, unreadable or empty."""
    if not path.exists():
        raise InputError("no such file")
    if path.is_dir():
        raise InputError("is a directory")
    try:
        with open(path, "rb") as fh:
            head = fh.read(1 << 16)
    except OSError as e:
        raise InputError(e.strerror or str(e)) from None
    if not head.strip():
        raise InputError("file is empty")
    return head


def fix_iges_dates(model: Any) -> None:
    """Set an IGES model's dates to the fixed ``IGES_DATE``, like STEP's time stamp."""
    gs = model.GlobalSection()
    gs.SetDate(TCollection_HAsciiString(IGES_DATE))
    gs.SetLastChangeDate(TCollection_HAsciiString(IGES_DATE))
    model.SetGlobalSection(gs)


@contextlib.contextmanager
def settled(model: Any) -> Iterator[None]:
    """A STEP model settled (:func:`settle_model`) while the block writes it,
    its dates and times put back after."""
    restore = settle_model(model)
    try:
        yield
    finally:
        restore()


def settle_model(model: Any) -> Callable[[], None]:
    """Make a STEP model's bytes depend on nothing but the shape: number its
    assembly occurrences 1, 2 … in entity order (OCCT's own ids count what
    was written before in the same process), and date its dates and times
    ``STEP_TIME_STAMP`` (OCCT's AP203 writer dates its approvals and
    security classification with the wall clock).

    Returns what puts the dates and times back: OCCT's AP203 writer shares
    its date and time entities between all the files a process writes, so
    call it once the file is written (:func:`settled` does), or every AP203
    file the process writes afterwards, by OCCT or by its user, is dated 1970
    too."""
    occurrences = 0
    year, month, day = (int(x) for x in STEP_TIME_STAMP[:10].split("-"))
    undo: list[Callable[[], None]] = []
    for i in range(1, model.NbEntities() + 1):
        e = model.Value(i)
        if isinstance(e, StepRepr_NextAssemblyUsageOccurrence):
            occurrences += 1
            e.SetId(TCollection_HAsciiString(str(occurrences)))
        elif isinstance(e, StepBasic_CalendarDate):
            undo.append(_date_undo(e))
            e.SetYearComponent(year)
            e.SetMonthComponent(month)
            e.SetDayComponent(day)
        elif isinstance(e, StepBasic_LocalTime):
            undo.append(_time_undo(e))
            e.SetHourComponent(0)
            if e.HasMinuteComponent():
                e.SetMinuteComponent(0)
            if e.HasSecondComponent():
                e.SetSecondComponent(0.0)

    def restore() -> None:
        for f in reversed(undo):
            f()

    return restore


def _date_undo(e: Any) -> Callable[[], None]:
    """What sets a calendar date back to its values of now."""
    y, m, d = e.YearComponent(), e.MonthComponent(), e.DayComponent()

    def back() -> None:
        e.SetYearComponent(y)
        e.SetMonthComponent(m)
        e.SetDayComponent(d)

    return back


def _time_undo(e: Any) -> Callable[[], None]:
    """What sets a local time back to its values of now."""
    h = e.HourComponent()
    mi = e.MinuteComponent() if e.HasMinuteComponent() else None
    s = e.SecondComponent() if e.HasSecondComponent() else None

    def back() -> None:
        e.SetHourComponent(h)
        if mi is not None:
            e.SetMinuteComponent(mi)
        if s is not None:
            e.SetSecondComponent(s)

    return back
