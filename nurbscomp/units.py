"""Lengths with unit suffixes, for ``--tol``: ``0.01``, ``10um``, ``0.0004in``."""

from __future__ import annotations

import math
import re

#: The default ``--tol``, in millimetres.
DEFAULT_TOL_MM = 0.01
#: The tolerances ``compress`` takes, in millimetres: from 1 nm, ten times
#: OCCT's ``Precision::Confusion`` below which STEP files hold no meaning (a
#: double's spacing there is near the quantizer's steps on ordinary parts),
#: to 1 km, far past any part (steps and vertex grids stay in range).
TOL_RANGE_MM = (1e-6, 1e6)

#: Length units the STEP and IGES writers know (and a container's META may
#: name), with their size in millimetres.
UNITS_MM = {
    "MM": 1.0,
    "CM": 10.0,
    "M": 1000.0,
    "KM": 1e6,
    "UM": 1e-3,
    "INCH": 25.4,
    "FT": 304.8,
    "MI": 1609344.0,
    "MIL": 0.0254,
    "UIN": 25.4e-6,
}

#: Suffix -> millimetres.  A bare number is in millimetres.
SUFFIX_MM = {
    "": 1.0,
    "mm": 1.0,
    "um": 1e-3,
    "µm": 1e-3,
    "micron": 1e-3,
    "nm": 1e-6,
    "cm": 10.0,
    "m": 1000.0,
    "km": 1e6,
    "in": 25.4,
    "inch": 25.4,
    '"': 25.4,
    "mil": 0.0254,
    "thou": 0.0254,
    "ft": 304.8,
}

_RE = re.compile(r"^\s*([0-9]*\.?[0-9]+(?:[eE][-+]?[0-9]+)?)\s*([a-zA-Zµ\"]*)\s*$")


def parse_length(text: str) -> float:
    """A positive length in millimetres.

    Raises
    ------
    ValueError
        With a message that lists the accepted suffixes.
    """
    m = _RE.match(text)
    unit = m.group(2).lower() if m else None
    if not m or unit not in SUFFIX_MM:
        units = ", ".join(k for k in SUFFIX_MM if k)
        raise ValueError(f"{text!r} is not a length (a number, optionally followed by {units})")
    value = float(m.group(1)) * SUFFIX_MM[unit]
    if not math.isfinite(value) or value <= 0:
        raise ValueError(f"{text!r} must be a positive length")
    return value


def check_tolerance(value: float) -> float:
    """``value`` (mm) if ``compress`` can code to it.

    Raises
    ------
    ValueError
        Outside ``TOL_RANGE_MM``, with the range in the message.
    """
    lo, hi = TOL_RANGE_MM
    if not lo <= value <= hi:
        raise ValueError(
            f"tolerance {value:g} mm is outside the range coded, {lo:g} to {hi:g} mm "
            "(--lossless keeps every number)"
        )
    return value
