"""The topology (``SHAP``, format 2.0) coded by prediction.

docs/format.md §2.5.1 specifies the layout; this module is its reference.  The
shapes table is walked from the root depth first, each shape numbered when its
walk ends (post-order, the model's own numbering).  Each child reference is a
"more" flag, a type, and either a shared shape (ranked among predicted
candidates and the recent shapes of its type, or past them a distance back
among the open edges or the shapes of its type) or a new one, walked.  A wire
is coded in two phases: its edges first (a shared edge chained through the
open edges at the known end of the previous one; a later use of one of the
wire's own new edges named by position), then its new edges walked, each
vertex predicted from the neighbouring edge uses.  Every decision is a binary
symbol coded by LZMA's range coder with a 15-bit probability from the
context's adaptive counts.

Format 2.19's mode 2 is the same walk less what the tables' properties
imply (:func:`properties`: a wire's children are edges, an edge's two
children its FORWARD and REVERSED vertices, no location below a solid, ...),
each named by a bit of its header, with a shape's flags coded once its
children are known (an edge whose ends are one vertex is one OCCT marks
closed).  On the corpus it leaves out almost half the decisions: the walk decodes
in about 16 % less time, for 3 % fewer bytes.

A model that this walk cannot write as it is numbered (shapes that the root
does not reach, other orders, a wire's child numbered by a sibling's walk) is
written in the 1.x layout behind a mode byte: every model is written, none is
renumbered.

Nothing here imports OCP: the format layer works on the model's arrays.
"""

from __future__ import annotations

import struct
from typing import Any

import numpy as np

from . import budget
from .errors import BadReferenceError, SectionError

#: Mode byte of a 2.0 SHAP section (mode 2: format 2.19).
MODE_ARRAYS, MODE_WALK, MODE_IMPLIED = 0, 1, 2
#: Shapes of one type kept in its recency window.
WINDOW = 64
#: Edges per vertex kept for the open-edge candidates.
INCIDENT = 16
#: A context's counts are halved when their sum passes this.
LIMIT = 255
#: A wire's latest new children that a later use in the wire may name.
PENDING = 4
#: Most shapes plus references a section may declare whatever the limits.
MAX_ROWS = 1 << 28
#: Largest integer the uint code carries (bit length of v + 1 at most 40).
_MAX_BITS = 40

#: Mode-1 header: mode, shapes, references.
HEAD = struct.Struct("<BII")
#: Mode-2 header: mode, the model's properties (``KIDS_TYPED`` ...), shapes, references.
HEAD2 = struct.Struct("<BBII")
_SHELL, _FACE, _WIRE, _EDGE, _VERTEX = 3, 4, 5, 6, 7
#: Mode 2's properties (docs/format.md §2.5.1, *(2.19)*): bits of its header
#: byte, each naming what the walk then does not code.
#: Every child of a wire is an edge, every child of an edge a vertex.
KIDS_TYPED = 1
#: Every child of a shell is a face, every child of a face a wire.
FACES_TYPED = 2
#: Every edge has two children.
TWO_ENDS = 4
#: ... the first FORWARD, the second REVERSED (with TWO_ENDS only).
ENDS_FR = 8
#: No reference from a shell, face, wire or edge has a location.
UNLOCATED = 16
#: Every property mode 2 may name.
IMPLIED_ALL = KIDS_TYPED | FACES_TYPED | TWO_ENDS | ENDS_FR | UNLOCATED
#: The child type each property implies, by the parent's type.
_KID_TYPE = {
    KIDS_TYPED: {_WIRE: _EDGE, _EDGE: _VERTEX},
    FACES_TYPED: {_SHELL: _FACE, _FACE: _WIRE},
}
_PARENTS_UNLOCATED = (_SHELL, _FACE, _WIRE, _EDGE)
_F, _R = 0, 1

_TOP = 1 << 24
#: Precision of a probability given to the range coder.
_PROB_BITS = 15
_SHIFT = LIMIT.bit_length()
#: The probability of a 0 after n0 zeros and n1 ones (each at most LIMIT, as
#: the halving keeps them), ``((2·n0 + 1) << 15) // (2·(n0 + n1) + 2)``, looked
#: up at ``n0 << _SHIFT | n1`` rather than computed at each binary decision
#: (the walk of the corpus's 11 containers: 1.22 → 0.96 s).
_N0, _N1 = np.divmod(np.arange(1 << 2 * _SHIFT, dtype=np.int64), 1 << _SHIFT)
_PROB: list[int] = (((2 * _N0 + 1) << _PROB_BITS) // (2 * (_N0 + _N1) + 2)).tolist()
del _N0, _N1


class _Models:
    """Adaptive binary models by context (counts, halved past LIMIT) and the
    binarizations of §2.5.1, over LZMA's binary range coder (the subclasses).

    A context's two counts start at 0 and give the coder the probability of
    a 0 as ``((2·n0 + 1) << 15) // (2·(n0 + n1) + 2)``.  Each family keeps
    its counts in one flat list, looked up once per symbol: a plain bit's
    context two counts, a tree's two per prefix (the bit under prefix m at
    2·m), a uint's 2·16 for its unary part and 2·16·16 for its bits.  The
    families' keys never meet, so each (family, key, index) is the one
    context §2.5.1 names."""

    __slots__ = ("p", "pt", "pu")

    def __init__(self) -> None:
        self.p: dict[Any, list[int]] = {}
        self.pt: dict[Any, list[int]] = {}
        self.pu: dict[Any, list[int]] = {}

    def code(self, n: list[int], i: int, b: int) -> int:
        """Code bit ``b`` (or decode one: ``b`` is ignored) under the counts
        ``n[i], n[i + 1]``, then count it.  The subclasses repeat the count
        update beside their coder on purpose: one Python call per binary
        decision is what makes the walk fast."""
        raise NotImplementedError

    def bit(self, ctx: Any, b: int = 0) -> int:
        n = self.p.get(ctx)
        if n is None:
            n = self.p[ctx] = [0, 0]
        return self.code(n, 0, b)

    def tree(self, ctx: Any, nbits: int, v: int = 0) -> int:
        """``nbits`` bits, most significant first, each under its prefix."""
        n = self.pt.get(ctx)
        if n is None:
            n = self.pt[ctx] = [0] * (2 << nbits)
        code = self.code
        m = 1
        for i in range(nbits - 1, -1, -1):
            m = (m << 1) | code(n, 2 * m, (v >> i) & 1)
        return m - (1 << nbits)

    def uint(self, ctx: Any, v: int = 0) -> int:
        """Elias gamma of v + 1: n = bit length − 1 in unary (bit k under
        (ctx, "n", min(k, 15))), then its n low bits, most significant first
        (bit i under (ctx, "m", min(n, 15), min(i, 15)))."""
        t = self.pu.get(ctx)
        if t is None:
            t = self.pu[ctx] = [0] * (2 * 16 + 2 * 16 * 16)
        code = self.code
        x = v + 1
        n = x.bit_length() - 1
        k = 0
        while code(t, 2 * min(k, 15), int(k < n)):
            k += 1
            if k > _MAX_BITS:
                raise SectionError("SHAP: an integer is out of range")
        n = k
        base = 32 + 32 * min(n, 15)
        x = 1
        for i in range(n - 1, -1, -1):
            x = (x << 1) | code(t, base + 2 * min(n - 1 - i, 15), (v + 1) >> i & 1)
        return x - 1


class _Encoder(_Models):
    """The models over LZMA's binary range encoder (carry propagated through
    a cache byte)."""

    __slots__ = ("low", "range", "cache", "cache_size", "out")

    def __init__(self) -> None:
        super().__init__()
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

    def code(self, n: list[int], i: int, b: int) -> int:
        n0, n1 = n[i], n[i + 1]
        bound = (self.range >> _PROB_BITS) * _PROB[n0 << _SHIFT | n1]
        if b:
            self.low += bound
            self.range -= bound
            n1 += 1
            n[i + 1] = n1
        else:
            self.range = bound
            n0 += 1
            n[i] = n0
        if n0 + n1 > LIMIT:
            n[i], n[i + 1] = (n0 + 1) >> 1, (n1 + 1) >> 1
        while self.range < _TOP:
            self.range <<= 8
            self._shift_low()
        return b

    def finish(self) -> bytes:
        for _ in range(5):
            self._shift_low()
        return bytes(self.out)


class _Decoder(_Models):
    """The models over LZMA's binary range decoder; reading past the stream
    is a SectionError."""

    __slots__ = ("data", "pos", "value", "range")

    def __init__(self, data: bytes) -> None:
        super().__init__()
        if len(data) < 5 or data[0] != 0:
            raise SectionError("SHAP: the coded stream does not start with a zero byte")
        self.data, self.pos = data, 5
        self.value = int.from_bytes(data[1:5], "big")
        self.range = 0xFFFFFFFF

    def code(self, n: list[int], i: int, b: int) -> int:
        n0, n1 = n[i], n[i + 1]
        bound = (self.range >> _PROB_BITS) * _PROB[n0 << _SHIFT | n1]
        if self.value < bound:
            self.range = bound
            b = 0
            n0 += 1
            n[i] = n0
        else:
            self.value -= bound
            self.range -= bound
            b = 1
            n1 += 1
            n[i + 1] = n1
        if n0 + n1 > LIMIT:
            n[i], n[i + 1] = (n0 + 1) >> 1, (n1 + 1) >> 1
        while self.range < _TOP:
            if self.pos >= len(self.data):
                raise SectionError("SHAP: the coded stream ends early")
            self.range <<= 8
            self.value = ((self.value << 8) | self.data[self.pos]) & 0xFFFFFFFF
            self.pos += 1
        return b

    def finish(self) -> None:
        if self.pos != len(self.data):
            raise SectionError(f"SHAP: {len(self.data) - self.pos} bytes after the coded stream")


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


class _Unfit(Exception):
    """The model cannot be written by the walk (a wire's child that a sibling's
    walk numbers): it goes in the arrays."""


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


class _Marks:
    """Marked positions 0, 1, ... (a Fenwick tree that grows): how many marks
    lie after a position, and the position with d marks after it, in
    O(log n)."""

    def __init__(self) -> None:
        self.tree = [0] * 2
        self.bits: list[int] = []
        self.total = 0

    def append(self) -> None:
        self.bits.append(0)
        if len(self.bits) >= len(self.tree):
            self.tree = [0] * (2 * len(self.tree))
            for i, b in enumerate(self.bits):
                if b:
                    self._add(i, 1)

    def _add(self, i: int, d: int) -> None:
        i += 1
        while i < len(self.tree):
            self.tree[i] += d
            i += i & -i

    def set(self, i: int, b: int) -> None:
        if self.bits[i] != b:
            self.bits[i] = b
            self._add(i, 1 if b else -1)
            self.total += 1 if b else -1

    def after(self, i: int) -> int:
        """Marks at positions > i."""
        k, n = i + 1, 0
        while k > 0:
            n += self.tree[k]
            k -= k & -k
        return self.total - n

    def back(self, d: int) -> int:
        """The marked position with d marks after it (0 <= d < total)."""
        k = self.total - d  # the k-th mark from the start
        pos, step = 0, 1 << (len(self.tree).bit_length())
        while step:
            if pos + step < len(self.tree) and self.tree[pos + step] < k:
                pos += step
                k -= self.tree[pos]
            step >>= 1
        return pos


class _Frame:
    """A shape being walked: type, flags, model index (encoder), flip, parent
    frame and position in it, children so far (slots [shape, o, loc, kind]:
    kind 0 known, 1 new not yet walked, 2 a later use of slot ``shape``),
    and for a wire in its second phase the next slot to walk."""

    __slots__ = ("t", "f", "src", "flip", "parent", "pos", "slots", "phase", "nxt", "hi", "news")

    def __init__(self, t: int, f: int, src: int, flip: int, parent: Any, pos: int) -> None:
        self.t, self.f, self.src, self.flip, self.parent, self.pos = t, f, src, flip, parent, pos
        self.slots: list[list[Any]] = []
        self.phase, self.nxt, self.hi = 1, 0, -1
        self.news: list[int] = []


def _run(
    c: _Models,
    m: Any | None,
    n_shapes: int,
    n_refs: int,
    depth: int | None = None,
    implied: int | None = None,
) -> dict[str, Any]:
    """The walk of §2.5.1: encodes ``m`` (m given) or decodes (m None);
    ``implied``: mode 2's walk, with these properties of the model
    (:func:`properties`), which it then does not code; None: mode 1's."""
    enc = m is not None
    mode2 = implied is not None
    props = implied or 0
    kid_type = {t: u for bit, tu in _KID_TYPE.items() if props & bit for t, u in tu.items()}
    two_ends, ends_fr = bool(props & TWO_ENDS), bool(props & ENDS_FR)
    unlocated = _PARENTS_UNLOCATED if props & UNLOCATED else ()
    types: list[int] = []
    flags: list[int] = []
    start = [0]
    kid_shape: list[int] = []
    kid_orient: list[int] = []
    kid_loc: list[int] = []
    window: list[list[int]] = [[] for _ in range(8)]
    of_type: list[list[int]] = [[] for _ in range(8)]
    rank_in_type: list[int] = []
    uses: list[int] = []
    last_orient: list[int] = []
    incident: dict[int, list[int]] = {}
    opens: dict[int, int] = {}
    opened = _Marks()  # the edges used an odd number of times, by rank_in_type
    last_flags = [0] * 8
    closed_flags: dict[tuple[int, int], int] = {}  # mode 2's last flags by (type, hint)
    last_new: dict[Any, int] = {}
    if m is not None:
        m_start, m_kids = m.child_start.tolist(), m.child_shape.tolist()
        m_or, m_loc = m.child_orient.tolist(), m.child_loc.tolist()
        m_type, m_flags = m.shape_type.tolist(), m.shape_flags.tolist()
    refs = 0
    reserved = 1  # frames on the stack and new children not yet walked

    def touch(t: int, s: int) -> None:
        wl = window[t]
        if s in wl:
            wl.remove(s)
        wl.insert(0, s)
        if len(wl) > WINDOW:
            wl.pop()

    def ends(s: int, o: int) -> tuple[int | None, int | None]:
        if types[s] != _EDGE:
            return None, None
        return _ends(o, kid_shape[start[s] : start[s + 1]], kid_orient[start[s] : start[s + 1]])

    def slot_shape(fr: _Frame, i: int) -> int | None:
        sl = fr.slots[i]
        if sl[3] == 2:
            sl = fr.slots[sl[0]]
        return None if sl[3] else sl[0]

    def open_frame(t: int, src: int, flip: int, parent: Any, pos: int) -> _Frame:
        f = m_flags[src] if enc else 0
        if not mode2:  # mode 2 codes a shape's flags once its children are known
            if c.bit(("fs", t), int(f == last_flags[t])):
                f = last_flags[t]
            else:
                f = c.tree(("f", t), 8, f)
            last_flags[t] = f
        if depth is not None and parent is not None and len(stack) >= depth:
            raise budget._refuse(len(stack) + 1, "levels of nested sub-shapes", depth)
        return _Frame(t, f, src, flip, parent, pos)

    def more(fr: _Frame, ctx: Any) -> bool:
        nonlocal refs
        j = len(fr.slots)
        if two_ends and fr.t == _EDGE:
            b = int(j < 2)
        else:
            b = c.bit(ctx, int(enc and j < m_start[fr.src + 1] - m_start[fr.src]))
        if b:
            refs += 1
            if refs > n_refs:
                raise SectionError("SHAP: more references than the section declares")
        return bool(b)

    def location(t: int, ct: int, loc: int) -> int:
        return 0 if t in unlocated else _location(c, t, ct, loc)

    def reserve() -> None:
        nonlocal reserved
        if len(types) + reserved >= n_shapes:
            raise SectionError("SHAP: more shapes than the section declares")
        reserved += 1

    def used(fr: _Frame, s: int, o: int) -> None:
        """A reference of ``fr`` to ``s`` is complete: the state moves."""
        ct = types[s]
        uses[s] += 1
        last_orient[s] = _flip(o, fr.flip)
        if ct == _EDGE:
            opened.set(rank_in_type[s], uses[s] & 1)
            step = 1 if uses[s] & 1 else -1
            for v in set(kid_shape[start[s] : start[s + 1]]):
                opens[v] = opens.get(v, 0) + step
        touch(ct, s)
        if fr.t == _WIRE and ct == _EDGE:
            for e in ends(s, o):
                if e is not None:
                    touch(_VERTEX, e)

    def live(ct: int, x: int) -> bool:
        """Whether ``x`` ranks among the window's first: a vertex with open
        edges, another shape used an odd number of times."""
        return bool(opens.get(x)) if ct == _VERTEX else bool(uses[x] & 1)

    def rank_of(ct: int, head: list[int], true: int) -> int:
        """The rank of ``true`` in ``head`` + the window of type ``ct`` less
        ``head``, its live shapes first (most recent first in each part), or
        the length of that list when it is in neither."""
        if true in head:
            return head.index(true)
        rest = [x for x in window[ct] if x not in head]
        if true not in rest:
            return len(head) + len(rest)
        up = live(ct, true)
        before = 0
        for x in rest:
            if x == true:
                break
            if live(ct, x) == up:
                before += 1
        if not up:
            before += sum(1 for x in rest if live(ct, x))
        return len(head) + before

    def ranked_at(ct: int, head: list[int], r: int) -> int | None:
        """The shape of rank ``r`` (see :func:`rank_of`); None at the length
        of the list, a SectionError past it.  Each of the two builds the
        window less ``head`` only when the rank is past ``head``: mostly it
        is not."""
        if r < len(head):
            return head[r]
        k = r - len(head)
        rest = [x for x in window[ct] if x not in head]
        if k > len(rest):
            raise SectionError("SHAP: a shared reference's rank is out of range")
        if k == len(rest):
            return None
        for up in (True, False):
            for x in rest:
                if live(ct, x) == up:
                    if not k:
                        return x
                    k -= 1
        raise AssertionError("unreachable: k < len(rest)")

    def choose(ctx: Any, ct: int, head: list[int], true: int, news: list[int] | None) -> int:
        """A shared reference: its rank among ``head`` and the recent shapes
        of type ``ct`` (:func:`rank_of`) or, past them, its distance back
        among the wire's new children (``news``: ~position) or among the
        shapes of type ``ct``."""
        r = c.uint(("r",) + ctx, rank_of(ct, head, true) if enc else 0)
        s = ranked_at(ct, head, r)
        if s is not None:
            return s
        if news is not None and c.bit(("xw", ct), int(enc and true < 0)):
            d = c.uint(("xn", ct), len(news) - 1 - news.index(~true) if enc else 0)
            if d >= len(news):
                raise BadReferenceError("SHAP: a later use of a missing new child")
            return ~news[len(news) - 1 - d]
        lst = of_type[ct]
        if ct == _EDGE and c.bit(("xo",), int(enc and uses[true] & 1)):
            d = c.uint(("xd",), opened.after(rank_in_type[true]) if enc else 0)
            if d >= opened.total:
                raise BadReferenceError("SHAP: a shared reference to a missing open edge")
            return lst[opened.back(d)]
        d = c.uint(("x", ct), len(lst) - 1 - rank_in_type[true] if enc else 0)
        if d >= len(lst):
            raise BadReferenceError("SHAP: a shared reference to a missing shape")
        return lst[len(lst) - 1 - d]

    def _wire_child(
        fr: _Frame, ct: int, true_s: int, true_o: int, true_loc: int, chain: Any, prev: Any
    ) -> None:
        """Phase 1 of a wire: child ``len(fr.slots)`` is shared (a shape
        numbered before the wire, or a later use of one of the wire's new
        children) or new (walked in phase 2)."""
        count, j = len(types), len(fr.slots)
        cand: list[int] = []
        if ct == _EDGE and chain is not None:
            cand = [e for e in reversed(incident.get(chain, ())) if uses[e] & 1 and e != prev]
        pend = [~k for k in reversed(fr.news[-PENDING:]) if fr.slots[k][4] == ct]
        kind = 0
        if enc:
            if true_s >= count:
                kind = 1
                if true_s <= fr.hi:
                    hit = [k for k in fr.news if fr.slots[k][0] == true_s]
                    if not hit:
                        raise _Unfit
                    kind, true_s = 2, ~hit[0]
        ctx = (_WIRE, ct, int(chain is not None), min(len(cand), 2), int(bool(pend)))
        if c.bit(("s",) + ctx, int(enc and kind != 1)):
            s = choose(ctx, ct, cand + pend, true_s, fr.news)
            if s < 0:
                k = ~s
                o = c.tree(("o", _WIRE, ct, 2, fr.slots[k][1]), 2, true_o)
                loc = location(_WIRE, ct, true_loc)
                fr.slots.append([k, o, loc, 2, ct])
                return
            last = last_orient[s]
            pred = _flip(_reverse(last) if ct == _EDGE else last, fr.flip)
            o = c.tree(("o", _WIRE, ct, 1, pred), 2, true_o)
            loc = location(_WIRE, ct, true_loc)
            fr.slots.append([s, o, loc, 0, ct])
            used(fr, s, o)
            return
        pred = fr.slots[j - 1][1] if j else 4
        o = c.tree(("o", _WIRE, ct, 0, pred), 2, true_o)
        loc = location(_WIRE, ct, true_loc)
        reserve()
        fr.news.append(j)
        fr.hi = max(fr.hi, true_s)
        fr.slots.append([true_s, o, loc, 1, ct])

    t0 = c.tree(("t", 8), 3, m_type[m.root_shape] if m is not None else 0)
    root_orient = c.tree(("ro",), 2, m.root_orient if m is not None else 0)
    root_loc = c.uint(("rl",), m.root_loc if m is not None else 0)
    stack: list[_Frame] = []
    root = m.root_shape if m is not None else 0
    stack.append(open_frame(t0, root, int(root_orient == _R), None, 0))
    while stack:
        fr = stack[-1]
        t, j = fr.t, len(fr.slots)
        if fr.phase == 2:  # a wire's second phase: walk its new children in order
            while fr.nxt < j and fr.slots[fr.nxt][3] != 1:
                fr.nxt += 1
            if fr.nxt < j:
                sl = fr.slots[fr.nxt]
                ct = sl[4]
                stack.append(open_frame(ct, sl[0], fr.flip ^ int(sl[1] == _R), fr, fr.nxt))
                fr.nxt += 1
                continue
            for sl in fr.slots:
                if sl[3] == 2:
                    sl[0], sl[3] = fr.slots[sl[0]][0], 0
                    used(fr, sl[0], sl[1])
            fr.phase = 3
        elif fr.phase == 1:
            if t == _WIRE:
                prev = slot_shape(fr, j - 1) if j else None
                chain = ends(prev, fr.slots[j - 1][1])[1] if prev is not None else None
                first = slot_shape(fr, 0) if j else None
                head = ends(first, fr.slots[0][1])[0] if first is not None else None
                closed = 2 if chain is None else int(chain == head)
                go = more(fr, ("m", t, min(j, 7), closed))
            else:
                go = more(fr, ("m", t, min(j, 3)))
            if not go:
                fr.phase = 2 if t == _WIRE else 3
                continue
            if enc:
                mk = m_start[fr.src] + j
                true_s, true_o, true_loc = m_kids[mk], m_or[mk], m_loc[mk]
            else:
                true_s = true_o = true_loc = 0
            ct = kid_type.get(t, -1)
            if ct < 0:
                ct = c.tree(("t", t), 3, m_type[true_s] if enc else 0)
            if t == _WIRE:
                _wire_child(fr, ct, true_s, true_o, true_loc, chain, prev)
                continue
            count = len(types)
            cand: list[int] = []
            role = 0
            if t == _EDGE and ct == _VERTEX:  # orientation first: it tells the end
                o = j if ends_fr else c.tree(("o", t, ct, min(j, 2)), 2, true_o)
                par = fr.parent
                if par is not None and par.t == _WIRE:
                    x = _flip(o, int(par.slots[fr.pos][1] == _R))
                    n = len(par.slots)
                    if x == _F:
                        role = 1
                        s2 = slot_shape(par, (fr.pos - 1) % n)
                        v = ends(s2, par.slots[(fr.pos - 1) % n][1])[1] if s2 is not None else None
                    elif x == _R:
                        role = 2
                        s2 = slot_shape(par, (fr.pos + 1) % n)
                        v = ends(s2, par.slots[(fr.pos + 1) % n][1])[0] if s2 is not None else None
                    else:
                        v = None
                    if v is not None:
                        cand = [v]
            ctx = (t, ct, role, len(cand))
            if c.bit(("s",) + ctx, int(enc and true_s < count)):
                s = choose(ctx, ct, cand, true_s, None)
                if not (t == _EDGE and ct == _VERTEX):
                    pred = _flip(last_orient[s], fr.flip)
                    o = c.tree(("o", t, ct, 1, pred), 2, true_o)
                loc = location(t, ct, true_loc)
                fr.slots.append([s, o, loc, 0, ct])
                used(fr, s, o)
                continue
            if not (t == _EDGE and ct == _VERTEX):
                pred = last_new.get((t, ct), _F)
                o = c.tree(("o", t, ct, 0, pred), 2, true_o)
                last_new[(t, ct)] = o
            loc = location(t, ct, true_loc)
            reserve()
            fr.slots.append([true_s, o, loc, 1, ct])
            stack.append(open_frame(ct, true_s, fr.flip ^ int(o == _R), fr, j))
            continue
        # complete: number it
        stack.pop()
        s = len(types)
        if s >= n_shapes:
            raise SectionError("SHAP: more shapes than the section declares")
        if enc and fr.src != s:
            raise AssertionError("the walk numbers a shape otherwise")
        reserved -= 1
        if mode2:  # the flags, an edge's under whether its two ends are one vertex
            hint = int(t == _EDGE and len(fr.slots) == 2 and fr.slots[0][0] == fr.slots[1][0])
            key = (t, hint)
            last = closed_flags.get(key, 0)
            if c.bit(("fs", t, hint), int(fr.f == last)):
                fr.f = last
            else:
                fr.f = c.tree(("f", t, hint), 8, fr.f)
            closed_flags[key] = fr.f
        types.append(t)
        flags.append(fr.f)
        for k, o, loc, _, _ in fr.slots:
            kid_shape.append(k)
            kid_orient.append(o)
            kid_loc.append(loc)
        start.append(len(kid_shape))
        rank_in_type.append(len(of_type[t]))
        of_type[t].append(s)
        uses.append(0)
        last_orient.append(_F)
        if t == _EDGE:
            opened.append()
            for v in kid_shape[start[s] :]:
                inc = incident.setdefault(v, [])
                if s not in inc:
                    inc.append(s)
                    if len(inc) > INCIDENT:
                        del inc[0]
        par = fr.parent
        if par is not None:
            sl = par.slots[fr.pos]
            sl[0], sl[3] = s, 0
            used(par, s, sl[1])
    if len(types) != n_shapes or refs != n_refs:
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


def properties(m: Any) -> int:
    """The properties of mode 2 (``KIDS_TYPED`` ...) that ``m``'s shapes
    table has (its references checked in range first: ``_model_fits``)."""
    kids = np.diff(m.child_start)
    parent_t = np.repeat(m.shape_type, kids)
    child_t = m.shape_type[m.child_shape]
    out = 0
    for bit, tu in _KID_TYPE.items():
        if all((child_t[parent_t == t] == u).all() for t, u in tu.items()):
            out |= bit
    if (kids[m.shape_type == _EDGE] == 2).all():
        out |= TWO_ENDS
        ends = m.child_orient[parent_t == _EDGE].reshape(-1, 2)
        if (ends[:, 0] == 0).all() and (ends[:, 1] == 1).all():
            out |= ENDS_FR
    if not (m.child_loc[np.isin(parent_t, _PARENTS_UNLOCATED)] != 0).any():
        out |= UNLOCATED
    return out


def encode(m: Any, implied: int | None = None) -> bytes | None:
    """The coded stream of ``m``'s shapes table, or None if the walk does not
    number ``m`` as it is numbered (``implied``: mode 2's walk, with those of
    :func:`properties` that ``m`` has)."""
    if not _model_fits(m):
        return None
    rc = _Encoder()
    try:
        _run(rc, m, len(m.shape_type), len(m.child_shape), implied=implied)
    except _Unfit:
        return None
    return rc.finish()


def decode(
    data: bytes, n_shapes: int, n_refs: int, depth: int | None = None, implied: int | None = None
) -> dict[str, Any]:
    """The tables of a coded stream of ``n_shapes`` shapes and ``n_refs``
    references; a walk deeper than ``depth`` (the budget's, when given: the
    nesting it would refuse later anyway) is a LimitError as soon as it is.
    ``implied``: the stream is mode 2's."""
    rc = _Decoder(data)
    out = _run(rc, None, n_shapes, n_refs, depth, implied)
    rc.finish()
    return out
