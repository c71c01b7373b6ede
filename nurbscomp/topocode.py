"""The topology (``SHAP``, format 2.0) coded by prediction.

docs/format.md §2.5 specifies the layout; this module is its reference.  The
shapes table is walked from the root depth first, each sub-shape reference in
its parent's order: a reference to a shape not met before (a *new* one) walks
that shape, which is numbered when its walk ends (post-order, the model's own
numbering), and a reference to a shape met before (a *shared* one) is coded
as a rank among predicted candidates (the vertex where the wire's last edge
ended, the still-open edges at that vertex, the wire's first vertex) and the
shapes of its type referenced most recently, or, past them, as a distance back
among the shapes of its type.  Every decision is one or more binary symbols
coded by an adaptive binary range coder (the one LZMA uses: 11-bit
probabilities, adaptation shift 5) with a probability per context.

A model that this walk does not number as it is numbered (shapes that the
root does not reach, or that a depth-first walk would number otherwise) is
written in the 1.x layout behind a mode byte: every model is written, none is
renumbered.

Nothing here imports OCP: the format layer works on the model's arrays.
"""

from __future__ import annotations

import struct
from typing import Any

from . import budget
from .errors import BadReferenceError, SectionError

#: Mode byte of a 2.0 SHAP section.
MODE_ARRAYS, MODE_WALK = 0, 1
#: Shapes of one type kept in its recency window.
WINDOW = 64
#: Edges per vertex kept for the open-edge candidates.
INCIDENT = 16
#: Most shapes plus references a section may declare whatever the limits.
MAX_ROWS = 1 << 28
#: Largest integer the uint code carries (bit length of v + 1 at most 40).
_MAX_BITS = 40

#: Mode-1 header: mode, shapes, references.
HEAD = struct.Struct("<BII")
_EDGE, _WIRE, _VERTEX = 6, 5, 7
_F, _R = 0, 1

_TOP = 1 << 24
_PROB_BITS = 11
_ONE = 1 << _PROB_BITS
_MOVE = 5


class _Encoder:
    """LZMA's binary range encoder (carry propagated through a cache byte)."""

    def __init__(self) -> None:
        self.low, self.range, self.cache, self.cache_size = 0, 0xFFFFFFFF, 0, 1
        self.out = bytearray()

    def _shift_low(self) -> None:
        if self.low < 0xFF000000 or self.low >= 1 << 32:
            carry = self.low >> 32
            temp = self.cache
            while True:
                self.out.append((temp + carry) & 0xFF)
                temp = 0xFF
                self.cache_size -= 1
                if not self.cache_size:
                    break
            self.cache = (self.low >> 24) & 0xFF
        self.cache_size += 1
        self.low = (self.low & 0x00FFFFFF) << 8

    def bit(self, probs: list[int], i: int, b: int) -> int:
        p = probs[i]
        bound = (self.range >> _PROB_BITS) * p
        if b:
            self.low += bound
            self.range -= bound
            probs[i] = p - (p >> _MOVE)
        else:
            self.range = bound
            probs[i] = p + ((_ONE - p) >> _MOVE)
        while self.range < _TOP:
            self.range <<= 8
            self._shift_low()
        return b

    def finish(self) -> bytes:
        for _ in range(5):
            self._shift_low()
        return bytes(self.out)


class _Decoder:
    """LZMA's binary range decoder; reading past the stream is a SectionError."""

    def __init__(self, data: bytes) -> None:
        if len(data) < 5 or data[0] != 0:
            raise SectionError("SHAP: the coded stream does not start with a zero byte")
        self.data, self.pos = data, 5
        self.code = int.from_bytes(data[1:5], "big")
        self.range = 0xFFFFFFFF

    def bit(self, probs: list[int], i: int, b: int) -> int:
        p = probs[i]
        bound = (self.range >> _PROB_BITS) * p
        if self.code < bound:
            self.range = bound
            probs[i] = p + ((_ONE - p) >> _MOVE)
            out = 0
        else:
            self.code -= bound
            self.range -= bound
            probs[i] = p - (p >> _MOVE)
            out = 1
        while self.range < _TOP:
            if self.pos >= len(self.data):
                raise SectionError("SHAP: the coded stream ends early")
            self.range <<= 8
            self.code = ((self.code << 8) | self.data[self.pos]) & 0xFFFFFFFF
            self.pos += 1
        return out

    def finish(self) -> None:
        if self.pos != len(self.data):
            raise SectionError(f"SHAP: {len(self.data) - self.pos} bytes after the coded stream")


class _Models:
    """Adaptive probabilities by context, and the binarizations of §2.5."""

    def __init__(self, rc: Any) -> None:
        self.rc = rc
        self.p: dict[Any, list[int]] = {}

    def probs(self, ctx: Any, n: int) -> list[int]:
        p = self.p.get(ctx)
        if p is None:
            p = self.p[ctx] = [_ONE // 2] * n
        return p

    def bit(self, ctx: Any, b: int = 0) -> int:
        return int(self.rc.bit(self.probs(ctx, 1), 0, b))

    def tree(self, ctx: Any, nbits: int, v: int = 0) -> int:
        """``nbits`` bits, most significant first, each under its prefix."""
        p = self.probs(ctx, 1 << nbits)
        m = 1
        for i in range(nbits - 1, -1, -1):
            m = (m << 1) | self.rc.bit(p, m, (v >> i) & 1)
        return m - (1 << nbits)

    def uint(self, ctx: Any, v: int = 0) -> int:
        """Elias gamma of v + 1: n = bit length − 1 in unary (bit k under
        (ctx, "n", min(k, 15))), then its n low bits, most significant first
        (bit k under (ctx, "m", min(n, 15), min(k, 15)))."""
        x = v + 1
        n = x.bit_length() - 1
        k = 0
        while self.bit((ctx, "n", min(k, 15)), int(k < n)):
            k += 1
            if k > _MAX_BITS:
                raise SectionError("SHAP: an integer is out of range")
        n = k
        x = 1
        for i in range(n - 1, -1, -1):
            x = (x << 1) | self.bit((ctx, "m", min(n, 15), min(n - 1 - i, 15)), (v + 1) >> i & 1)
        return x - 1


def _reverse(o: int) -> int:
    return o ^ 1 if o < 2 else o


def _flip(o: int, flip: int) -> int:
    """``o`` reversed if ``flip`` (INTERNAL and EXTERNAL stay)."""
    return _reverse(o) if flip else o


def _model_fits(m: Any) -> bool:
    """Whether a depth-first walk from the root numbers ``m``'s shapes as they
    are numbered (every shape reached, each new one completed at its index)."""
    n = len(m.shape_type)
    if n == 0 or not 0 <= m.root_shape < n:
        return False
    start, kids = m.child_start.tolist(), m.child_shape.tolist()
    done = [False] * n
    seen = [False] * n
    nxt = 0
    seen[m.root_shape] = True
    stack = [[m.root_shape, start[m.root_shape]]]
    while stack:
        top = stack[-1]
        s, j = top
        if j < start[s + 1]:
            top[1] = j + 1
            c = kids[j]
            if not 0 <= c < n:
                return False
            if not seen[c]:
                seen[c] = True
                stack.append([c, start[c]])
            elif not done[c]:
                return False  # a cycle
            continue
        stack.pop()
        if s != nxt:
            return False
        done[s] = True
        nxt += 1
    return nxt == n


class _Walk:
    """The state both sides keep (docs/format.md §2.5, "state")."""

    def __init__(self, coder: _Models) -> None:
        self.c = coder
        self.window: list[list[int]] = [[] for _ in range(8)]
        self.of_type: list[list[int]] = [[] for _ in range(8)]
        self.uses: list[int] = []
        self.last_orient: list[int] = []
        self.incident: dict[int, list[int]] = {}
        self.open: dict[int, int] = {}
        self.rank_in_type: list[int] = []
        self.last_flags = [0] * 8
        self.last_new_orient: dict[Any, int] = {}

    def touch(self, t: int, s: int) -> None:
        w = self.window[t]
        if s in w:
            w.remove(s)
        w.insert(0, s)
        if len(w) > WINDOW:
            w.pop()


def _ends(o: int, kids: list[int], orients: list[int]) -> tuple[int | None, int | None]:
    """Start and end vertex of an edge used with orientation ``o``."""
    start = end = None
    for v, vo in zip(kids, orients):
        r = _reverse(vo) if o == _R else vo
        if r == _F and start is None:
            start = v
        elif r == _R and end is None:
            end = v
    return start, end


def _run(
    c: _Models, m: Any | None, n_shapes: int, n_refs: int, depth: int | None = None
) -> dict[str, Any]:
    """The walk of §2.5: encodes ``m`` (m given) or decodes (m None)."""
    enc = m is not None
    w = _Walk(c)
    types = [0] * n_shapes
    flags = [0] * n_shapes
    start = [0] * (n_shapes + 1)
    kid_shape: list[int] = []
    kid_orient: list[int] = []
    kid_loc: list[int] = []
    if m is not None:
        m_start, m_kids = m.child_start.tolist(), m.child_shape.tolist()
        m_or, m_loc = m.child_orient.tolist(), m.child_loc.tolist()
        m_type, m_flags = m.shape_type.tolist(), m.shape_flags.tolist()
    count = 0  # shapes numbered
    refs = 0  # references declared by the child counts read so far

    def new_shape(t: int, src: int) -> list[Any]:
        """Begin a new shape of type t: its flags and child count; its frame:
        [type, flags, children, model index, next child, references so far,
        wire state [end vertex, first vertex, last edge], child being walked,
        flip: 1 if the references down to it reverse it an odd number of times]."""
        nonlocal refs
        f = m_flags[src] if enc else 0
        if c.bit(("fs", t), int(f == w.last_flags[t])):
            f = w.last_flags[t]
        else:
            f = c.tree(("f", t), 8, f)
        w.last_flags[t] = f
        nk = c.uint(("k", t), m_start[src + 1] - m_start[src] if enc else 0)
        if refs + nk > n_refs:
            raise SectionError("SHAP: more references than the section declares")
        refs += nk
        return [t, f, nk, src, 0, [], [None, None, None], None, 0]

    def finish_ref(fr: list[Any], s: int, o: int, loc: int) -> None:
        """A reference of frame ``fr`` to shape ``s`` is known: the state moves."""
        ct = types[s]
        fr[5].append((s, o, loc))
        fr[4] += 1
        w.uses[s] += 1
        w.last_orient[s] = _flip(o, fr[8])
        if ct == _EDGE:  # the open-edge count of the edge's vertices
            step = 1 if w.uses[s] & 1 else -1
            for v in set(kid_shape[start[s] : start[s + 1]]):
                w.open[v] = w.open.get(v, 0) + step
        w.touch(ct, s)
        if fr[0] == _WIRE and ct == _EDGE:
            ws = fr[6]
            st, en = _ends(
                o, kid_shape[start[s] : start[s + 1]], kid_orient[start[s] : start[s + 1]]
            )
            if ws[2] is None:
                ws[1] = st
            ws[0], ws[2] = en, s
            if st is not None:
                w.touch(_VERTEX, st)
            if en is not None:
                w.touch(_VERTEX, en)

    t0 = c.tree(("t", 8), 3, m_type[m.root_shape] if m is not None else 0)
    stack = [new_shape(t0, m.root_shape if m is not None else 0)]
    root_orient = c.tree(("ro",), 2, m.root_orient if m is not None else 0)
    stack[0][8] = int(root_orient == _R)
    root_loc = c.uint(("rl",), m.root_loc if m is not None else 0)
    true_s = true_o = true_loc = 0
    while stack:
        fr = stack[-1]
        t, nk, src, j = fr[0], fr[2], fr[3], fr[4]
        if j == nk:  # the shape is complete: number it
            stack.pop()
            if count >= n_shapes:
                raise SectionError("SHAP: more shapes than the section declares")
            s = count
            count += 1
            if enc and src != s:
                raise AssertionError("the walk numbers a shape otherwise")
            types[s], flags[s] = t, fr[1]
            start[s] = len(kid_shape)
            for k, o, loc in fr[5]:
                kid_shape.append(k)
                kid_orient.append(o)
                kid_loc.append(loc)
            start[s + 1] = len(kid_shape)
            w.rank_in_type.append(len(w.of_type[t]))
            w.of_type[t].append(s)
            w.uses.append(0)
            w.last_orient.append(_F)
            if t == _EDGE:
                for v in kid_shape[start[s] :]:
                    inc = w.incident.setdefault(v, [])
                    if s not in inc:
                        inc.append(s)
                        if len(inc) > INCIDENT:
                            del inc[0]
            if stack:
                o, loc = stack[-1][7]
                stack[-1][7] = None
                finish_ref(stack[-1], s, o, loc)
            continue
        # child j of this shape
        if enc:
            mk = m_start[src] + j
            true_s, true_o, true_loc = m_kids[mk], m_or[mk], m_loc[mk]
        ct = c.tree(("t", t), 3, m_type[true_s] if enc else 0)
        ws = fr[6]
        cand: list[int] = []
        role = 0
        if t == _EDGE and ct == _VERTEX and j < 2 and len(stack) > 1 and stack[-2][0] == _WIRE:
            par = stack[-2]
            uo = par[7][0]
            if (j == 0) != (uo == _R):  # the vertex the edge starts from
                role = 1
                if par[6][0] is not None:
                    cand = [par[6][0]]
            elif par[4] == par[2] - 1 and par[6][1] is not None:  # ends the wire
                role = 3
                cand = [par[6][1]]
            else:
                role = 2
        elif t == _WIRE and ct == _EDGE and ws[0] is not None:
            role = 4
            for e in reversed(w.incident.get(ws[0], ())):
                if w.uses[e] & 1 and e != ws[2]:
                    cand.append(e)
        ctx = (t, ct, role, min(len(cand), 2))
        if c.bit(("s",) + ctx, int(enc and true_s < count)):
            win = [x for x in w.window[ct] if x not in cand]
            if ct == _VERTEX:
                rank = (
                    cand + [x for x in win if w.open.get(x)] + [x for x in win if not w.open.get(x)]
                )
            else:
                rank = (
                    cand + [x for x in win if w.uses[x] & 1] + [x for x in win if not w.uses[x] & 1]
                )
            r = len(rank)
            if enc and true_s in rank:
                r = rank.index(true_s)
            r = c.uint(("r",) + ctx, r)
            if r < len(rank):
                s = rank[r]
            elif r == len(rank):
                lst = w.of_type[ct]
                d = c.uint(("x", ct), len(lst) - 1 - w.rank_in_type[true_s] if enc else 0)
                if d >= len(lst):
                    raise BadReferenceError("SHAP: a shared reference to a missing shape")
                s = lst[len(lst) - 1 - d]
            else:
                raise SectionError("SHAP: a shared reference's rank is out of range")
            if t == _EDGE and ct == _VERTEX:
                pred = _F if j == 0 else _R
            elif ct == _EDGE:
                pred = _flip(_reverse(w.last_orient[s]), fr[8])
            else:
                pred = _flip(w.last_orient[s], fr[8])
            o = c.tree(("o", t, ct, 1, pred), 2, true_o)
            loc = _location(c, t, ct, true_loc)
            finish_ref(fr, s, o, loc)
            continue
        if t == _EDGE and ct == _VERTEX:
            pred = _F if j == 0 else _R
        elif t == _WIRE and ct == _EDGE:
            pred = 4 if ws[2] is None else _flip(w.last_orient[ws[2]], fr[8])
        else:
            pred = w.last_new_orient.get((t, ct), _F)
        o = c.tree(("o", t, ct, 0, pred), 2, true_o)
        loc = _location(c, t, ct, true_loc)
        w.last_new_orient[(t, ct)] = o
        if count + len(stack) >= n_shapes:
            raise SectionError("SHAP: more shapes than the section declares")
        if depth is not None and len(stack) >= depth:
            raise budget._refuse(len(stack) + 1, "levels of nested sub-shapes", depth)
        fr[7] = (o, loc)
        stack.append(new_shape(ct, true_s))
        stack[-1][8] = fr[8] ^ int(o == _R)
    if count != n_shapes or refs != n_refs:
        raise SectionError("SHAP: fewer shapes or references than the section declares")
    return {
        "types": types,
        "flags": flags,
        "start": start,
        "shape": kid_shape,
        "orient": kid_orient,
        "loc": kid_loc,
        "root_orient": root_orient,
        "root_loc": root_loc,
    }


def _location(c: _Models, t: int, ct: int, loc: int) -> int:
    """A reference's location: 0 (identity) or 1 + a uint."""
    if c.bit(("l", t, ct), int(loc != 0)):
        return c.uint(("L", t, ct), loc - 1) + 1
    return 0


def encode(m: Any) -> bytes | None:
    """The coded stream of ``m``'s shapes table, or None if the walk does not
    number ``m`` as it is numbered."""
    if not _model_fits(m):
        return None
    rc = _Encoder()
    _run(_Models(rc), m, len(m.shape_type), len(m.child_shape))
    return rc.finish()


def decode(data: bytes, n_shapes: int, n_refs: int, depth: int | None = None) -> dict[str, Any]:
    """The tables of a coded stream of ``n_shapes`` shapes and ``n_refs``
    references; a walk deeper than ``depth`` (the budget's, when given: the
    nesting it would refuse later anyway) is a LimitError as soon as it is."""
    rc = _Decoder(data)
    out = _run(_Models(rc), None, n_shapes, n_refs, depth)
    rc.finish()
    return out
