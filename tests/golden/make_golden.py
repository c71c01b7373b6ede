"""Write the golden files: ``python -m tests.golden.make_golden``.

It writes only the golden files that are missing (a new minor version adds
its own); ``--every`` rewrites all of them, **only when the format's major
version changes**.  The golden files are
the promise that every 1.x reader decodes what 1.0 wrote: a test
(``tests/test_golden.py``) decodes them with the current code and compares
with what was stored here when they were made.  Regenerating them to make a
failing test pass breaks that promise.

Written here:

* ``<sample>.<mode>.nzc``: containers of the samples, lossless and at 0.01 mm;
* ``expected.json``: per container, the format version, topology counts, a
  SHA-256 of the decoded integer tables (:func:`int_digest`) and of the
  decoded floats (:func:`float_digest`, informative only);
* (format 1.2) ``product_digest``: a SHA-256 of the decoded product data
  (:func:`product_digest`), for the containers that hold some;
* ``<sample>.<mode>.npz``: the decoded floats (:func:`model_floats`), compared
  within 1e-12 (relative to max(1, |x|));
* ``errors/*.nzc`` and ``errors/expected.json``: damaged containers, each with
  the ``FormatError`` subclass and a fragment of the message it must raise
  (``None``: it must decode).
"""

from __future__ import annotations

import hashlib
import json
import struct
import zlib
from pathlib import Path
from typing import Any

import numpy as np

from nurbscomp import container, entropy, occ, passthrough, pipeline, product
from nurbscomp.model import BRepModel, BSplineCurve, BSplineSurface
from nurbscomp.streams import BlockReader, BlockWriter

HERE = Path(__file__).resolve().parent
SAMPLES = HERE.parent.parent / "samples"
#: (sample, mode name, compress options); a mode starting "faces." compresses
#: the sample written as an IGES surface model (faces mode: every face with
#: edges of its own), which has coincident boundaries.
GOLDEN = [
    ("loft.step", "lossless", {"lossless": True}),
    ("loft.step", "tol0.01", {"tol": 0.01}),
    ("teapot.step", "lossless", {"lossless": True}),
    ("teapot.step", "tol0.01", {"tol": 0.01}),
    ("bracket.step", "lossless", {"lossless": True}),  # edge ranges from vertices (kind 4)
    ("blob.step", "tol0.01", {"tol": 0.01}),  # bicubic Coons nets (methods 7, 8)
    # format 1.1
    ("teapot.step", "faces.tol0.01", {"tol": 0.01}),  # SIDE: joined net sides
    ("loft.step", "faces.tol0.01", {"tol": 0.01}),  # CNET method 9: a copied curve
    # format 1.2: PROD (assembly tree, names, colours, layers, header)
    ("assembly.step", "lossless", {"lossless": True}),
    ("assembly.step", "tol0.01", {"tol": 0.01}),
    # format 2.0: sections laid out anew (issue 28), byte-exact containers (issue 29)
    ("loft.step", "v2.tol0.01", {"tol": 0.01}),
    ("blob.step", "v2.tol0.1", {"tol": 0.1}),
    ("bracket.step", "v2.tol0.001", {"tol": 0.001}),
    ("teapot.step", "v2.faces.tol0.01", {"tol": 0.01}),
    ("assembly.step", "v2.tol0.01", {"tol": 0.01}),
    ("assembly.step", "v2.lossless", {"lossless": True}),
    ("loft.step", "v2.exact", {"exact": True}),
    # format 2.1: SNET/CNET in streams by kind, nets anchored at face vertices (issue 28)
    ("loft.step", "v2_1.tol0.01", {"tol": 0.01}),
    ("blob.step", "v2_1.tol0.1", {"tol": 0.1}),  # bicubic Coons nets, anchors
    ("teapot.step", "v2_1.faces.tol0.01", {"tol": 0.01}),  # ISO rows, copies, SIDE
    ("assembly.step", "v2_1.tol0.001", {"tol": 0.001}),
    # format 2.2: lines through their edges' vertices (CRV3 kind 176)
    ("bracket.step", "v2_2.tol0.01", {"tol": 0.01}),
    ("assembly.step", "v2_2.tol0.1", {"tol": 0.1}),
    # format 2.3: PROD's sub-shapes numbered by their place in their product's walk
    ("assembly.step", "v2_3.tol0.01", {"tol": 0.01}),
    ("assembly.step", "v2_3.lossless", {"lossless": True}),
    # format 2.4: circles through their edge's vertex about a face's axis (CRV3 177, 178)
    ("bracket.step", "v2_4.tol0.01", {"tol": 0.01}),
    ("assembly.step", "v2_4.tol0.1", {"tol": 0.1}),
    # format 2.5: vertices near an earlier vertex (VERT kind 2: a surface model's twins)
    ("teapot.step", "v2_5.faces.tol0.01", {"tol": 0.01}),
    ("teapot.step", "v2_5.faces.lossless", {"lossless": True}),
    # format 2.6: the compact directory and body header, META in binary
    ("bracket.step", "v2_6.tol0.01", {"tol": 0.01}),
    ("blob.step", "v2_6.tol0.1", {"tol": 0.1}),  # grid vertices at quad corners
    ("assembly.step", "v2_6.lossless", {"lossless": True}),
    ("loft.step", "v2_6.exact", {"exact": True}),
    # format 2.7: planes through a vertex of their face
    ("bracket.step", "v2_7.tol0.01", {"tol": 0.01}),
    ("assembly.step", "v2_7.tol0.1", {"tol": 0.1}),
    # format 2.8: degenerated edges' pcurves follow their projected neighbours
    ("bracket.step", "v2_8.tol0.01", {"tol": 0.01}),
    # format 2.9: pcurves projected a period beyond a trimmed surface's bounds moved back
    ("bracket.step", "v2_9.tol0.01", {"tol": 0.01}),
    # format 2.10: a curve coded between its anchors (CNET method 11)
    ("loft.step", "v2_10.tol0.01", {"tol": 0.01}),
    # format 2.11: EDGE's kinds, range kinds and surface picks by prediction
    ("bracket.step", "v2_11.tol0.01", {"tol": 0.01}),
    ("teapot.step", "v2_11.faces.tol0.1", {"tol": 0.1}),
    # format 2.12: unit knot vectors, end multiplicities less degree + 1, weight grids
    ("bracket.step", "v2_12.tol0.01", {"tol": 0.01}),
    ("loft.step", "v2_12.lossless", {"lossless": True}),
    # format 2.13: the short header, META's decimals, coder 7
    ("bracket.step", "v2_13.tol0.01", {"tol": 0.01}),
    ("teapot.step", "v2_13.faces.tol0.1", {"tol": 0.1}),
    ("loft.step", "v2_13.exact", {"exact": True}),
    # format 2.14: rows of arcs (SNET 12, 13), extrapolation on the abscissae (14-22)
    ("rings.step", "v2_14.tol0.01", {"tol": 0.01}),
    ("blob.step", "v2_14.tol0.01", {"tol": 0.01}),
    # format 2.15: pcurves left out projected face by face (a decoding rule, no layout)
    ("blob.step", "v2_15.tol0.01", {"tol": 0.01}),
    # format 2.16: wires shifted in the order their edges connect (a decoding rule)
    ("bracket.step", "v2_16.tol0.01", {"tol": 0.01}),
    # format 2.17: knot vectors mapped from an earlier one (a surface model's twin curves)
    ("crossed.step", "v2_17.faces.tol0.01", {"tol": 0.01}),
    # format 2.18: twin vertices' references as differences (a surface model's corners)
    ("bracket.step", "v2_18.faces.tol0.01", {"tol": 0.01}),
    # format 2.19: SHAP mode 2 (the walk less what the tables' properties imply)
    ("bracket.step", "v2_19.tol0.01", {"tol": 0.01}),
]


def _version(sample: str, mode: str) -> str:
    if mode.startswith("v2_19."):
        return "2.19"
    if mode.startswith("v2_18."):
        return "2.18"
    if mode.startswith("v2_17."):
        return "2.17"
    if mode.startswith("v2_16."):
        return "2.16"
    if mode.startswith("v2_15."):
        return "2.15"
    if mode.startswith("v2_14."):
        return "2.14"
    if mode.startswith("v2_13."):
        return "2.13"
    if mode.startswith("v2_12."):
        return "2.12"
    if mode.startswith("v2_11."):
        return "2.11"
    if mode.startswith("v2_10."):
        return "2.10"
    if mode.startswith("v2_9."):
        return "2.9"
    if mode.startswith("v2_8."):
        return "2.8"
    if mode.startswith("v2_7."):
        return "2.7"
    if mode.startswith("v2_6."):
        return "2.6"
    if mode.startswith("v2_5."):
        return "2.5"
    if mode.startswith("v2_4."):
        return "2.4"
    if mode.startswith("v2_3."):
        return "2.3"
    if mode.startswith("v2_2."):
        return "2.2"
    if mode.startswith("v2_1."):
        return "2.1"
    if mode.startswith("v2."):
        return "2.0"
    if sample.startswith("assembly."):
        return "1.2"
    return "1.1" if mode.startswith("faces.") else "1.0"


#: The format version each golden file was written in (the files of an older
#: version are never rewritten: ``main`` only adds missing ones).
VERSION = {f"{Path(s).stem}.{m}": _version(s, m) for s, m, _ in GOLDEN}


def golden_name(sample: str, mode: str) -> str:
    return f"{Path(sample).stem}.{mode}"


# ---------------------------------------------------------------- what is compared


def _records(m: BRepModel) -> list:
    return [*m.surfaces, *m.curves3d, *m.curves2d]


def int_arrays(m: BRepModel) -> dict[str, np.ndarray]:
    """Every integer of a decoded model: topology tables and the geometry's
    kinds, degrees, multiplicities and flags."""
    geo = []
    for g in _records(m):
        geo.append([int(g.kind)])
        if isinstance(g, BSplineSurface):
            geo.append([g.udegree, g.vdegree, *g.poles.shape, g.uperiodic, g.vperiodic])
            geo.append([*g.umults.tolist(), -1, *g.vmults.tolist(), g.weights is not None])
        elif isinstance(g, BSplineCurve):
            geo.append([g.degree, *g.poles.shape, g.periodic, *g.mults.tolist()])
            geo.append([g.weights is not None])
        elif hasattr(g, "basis"):
            geo.append([g.basis])
    out = {
        "geometry": np.array([x for row in geo for x in row], np.int64),
        "datum_forms": m.datum_forms,
        "locations": np.array([x for loc in m.locations for x in (*loc.datums, *loc.powers)]),
        "shape_type": m.shape_type,
        "shape_flags": m.shape_flags,
        "child_start": m.child_start,
        "child_shape": m.child_shape,
        "child_orient": m.child_orient,
        "child_loc": m.child_loc,
        "root": np.array([m.root_shape, m.root_orient, m.root_loc]),
        "vertex_reps": m.vertex_reps,
        "edge_flags": m.edge_flags,
        "edge_reps": m.edge_reps,
        "edge_rep_cont": m.edge_rep_cont,
        "face_surface": m.face_surface,
        "face_loc": m.face_loc,
        "face_natural": m.face_natural,
    }
    return {k: np.asarray(v).astype(np.int64) for k, v in out.items()}


def int_digest(m: BRepModel) -> str:
    """SHA-256 of :func:`int_arrays`, in a fixed order and byte layout."""
    h = hashlib.sha256()
    for k, a in sorted(int_arrays(m).items()):
        h.update(k.encode() + struct.pack("<Q", a.size) + a.astype("<i8").tobytes())
    return h.hexdigest()


def model_floats(m: BRepModel) -> dict[str, np.ndarray]:
    """Every float of a decoded model, one array per kind of value."""

    def cat(parts: list[np.ndarray]) -> np.ndarray:
        return np.concatenate([np.asarray(p, float).reshape(-1) for p in parts] or [np.zeros(0)])

    recs = _records(m)
    spl = [g for g in recs if isinstance(g, (BSplineSurface, BSplineCurve))]
    return {
        "poles": cat([g.poles for g in spl]),
        "weights": cat([g.weights for g in spl if g.weights is not None]),
        "knots": cat([k for g in spl for k in _knots(g)]),
        "frames": cat([g.frame for g in recs if hasattr(g, "frame")]),
        "params": cat([g.params for g in recs if hasattr(g, "params")]),
        "datums": m.datums.reshape(-1),
        "vertex_point": m.vertex_point.reshape(-1),
        "vertex_tol": m.vertex_tol,
        "vertex_rep_params": m.vertex_rep_params.reshape(-1),
        "edge_tol": m.edge_tol,
        "edge_rep_range": m.edge_rep_range.reshape(-1),
        "edge_rep_uv": m.edge_rep_uv.reshape(-1),
        "face_tol": m.face_tol,
    }


def _knots(g: BSplineSurface | BSplineCurve) -> list[np.ndarray]:
    return [g.uknots, g.vknots] if isinstance(g, BSplineSurface) else [g.knots]


def float_digest(m: BRepModel) -> str:
    h = hashlib.sha256()
    for k, a in sorted(model_floats(m).items()):
        h.update(k.encode() + a.astype("<f8").tobytes())
    return h.hexdigest()


def product_digest(m: BRepModel) -> str | None:
    """SHA-256 of the decoded product data written back as a PROD section
    (format 1.2), or None when the container holds none."""
    if m.product is None:
        return None
    return hashlib.sha256(product.write(m.product)).hexdigest()


def describe(data: bytes) -> dict:
    """What the test compares: version, counts, digests (the product data's
    only where there is some: older golden files have no such key)."""
    c = container.unpack(data)
    if c.flags & container.FLAG_EXACT:  # the file itself: its digest is the whole promise
        meta, text = passthrough.read(c)
        return {
            "format_version": f"{c.major}.{c.minor}",
            "mode": meta["mode"],
            "model": meta["model"],
            "sha256": hashlib.sha256(text).hexdigest(),
        }
    m, meta = pipeline.decode(c)
    out = {
        "format_version": f"{c.major}.{c.minor}",
        "mode": meta["mode"],
        "counts": m.counts(),
        "geometry": [len(m.surfaces), len(m.curves3d), len(m.curves2d)],
        "int_digest": int_digest(m),
        "float_digest": float_digest(m),
    }
    if m.product is not None:
        out["product_digest"] = product_digest(m)
        # faces as placed in the built shape (an assembly places a part's faces many times)
        out["placed_faces"] = occ.counts(pipeline.build(m))["faces"]
    return out


# ---------------------------------------------------------------- damaged files


def compact(data: bytes) -> bool:
    """Whether container bytes' header says format 2.6's directory and body header."""
    v = (data[4], data[5])
    return v in container.VERSIONS and container.revision(*v) >= container.COMPACT


def length_fields(data: bytes) -> list[tuple[int, int]] | None:
    """Format 2.6: the (start, end) offsets of each directory entry's varint
    length, None where the directory is cut (from 2.13, :func:`short_fields`)."""
    if short(data):
        fields = short_fields(data)
        return None if fields is None else fields[0]
    nsec = struct.unpack_from("<H", data, 8)[0]
    at, out = 16, []
    for _ in range(nsec):
        if at >= len(data):
            return None
        at += 5 if data[at] == container.TAG_ESCAPE else 1
        start = at
        while at < len(data) and data[at] & 0x80:
            at += 1
        at += 1
        out.append((start, at))
    return out if at <= len(data) else None


def body_at(data: bytes) -> int | None:
    """Where the body header of container bytes starts (their header's version
    says how the directory is laid out), None where the directory is cut."""
    if len(data) < 16:
        return None
    if not compact(data):
        return 16 + 12 * struct.unpack_from("<H", data, 8)[0]
    fields = length_fields(data)
    if fields is None:
        return None
    return fields[-1][1] if fields else 16


def short(data: bytes) -> bool:
    """Whether container bytes' header says format 2.13's short header."""
    v = (data[4], data[5]) if len(data) >= 6 else (0, 0)
    return v in container.VERSIONS and container.revision(*v) >= container.SHORT


def short_fields(data: bytes) -> tuple[list[tuple[int, int]], int] | None:
    """Format 2.13: the (start, end) offsets of each section's varint length
    and the offset of the coder byte, None where the directory is cut."""
    if len(data) < 7:
        return None
    at = 7
    if data[6] & container.FLAG_MASK:
        if len(data) < 9:
            return None
        n, at = bin(struct.unpack_from("<H", data, 7)[0] & 0x7FFF).count("1"), 9
    else:
        n = 0
        for shift in range(0, 63, 7):  # the count's varint
            if at >= len(data):
                return None
            n |= (data[at] & 0x7F) << shift
            at += 1
            if not data[at - 1] & 0x80:
                break
        for _ in range(n):
            if at >= len(data):
                return None
            at += 5 if data[at] == container.TAG_ESCAPE else 1
    out = []
    for _ in range(n):
        start = at
        while at < len(data) and data[at] & 0x80:
            at += 1
        at += 1
        out.append((start, at))
    return (out, at) if at <= len(data) else None


def fix_crcs(data: bytes) -> bytes:
    """Recompute the header and body CRCs of (possibly damaged) container bytes,
    where the layout allows it (not the CRCs of the decoded sections)."""
    b = bytearray(data)
    if short(data):
        fields = short_fields(data)
        if fields is None or fields[1] + 5 > len(b):
            return data
        at = fields[1]
        crc = zlib.crc32(bytes(b[at + 5 :]), zlib.crc32(bytes(b[: at + 1])))
        b[at + 1 : at + 5] = struct.pack("<I", crc)
        return bytes(b)
    if len(b) < 16:
        return data
    b[12:16] = struct.pack("<I", zlib.crc32(bytes(b[:12])))
    body = body_at(bytes(b))
    head = 5 if compact(bytes(b)) else 12
    if body is None or body + head + 4 > len(b):
        return bytes(b)
    crc = zlib.crc32(bytes(b[body : body + head]), zlib.crc32(bytes(b[16:body])))
    b[body + head : body + head + 4] = struct.pack(
        "<I", zlib.crc32(bytes(b[body + head + 4 :]), crc)
    )
    return bytes(b)


def pack_raw(
    sections: list[tuple[str, bytes]],
    flags: int,
    minor: int = container.MINOR,
    major: int = container.MAJOR,
) -> bytes:
    """``container.pack`` without its checks (duplicate tags allowed), any version."""
    body = b"".join(r for _, r in sections)
    stored = entropy._compress(entropy.Coder.STORED, body)
    return container.frame(sections, flags, (major, minor), 0, stored)


def _replace(secs: list[tuple[str, bytes]], tag: str, raw: bytes) -> list[tuple[str, bytes]]:
    return [(t, raw if t == tag else r) for t, r in secs]


def _arrays(raw: bytes, tag: str) -> list[tuple[str, np.ndarray]]:
    """A section's arrays as (kind, values), to edit one and write them back."""
    r, out = BlockReader(raw, tag), []
    while r.remaining:
        kind = raw[len(raw) - r.remaining]
        out.append(("f", r.floats()) if kind == 1 else ("i", r.ints()))
    return out


def _write_arrays(arrays: list[tuple[str, np.ndarray]]) -> bytes:
    w = BlockWriter()
    for kind, a in arrays:
        (w.floats if kind == "f" else w.ints)(a)
    return bytes(w)


def damaged(base: bytes) -> dict[str, tuple[bytes, str | None, str | None]]:
    """Damaged versions of ``base`` (a lossless container): name -> (bytes, error, fragment)."""
    c = container.unpack(base)
    secs = [(s.tag, s.raw) for s in c.sections]
    nsec = len(secs)
    body = 16 + 12 * nsec

    def edit(off: int, value: bytes, crc: bool = True) -> bytes:
        b = bytearray(base)
        b[off : off + len(value)] = value
        return fix_crcs(bytes(b)) if crc else bytes(b)

    out: dict[str, tuple[bytes, str | None, str | None]] = {
        "bad_magic": (b"ISO-10303-21;\n" + base[14:], "BadMagicError", "bad magic at offset 0"),
        "empty": (b"", "BadMagicError", "bad magic"),
        "truncated_header": (base[:10], "TruncatedError", "header truncated at offset 10"),
        "truncated_body": (base[:-7], "TruncatedError", "remain"),
        "header_crc": (edit(12, b"\0\0\0\0", crc=False), "ChecksumError", "offset 12"),
        "body_crc": (
            edit(len(base) - 3, bytes([base[-3] ^ 1]), crc=False),
            "ChecksumError",
            "body",
        ),
        "unknown_major": (edit(4, b"\x03"), "VersionError", "version 3.0 is not supported"),
        "reserved_flags": (edit(6, b"\x03\x00"), "ReservedBitsError", "offset 6"),
        "reserved_header": (edit(10, b"\x01\x00"), "ReservedBitsError", "offset 10"),
        "reserved_body": (edit(body + 2, b"\x01"), "ReservedBitsError", f"offset {body + 1}"),
        "trailing_bytes": (base + b"\0\0", "TrailingDataError", "2 unexpected bytes"),
        "bomb": (edit(body + 4, struct.pack("<I", 2**32 - 1)), "LimitError", "declares"),
        "bad_coder": (edit(body, b"\x09"), "CorruptError", "unknown coder id 9"),
        "section_crc": (edit(16 + 8, b"\0\0\0\0"), "ChecksumError", "section META checksum"),
        "bad_array_header": (
            container.pack(_replace(secs, "SHAP", b"\x07" + c.get("SHAP")[1:]), c.flags),
            "SectionError",
            "section SHAP: bad array header at offset 0",
        ),
        "missing_section": (
            container.pack([s for s in secs if s[0] != "EDGE"], c.flags),
            "CorruptError",
            "missing section EDGE",
        ),
        "out_of_order": (
            container.pack([secs[0], secs[2], secs[1], *secs[3:]], c.flags),
            "CorruptError",
            "out of order",
        ),
        "duplicate_section": (pack_raw([*secs, secs[1]], c.flags), "CorruptError", "appears twice"),
        "unknown_section": (
            pack_raw([*secs, ("ZZZZ", b"")], c.flags),
            "CorruptError",
            "unknown section",
        ),
        "newer_minor_extra_section": (
            pack_raw([*secs, ("ZZZZ", b"new")], c.flags, minor=9, major=1),
            None,
            None,
        ),
        "meta_not_json": (
            container.pack(_replace(secs, "META", b"{not json"), c.flags),
            "SectionError",
            "META section is not valid JSON",
        ),
        "meta_bad_unit": (
            container.pack(
                _replace(secs, "META", c.get("META").replace(b'"MM"', b'"XX"')), c.flags
            ),
            "SectionError",
            "unknown unit",
        ),
        "lossless_flag_mismatch": (container.pack(secs, 0), "CorruptError", "lossless flag"),
    }

    def edited(tag: str, index: int, edit: Any) -> bytes:
        """The container with array ``index`` of section ``tag`` changed by ``edit``."""
        arrays = _arrays(c.get(tag), tag)
        kind, values = arrays[index]
        values = values.copy()
        edit(values)
        arrays[index] = (kind, values)
        return container.pack(_replace(secs, tag, _write_arrays(arrays)), c.flags)

    def past_surfaces(a: np.ndarray) -> None:  # a face's surface index past the table
        a[-1] += 10**6

    def decreasing(a: np.ndarray) -> None:  # knots that do not increase
        if len(a) >= 2:
            a[1] = a[0] - 1.0

    def inflated(a: np.ndarray) -> None:  # a count far past the section's bytes
        a[0] = 2**40

    def no_frame(a: np.ndarray) -> None:  # a plane with an all-zero frame: OCCT refuses it
        a[:12] = 0.0

    out["dangling_reference"] = (
        edited("FACE", 0, past_surfaces),
        "BadReferenceError",
        "a face surface (entry",
    )
    out["bad_knots"] = (edited("SURF", -1, decreasing), "SectionError", "knots do not increase")
    out["inflated_count"] = (edited("SHAP", 2, inflated), "SectionError", "SHAP child counts")
    out["rebuild_fails"] = (
        edited("SURF", 5, no_frame),
        "RebuildError",
        "does not rebuild into a shape",
    )
    return out


def faces_iges(step: Path, dst: Path) -> Path:
    """``step`` written as an IGES surface model (faces mode) at ``dst``."""
    from OCP.IGESControl import IGESControl_Writer

    w = IGESControl_Writer("MM", 0)
    w.AddShape(occ.read_cad(step).shape)
    w.ComputeModel()
    if not w.Write(str(dst)):
        raise RuntimeError(f"cannot write {dst}")
    return dst


def main(every: bool = False) -> None:
    """Write the golden files that are missing (with ``every``, all of them:
    only when the major version changes), then the damaged files."""
    import tempfile

    path = HERE / "expected.json"
    expected = json.loads(path.read_text()) if path.exists() and not every else {}
    with tempfile.TemporaryDirectory() as tmp:
        for sample, mode, opts in GOLDEN:
            name = golden_name(sample, mode)
            dst = HERE / f"{name}.nzc"
            if name in expected and dst.exists():
                continue
            src = SAMPLES / sample
            if ".faces." in f".{mode}":
                src = faces_iges(src, Path(tmp) / f"{Path(sample).stem}.igs")
            pipeline.compress_file(src, dst, force=True, **opts)  # type: ignore[arg-type]
            data = dst.read_bytes()
            expected[name] = describe(data)
            if opts.get("exact"):
                continue  # no model: the file itself
            m, _ = pipeline.decode(container.unpack(data))
            np.savez_compressed(HERE / f"{name}.npz", **model_floats(m))
    path.write_text(json.dumps(expected, indent=1, sort_keys=True) + "\n")
    errors = HERE / "errors"
    if (errors / "expected.json").exists() and not every:
        return  # the damaged files are those of 1.0: kept as they are
    errors.mkdir(exist_ok=True)
    table = {}
    base = (HERE / f"{golden_name('loft.step', 'lossless')}.nzc").read_bytes()
    for name, (data, err, fragment) in sorted(damaged(base).items()):
        (errors / f"{name}.nzc").write_bytes(data)
        table[f"{name}.nzc"] = {"error": err, "message": fragment}
    (errors / "expected.json").write_text(json.dumps(table, indent=1, sort_keys=True) + "\n")


if __name__ == "__main__":
    import sys

    main(every="--every" in sys.argv[1:])
