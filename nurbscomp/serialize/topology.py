"""`LOCS` (datums and locations, §2.2) and `SHAP` (the shapes table, §2.5:
the 1.x arrays, or the 2.0 walk of ``topocode``)."""

from __future__ import annotations

import lzma
from typing import Any

import numpy as np

from .. import budget, container, topocode
from ..entropy import xz_size
from ..errors import BadReferenceError, LimitError, SectionError
from ..model import (
    BRepModel,
    Location,
)
from ..streams import BlockReader, BlockWriter
from .limits import MAX_COORD, _counts, finite

# ---------------------------------------------------------------- topology


def _write_locations(m: BRepModel) -> bytes:
    w = BlockWriter()
    w.ints(m.datum_forms)
    w.floats(m.datums.reshape(-1))
    locs = m.locations[1:]
    w.ints([len(loc.datums) for loc in locs])
    w.ints([d for loc in locs for d in loc.datums])
    w.ints([p for loc in locs for p in loc.powers])
    return bytes(w)


def _read_locations(data: bytes, m: BRepModel) -> None:
    r = BlockReader(data, "LOCS")
    forms = r.ints()
    if len(forms) and (forms.min() < 0 or forms.max() > _MAX_TRSF_FORM):
        raise SectionError("LOCS: unknown transformation form")
    m.datum_forms = forms.astype(np.uint8)
    nd = len(m.datum_forms)
    m.datums = r.floats(nd * 12).reshape(nd, 3, 4)
    finite(m.datums, "LOCS datums", MAX_COORD)
    lengths = r.ints()
    total = _counts(lengths, r, "LOCS lengths")
    datums, powers = r.ints(total), r.ints(total)
    r.done()
    if len(datums) and (datums.min() < 0 or datums.max() >= nd):
        raise BadReferenceError("LOCS: a location refers to a missing datum")
    if len(powers) and (np.abs(powers).max() > _MAX_POWER or (powers == 0).any()):
        raise SectionError("LOCS: a location power is zero or out of range")
    ends = np.cumsum(lengths)
    m.locations = [Location((), ())] + [
        Location(tuple(datums[e - n : e].tolist()), tuple(powers[e - n : e].tolist()))
        for n, e in zip(lengths.tolist(), ends.tolist())
    ]


#: Largest ``gp_TrsfForm`` value (``gp_Other``).
_MAX_TRSF_FORM = 8
#: Largest |power| of a location factor (OCCT stores it as a 32-bit integer).
_MAX_POWER = 2**31 - 1


#: The shapes table of the last SHAP written, and its bytes (:func:`_write_shapes`).
_last_shapes: tuple[tuple[Any, ...], bytes] | None = None


def _shapes_key(m: BRepModel) -> tuple[Any, ...]:
    """Everything SHAP is written from: the shapes table, by value."""
    arrays = (m.shape_type, m.shape_flags, m.child_start, m.child_shape, m.child_orient)
    return (
        *((a.dtype.str, a.shape, a.tobytes()) for a in map(np.asarray, (*arrays, m.child_loc))),
        int(m.root_shape),
        int(m.root_orient),
        int(m.root_loc),
    )


#: A B-rep-exact model of this many sub-shape references or more has its
#: SHAP written as arrays (:func:`_write_shapes`): its walk would take 50 ms
#: or more to decode.  On the corpus's B-rep-exact containers the arrays cost
#: about one byte more a reference (NIST_MBE_PMI_2: 7,531 references, 4,899
#: bytes, 189 ms of walk), but on a small analytic part a fifth of the file
#: (featuretype: 1,196 references, 908 bytes, +22 %, 19 ms).
ARRAYS_REFS = 2048


def _write_shapes(m: BRepModel, arrays: bool = False) -> bytes:
    """SHAP as format 2.0 lays it out (docs/format.md §2.5.1): a mode byte, then
    the walk's coded stream, or the 1.x arrays for a model the walk does not
    number as it is numbered or, under 512 coded bytes, whose arrays compress
    smaller.

    ``arrays``: the 1.x arrays (mode 0) whatever the walk would make, for a
    model of at least :data:`ARRAYS_REFS` sub-shape references: what a
    B-rep-exact container holds, whose decoding the walk's Python loop
    (some 20–35 µs a reference) would otherwise lead.

    The last table's bytes are kept: the validity stage's candidates of one
    source differ in their geometry, not in their shapes, and the walk's
    coder is a Python loop (a fifth of a second on NIST_MBE_PMI_2)."""
    global _last_shapes
    if arrays and len(m.child_shape) >= ARRAYS_REFS:
        return _arrays_section(m)
    key = _shapes_key(m)
    last = _last_shapes
    if last is not None and last[0] == key:
        return last[1]
    out = _write_shapes_now(m)
    _last_shapes = (key, out)
    return out


def _write_shapes_now(m: BRepModel) -> bytes:
    """:func:`_write_shapes`, without the kept table."""
    arrays = _arrays_section(m)
    if not topocode._model_fits(m):
        return arrays
    coded = walk_section(m, topocode.properties(m))
    if coded is None:
        return arrays
    # a tiny model whose adaptive contexts never warm up can be smaller in the
    # arrays, once compressed: the smaller of the two is written
    if len(coded) < 512 and _xz(arrays) < _xz(coded):
        return arrays
    return coded


def walk_section(m: BRepModel, implied: int | None = None) -> bytes | None:
    """``m``'s SHAP as the walk writes it: mode 2 with the properties
    ``implied``, or mode 1 (None: as formats 2.0 to 2.18 write it, which a
    2.19 reader reads too); None where the walk does not write ``m``."""
    coded = topocode.encode(m, implied)
    if coded is None:
        return None
    n, c = len(m.shape_type), len(m.child_shape)
    if implied is None:
        return topocode.HEAD.pack(topocode.MODE_WALK, n, c) + coded
    return topocode.HEAD2.pack(topocode.MODE_IMPLIED, implied, n, c) + coded


def _arrays_section(m: BRepModel) -> bytes:
    """``m``'s SHAP in mode 0: the mode byte, then the 1.x arrays."""
    return bytes([topocode.MODE_ARRAYS]) + _write_shape_arrays(m)


def _xz(raw: bytes) -> int:
    """Bytes of ``raw`` compressed alone (xz -9e)."""
    return xz_size(raw, 9 | lzma.PRESET_EXTREME)


def _write_shape_arrays(m: BRepModel) -> bytes:
    """SHAP as format 1.x lays it out (and 2.0 in mode 0)."""
    w = BlockWriter()
    w.ints(m.shape_type)
    w.ints(m.shape_flags)
    nkids = np.diff(m.child_start)
    w.ints(nkids)
    parent = np.repeat(np.arange(len(m.shape_type)), nkids)
    w.ints(parent - m.child_shape)
    w.ints(m.child_orient)
    w.ints(m.child_loc)
    w.ints([m.root_shape, m.root_orient, m.root_loc])
    return bytes(w)


def _read_shapes(
    data: bytes, m: BRepModel, revision: int = 0, limits: budget.Limits | None = None
) -> None:
    """Read SHAP as the file's ``revision`` lays it out (2.0: a mode byte, then
    the walk's coded stream or the 1.x arrays), checking every reference."""
    if revision < 3:
        _read_shape_arrays(data, m)
        return
    if not data:
        raise SectionError("SHAP: empty section")
    if data[0] == topocode.MODE_ARRAYS:
        _read_shape_arrays(data[1:], m)
        return
    implied = None
    head = topocode.HEAD
    if data[0] == topocode.MODE_IMPLIED and revision >= container.SHAP_IMPLIED:
        head = topocode.HEAD2
        if len(data) < head.size:
            raise SectionError("SHAP: truncated header at offset 0")
        _, implied, n, c = head.unpack_from(data)
        if implied & ~topocode.IMPLIED_ALL or (
            implied & topocode.ENDS_FR and not implied & topocode.TWO_ENDS
        ):
            raise SectionError(f"SHAP: unknown properties {implied:#04x} at offset 1")
    elif data[0] != topocode.MODE_WALK or len(data) < head.size:
        raise SectionError("SHAP: unknown mode or truncated header at offset 0")
    else:
        _, n, c = head.unpack_from(data)
    top = topocode.MAX_ROWS if limits is None else min(topocode.MAX_ROWS, limits.rows)
    if n + c > top:
        raise LimitError(f"SHAP declares {n + c:,} shapes and references, more than {top:,}")
    if n == 0:
        raise BadReferenceError("SHAP: bad root reference")
    depth = None if limits is None else limits.depth
    t = topocode.decode(data[head.size :], n, c, depth, implied)
    m.shape_type = np.array(t["types"], np.uint8)
    m.shape_flags = np.array(t["flags"], np.uint8)
    m.child_start = np.array(t["start"], np.int64)
    m.child_shape = np.array(t["shape"], np.int64)
    m.child_orient = np.array(t["orient"], np.uint8)
    m.child_loc = np.array(t["loc"], np.int64)
    m.root_shape, m.root_orient, m.root_loc = n - 1, t["root_orient"], t["root_loc"]


def _read_shape_arrays(data: bytes, m: BRepModel) -> None:
    r = BlockReader(data, "SHAP")
    types = r.ints()
    if len(types) and (types.min() < 0 or types.max() > 7):
        raise SectionError("SHAP: unknown shape type")
    m.shape_type = types.astype(np.uint8)
    n = len(m.shape_type)
    flags = r.ints(n)
    if n and (flags.min() < 0 or flags.max() > 255):
        raise SectionError("SHAP: unknown shape flags")
    m.shape_flags = flags.astype(np.uint8)
    nkids = r.ints(n)
    c = _counts(nkids, r, "SHAP child counts")
    back = r.ints(c)
    orient = r.ints(c)
    m.child_loc = r.ints(c)
    m.root_shape, m.root_orient, m.root_loc = r.ints(3).tolist()
    r.done()
    m.child_start = np.concatenate([[0], np.cumsum(nkids)]).astype(np.int64)
    parent = np.repeat(np.arange(n), nkids)
    if c and ((back < 1).any() or (back > parent).any()):
        raise BadReferenceError(
            "SHAP: a shape refers to itself or to a later shape (a cycle, or out of order)"
        )
    if c and (orient.min() < 0 or orient.max() > 3):
        raise SectionError("SHAP: unknown orientation")
    m.child_shape = parent - back
    m.child_orient = orient.astype(np.uint8)
    if not 0 <= m.root_shape < n or not 0 <= m.root_orient <= 3:
        raise BadReferenceError("SHAP: bad root reference")


#: Format 2.0: the mantissas of 2^(c/4), c mod 4 = 0..3 (:func:`quarter_power`).
