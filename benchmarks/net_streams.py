"""What the coded nets' integers cost under other entropy coders (issue 28 item 4).

``python benchmarks/net_streams.py [--tol 0.01] [--keep DIR]`` compresses every
CAD file of the corpus (``../shared/corpus``) at ``--tol`` (or reads the
containers ``--keep DIR`` holds, made by an earlier run), reads each
container's ``SNET`` and ``CNET`` tables back (``serialize.read_sections``),
labels each coded net's integers by what they code (a pole's residual on the
first row or inside the net, a DCT coefficient by its frequency, the corners
and ends against their origin, copies) and prints, per section and corpus
total, bits per coded pole under:

- ``xz``: the section compressed alone by xz -9e (what ``benchmarks/sections.py``
  reports; .xz framing included);
- ``xz ints``: the integers array alone, as the section lays it out;
- ``exp-golomb``: ``codec.cost_bits``, the search's proxy;
- ``order-0``: the empirical entropy of the integers per label (a static
  model's table not counted);
- ``adaptive``: an adaptive binary arithmetic coder (``netcoder``'s model:
  zero flag, sign, Exp-Golomb classes and mantissa bits, each with a
  probability adapted after every bit), with the contexts named.

The coded format is not changed: it measures what each coder would pay.
"""

from __future__ import annotations

import argparse
import lzma
import math
import tempfile
from collections import Counter, defaultdict
from pathlib import Path

import numpy as np

from nurbscomp import codec, container, pipeline, serialize

ROOT = Path(__file__).resolve().parent.parent
CORPUS = ROOT.parent / "shared" / "corpus"
CAD = (".step", ".stp", ".igs", ".iges")


def xz(raw: bytes) -> int:
    return len(lzma.compress(raw, preset=9 | lzma.PRESET_EXTREME))


def nets_of(path: Path) -> tuple[dict[str, bytes], list[dict]]:
    """The SNET and CNET sections of a container, and per coded net its
    table, method, shape and integers."""
    c = container.unpack(path.read_bytes())
    m, _, t = serialize.read_sections(c.get, c.revision, None)
    out = []
    for tag, table, rows in (
        ("SNET", t.snet, serialize.coded_rows(m.surfaces)),
        ("CNET", t.cnet, serialize.coded_rows(m.curves3d)),
    ):
        recs = m.surfaces if tag == "SNET" else m.curves3d
        for k, row in enumerate(rows):
            out.append(
                {
                    "tag": tag,
                    "method": int(table.method[k]),
                    "level": int(table.level[k]),
                    "shape": recs[row].poles.shape,
                    "ints": np.asarray(table.ints[k], np.int64),
                }
            )
    return {"SNET": c.get("SNET"), "CNET": c.get("CNET")}, out


def poles(net: dict) -> int:
    s = net["shape"]
    return int(np.prod(s[:-1]))


# ---------------------------------------------------------------- labelling


def _bucket(k: int) -> int:
    return 0 if k == 0 else 1 if k == 1 else 2 if k < 4 else 3


def label(net: dict) -> list[tuple[str, int, tuple[int, ...]]]:
    """Per integer: (label, value, neighbour values) in storage order.  The
    neighbours are integers stored before it that a decoder has: for a grid
    residual the same coordinate one pole back in u and in v and the previous
    coordinate of the same pole; for a DCT coefficient the previous one of
    the same coordinate."""
    q = net["ints"].tolist()
    m = codec.Method(net["method"])
    shape = net["shape"]
    out: list[tuple[str, int, tuple[int, ...]]] = []
    if m in (codec.Method.ISO, codec.Method.COPY):
        return [("copy", v, ()) for v in q]
    if m in (codec.Method.SPATIAL, codec.Method.SPATIAL2, codec.Method.DELTA):
        if len(shape) == 2:
            shape = (shape[0], 1, shape[1])
        nu, nv, c = shape
        r = np.asarray(q).reshape(nu, nv, c)
        name = {0: "par", 10: "ext", 3: "delta"}[int(m)]
        for i in range(nu):
            for j in range(nv):
                for k in range(c):
                    if i == 0 and j == 0:
                        lab = "origin"
                    elif i < 2 and j < 2 and not (nv == 1):
                        lab = f"{name}.head"
                    elif (i < 2 or j < 2) and nv > 1:
                        lab = f"{name}.edge"
                    elif nv == 1 and i < 2:
                        lab = f"{name}.head"
                    else:
                        lab = f"{name}.in"
                    nb = (
                        int(r[i - 1, j, k]) if i else 0,
                        int(r[i, j - 1, k]) if j else 0,
                        int(r[i, j, k - 1]) if k else 0,
                    )
                    out.append((lab, int(r[i, j, k]), nb))
        return out
    # DCT methods: corners / ends, then curves, then the DD-map
    pos = 0

    def take(n: int) -> list[int]:
        nonlocal pos
        x = q[pos : pos + n]
        pos += n
        return x

    def curve(n_inner: int, what: str) -> None:
        vals = np.asarray(take(n_inner * 3)).reshape(n_inner, 3) if n_inner else np.zeros((0, 3))
        for i in range(n_inner):
            for k in range(3):
                nb = (int(vals[i - 1, k]) if i else 0, 0, int(vals[i, k - 1]) if k else 0)
                out.append((f"{what}.f{_bucket(i)}", int(vals[i, k]), nb))

    if m == codec.Method.CHORD:
        for v in take(6):
            out.append(("ends", v, ()))
        curve(shape[0] - 2, "chord")
    else:
        nu, nv = shape[:2]
        for v in take(12):
            out.append(("corners", v, ()))
        for n in (nv, nv, nu, nu):
            curve(max(n - 2, 0), "bcurve")
        rest = take(len(q) - pos)
        if rest:
            nc = 1 if m == codec.Method.DMAP else 3
            a, b = nu - 2, nv - 2
            d = np.asarray(rest).reshape(a, b, nc)
            for i in range(a):
                for j in range(b):
                    for k in range(nc):
                        nb = (
                            int(d[i - 1, j, k]) if i else 0,
                            int(d[i, j - 1, k]) if j else 0,
                            int(d[i, j, k - 1]) if k else 0,
                        )
                        out.append((f"ddmap.f{_bucket(i + j)}", int(d[i, j, k]), nb))
    assert pos == len(q), (m, shape, pos, len(q))
    return out


# ---------------------------------------------------------------- coders


def order0(labelled: list[tuple[str, int, tuple[int, ...]]]) -> float:
    """Empirical entropy in bits, per label (a static model's table not counted)."""
    by: dict[str, Counter[int]] = defaultdict(Counter)
    for lab, v, _ in labelled:
        by[lab][v] += 1
    bits = 0.0
    for cnt in by.values():
        n = sum(cnt.values())
        bits -= sum(c * math.log2(c / n) for c in cnt.values())
    return bits


class Adaptive:
    """Ideal code length of an adaptive binary arithmetic coder: 16-bit
    probabilities, each the mean of a fast (shift ``fast``) and a slow (shift
    ``slow``) estimate, updated after each bit."""

    def __init__(self, fast: int = 4, slow: int = 7) -> None:
        self.p: dict[object, list[int]] = {}
        self.fast, self.slow = fast, slow
        self.bits = 0.0

    def bit(self, ctx: object, b: int) -> None:
        s = self.p.get(ctx)
        if s is None:
            s = self.p[ctx] = [1 << 15, 1 << 15]
        p0 = (s[0] + s[1]) >> 1
        p = p0 if b == 0 else 65536 - p0
        self.bits -= math.log2(max(p, 1) / 65536)
        if b == 0:
            s[0] += (65536 - s[0]) >> self.fast
            s[1] += (65536 - s[1]) >> self.slow
        else:
            s[0] -= s[0] >> self.fast
            s[1] -= s[1] >> self.slow

    def value(self, ctx: object, v: int) -> None:
        """Zero flag, sign, then |v|-1 in Exp-Golomb classes (unary, adaptive)
        and mantissa bits (adaptive on the class and bit position)."""
        self.bit((ctx, "z"), int(v != 0))
        if v == 0:
            return
        self.bit((ctx, "s"), int(v < 0))
        a = abs(v) - 1
        k = a.bit_length()  # class: a in [2^(k-1), 2^k)
        for i in range(k):
            self.bit((ctx, "c", min(i, 20)), 1)
        if k < 40:
            self.bit((ctx, "c", min(k, 20)), 0)
        for i in range(k - 2, -1, -1):
            self.bit((ctx, "m", k, min(k - 2 - i, 2)), (a >> i) & 1)


def magnitude_class(nb: tuple[int, ...]) -> int:
    """A context from neighbour residuals: the class of their mean magnitude."""
    if not nb:
        return 0
    s = sum(abs(x) for x in nb)
    return min(s.bit_length(), 6)


def adaptive_bits(
    labelled: list[tuple[str, int, tuple[int, ...]]], use_label: bool, use_nb: bool, **kw: int
) -> float:
    coder = Adaptive(**kw)
    for lab, v, nb in labelled:
        ctx = (lab if use_label else "", magnitude_class(nb) if use_nb else 0)
        coder.value(ctx, v)
    return coder.bits


# ---------------------------------------------------------------- main


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tol", type=float, default=0.01)
    ap.add_argument("--keep", type=Path, help="containers made earlier (or to keep)")
    args = ap.parse_args()
    files = sorted(p for p in CORPUS.iterdir() if p.suffix.lower() in CAD)
    rows: dict[str, dict[str, float]] = {t: defaultdict(float) for t in ("SNET", "CNET")}
    by_method: dict[tuple[str, int], list[float]] = defaultdict(lambda: [0, 0, 0.0])
    with tempfile.TemporaryDirectory() as tmp:
        folder = args.keep or Path(tmp)
        folder.mkdir(parents=True, exist_ok=True)
        for f in files:
            dst = folder / f"{f.name}.{args.tol:g}.nzc"
            if not dst.exists():
                pipeline.compress_file(
                    f, dst, tol=args.tol, lossless=False, force=True, verify=False
                )
            sections, nets = nets_of(dst)
            for tag in ("SNET", "CNET"):
                mine = [n for n in nets if n["tag"] == tag]
                r = rows[tag]
                r["poles"] += sum(poles(n) for n in mine)
                r["xz"] += 8 * xz(sections[tag])
                ints = np.concatenate([n["ints"] for n in mine]) if mine else np.zeros(0)
                from nurbscomp.streams import BlockWriter

                w = BlockWriter()
                w.ints(ints)
                r["xz ints"] += 8 * xz(bytes(w))
                r["exp-golomb"] += sum(codec.cost_bits(n["ints"]) for n in mine)
                lab = [x for n in mine for x in label(n)]
                r["order-0"] += order0(lab)
                r["adaptive, one context"] += adaptive_bits(lab, False, False)
                r["adaptive, by label"] += adaptive_bits(lab, True, False)
                r["adaptive, by label + neighbours"] += adaptive_bits(lab, True, True)
                r["adaptive, by label + neighbours (4/6)"] += adaptive_bits(
                    lab, True, True, fast=4, slow=6
                )
                for n in mine:
                    b = by_method[(tag, n["method"])]
                    b[0] += 1
                    b[1] += poles(n)
                    b[2] += codec.cost_bits(n["ints"])
    for tag, r in rows.items():
        print(f"## {tag} ({int(r['poles']):,} coded poles)\n")
        print("| coder | bytes | bits/pole |\n|---|---:|---:|")
        for k, v in r.items():
            if k != "poles":
                print(f"| {k} | {v / 8:,.0f} | {v / r['poles']:.2f} |")
        print()
    total = {k: rows["SNET"][k] + rows["CNET"][k] for k in rows["SNET"]}
    print(f"## SNET + CNET ({int(total['poles']):,} coded poles)\n")
    print("| coder | bytes | bits/pole |\n|---|---:|---:|")
    for k, v in total.items():
        if k != "poles":
            print(f"| {k} | {v / 8:,.0f} | {v / total['poles']:.2f} |")
    print("\n## By method (Exp-Golomb bits)\n")
    print("| table | method | nets | poles | exp-golomb bits/pole |\n|---|---|---:|---:|---:|")
    for (tag, meth), (n, p, b) in sorted(by_method.items()):
        name = codec.Method(meth).name
        print(f"| {tag} | {name} | {n:,} | {p:,} | {b / max(p, 1):.2f} |")


if __name__ == "__main__":
    main()
