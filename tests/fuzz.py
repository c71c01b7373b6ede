"""Mutations of valid containers, and the long fuzzing run of ``make fuzz``.

The mutations are shared with ``tests/test_fuzz.py``.  Two families:

* **raw**: the container's bytes are damaged as they are (truncation, bit
  flips, random bytes, inflated length fields, trailing or missing bytes);
  most are caught by a CRC, and some also have their CRCs recomputed so that
  the length checks behind them are reached;
* **sections**: the container is unpacked, its decoded sections are damaged
  (bytes, array headers, integers and floats inside the arrays, section
  order, duplicates, drops, renames, swaps between samples, META's JSON, the
  lossless flag, a newer minor version), and it is
  packed again with valid CRCs, so the section decoders
  (``decode.sections_to_model``) and the shape builder see it.

The property (:func:`check`): decoding, building (and in the long run,
writing STEP) either succeed or raise a ``FormatError`` subclass; anything
else is a failure, and so is a case that takes longer than the time limit.

Run ``python -m tests.fuzz --cases 10000`` (what ``make fuzz`` does): the cases
run in worker processes, so that a crash or a hang in OCCT is reported as a
failure of its case instead of ending the run.  The exit status is 1 when a
case failed.
"""

from __future__ import annotations

import argparse
import copy
import dataclasses
import json
import random
import resource
import signal
import struct
import sys
import tempfile
import traceback
from pathlib import Path
from typing import Any

import numpy as np
import zstandard

from nurbscomp import container, entropy, pipeline, serialize, writer
from nurbscomp.errors import FormatError, UndiagnosedError
from nurbscomp.model import (
    REBUILD,
    BRepModel,
    BSplineCurve,
    BSplineSurface,
    Geometry,
    Location,
    RepKind,
    ShapeType,
)
from nurbscomp.streams import varint

from .golden.make_golden import compact, fix_crcs, length_fields, pack_raw
from .supervisor import supervise

ROOT = Path(__file__).resolve().parent.parent
SAMPLES = ROOT / "samples"
GOLDEN = ROOT / "tests" / "golden"

#: (sample, options) the seed containers are made from.
SEEDS = [
    ("loft.step", {"lossless": True}),
    ("loft.step", {"tol": 0.01}),
    ("teapot.step", {"tol": 0.01}),
    ("bracket.step", {"lossless": True}),
    ("blob.step", {"tol": 0.01}),
]

_HEADER = 16
_ENTRY = 12
_ARRAY_HEAD = struct.Struct("<BBI")


def make_seeds(folder: Path) -> list[bytes]:
    """Compress the seed samples into ``folder``; return the containers' bytes."""
    out = []
    for name, opts in SEEDS:
        dst = folder / f"{name}.{'lossless' if opts.get('lossless') else 'tol'}.nzc"
        if not dst.exists():
            pipeline.compress_file(SAMPLES / name, dst, force=True, **opts)  # type: ignore[arg-type]
        out.append(dst.read_bytes())
    # format 1.1's parts (SIDE, copied curves): the golden surface models
    golden = Path(__file__).resolve().parent / "golden"
    out += [p.read_bytes() for p in sorted(golden.glob("*.faces.*.nzc"))]
    # format 1.2's PROD (assembly tree, names, colours, layers): the golden assemblies
    out += [p.read_bytes() for p in sorted(golden.glob("assembly.*.nzc"))]
    return out


# ---------------------------------------------------------------- raw mutations


def _length_fields(data: bytes) -> list[tuple[int, str]]:
    """Offsets and formats of every fixed-width length or count in the outer
    layout (from format 2.6 the lengths are varints: :func:`_varint_lengths`)."""
    fields = [(8, "<H")]  # nsections
    if compact(data):
        return fields
    nsec = struct.unpack_from("<H", data, 8)[0]
    for i in range(nsec):
        fields.append((_HEADER + i * _ENTRY + 4, "<I"))  # a section's raw length
    body = _HEADER + nsec * _ENTRY
    fields += [(body + 4, "<I"), (body + 8, "<I")]  # raw and stored length
    return [(o, f) for o, f in fields if o + struct.calcsize(f) <= len(data)]


def _varint_length(data: bytes, rng: random.Random) -> bytes:
    """``data`` (format 2.6) with one directory entry's varint length replaced
    by a large, small or random value (the file grows or shrinks with it)."""
    start, end = rng.choice(length_fields(data) or [(_HEADER, _HEADER)])
    value = rng.choice([2**62, 2**32, 2**28 + 1, rng.randrange(1 << 20), 0, 1])
    return data[:start] + varint(value) + data[end:]


def _big(rng: random.Random, fmt: str) -> int:
    top = (1 << (8 * struct.calcsize(fmt))) - 1
    return min(top, rng.choice([top, top // 2 + 1, rng.randrange(top + 1), 1 << 24, 0, 1]))


def mutate_raw(data: bytes, rng: random.Random) -> bytes:
    """One random damage to the container bytes as they are."""
    b = bytearray(data)
    kind = rng.randrange(8)
    if kind == 0:  # truncation
        return bytes(b[: rng.randrange(len(b))])
    if kind == 1:  # bit flips
        for _ in range(rng.randint(1, 4)):
            b[rng.randrange(len(b))] ^= 1 << rng.randrange(8)
        return bytes(b)
    if kind == 2:  # a run of random bytes
        at = rng.randrange(len(b))
        n = rng.randint(1, 16)
        b[at : at + n] = rng.randbytes(n)
        return bytes(b)
    if kind == 3:  # trailing bytes
        return bytes(b) + rng.randbytes(rng.randint(1, 8))
    if kind == 4:  # bytes cut out of the middle
        at = rng.randrange(len(b))
        del b[at : at + rng.randint(1, 8)]
        return bytes(b)
    if kind == 5:  # random bytes with the magic
        return container.MAGIC + rng.randbytes(rng.randint(0, 64))
    # an inflated (or shrunk) length field, CRCs kept (6) or recomputed (7)
    if compact(data) and rng.random() < 0.7:  # a directory's varint length (2.6)
        out = _varint_length(data, rng)
        return fix_crcs(out) if kind == 7 else out
    off, fmt = rng.choice(_length_fields(data))
    struct.pack_into(fmt, b, off, _big(rng, fmt))
    return fix_crcs(bytes(b)) if kind == 7 else bytes(b)


# ---------------------------------------------------------------- section mutations


def array_headers(raw: bytes) -> list[tuple[int, int, int, int]]:
    """(offset, kind, width, count) of the arrays of a section, as far as they parse."""
    out, pos = [], 0
    while pos + _ARRAY_HEAD.size <= len(raw):
        k, w, n = _ARRAY_HEAD.unpack_from(raw, pos)
        end = pos + _ARRAY_HEAD.size + w * n
        if k not in (0, 1) or w not in (1, 2, 4, 8) or end > len(raw):
            break
        out.append((pos, k, w, n))
        pos = end
    return out


_FLOATS = [float("nan"), float("inf"), -float("inf"), 0.0, -0.0, 1e308, -1e308, 5e-324, 1.0]


def _mutate_array(raw: bytes, rng: random.Random) -> bytes:
    """Damage one array of a section: its header's count, or one of its values."""
    heads = array_headers(raw)
    if not heads:
        return raw
    b = bytearray(raw)
    pos, k, w, n = rng.choice(heads)
    what = rng.randrange(4)
    if what == 0 or n == 0:  # the count: inflated, shrunk, or random
        struct.pack_into("<I", b, pos + 2, _big(rng, "<I") if rng.random() < 0.5 else n + 1)
        return bytes(b)
    if what == 1:  # the width
        b[pos + 1] = rng.choice([1, 2, 4, 8, 0, 3, 255])
        return bytes(b)
    i = rng.randrange(n)
    data_at = pos + _ARRAY_HEAD.size
    if k == 1:  # a float value
        struct.pack_into("<d", b, data_at + 8 * i, rng.choice(_FLOATS))
        return bytes(b)
    # an integer value: each byte plane of value i (planes are split)
    value = rng.choice(
        [0, 1, 2, 3, (1 << (8 * w)) - 1, (1 << (8 * w)) - 2, rng.randrange(1 << 8 * w)]
    )
    for plane in range(w):
        b[data_at + plane * n + i] = (value >> (8 * plane)) & 0xFF
    return bytes(b)


def _mutate_bytes(raw: bytes, rng: random.Random) -> bytes:
    b = bytearray(raw)
    kind = rng.randrange(5)
    if kind == 0 and b:
        for _ in range(rng.randint(1, 4)):
            b[rng.randrange(len(b))] ^= 1 << rng.randrange(8)
    elif kind == 1 and b:
        at = rng.randrange(len(b))
        n = rng.randint(1, 8)
        b[at : at + n] = rng.randbytes(n)
    elif kind == 2:
        return bytes(b[: rng.randrange(len(b) + 1)])
    elif kind == 3:
        at = rng.randrange(len(b) + 1)
        b[at:at] = rng.randbytes(rng.randint(1, 16))
    else:
        return rng.randbytes(rng.randint(0, 64))
    return bytes(b)


def _mutate_meta(raw: bytes, rng: random.Random) -> bytes:
    try:
        meta = serialize.parse_meta(raw)
    except FormatError:
        raise ValueError("META does not read") from None
    key = rng.choice([*meta, "unit", "tolerance_mm", "mode"])
    meta[key] = rng.choice(
        [None, 0, -1, 1e308, float("nan"), "x", "INCH", "lossless", "tolerance", [], {}, 1e-300]
    )
    # JSON, or (format 2.6) binary where every value has a binary form
    return serialize.write_meta(meta) if rng.random() < 0.5 else json.dumps(meta).encode()


def mutate_sections(data: bytes, rng: random.Random, others: list[bytes]) -> bytes:
    """Unpack, damage the decoded sections, pack again (every CRC valid)."""
    c = container.unpack(data)
    secs = [(s.tag, s.raw) for s in c.sections]
    dup = False
    for _ in range(rng.choice([1, 1, 1, 2, 3])):
        kind = rng.randrange(11)
        i = rng.randrange(len(secs))
        tag, raw = secs[i]
        if kind <= 3:
            secs[i] = (tag, _mutate_array(raw, rng))
        elif kind == 4:
            secs[i] = (tag, _mutate_bytes(raw, rng))
        elif kind == 5:  # another sample's section of the same tag
            other = container.unpack(rng.choice(others))
            if tag in other.tags():
                secs[i] = (tag, other.get(tag))
        elif kind == 6:
            rng.shuffle(secs)
        elif kind == 7 and len(secs) > 1:
            del secs[i]
        elif kind == 10:  # a section twice (``container.pack`` would refuse it)
            secs.insert(rng.randrange(len(secs) + 1), secs[i])
            dup = True
        elif kind == 8:  # a section under another (possibly unknown) tag
            secs[i] = (rng.choice(["ZZZZ", "\x00\x00\x00\x00", *(t for t, _ in secs)]), raw)
            if len({t for t, _ in secs}) != len(secs):
                secs[i] = (tag, raw)
        else:
            j = [t for t, _ in secs].index("META") if any(t == "META" for t, _ in secs) else i
            try:
                secs[j] = ("META", _mutate_meta(secs[j][1], rng))
            except ValueError:
                pass
    flags = c.flags if rng.random() < 0.9 else c.flags ^ container.FLAG_LOSSLESS
    if dup:
        out = pack_raw(secs, flags, c.minor, c.major)
    else:
        # one coder, mostly the fast ones: packing with all of them is slow
        usable = [
            k
            for k in entropy.Coder
            if container.CODER_SINCE.get(int(k), (0, 0)) <= (c.major, c.minor)
        ]
        coder = rng.choice([*[entropy.Coder.STORED] * 3, *usable])
        out = container.pack(secs, flags, (coder,), version=(c.major, c.minor))
    if c.major == 1 and rng.random() < 0.05:  # a 1.y past 1.2: read as 1.2
        b = bytearray(out)  # (a 2.y past the reader's is refused: tests/test_container.py)
        b[4], b[5] = 1, rng.randint(3, 255)
        out = fix_crcs(bytes(b))
    return out


def mutate(seeds: list[bytes], rng: random.Random) -> bytes:
    """One fuzz case: a seed container damaged raw, or through its sections."""
    data = rng.choice(seeds)
    if rng.random() < 0.35:
        return mutate_raw(data, rng)
    return mutate_sections(data, rng, seeds)


# ---------------------------------------------------------------- structure-aware cases
#
# Issue 11: a container *built* by someone hostile.  A seed is decoded into
# its model; the model is edited (shared and nested compounds, deep chains,
# extreme counts, huge nets, many located instances, extreme coordinates,
# weights and location matrices, cycles, META abuse) and packed again,
# lossless, with valid CRCs.  The verdict is the same as for the mutations:
# decode within the budget, or one FormatError.


def decoded(data: bytes) -> tuple[BRepModel, dict[str, Any]]:
    """The model and META of a valid container (no budget: seeds are trusted)."""
    return pipeline.decode(container.unpack(data), limits=None)


def pack_fast(sections: list[tuple[str, bytes]], flags: int) -> bytes:
    """A container coded with zstd at a fast level (a reader takes any level):
    as small as a writer's, in milliseconds even for a 24 MB net."""
    body = b"".join(r for _, r in sections)
    stored = zstandard.ZstdCompressor(level=3).compress(body)
    version = (container.MAJOR, container.MINOR)
    return container.frame(sections, flags, version, int(entropy.Coder.ZSTD), stored)


def pack_model(m: BRepModel, meta: dict[str, Any]) -> bytes:
    """``m`` as a lossless container (its decoded poles stored as floats)."""
    m.side_joins = np.zeros((0, 5), np.int64)
    meta = {**meta, "mode": "lossless", "tolerance_mm": None}
    return pack_fast(writer.model_to_sections(m, meta), container.FLAG_LOSSLESS)


def add_shapes(m: BRepModel, types: list[int], kids: list[list[tuple[int, int, int]]]) -> int:
    """Append shapes (each with its (child, orientation, location) references);
    return the index of the first.  Faces get a face row on surface 0."""
    first = len(m.shape_type)
    counts = [len(k) for k in kids]
    flat = [r for k in kids for r in k]
    m.shape_type = np.concatenate([m.shape_type, np.array(types, np.uint8)])
    m.shape_flags = np.concatenate([m.shape_flags, np.zeros(len(types), np.uint8)])
    ends = m.child_start[-1] + np.cumsum(counts, dtype=np.int64)
    m.child_start = np.concatenate([m.child_start, ends])
    arr = np.array(flat, np.int64).reshape(-1, 3)
    m.child_shape = np.concatenate([m.child_shape, arr[:, 0]])
    m.child_orient = np.concatenate([m.child_orient, arr[:, 1].astype(np.uint8)])
    m.child_loc = np.concatenate([m.child_loc, arr[:, 2]])
    nf = sum(t == ShapeType.FACE for t in types)
    if nf:
        m.face_surface = np.concatenate([m.face_surface, np.zeros(nf, np.int64)])
        m.face_loc = np.concatenate([m.face_loc, np.zeros(nf, np.int64)])
        m.face_tol = np.concatenate([m.face_tol, np.full(nf, 1e-7)])
        m.face_natural = np.concatenate([m.face_natural, np.zeros(nf, bool)])
    return first


def nest(m: BRepModel, depth: int, width: int = 1, kind: int = ShapeType.COMPOUND) -> None:
    """A chain of ``depth`` new shapes above the root, each holding the one
    below ``width`` times (2 and 40: 2^40 references once unfolded)."""
    below = (m.root_shape, m.root_orient, m.root_loc)
    first = len(m.shape_type)
    kids = [[below] * width] + [[(first + i, 0, 0)] * width for i in range(depth - 1)]
    add_shapes(m, [kind] * depth, kids)
    m.root_shape, m.root_orient, m.root_loc = first + depth - 1, 0, 0


def unreached_wires(m: BRepModel, depth: int, width: int = 2) -> None:
    """Wires nested ``width`` times per level under a new face that nothing
    reaches (``joins.face_vertices`` used to walk every path)."""
    wires = np.flatnonzero(m.shape_type == ShapeType.WIRE)
    if not len(wires):
        return
    first = len(m.shape_type)
    kids = [[(int(wires[0]), 0, 0)] * width]
    kids += [[(first + i, 0, 0)] * width for i in range(depth - 1)]
    add_shapes(m, [ShapeType.WIRE] * depth + [ShapeType.FACE], [*kids, [(first + depth - 1, 0, 0)]])


def add_datums(m: BRepModel, rows: np.ndarray, form: int) -> list[int]:
    """Append datums (n, 3, 4) of one ``gp_TrsfForm``, a location for each; their indices."""
    n0 = len(m.datums)
    m.datums = np.concatenate([m.datums.reshape(-1, 3, 4), rows])
    m.datum_forms = np.concatenate([m.datum_forms, np.full(len(rows), form, np.uint8)])
    first = len(m.locations)
    m.locations = [*m.locations, *(Location((n0 + i,), (1,)) for i in range(len(rows)))]
    return list(range(first, first + len(rows)))


def instances(m: BRepModel, n: int) -> None:
    """A compound of ``n`` translated copies of the root (IGES flattens them)."""
    rows = np.tile(np.hstack([np.eye(3), np.zeros((3, 1))]), (n, 1, 1))
    rows[:, :, 3] = np.arange(1, n + 1)[:, None] * np.array([10.0, 0.0, 0.0])
    locs = add_datums(m, rows, 2)  # gp_Translation
    r = add_shapes(m, [ShapeType.COMPOUND], [[(m.root_shape, m.root_orient, k) for k in locs]])
    m.root_shape, m.root_orient, m.root_loc = r, 0, 0


def odd_matrices(m: BRepModel, rng: random.Random) -> None:
    """Located references with singular, non-orthogonal, huge or tiny matrices."""
    choices = [
        np.zeros((3, 4)),  # singular
        np.array([[1.0, 0.5, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0]]),  # shear
        np.array([[2.0, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0]]),  # non-uniform scale
        np.array([[1e100, 0, 0, 1e100], [0, 1e100, 0, 0], [0, 0, 1e100, 0]]),
        np.array([[1e-300, 0, 0, 0], [0, 1e-300, 0, 0], [0, 0, 1e-300, 0]]),
        np.array([[0.0, 1, 0, 0], [1, 0, 0, 0], [0, 0, 1, 0]]),  # a mirror
    ]
    rows = np.array([rng.choice(choices) for _ in range(rng.randint(1, 3))])
    locs = add_datums(m, rows, rng.choice([6, 7, 8]))
    if rng.random() < 0.3:  # raised to a large power
        k = locs[0]
        m.locations[k] = Location(m.locations[k].datums, (rng.choice([2**31 - 1, -(2**20), 64]),))
    refs = np.flatnonzero(m.child_shape >= 0)
    for _ in range(rng.randint(1, 8)):
        m.child_loc[int(rng.choice(refs))] = rng.choice(locs)
    if rng.random() < 0.5:
        m.root_loc = rng.choice(locs)


def _bsplines(m: BRepModel) -> list[tuple[list[Geometry], int]]:
    return [
        (t, i)
        for t in (m.surfaces, m.curves3d, m.curves2d)
        for i, g in enumerate(t)
        if isinstance(g, (BSplineSurface, BSplineCurve))
    ]


def huge_net(m: BRepModel, nu: int, nv: int, degree: int) -> None:
    """Surface row 0 becomes a clamped nu x nv net of ``degree`` (a ramp of
    equal rows, so that it packs small, like a coded net)."""

    def knots(n: int) -> tuple[np.ndarray, np.ndarray]:
        k = n - degree + 1
        mults = np.ones(k, np.int64)
        mults[[0, -1]] = degree + 1
        return np.linspace(0.0, 1.0, k), mults

    (uk, um), (vk, vm) = knots(nu), knots(nv)
    poles = np.zeros((nu, nv, 3))
    poles[:, :, 0] = np.arange(nu)[:, None]  # rows of equal poles: packs to a few KB
    g = BSplineSurface(poles, None, uk, vk, um, vm, degree, degree, False, False, False)
    old = m.surfaces[0]
    m.surfaces = [g if x is old else x for x in m.surfaces]


def plane_net(m: BRepModel, nu: int, nv: int, degree: int) -> None:
    """:func:`huge_net`, its poles on a plane: an (i, j, 0) grid (small
    integers: packs to a few KB), a surface with area, which
    ``budget.check_projections`` lets through."""
    huge_net(m, nu, nv, degree)
    g = m.surfaces[0]
    assert isinstance(g, BSplineSurface)
    g.poles[:, :, 1] = np.arange(nv)[None, :]


def computed_pcurves(m: BRepModel, faces: int) -> None:
    """Every pcurve left for the decoder to compute, and ``faces`` more faces
    on the surface of face 0 (each computed pcurve on it is projected on each)."""
    reps = m.edge_reps
    on = (reps[:, 1] == RepKind.ON_SURFACE) | (reps[:, 1] == RepKind.ON_CLOSED_SURFACE)
    reps[on, 2] = REBUILD
    reps[reps[:, 1] == RepKind.ON_CLOSED_SURFACE, 3] = REBUILD
    m.edge_rep_range[on] = 0.0
    m.edge_rep_uv[on] = 0.0
    if len(m.face_surface):
        s, loc = int(m.face_surface[0]), int(m.face_loc[0])
        reps[on, 4], reps[on, 6] = s, loc
        first = add_shapes(m, [ShapeType.FACE] * faces, [[] for _ in range(faces)])
        del first
        m.face_surface[-faces:] = s
        m.face_loc[-faces:] = loc


def extreme_values(m: BRepModel, rng: random.Random) -> None:
    """Coordinates at ±1e100, weights at 1e-300 and 1e300."""
    rows = _bsplines(m)
    for _ in range(rng.randint(1, 4)):
        if not rows:
            break
        t, i = rng.choice(rows)
        g = t[i]
        assert isinstance(g, (BSplineSurface, BSplineCurve))
        what = rng.randrange(3)
        if what == 0:
            flat = g.poles.reshape(-1)
            idx = rng.sample(range(flat.size), min(flat.size, rng.randint(1, 6)))
            flat[idx] = [rng.choice([1e100, -1e100, 2e100 * 0.999]) for _ in idx]
        else:
            w = np.ones(g.poles.shape[:-1]) if g.weights is None else g.weights.copy()
            flat = w.reshape(-1)
            idx = rng.sample(range(flat.size), min(flat.size, rng.randint(1, 6)))
            flat[idx] = [rng.choice([1e-300, 1e300, 5e-324]) for _ in idx]
            t[i] = dataclasses.replace(g, weights=w)
    if rng.random() < 0.5 and len(m.vertex_point):
        m.vertex_point[rng.randrange(len(m.vertex_point))] = rng.choice([1e100, -1e100])


def cycle(m: BRepModel, rng: random.Random) -> None:
    """A reference to the shape itself or to one of its parents (the writer
    stores the difference; the reader must refuse it)."""
    parents = np.repeat(np.arange(len(m.shape_type)), np.diff(m.child_start))
    if not len(parents):
        return
    k = rng.randrange(len(parents))
    m.child_shape[k] = parents[k] + rng.choice([0, 0, 1, len(m.shape_type) - parents[k] - 1])


def meta_abuse(meta: dict[str, Any], rng: random.Random) -> bytes:
    key = rng.choice(["source_name", "writer", "source_bytes", "unit", "source_format", "extra"])
    meta = dict(meta)
    bad = [
        "a\r\x07b",
        "x\ud800",
        "\x1b[2J",
        "n" * rng.choice([1024, 1025, 60000]),
        10**400,
        -(10**19),
        2**53 + 1,
        1e308,
        [[[]]],
        {"a": "\x00"},
    ]
    meta[key] = rng.choice(bad)
    raw = json.dumps(meta, ensure_ascii=rng.random() < 0.5).encode("utf-8", "surrogatepass")
    if rng.random() < 0.3:  # binary (format 2.6), where every value has a binary form
        raw = serialize.write_meta(meta)
    elif rng.random() < 0.2:  # integers longer than Python's int() takes
        raw = raw[:-1] + b',"big":' + b"9" * rng.choice([21, 4301, 50000]) + b"}"
    return raw


#: The structure-aware edits, by name (``build_case`` picks one or two).
EDITS = (
    "shared_compounds",
    "deep_chain",
    "unreached_wires",
    "instances",
    "huge_net",
    "computed_pcurves",
    "extreme_values",
    "odd_matrices",
    "cycle",
    "meta",
)


def build_case(
    models: list[tuple[BRepModel, dict[str, Any]]],
    rng: random.Random,
    names: list[str] | None = None,
) -> tuple[str, bytes]:
    """One structure-aware case: (what was done, container bytes).  ``names``
    forces the edits (default: one or two of ``EDITS`` at random)."""
    base, meta = rng.choice(models)
    m = copy.deepcopy(base)
    names = names or rng.sample(EDITS, rng.choice([1, 1, 1, 2]))
    meta_raw = None
    for name in names:
        if name == "shared_compounds":
            nest(m, rng.choice([2, 10, 21, 40, 64]), rng.choice([2, 2, 3, 16]))
        elif name == "deep_chain":
            nest(m, rng.choice([999, 1001, 5000, 100_000]), 1, rng.choice([0, 0, 1, 3, 5]))
        elif name == "unreached_wires":
            unreached_wires(m, rng.choice([5, 40, 1000]), rng.choice([1, 2]))
        elif name == "instances":
            instances(m, rng.choice([2, 100, 1000, 10_000]))
        elif name == "huge_net":
            n = rng.choice([(30, 30), (200, 300), (1000, 1000), (1100, 1000)])
            huge_net(m, n[0], n[1], rng.choice([1, 3, 25]))
        elif name == "computed_pcurves":
            computed_pcurves(m, rng.choice([1, 10, 100, 2000]))
        elif name == "extreme_values":
            extreme_values(m, rng)
        elif name == "odd_matrices":
            odd_matrices(m, rng)
        elif name == "cycle":
            cycle(m, rng)
        else:
            meta_raw = meta_abuse(meta, rng)
    data = pack_model(m, meta)
    if meta_raw is not None:
        c = container.unpack(data)
        secs = [(s.tag, meta_raw if s.tag == "META" else s.raw) for s in c.sections]
        data = pack_fast(secs, c.flags)
    return "+".join(names), data


# ---------------------------------------------------------------- the property


class Hang(BaseException):
    """A case ran past its time limit (``BaseException``: no ``except Exception`` eats it)."""


def _alarm(signum: int, frame: object) -> None:
    raise Hang


def check(data: bytes, seconds: float = 20.0, write: bool = False, fmt: str = "STEP") -> str:
    """Decode and build ``data``: ``"ok"`` or the FormatError's class name.

    With ``write``, a shape that builds is also written to ``fmt`` (in a
    temporary folder), as ``nurbscomp decompress`` does, within the decoding
    budget of that format.

    Raises
    ------
    Hang
        The case took more than ``seconds`` of this process's CPU time (not
        wall time: a loaded machine does not make a case hang; checked
        between Python bytecodes: a hang inside one OCCT call is caught by
        the worker's timeout instead).
    MemoryError
        Python or OCCT ran out of memory (the worker's memory limit).
    Exception
        Anything but a ``FormatError``, or an ``UndiagnosedError`` (the
        decoder's last-resort wrapper): the property is broken.
    """
    old = signal.signal(signal.SIGPROF, _alarm)
    signal.setitimer(signal.ITIMER_PROF, seconds)
    try:
        m, meta = pipeline.decode(container.unpack(data), fmt=fmt if write else None)
        shape = pipeline.build(m)
        if write:
            suffix = {"STEP": ".step", "IGES": ".igs", "BREP": ".brep"}[fmt]
            with tempfile.TemporaryDirectory() as d:
                pipeline.write(shape, Path(d) / f"out{suffix}", fmt, m.unit, meta, m.product)
        return "ok"
    except UndiagnosedError:
        raise  # a FormatError, but one that no specific check caught: a failure
    except FormatError as e:
        if "OutOfMemory" in str(e) or "bad_alloc" in str(e):
            raise MemoryError(str(e)) from None  # OCCT's, turned into a RebuildError
        return type(e).__name__
    finally:
        signal.setitimer(signal.ITIMER_PROF, 0)
        signal.signal(signal.SIGPROF, old)


# ---------------------------------------------------------------- the long run

#: Seconds a structure-aware case may take in ``check`` (issue 11: 10 s).
STRUCTURE_SECONDS = 10.0


def _vm_bytes() -> int:
    """The process's virtual size (Linux), the base of its address-space limit."""
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmSize:"):
            return int(line.split()[1]) * 1024
    return 0


def _limit_memory(mb: int) -> int:
    """Allow the worker ``mb`` MiB of address space beyond what its imports
    hold (``resource.setrlimit``); return its peak RSS so far, in KiB."""
    if mb > 0:
        cap = _vm_bytes() + (mb << 20)
        resource.setrlimit(resource.RLIMIT_AS, (cap, cap))
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss


def _verdict(data: bytes, seconds: float, fmt: str, base_kb: int, mb: int) -> str:
    try:
        result = check(data, seconds, write=True, fmt=fmt)
    except Hang:
        return f"FAIL hang (over {seconds:g} s)"
    except MemoryError as e:
        return f"FAIL out of memory ({e})"
    except Exception as e:  # the property is broken: report, go on
        tb = traceback.format_exc().strip().splitlines()
        return f"FAIL {type(e).__name__}: {e} | {' / '.join(tb[-3:])}"
    grown = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - base_kb
    if mb > 0 and grown > mb * 1024:
        return f"FAIL memory: peak {grown >> 10} MiB above the imports"
    return result


def _worker(seed: int, first: int, count: int, folder: Path, mode: str, mb: int) -> None:
    """Run cases ``first`` … ``first + count - 1``; one line per case on stdout."""
    seeds = make_seeds(folder) if mode != "structure" else []
    models = [decoded(p.read_bytes()) for p in sorted(GOLDEN.glob("*.nzc"))]
    base_kb = _limit_memory(mb)
    for case in range(first, first + count):
        print(f"start {case}", flush=True)
        rng = random.Random(f"{seed}:{case}")
        name, fmt, seconds = "", "STEP", 20.0
        try:
            if mode == "structure":
                name, data = build_case(models, rng)
                fmt, seconds = rng.choice(["STEP", "STEP", "IGES", "BREP"]), STRUCTURE_SECONDS
            else:
                data = mutate(seeds, rng)
        except Exception as e:  # a bug of the fuzzer itself: reported, not hidden
            print(f"done {case} FAIL fuzzer {type(e).__name__}: {e}", flush=True)
            continue
        result = _verdict(data, seconds, fmt, base_kb, mb)
        print(f"done {case} {result}{f' [{name}, {fmt}]' if name else ''}", flush=True)


def run(
    cases: int,
    seed: int,
    jobs: int,
    timeout: float,
    chunk: int = 500,
    mode: str = "mutate",
    mb: int = 1024,
) -> int:
    """Fuzz ``cases`` cases in ``jobs`` worker processes; print a summary; 1 if any failed."""
    with tempfile.TemporaryDirectory() as d:
        folder = Path(d)
        if mode != "structure":
            make_seeds(folder)

        def command(first: int, n: int) -> list[str]:
            return [sys.executable, "-m", "tests.fuzz", "--worker"] + [
                str(x) for x in (seed, first, n, folder, mode, mb)
            ]

        return supervise(cases, jobs, timeout, chunk, command, f"fuzz ({mode})", seed)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--cases", type=int, default=10000)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--timeout", type=float, default=60.0, help="seconds per case")
    ap.add_argument(
        "--structure",
        action="store_true",
        help="structure-aware cases (decoded models edited and packed again) "
        "instead of mutated bytes",
    )
    ap.add_argument(
        "--memory-mb",
        type=int,
        default=1024,
        help="address space a worker may use beyond its imports (0: no limit)",
    )
    ap.add_argument("--worker", nargs=6, help=argparse.SUPPRESS)
    a = ap.parse_args()
    if a.worker:
        seed, first, count, folder, mode, mb = a.worker
        _worker(int(seed), int(first), int(count), Path(folder), mode, int(mb))
        return
    mode = "structure" if a.structure else "mutate"
    sys.exit(run(a.cases, a.seed, a.jobs, a.timeout, mode=mode, mb=a.memory_mb))


if __name__ == "__main__":
    main()
