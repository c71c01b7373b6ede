"""§2.2 LOCS, §2.3 geometry tables, §2.6 VERT, §2.7 EDGE, §2.8 FACE, §2.10 SIDE
of docs/format.md: bytes to tables, no geometry."""

from __future__ import annotations

import math
import struct
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from .container import Arrays, ReadError, Take

# ---------------------------------------------------------------- records


@dataclass(eq=False)
class Analytic:
    kind: int
    frame: np.ndarray
    params: np.ndarray
    # §2.3: a line through its edge's vertices (2.2), a circle through one (2.4),
    # a plane's origin at a vertex (2.7)
    through: int = 0


@dataclass(eq=False)
class Derived:
    kind: int
    basis: int
    frame: np.ndarray
    params: np.ndarray


@dataclass(eq=False)
class Spline:
    """A B-spline or Bezier surface (two knot vectors) or curve (one)."""

    kind: int
    dim: int
    shape: tuple[int, ...]  # (nu, nv) or (n,)
    degrees: list[int]
    knots: list[np.ndarray]
    mults: list[np.ndarray]
    periodic: list[bool]
    weights: np.ndarray | None
    coded: bool
    poles: np.ndarray | None = None
    bezier: bool = False

    @property
    def is_surface(self) -> bool:
        return len(self.shape) == 2


Record = Analytic | Derived | Spline

SURFACE_KINDS = set(range(11))
CURVE_KINDS = set(range(16, 25))
BEZIER = {9, 21}
BSPLINE = {10, 22}
DERIVED = {5, 6, 7, 8, 23, 24}
#: kind -> (frame rows, params) of §2.3's table (dim-dependent ones below)
ANALYTIC = {0: (4, 0), 1: (4, 1), 2: (4, 2), 3: (4, 1), 4: (4, 2),
            16: (2, 0), 17: (3, 1), 18: (3, 2), 19: (3, 2), 20: (3, 1)}  # fmt: skip
#: lengths written on the grid, per analytic kind (§2.3, analytic rows on a grid)
GRID_LENGTHS = {0: 0, 1: 1, 2: 1, 3: 1, 4: 2, 16: 0, 17: 1, 18: 2, 19: 2, 20: 1}


def derived_shape(kind: int, dim: int) -> tuple[int, int]:
    return {5: (2, 0), 6: (1, 0), 7: (0, 1), 8: (0, 4), 23: (0, 2), 24: (1 if dim == 3 else 0, 1)}[
        kind
    ]


# ---------------------------------------------------------------- LOCS


def read_locs(raw: bytes) -> tuple[np.ndarray, np.ndarray, list[tuple[list[int], list[int]]]]:
    a = Arrays(raw, "LOCS")
    forms = a.ints()
    datums = a.floats().reshape(-1, 3, 4)
    lengths = a.ints()
    datum = a.ints()
    power = a.ints()
    a.end()
    locs: list[tuple[list[int], list[int]]] = [([], [])]
    at = 0
    for n in lengths.tolist():
        locs.append((datum[at : at + n].tolist(), power[at : at + n].tolist()))
        at += n
    return forms, datums, locs


# ---------------------------------------------------------------- knots (2.0)


def _key(x: float) -> int:
    (i,) = struct.unpack("<q", struct.pack("<d", x))
    return i if i >= 0 else -1 - (i + 2**63)


def _unkey(k: int) -> float:
    if not -(2**63) <= k < 2**63:
        raise ReadError("knot key out of range")
    i = k if k >= 0 else -1 - k - 2**63
    return struct.unpack("<d", struct.pack("<q", i))[0]


def evenly_spaced(a: float, b: float, res: np.ndarray) -> np.ndarray:
    nk = len(res) + 2
    h = (b - a) / float(nk - 1)
    out = [a]
    for j in range(1, nk - 1):
        p = a + float(j) * h
        if not math.isfinite(p):
            raise ReadError("knot not finite")
        out.append(_unkey(_key(p) + int(res[j - 1])))
    out.append(b)
    return np.array(out, float)


# ---------------------------------------------------------------- geometry tables


def read_geometry(raw: bytes, tag: str, dim: int, revision: int) -> tuple[list[Record], list[bool]]:
    """The rows, and for each whether it is a copy (kind 255) of an earlier one."""
    a = Arrays(raw, tag)
    kinds = a.ints()
    copy = Take(a.ints(), f"{tag} copy")
    header = Take(a.ints(), f"{tag} header")
    basis = Take(a.ints(), f"{tag} basis")
    mults = Take(a.ints(), f"{tag} mults")
    kres = Take(a.ints() if revision >= 3 else np.zeros(0, np.int64), f"{tag} kres")
    has_grid = revision >= 3 and tag != "CRV2"
    grid = Take(a.ints() if has_grid else np.zeros(0, np.int64), f"{tag} grid")
    frames = Take(a.floats(), f"{tag} frames")
    params = Take(a.floats(), f"{tag} params")
    poles = Take(a.floats(), f"{tag} poles")
    wgrid = None  # §2.3 (2.12): weights as integers on a grid 2^-b, first value b
    if revision >= 15 and a.next_kind() == "int":
        ints = a.ints()
        if len(ints) == 0 or not 0 <= int(ints[0]) <= 1074:
            raise ReadError(f"{tag}: weight grid")
        wgrid = int(ints[0])
        weights = Take(ints[1:], f"{tag} weights")
    else:
        weights = Take(a.floats(), f"{tag} weights")
    knots = Take(a.floats(), f"{tag} knots")
    a.end()
    vectors: list[tuple[np.ndarray, np.ndarray]] = []  # knot vectors by number (2.0)
    rational: list[np.ndarray] = []  # weights of the rows with a wref, in order (2.0)
    rows: list[Record] = []
    copies: list[bool] = []

    def vector(nk: int, degree: int) -> tuple[np.ndarray, np.ndarray]:
        if revision < 3:
            out = (knots(nk).copy(), mults(nk).copy())
        else:
            f = header()
            unit = revision >= 15 and f in (8, 10, 12, 14) or revision >= 20 and f == 11
            if unit:  # §2.3 (2.12): ends 0 and 1
                f -= 8
            end = degree + 1 if revision >= 15 else 0  # end multiplicities stored less this
            if f == 3 and revision >= 20:  # §2.3 (2.17): an earlier vector mapped
                d, s = header(), header()
                if not 1 <= d <= len(vectors) or s not in (0, 1):
                    raise ReadError(f"{tag}: mapped knot vector {d}, {s}")
                lk, lm = vectors[len(vectors) - d]
                if len(lk) != nk:
                    raise ReadError(f"{tag}: mapped knot count")
                a, b = (0.0, 1.0) if unit else (float(x) for x in knots(2))
                n = len(lk)
                if s:
                    c = float(lk[-1]) + float(lk[0])
                    t = [c - float(lk[n - 1 - j]) for j in range(n)]
                else:
                    t = [float(x) for x in lk]
                h = (b - a) / (t[-1] - t[0])
                kv = np.array([a] + [a + (t[j] - t[0]) * h for j in range(1, n - 1)] + [b])
                mv = (lm[::-1] if s else lm).copy()
                out = (kv, mv)
            elif f == 1:
                d = header()
                if not 1 <= d <= len(vectors):
                    raise ReadError(f"{tag}: knot repeat {d}")
                out = vectors[len(vectors) - d]
                if len(out[0]) != nk:
                    raise ReadError(f"{tag}: repeated knot count")
            elif f in (0, 4, 2, 6):
                if f in (0, 4):
                    kv = np.r_[0.0, knots(nk - 2), 1.0] if unit else knots(nk).copy()
                else:
                    if nk < 3:
                        raise ReadError(f"{tag}: evenly spaced vector of {nk}")
                    ab = [0.0, 1.0] if unit else knots(2)
                    kv = evenly_spaced(float(ab[0]), float(ab[1]), kres(nk - 2))
                if f in (0, 2):
                    mv = mults(nk).copy()
                    mv[0] += end
                    mv[-1] += end
                else:
                    e = mults() + end
                    mv = np.ones(nk, np.int64)
                    mv[0] = mv[-1] = e
                out = (kv, mv)
            else:
                raise ReadError(f"{tag}: knot form {f}")
        vectors.append(out)
        return out

    def grid_weights(r: np.ndarray, b: int) -> np.ndarray:
        """§2.3 (2.12): a weight set's integers from its residuals, rows first."""
        k = np.zeros(r.shape, np.int64)
        one = 2**b if b <= 52 else 0
        for i in range(r.shape[0]):
            for j in range(r.shape[1]):
                if j == 0:
                    p = k[i - 1, 0] if i > 0 else one
                elif j == 1:
                    p = k[i, 0]
                else:
                    p = 2 * int(k[i, j - 1]) - int(k[i, j - 2])
                v = (int(p) + int(r[i, j]) + 2**63) % 2**64 - 2**63  # 64-bit, wrapping
                k[i, j] = v
        if (np.abs(k.astype(float)) >= 2.0**53).any():
            raise ReadError(f"{tag}: a weight on its grid out of range")
        return np.ldexp(k.astype(np.float64), -b)

    def weights_of(shape: tuple[int, int]) -> np.ndarray:
        count = shape[0] * shape[1]
        if revision < 3:
            return weights(count).copy()
        d = header()
        if d == 0 and wgrid is not None:
            w = grid_weights(weights(count).reshape(shape), wgrid).reshape(-1)
        elif d == 0:
            w = weights(count).copy()
        else:
            if not 1 <= d <= len(rational):
                raise ReadError(f"{tag}: wref {d}")
            w = rational[len(rational) - d]
            if len(w) != count:
                raise ReadError(f"{tag}: wref count")
        rational.append(w)
        return w

    for i, kind in enumerate(kinds.tolist()):
        if kind == 255:
            back = copy()
            if not 1 <= back <= i:
                raise ReadError(f"{tag}: copy {back} at row {i}")
            rows.append(rows[i - back])
            copies.append(True)
            continue
        copies.append(False)
        if kind == 176 and revision >= 5 and tag == "CRV3":  # §2.3 (2.2): frame from the vertices
            rows.append(Analytic(16, np.full((2, 3), np.nan), np.zeros(0), through=1))
            continue
        if 179 <= kind <= 183 and revision >= 10 and tag == "SURF":  # §2.3 (2.7): at a vertex
            frame = np.vstack([np.full((1, 3), np.nan), frames(9).reshape(3, 3)])
            if kind == 179:
                rows.append(Analytic(0, frame, np.zeros(0), 1))
                continue
            radius = params(1).copy()
            if not radius[0] > 0:
                raise ReadError(f"{tag}: a cylinder through a vertex with radius {radius[0]}")
            rows.append(Analytic(1, frame, radius, kind - 179))
            continue
        if kind in (177, 178) and revision >= 7 and tag == "CRV3":  # §2.3 (2.4): a face axis
            sense = 1 if kind == 177 else -1
            rows.append(Analytic(17, np.full((3, 3), np.nan), np.full(1, np.nan), through=sense))
            continue
        on_grid = kind >= 128
        if on_grid:
            kind -= 128
            if revision < 3 or tag == "CRV2" or kind not in ANALYTIC:
                raise ReadError(f"{tag}: unknown kind {kind + 128}")
        if (dim == 3 and tag == "SURF") != (kind in SURFACE_KINDS):
            raise ReadError(f"{tag}: kind {kind} in the wrong table")
        if kind in ANALYTIC:
            nrows, nparams = ANALYTIC[kind]
            if on_grid:
                g = grid()
                mask = grid()
                if not 1 <= g <= 127 or not 0 <= mask <= 7:
                    raise ReadError(f"{tag}: grid {g} mask {mask}")
                q = 2.0 ** (g - 64)
                coded = [float(grid()) * q if mask >> j & 1 else None for j in range(3)]
                lengths = [float(grid()) * q for _ in range(GRID_LENGTHS[kind])]
                origin = [c if c is not None else float(frames()) for c in coded]
                rest = frames((nrows - 1) * dim)
                frame = np.concatenate([np.array(origin), rest]).reshape(nrows, dim)
                par = np.concatenate([np.array(lengths), params(nparams - len(lengths))])
            else:
                frame = frames(nrows * dim).reshape(nrows, dim).copy()
                par = params(nparams).copy()
            rows.append(Analytic(kind, frame, par))
        elif kind in DERIVED:
            nrows, nparams = derived_shape(kind, dim)
            b = basis()
            b = b if kind in (5, 6) else i - b
            frame = frames(nrows * 3).reshape(nrows, 3).copy()
            rows.append(Derived(kind, b, frame, params(nparams).copy()))
        elif kind in (9, 10):  # surfaces
            nu, nv, flags = header(), header(), header()
            if kind == 10:
                udeg, vdeg, nku, nkv = header(), header(), header(), header()
                uk, um = vector(nku, udeg)
                vk, vm = vector(nkv, vdeg)
            else:
                udeg, vdeg = nu - 1, nv - 1
                uk, vk = np.array([0.0, 1.0]), np.array([0.0, 1.0])
                um, vm = np.array([nu, nu]), np.array([nv, nv])
            w = weights_of((nu, nv)).reshape(nu, nv) if flags & 1 else None
            coded = bool(flags & 8)
            p = None if coded else poles(nu * nv * 3).reshape(nu, nv, 3).copy()
            rows.append(
                Spline(
                    kind,
                    3,
                    (nu, nv),
                    [udeg, vdeg],
                    [uk, vk],
                    [um, vm],
                    [bool(flags & 2), bool(flags & 4)],
                    w,
                    coded,
                    p,
                    kind == 9,
                )  # fmt: skip
            )
        elif kind in (21, 22):
            n, flags = header(), header()
            if kind == 22:
                deg, nk = header(), header()
                kv, mv = vector(nk, deg)
            else:
                deg, kv, mv = n - 1, np.array([0.0, 1.0]), np.array([n, n])
            w = weights_of((1, n)) if flags & 1 else None
            coded = bool(flags & 4)
            p = None if coded else poles(n * dim).reshape(n, dim).copy()
            rows.append(
                Spline(
                    kind, dim, (n,), [deg], [kv], [mv], [bool(flags & 2)], w, coded, p, kind == 21
                )  # fmt: skip
            )
        else:
            raise ReadError(f"{tag}: unknown kind {kind}")
    for t in (copy, header, basis, mults, kres, grid, frames, params, poles, weights, knots):
        t.end()
    return rows, copies


# ---------------------------------------------------------------- tolerances (2.0)

_Q = (1.0, float.fromhex("0x1.306fe0a31b715p+0"), float.fromhex("0x1.6a09e667f3bcdp+0"),
      float.fromhex("0x1.ae89f995ad3adp+0"))  # fmt: skip


def tolerances(a: Arrays, n: int | None, revision: int) -> np.ndarray:
    if revision < 3:
        t = a.floats()
        if n is not None and len(t) != n:
            raise ReadError("tolerance count")
        return t.copy()
    codes = a.ints()
    rest = Take(a.floats(), "tolerance floats")
    out = np.zeros(len(codes))
    for i, c in enumerate(codes.tolist()):
        if abs(c) > 4000:
            raise ReadError("tolerance code")
        out[i] = math.ldexp(_Q[c % 4], c // 4) if c else rest()
    rest.end()
    if n is not None and len(out) != n:
        raise ReadError("tolerance count")
    return out


# ---------------------------------------------------------------- shapes


@dataclass
class Shapes:
    type: list[int]
    flags: list[int]
    children: list[list[tuple[int, int, int]]]  # (shape, orientation, location)
    root: tuple[int, int, int]
    rows: dict[int, list[int]] = field(default_factory=dict)  # type -> shapes owning rows
    row_of: dict[int, int] = field(default_factory=dict)  # shape -> its row in VERT/EDGE/FACE

    def __post_init__(self) -> None:
        for s, t in enumerate(self.type):
            if t in (4, 6, 7):
                lst = self.rows.setdefault(t, [])
                self.row_of[s] = len(lst)
                lst.append(s)

    def of(self, t: int) -> list[int]:
        return self.rows.get(t, [])


def shapes_from_arrays(a: Arrays) -> Shapes:
    types = a.ints().tolist()
    flags = a.ints().tolist()
    nchild = a.ints().tolist()
    back = a.ints().tolist()
    orient = a.ints().tolist()
    loc = a.ints().tolist()
    root = a.ints().tolist()
    a.end()
    children = []
    at = 0
    for s, n in enumerate(nchild):
        children.append([(s - back[at + k], orient[at + k], loc[at + k]) for k in range(n)])
        at += n
    return Shapes(types, flags, children, (root[0], root[1], root[2]))


# ---------------------------------------------------------------- VERT


@dataclass
class Vertices:
    point: np.ndarray
    tol: np.ndarray
    reps: np.ndarray  # (R, 5): vertex, kind, curve, surface, location
    params: np.ndarray  # (R, 2)


def quad_corners(shapes: Shapes) -> dict[int, list[tuple[int, int, int]]]:
    """§2.6 (2.6): per vertex row, (x, y, z) of each four-edge wire it is a corner of."""
    out: dict[int, list[tuple[int, int, int]]] = {}
    for w, t in enumerate(shapes.type):
        kids = [c for c, _, _ in shapes.children[w]]
        if t != 5 or len(kids) != 4 or any(shapes.type[c] != 6 for c in kids):
            continue
        ends = [
            {shapes.row_of[c] for c, _, _ in shapes.children[e] if shapes.type[c] == 7}
            for e in kids
        ]
        corners = []
        for i in range(4):
            both = ends[i] & ends[(i + 1) % 4]
            if len(ends[i]) != 2 or len(both) != 1:
                break
            corners += list(both)
        if len(corners) != 4 or len(set(corners)) != 4:
            continue
        for i in range(4):
            out.setdefault(corners[i], []).append(
                (corners[i - 1], corners[(i + 2) % 4], corners[(i + 1) % 4])
            )
    return out


def _walk(
    kind: np.ndarray,
    which: int,
    res: np.ndarray,
    nbr: dict[int, set[int]],
    quads: dict[int, list[tuple[int, int, int]]],
) -> np.ndarray:
    """§2.6: the integers of the vertices of kind ``which`` (1, or 3 from
    2.13) from their residuals, each predicted among those of its kind."""
    grid = np.zeros_like(res)
    last = np.zeros(3, np.int64)
    done: dict[int, np.ndarray] = {}
    k = 0
    for v in range(len(kind)):
        if kind[v] != which:
            continue
        before = [u for u in nbr.get(v, ()) if u in done]
        pred = done[max(before)] if before else last
        for x, y, z in quads.get(v, []):  # 2.6: a parallelogram first
            if x in done and y in done and z in done:
                pred = done[x] + done[z] - done[y]
                break
        q = pred + res[k]
        grid[k] = q
        done[v] = q
        last = q
        k += 1
    return grid


def read_vertices(raw: bytes, revision: int, shapes: Shapes, tol: float | None) -> Vertices:
    a = Arrays(raw, "VERT")
    kind = a.ints()
    nv = len(kind)
    pts = a.floats().reshape(-1, 3)
    if revision < 3:
        grid = np.stack([a.deltas(), a.deltas(), a.deltas()], axis=1)
    else:
        res = np.stack([a.ints(), a.ints(), a.ints()], axis=1)
        nbr: dict[int, set[int]] = {}
        for s, t in enumerate(shapes.type):
            if t != 6:
                continue
            vs = [shapes.row_of[c] for c, _, _ in shapes.children[s] if shapes.type[c] == 7]
            for x in vs:
                for y in vs:
                    if x != y:
                        nbr.setdefault(x, set()).add(y)
        quads = quad_corners(shapes) if revision >= 9 else {}
        grid = _walk(kind, 1, res, nbr, quads)
    n3 = int((kind == 3).sum()) if revision >= 16 else 0
    if n3:  # 2.13: exponent, then residuals predicted among the kind-3 vertices
        (e3,) = a.ints()
        if not -1074 <= e3 <= 0:
            raise ReadError("VERT: binary exponent")
        res3 = np.stack([a.ints(), a.ints(), a.ints()], axis=1)
        binary = _walk(kind, 3, res3, nbr, quads)
        if (np.abs(binary) >= 2**53).any():
            raise ReadError("VERT: binary integer")
    n2 = int((kind == 2).sum()) if revision >= 8 else 0
    deltas = False
    if n2:  # 2.5: back, exponent, offsets
        back, ex = a.ints(), a.ints()
        off = np.stack([a.ints(), a.ints(), a.ints()], axis=1)
        if len(back) != n2 or len(ex) != (2 if revision >= 21 else 1) or len(off) != n2:
            raise ReadError("VERT: twin arrays")
        if revision >= 21 and ex[1] not in (0, 1):
            raise ReadError("VERT: twin reference mode")
        deltas = revision >= 21 and ex[1] == 1  # 2.18: references as differences
    point = np.zeros((nv, 3))
    i0 = i1 = i2 = i3 = 0
    h = (tol / math.sqrt(3.0)) if tol else 0.0
    for v in range(nv):  # kinds 0, 1 and 3 first
        if kind[v] == 0:
            point[v] = pts[i0]
            i0 += 1
        elif kind[v] == 1:
            point[v] = grid[i1].astype(np.int64) * h
            i1 += 1
        elif kind[v] == 3 and n3:
            point[v] = [math.ldexp(float(x), int(e3)) for x in binary[i3]]
            i3 += 1
        elif not (kind[v] == 2 and revision >= 8):
            raise ReadError("VERT kind")
    r = 0
    for v in range(nv):  # then each vertex near an earlier one, in row order
        if kind[v] == 2:
            if deltas:
                if abs(int(back[i2])) >= 2**31:
                    raise ReadError("VERT: twin reference")
                r += int(back[i2])
            else:
                r = v - int(back[i2])
            if not 0 <= r < v:
                raise ReadError("VERT: twin reference")
            for c in range(3):
                point[v, c] = point[r, c] + math.ldexp(float(int(off[i2, c])), int(ex[0]))
            i2 += 1
    t = tolerances(a, nv, revision)
    nreps = a.ints()
    rk, rc, rs, rl = a.ints(), a.ints(), a.ints(), a.ints()
    par = a.floats().reshape(-1, 2)
    a.end()
    owner = np.repeat(np.arange(len(nreps)), nreps) if len(nreps) else np.zeros(0, np.int64)
    reps = np.stack([owner, rk, rc, rs, rl], axis=1) if len(rk) else np.zeros((0, 5), np.int64)
    return Vertices(point, t, reps, par.copy())


# ---------------------------------------------------------------- EDGE


@dataclass
class Edges:
    tol: np.ndarray
    flags: np.ndarray
    reps: np.ndarray  # (Q, 8): edge, kind, curve, curve2, surface, surface2, loc, loc2
    cont: np.ndarray
    range_kind: np.ndarray  # -1 for kind 3
    range: np.ndarray  # (Q, 2); kinds 1, 2, 4 filled by fill_ranges
    uv: np.ndarray  # (Q, 8)
    picks: tuple[list[int], list[int], list[int]] | None = None  # 2.0: surface, surface2, escaped
    settings: tuple[int, int, int] = (1, 1, 0)  # 2.11: bare kinds, regularity, 3-D curve last


def read_edges(
    raw: bytes,
    revision: int,
    predict: Callable[[int, int, int], list[list[int]]] | None = None,
    curves3d: list[Record] | None = None,
) -> Edges:
    """``predict`` (2.11): each edge's predicted representation kinds from the
    settings (bare, regular); ``curves3d``: the CRV3 rows, whose lines and
    circles predict range kind 4."""
    a = Arrays(raw, "EDGE")
    etol = tolerances(a, None, revision)
    flags = a.ints()
    settings = (1, 1, 0)
    if revision >= 14:  # (2.11) the settings, the edges off their prediction, then theirs
        assert predict is not None and curves3d is not None
        bare, regular, last = (int(x) for x in a.ints())
        if not (0 <= bare < 1 << 32 and regular in (0, 1) and last in (0, 1)):
            raise ReadError("EDGE: settings")
        settings = (bare, regular, last)
        predicted = predict(bare, regular, last)
        if len(predicted) != len(etol):
            raise ReadError("EDGE: edges against the shapes table")
        odd, counts = a.deltas(), a.ints()
        given = Take(a.ints(), "EDGE odd kinds")
        lists = [list(k) for k in predicted]
        if len(counts) != len(odd) or any(b <= x for x, b in zip(odd, odd[1:])):
            raise ReadError("EDGE: odd edges")
        for e, n in zip(odd.tolist(), counts.tolist()):
            lists[e] = [int(given()) for _ in range(n)]
        given.end()
        nreps = np.array([len(k) for k in lists], np.int64)
        kind = np.array([k for ks in lists for k in ks], np.int64)
    else:
        nreps = a.ints()
        kind = a.ints()
    q = len(kind)
    curve = Take(a.deltas(), "EDGE curve")
    pcurve = Take(a.deltas(), "EDGE pcurve")
    curve2 = Take(a.ints(), "EDGE curve2")
    picks = None
    if revision < 3:
        surf = Take(a.deltas(), "EDGE surface")
        surf2 = Take(a.deltas(), "EDGE surface2")
    else:
        p1, p2, esc = a.ints(), a.ints(), a.deltas()
        picks = (p1.tolist(), p2.tolist(), esc.tolist())
    loc = a.ints()
    loc2 = Take(a.ints(), "EDGE location2")
    cont = Take(a.ints(), "EDGE continuity")
    rkind = Take(a.ints(), "EDGE range kind")
    rng = Take(a.floats(), "EDGE range")
    uv = Take(a.floats(), "EDGE uv")
    uv2 = Take(a.floats(), "EDGE uv2")
    a.end()
    owner = np.repeat(np.arange(len(nreps)), nreps)
    reps = np.full((q, 8), -1, np.int64)
    reps[:, 7] = 0  # location2: 0 where it does not apply (kind 0-2), as the model has it
    out_cont = np.zeros(q, np.int64)
    out_rk = np.full(q, -1, np.int64)
    out_range = np.zeros((q, 2))
    out_uv = np.zeros((q, 8))
    for r, k in enumerate(kind.tolist()):
        reps[r, 0], reps[r, 1], reps[r, 6] = owner[r], k, loc[r]
        if k == 0:
            reps[r, 2] = curve()
        elif k in (1, 2):
            reps[r, 2] = pcurve()
            if k == 2:
                reps[r, 3] = curve2()
        if k in (1, 2, 3) and picks is None:
            reps[r, 4] = surf()
        if k == 3:
            if picks is None:
                reps[r, 5] = surf2()
            reps[r, 7] = loc2()
        if k in (2, 3):
            out_cont[r] = cont()
        if k in (0, 1, 2):
            out_rk[r] = rkind()
            if revision >= 14:  # (2.11) stored less its prediction, modulo 5
                if k == 0:
                    c = int(reps[r, 2])
                    g = curves3d[c] if curves3d is not None and 0 <= c < len(curves3d) else None
                    line = isinstance(g, Analytic) and g.kind in (16, 17)
                    guess = 0 if g is None else 4 if line else 1
                else:
                    guess = 3
                out_rk[r] = (out_rk[r] + guess) % 5
            if out_rk[r] == 0:
                out_range[r] = rng(2)
        if k in (1, 2) and (revision < 14 or out_rk[r] != 3):
            out_uv[r, :4] = uv(4)
            if k == 2:
                out_uv[r, 4:] = uv2(4)
    takes = [curve, pcurve, curve2, loc2, cont, rkind, rng, uv, uv2]
    if picks is None:
        takes += [surf, surf2]
    for t in takes:
        t.end()
    return Edges(etol, flags, reps, out_cont, out_rk, out_range, out_uv, picks, settings)


# ---------------------------------------------------------------- FACE


@dataclass
class Faces:
    surface: np.ndarray
    loc: np.ndarray
    tol: np.ndarray
    natural: np.ndarray


def read_faces(raw: bytes) -> Faces:
    a = Arrays(raw, "FACE")
    f = Faces(a.deltas(), a.ints(), a.floats().copy(), a.ints())
    a.end()
    return f


# ---------------------------------------------------------------- SIDE


def read_sides(raw: bytes) -> list[tuple[int, int, int, int, int]]:
    """Joins as (surface, side, leader, leader side, reversed)."""
    a = Arrays(raw, "SIDE")
    (n,) = a.ints().tolist()
    surf, side, back, lside, rev = a.deltas(), a.ints(), a.ints(), a.ints(), a.ints()
    a.end()
    if len(surf) != n:
        raise ReadError("SIDE count")
    return [
        (int(surf[k]), int(side[k]), int(surf[k] - back[k]), int(lside[k]), int(rev[k]))
        for k in range(n)
    ]
