"""What a reader refuses before it loops: the bounds of the tables it reads
(degrees, net sizes, coordinates, levels) and the checks of finite values,
tolerances, counts and B-spline records (docs/format.md §4)."""

from __future__ import annotations

import numpy as np

from ..errors import SectionError
from ..streams import BlockReader

# ---------------------------------------------------------------- reader limits
#
# The reader trusts nothing: every count is checked against the bytes that
# remain before anything is allocated from it, every index against its table,
# and every B-spline against OCCT's own rules, so that what reaches OCCT is
# something OCCT's constructors accept.

#: OCCT's largest B-spline degree (``Geom_BSplineSurface::MaxDegree``).
MAX_DEGREE = 25
#: Most poles one coded net may have.  A coded net's poles are not backed by
#: bytes (a boundary-coded n x m net holds O(n + m) integers), so its size is bounded here.
MAX_NET_POLES = 1 << 20
#: Most poles all coded nets of one table may have together.
MAX_CODED_POLES = 1 << 23
#: Largest magnitude of a decoded coordinate (OCCT's ``Precision::Infinite()``).
MAX_COORD = 2e100
#: Largest |level| of a net code's quantizer (steps tol·2^(level/4)).
MAX_LEVEL = 96


def finite(a: np.ndarray, where: str, bound: float = np.inf, at_most: bool = False) -> None:
    """Raise ``SectionError`` unless every value of ``a`` is finite and below
    ``bound`` in magnitude (``at_most``: or equal to it)."""
    with np.errstate(invalid="ignore"):
        if a.size and not (np.abs(a) <= bound if at_most else np.abs(a) < bound).all():
            raise SectionError(f"{where}: a value is not finite or out of range")


def _tolerances(a: np.ndarray, where: str) -> None:
    """Raise ``SectionError`` unless every tolerance is finite and not negative."""
    finite(a, where, MAX_COORD)
    if a.size and a.min() < 0:
        raise SectionError(f"{where}: a tolerance is negative")


def _counts(per: np.ndarray, r: BlockReader, where: str) -> int:
    """The exact total of per-row counts, each checked against the bytes that remain.

    Every counted value is read from an array of at least one byte per value, so
    a total above ``r.remaining`` cannot be right; it is refused before any
    array of that size is made.
    """
    if len(per) and (per.min() < 0 or per.max() > r.remaining):
        raise SectionError(f"{where}: a count is negative or larger than the section")
    total = sum(per.tolist())  # Python ints: no wrap-around
    if total > r.remaining:
        raise SectionError(f"{where}: counts add up to more than the section holds")
    return int(total)


def _check_bspline(
    where: str, n: int, degree: int, knots: np.ndarray, mults: np.ndarray, periodic: bool
) -> None:
    """OCCT's rules for a B-spline's knots (``BSplCLib::NbPoles``, ``CheckCurveData``).

    Raises
    ------
    SectionError
        The degree, multiplicities or knots do not make a B-spline of ``n`` poles.
    """
    if not 1 <= degree <= MAX_DEGREE:
        raise SectionError(f"{where}: degree {degree} is out of range")
    if len(knots) < 2 or len(mults) != len(knots):
        raise SectionError(f"{where}: too few knots")
    # Python lists: a record has a few knots, where numpy's cost per call dominates
    k, m = knots.tolist(), [int(x) for x in mults.tolist()]
    if not all(-MAX_COORD < x < MAX_COORD for x in k):  # NaN fails both
        raise SectionError(f"{where}: a value is not finite or out of range")
    if not all(b > a for a, b in zip(k, k[1:])):
        raise SectionError(f"{where}: knots do not increase")
    if min(m) < 1 or any(x > degree for x in m[1:-1]):
        raise SectionError(f"{where}: bad knot multiplicity")
    first, last = m[0], m[-1]
    if periodic:
        if first > degree or last > degree or first != last:
            raise SectionError(f"{where}: bad end multiplicities of a periodic B-spline")
        poles = sum(m) - last
    else:
        if first > degree + 1 or last > degree + 1:
            raise SectionError(f"{where}: bad end multiplicities")
        poles = sum(m) - degree - 1
    if poles != n:
        raise SectionError(f"{where}: knots make {poles} poles, the header says {n}")
