"""§2.5.1 of docs/format.md: ``SHAP`` from revision 3, the range-coded walk."""

from __future__ import annotations

import bisect
import struct

from .container import Arrays, ReadError
from .tables import Shapes, shapes_from_arrays


class _Range:
    def __init__(self, stream: bytes) -> None:
        if len(stream) < 5 or stream[0] != 0:
            raise ReadError("SHAP: range stream")
        self.s = stream
        self.code = int.from_bytes(stream[1:5], "big")
        self.range = 0xFFFFFFFF
        self.pos = 5
        self.counts: dict[tuple, list[int]] = {}

    def decode(self, p0: int) -> int:
        bound = (self.range >> 15) * p0
        if self.code < bound:
            self.range = bound
            b = 0
        else:
            self.code -= bound
            self.range -= bound
            b = 1
        while self.range < 1 << 24:
            if self.pos >= len(self.s):
                raise ReadError("SHAP: past the stream")
            self.range <<= 8
            self.code = ((self.code << 8) | self.s[self.pos]) & 0xFFFFFFFF
            self.pos += 1
        return b

    def bit(self, ctx: tuple) -> int:
        n = self.counts.setdefault(ctx, [0, 0])
        p0 = ((2 * n[0] + 1) << 15) // (2 * (n[0] + n[1]) + 2)
        b = self.decode(p0)
        n[b] += 1
        if n[0] + n[1] > 255:
            n[0] = (n[0] + 1) >> 1
            n[1] = (n[1] + 1) >> 1
        return b

    def tree(self, ctx: tuple, nbits: int) -> int:
        m = 1
        for _ in range(nbits):
            m = 2 * m + self.bit((ctx, m))
        return m - (1 << nbits)

    def uint(self, ctx: tuple) -> int:
        k = 0
        while self.bit((ctx, "n", min(k, 15))) == 1:
            k += 1
            if k > 40:
                raise ReadError("SHAP: uint too long")
        x = 1
        for i in range(k):
            x = 2 * x + self.bit((ctx, "m", min(k, 15), min(i, 15)))
        return x - 1


def reverse(o: int) -> int:
    return {0: 1, 1: 0}.get(o, o)


def flip(o: int, x: int) -> int:
    return reverse(o) if x == 1 else o


class _Frame:
    def __init__(self, t: int, f: int, flip: int, parent: _Frame | None, pos: int) -> None:
        self.T, self.f, self.flip, self.parent, self.pos = t, f, flip, parent, pos
        self.slots: list[list] = []  # [s, o, loc, kind, U]
        self.news: list[int] = []
        self.phase = 1  # 1, 2 (wire), 3 complete
        self.pushed = 0  # kind-1 slots pushed in phase 2


def read_shap(raw: bytes, revision: int) -> Shapes:
    if revision < 3:
        return shapes_from_arrays(Arrays(raw, "SHAP"))
    if not raw:
        raise ReadError("SHAP: empty")
    mode = raw[0]
    if mode == 0:
        return shapes_from_arrays(Arrays(raw, "SHAP", 1))
    if mode == 2 and revision >= 22:  # (2.19) the properties byte, then as mode 1
        if len(raw) < 10:
            raise ReadError("SHAP: mode 2 header")
        P = raw[1]
        if P & ~31 or (P & 8 and not P & 4):
            raise ReadError(f"SHAP: properties {P}")
        S, C = struct.unpack_from("<II", raw, 2)
        return _Walk(raw[10:], S, C, P).run()
    if mode != 1:
        raise ReadError(f"SHAP mode {mode}")
    S, C = struct.unpack_from("<II", raw, 1)
    return _Walk(raw[9:], S, C).run()


class _Walk:
    def __init__(self, stream: bytes, S: int, C: int, P: int | None = None) -> None:
        self.rc = _Range(stream)
        self.S, self.C = S, C
        self.mode2 = P is not None  # (2.19) with the properties P
        self.P = P or 0
        self.last2: dict[tuple[int, int], int] = {}
        self.type: list[int] = []
        self.flags: list[int] = []
        self.children: list[list[tuple[int, int, int]]] = []
        self.uses: list[int] = []
        self.last_orient: list[int] = []
        self.rank: list[int] = []
        self.of_type: dict[int, list[int]] = {}
        self.window: dict[int, list[int]] = {}
        self.last_flags: dict[int, int] = {}
        self.incident: dict[int, list[int]] = {}
        self.open: dict[int, int] = {}
        self.opened: list[int] = []  # ranks of the marked edges, sorted
        self.last_new: dict[tuple[int, int], int] = {}
        self.refs = 0
        self.reserved = 1

    # ------------------------------------------------------------ helpers
    def touch(self, t: int, s: int) -> None:
        w = self.window.setdefault(t, [])
        if s in w:
            w.remove(s)
        w.insert(0, s)
        del w[64:]

    def ends(self, e: int | None, o: int) -> tuple[int | None, int | None]:
        if e is None or self.type[e] != 6:
            return None, None
        start = end = None
        for c, co, _ in self.children[e]:
            x = reverse(co) if o == 1 else co
            if x == 0 and start is None:
                start = c
            if x == 1 and end is None:
                end = c
        return start, end

    def known(self, f: _Frame, i: int) -> int | None:
        s, _, _, kind, _ = f.slots[i]
        if kind == 0:
            return s
        if kind == 2:
            t = f.slots[s]
            return t[0] if t[3] == 0 else None
        return None

    def more(self, ctx: tuple, F: _Frame | None = None) -> int:
        if F is not None and F.T == 6 and self.P & 4:  # two ends: implied
            b = int(len(F.slots) < 2)
        else:
            b = self.rc.bit(ctx)
        if b:
            self.refs += 1
            if self.refs > self.C:
                raise ReadError("SHAP: too many references")
        return b

    def reserve(self) -> None:
        if len(self.type) + self.reserved >= self.S:
            raise ReadError("SHAP: too many shapes")
        self.reserved += 1

    def open_frame(self, t: int, parent: _Frame | None, pos: int, fl: int) -> _Frame:
        if self.mode2:  # the flags come when the frame completes
            return _Frame(t, 0, fl, parent, pos)
        if self.rc.bit(("fs", t)) == 1:
            f = self.last_flags.get(t, 0)
        else:
            f = self.rc.tree(("f", t), 8)
        self.last_flags[t] = f
        return _Frame(t, f, fl, parent, pos)

    def location(self, t: int, u: int) -> int:
        if self.P & 16 and t in (3, 4, 5, 6):
            return 0
        if self.rc.bit(("l", t, u)) == 1:
            return 1 + self.rc.uint(("L", t, u))
        return 0

    def ranked(self, u: int, cand: list[int]) -> list[int]:
        rest = [s for s in self.window.get(u, []) if s not in cand]
        if u == 7:
            first = [s for s in rest if self.open.get(s, 0) != 0]
        else:
            first = [s for s in rest if self.uses[s] % 2 == 1]
        return cand + first + [s for s in rest if s not in first]

    def choose(self, ctx: tuple, u: int, rank: list[int], news: list[int] | None) -> int:
        rc = self.rc
        r = rc.uint(("r", *ctx))
        if r < len(rank):
            return rank[r]
        if r > len(rank):
            raise ReadError("SHAP: rank past the list")
        if news is not None and rc.bit(("xw", u)) == 1:
            d = rc.uint(("xn", u))
            if d >= len(news):
                raise ReadError("SHAP: bad news reference")
            return ~news[len(news) - 1 - d]
        if u == 6 and rc.bit(("xo",)) == 1:
            d = rc.uint(("xd",))
            if d >= len(self.opened):
                raise ReadError("SHAP: bad open edge")
            return self.of_type[6][self.opened[len(self.opened) - 1 - d]]
        d = rc.uint(("x", u))
        lst = self.of_type.get(u, [])
        if d >= len(lst):
            raise ReadError("SHAP: bad shape reference")
        return lst[len(lst) - 1 - d]

    def used(self, f: _Frame, s: int, o: int) -> None:
        self.uses[s] += 1
        self.last_orient[s] = flip(o, f.flip)
        if self.type[s] == 6:
            odd = self.uses[s] % 2 == 1
            r = self.rank[s]
            i = bisect.bisect_left(self.opened, r)
            marked = i < len(self.opened) and self.opened[i] == r
            if odd and not marked:
                self.opened.insert(i, r)
            elif not odd and marked:
                del self.opened[i]
            for v in dict.fromkeys(c for c, _, _ in self.children[s]):
                self.open[v] = self.open.get(v, 0) + (1 if odd else -1)
        self.touch(self.type[s], s)
        if f.T == 5 and self.type[s] == 6:
            start, end = self.ends(s, o)
            if start is not None:
                self.touch(7, start)
            if end is not None:
                self.touch(7, end)

    # ------------------------------------------------------------ the walk
    def run(self) -> Shapes:
        rc = self.rc
        t = rc.tree(("t", 8), 3)
        root_orient = rc.tree(("ro",), 2)
        root_loc = rc.uint(("rl",))
        stack = [self.open_frame(t, None, 0, 1 if root_orient == 1 else 0)]
        while stack:
            F = stack[-1]
            j = len(F.slots)
            if F.phase == 2:
                kind1 = [i for i in F.news]
                if F.pushed < len(kind1):
                    i = kind1[F.pushed]
                    F.pushed += 1
                    sl = F.slots[i]
                    stack.append(self.open_frame(sl[4], F, i, F.flip ^ (1 if sl[1] == 1 else 0)))
                    continue
                for sl in F.slots:
                    if sl[3] == 2:
                        target = F.slots[sl[0]]
                        sl[0], sl[3] = target[0], 0
                        self.used(F, sl[0], sl[1])
                F.phase = 3
                continue
            if F.phase == 1:
                if F.T == 5:
                    chain = head = p = None
                    if j > 0:
                        p = self.known(F, j - 1)
                        chain = self.ends(p, F.slots[j - 1][1])[1] if p is not None else None
                        q = self.known(F, 0)
                        head = self.ends(q, F.slots[0][1])[0] if q is not None else None
                    go = self.more(("m", 5, min(j, 7), 2 if chain is None else int(chain == head)))
                else:
                    go = self.more(("m", F.T, min(j, 3)), F)
                if not go:
                    F.phase = 2 if F.T == 5 else 3
                    continue
                implied = {}
                if self.P & 1:
                    implied.update({5: 6, 6: 7})
                if self.P & 2:
                    implied.update({3: 4, 4: 5})
                U = implied[F.T] if F.T in implied else rc.tree(("t", F.T), 3)
                if F.T == 5:
                    self.wire_child(F, U, chain, p)
                    continue
                cand: list[int] = []
                role = 0
                ev = F.T == 6 and U == 7
                o = 0
                if ev:
                    o = j if self.P & 8 else rc.tree(("o", 6, 7, min(j, 2)), 2)
                    W = F.parent
                    if W is not None and W.T == 5:
                        i, n = F.pos, len(W.slots)
                        o_e = W.slots[i][1]
                        x = flip(o, 1 if o_e == 1 else 0)
                        v = None
                        if x == 0:
                            role = 1
                            k = (i - 1) % n
                            e = self.known(W, k)
                            v = self.ends(e, W.slots[k][1])[1] if e is not None else None
                        elif x == 1:
                            role = 2
                            k = (i + 1) % n
                            e = self.known(W, k)
                            v = self.ends(e, W.slots[k][1])[0] if e is not None else None
                        if v is not None:
                            cand = [v]
                ctx = (F.T, U, role, len(cand))
                if rc.bit(("s", *ctx)) == 1:
                    s = self.choose(ctx, U, self.ranked(U, cand), None)
                    if not ev:
                        o = rc.tree(("o", F.T, U, 1, flip(self.last_orient[s], F.flip)), 2)
                    loc = self.location(F.T, U)
                    F.slots.append([s, o, loc, 0, U])
                    self.used(F, s, o)
                else:
                    if not ev:
                        o = rc.tree(("o", F.T, U, 0, self.last_new.get((F.T, U), 0)), 2)
                        self.last_new[(F.T, U)] = o
                    loc = self.location(F.T, U)
                    self.reserve()
                    F.slots.append([None, o, loc, 1, U])
                    stack.append(self.open_frame(U, F, j, F.flip ^ (1 if o == 1 else 0)))
                continue
            # complete
            stack.pop()
            s = len(self.type)
            if s >= self.S:
                raise ReadError("SHAP: too many shapes")
            self.reserved -= 1
            if self.mode2:
                two = len(F.slots) == 2 and F.slots[0][0] == F.slots[1][0]
                h = 1 if F.T == 6 and two else 0
                if rc.bit(("fs", F.T, h)) == 1:
                    F.f = self.last2.get((F.T, h), 0)
                else:
                    F.f = rc.tree(("f", F.T, h), 8)
                self.last2[(F.T, h)] = F.f
            self.type.append(F.T)
            self.flags.append(F.f)
            self.children.append([(sl[0], sl[1], sl[2]) for sl in F.slots])
            lst = self.of_type.setdefault(F.T, [])
            self.rank.append(len(lst))
            lst.append(s)
            self.uses.append(0)
            self.last_orient.append(0)
            if F.T == 6:
                for c, _, _ in self.children[s]:
                    inc = self.incident.setdefault(c, [])
                    if s not in inc:
                        inc.append(s)
                        del inc[:-16]
            if F.parent is not None:
                P = F.parent
                sl = P.slots[F.pos]
                sl[0], sl[3] = s, 0
                self.used(P, s, sl[1])
        if len(self.type) != self.S or self.refs != self.C:
            raise ReadError("SHAP: counts")
        if self.rc.pos != len(self.rc.s):
            raise ReadError("SHAP: stream not read to its end")
        return Shapes(self.type, self.flags, self.children, (self.S - 1, root_orient, root_loc))

    def wire_child(self, F: _Frame, U: int, chain: int | None, p: int | None) -> None:
        rc = self.rc
        j = len(F.slots)
        cand: list[int] = []
        if U == 6 and chain is not None:
            cand = [
                e
                for e in reversed(self.incident.get(chain, []))
                if self.uses[e] % 2 == 1 and e != p
            ]
        pend = [~k for k in reversed(F.news[-4:]) if F.slots[k][4] == U]
        ctx = (5, U, int(chain is not None), min(len(cand), 2), int(bool(pend)))
        if rc.bit(("s", *ctx)) == 1:
            base = self.ranked(U, cand)
            rank = cand + pend + base[len(cand) :]
            s = self.choose(ctx, U, rank, F.news)
            if s < 0:
                k = ~s
                o = rc.tree(("o", 5, U, 2, F.slots[k][1]), 2)
                loc = self.location(5, U)
                F.slots.append([k, o, loc, 2, U])
            else:
                lo = self.last_orient[s]
                pred = flip(reverse(lo) if U == 6 else lo, F.flip)
                o = rc.tree(("o", 5, U, 1, pred), 2)
                loc = self.location(5, U)
                F.slots.append([s, o, loc, 0, U])
                self.used(F, s, o)
        else:
            o = rc.tree(("o", 5, U, 0, F.slots[j - 1][1] if j > 0 else 4), 2)
            loc = self.location(5, U)
            self.reserve()
            F.news.append(j)
            F.slots.append([None, o, loc, 1, U])
