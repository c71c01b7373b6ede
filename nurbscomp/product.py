"""Product data (format 1.2): the assembly tree, names, colours, layers and
the STEP header, as plain numpy data, and its ``PROD`` section.

OCCT's XDE document (``nurbscomp.occ.xcaf`` reads and writes it) holds a
tree of labels.  Here each label is a *node*:

* a **product** (kind 0): a part or an assembly, stored once however often
  it is used; a part refers to its shape's row of the ``SHAP`` table;
* an **instance** (kind 1): a use of a product inside an assembly, with its
  placement;
* a **sub-shape** (kind 2): a face, edge or solid of a part that carries a
  name or a colour of its own (``SHAP`` row, orientation, placement).

Colours are RGBA in OCCT's linear RGB (``Quantity_TOC_RGB``), one table
shared by the nodes; each node has up to three (generic, surface, curve).
Placements are 3 x 4 matrices stored as float64, exact in every mode.
Nothing here imports OCP.  docs/format.md §2.11 specifies the section.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .errors import BadReferenceError, SectionError
from .streams import BlockReader, BlockWriter

PRODUCT, INSTANCE, SUBSHAPE = 0, 1, 2
KIND_NAMES = ("product", "instance", "sub-shape")
#: Colour types, numbered as ``XCAFDoc_ColorType``.
COLOUR_TYPES = ("generic", "surface", "curve")
#: The STEP header's fields, in the order PROD stores them (each a list of strings).
HEADER_FIELDS = (
    "schema",
    "name",
    "time_stamp",
    "author",
    "organization",
    "preprocessor_version",
    "originating_system",
    "authorisation",
    "description",
    "implementation_level",
)
#: Node flags.
NAMED, HIDDEN = 1, 2
#: Longest string (bytes of UTF-8) a reader accepts.
MAX_STRING = 1 << 16
#: Largest |value| of a placement matrix entry (OCCT's ``Precision::Infinite()``).
MAX_COORD = 2e100
#: ``gp_TrsfForm`` values.
N_FORMS = 8


@dataclass
class ProductData:
    """The product structure of a CAD file.

    Attributes
    ----------
    kind, parent, ref, orient, place, flags : ndarray of int64, shape (N,)
        Per node: its kind; the product node it belongs to (-1 for
        products); a product's or sub-shape's ``SHAP`` row (-1: none, e.g.
        an assembly) or an instance's product node; the ``TopAbs``
        orientation of its shape; its placement (-1: identity); flags
        (``NAMED``, ``HIDDEN``).
    colour : ndarray of int64, shape (N, 3)
        Generic, surface and curve colour of each node (-1: none).
    names : list of str
        Per node ("" where not ``NAMED``).
    forms : ndarray of int64, shape (P,)
        ``gp_TrsfForm`` of each placement.
    placements : ndarray, shape (P, 3, 4)
    colours : ndarray, shape (C, 4)
        RGBA, linear RGB.
    layer_names : list of str
    layer_hidden : ndarray of bool, shape (L,)
    layer_members : list of list of int
        Node indices per layer.
    header : dict of str to list of str
        The STEP header's fields (``HEADER_FIELDS``); empty for IGES.
    dropped : list of str
        What the source held that the container does not keep.
    """

    kind: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    parent: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    ref: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    orient: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    place: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    flags: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    colour: np.ndarray = field(default_factory=lambda: np.zeros((0, 3), np.int64))
    names: list[str] = field(default_factory=list)
    forms: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    placements: np.ndarray = field(default_factory=lambda: np.zeros((0, 3, 4)))
    colours: np.ndarray = field(default_factory=lambda: np.zeros((0, 4)))
    layer_names: list[str] = field(default_factory=list)
    layer_hidden: np.ndarray = field(default_factory=lambda: np.zeros(0, bool))
    layer_members: list[list[int]] = field(default_factory=list)
    header: dict[str, list[str]] = field(default_factory=dict)
    dropped: list[str] = field(default_factory=list)

    def __len__(self) -> int:
        return len(self.kind)

    def children(self, node: int) -> list[int]:
        """Instances and sub-shapes of a product node, in order."""
        return np.flatnonzero(self.parent == node).tolist()

    def same(self, other: ProductData) -> bool:
        """True if both hold the same values, bit for bit."""
        return _key(self) == _key(other)


def _key(p: ProductData) -> tuple[Any, ...]:
    arrays = (p.kind, p.parent, p.ref, p.orient, p.place, p.flags, p.colour, p.forms)
    return (
        tuple(np.asarray(a, np.int64).tobytes() for a in arrays),
        np.asarray(p.placements, "<f8").tobytes(),
        np.asarray(p.colours, "<f8").tobytes(),
        tuple(p.names),
        tuple(p.layer_names),
        np.asarray(p.layer_hidden, bool).tobytes(),
        tuple(tuple(m) for m in p.layer_members),
        tuple((k, tuple(p.header.get(k, []))) for k in HEADER_FIELDS),
        tuple(p.dropped),
    )


# ---------------------------------------------------------------- section PROD


#: ``SHAP``'s references (``child_start``, ``child_shape``): what the format
#: 2.3 layout of ``ref`` numbers a sub-shape's shape by (:func:`walk`).
Shapes = tuple[np.ndarray, np.ndarray]


def write(p: ProductData, shapes: Shapes | None = None) -> bytes:
    """The ``PROD`` section of ``p`` (docs/format.md §2.11): with ``shapes``
    (``SHAP``'s references) in the layout of format 2.3, whose ``ref`` holds
    a sub-shape's place in its product's :func:`walk` and is written as
    differences; without, in the layout of formats 1.2 to 2.2."""
    w = BlockWriter()
    n = len(p)
    named = [s for s, f in zip(p.names, p.flags.tolist()) if f & NAMED]
    header = [p.header.get(k, []) for k in HEADER_FIELDS]
    w.ints([n, len(p.forms), len(p.colours), len(p.layer_names), len(p.dropped)])
    w.ints(p.kind)
    w.ints(p.parent)
    if shapes is None:
        w.ints(p.ref)
    else:
        w.deltas(_ref_values(p, shapes))
    for a in (p.orient, p.place, p.flags):
        w.ints(a)
    w.ints(np.asarray(p.colour, np.int64).reshape(n * 3))
    w.ints(p.forms)
    w.floats(np.asarray(p.placements).reshape(-1))
    w.floats(np.asarray(p.colours).reshape(-1))
    w.ints(np.asarray(p.layer_hidden, np.int64))
    w.ints([len(m) for m in p.layer_members])
    w.ints([x for m in p.layer_members for x in m])
    w.ints([len(h) for h in header])
    strings = [s.encode("utf-8") for s in [*named, *p.layer_names, *sum(header, []), *p.dropped]]
    w.ints([len(s) for s in strings])
    w.ints(np.frombuffer(b"".join(strings), np.uint8))
    return bytes(w)


def walk(shapes: Shapes, root: int, upto: int, limit: int | None = None) -> tuple[list[int], int]:
    """The first ``upto`` (≥ 1) shapes of the walk of ``root`` (format 2.3),
    and its work: depth first from ``root``, each child reference in
    ``SHAP`` order, a shape numbered when first reached (pre-order; a shape
    reached again is passed over).  Fewer where fewer are reached.  The work
    is the shapes numbered plus the references looked at, which is what a
    reader bounds (:func:`walk_budget`); the walk stops once it passes
    ``limit``."""
    start, child = shapes
    order, seen, work = [root], {root}, 1
    stack = [[root, int(start[root])]]
    while stack and len(order) < upto and (limit is None or work <= limit):
        top = stack[-1]
        s, i = top
        if i == start[s + 1]:
            stack.pop()
            continue
        top[1] = i + 1
        c = int(child[i])
        work += 1
        if c not in seen:
            seen.add(c)
            order.append(c)
            work += 1
            stack.append([c, int(start[c])])
    return order, work


def walk_budget(shapes: Shapes) -> int:
    """The most work all the walks of one ``PROD`` section may take: as many
    steps as ``SHAP`` has shapes and references (parts whose shapes share
    nothing never need more)."""
    return len(shapes[0]) - 1 + len(shapes[1])


def _ref_values(p: ProductData, shapes: Shapes) -> np.ndarray:
    """``ref`` as format 2.3 stores it: a sub-shape's shape as its place in
    the walk of its product's shape where it is in it, else as −1 − its row;
    the other nodes' as they are.  The walks' work is bounded
    (:func:`walk_budget`): once a product's walk, as far as its sub-shapes
    need, would pass it, that product's sub-shapes are written as rows."""
    out = np.array(p.ref, np.int64)
    sub = np.flatnonzero(p.kind == SUBSHAPE)
    by_root: dict[int, list[int]] = {}
    for i in sub.tolist():
        by_root.setdefault(int(p.ref[p.parent[i]]), []).append(i)
    out[sub] = -1 - out[sub]
    budget = walk_budget(shapes)
    nshapes = len(shapes[0]) - 1
    for root, nodes in by_root.items():
        if not 0 <= root < nshapes:
            continue
        rank = {s: k for k, s in enumerate(walk(shapes, root, nshapes)[0])}
        ranks = [rank.get(int(p.ref[i]), -1) for i in nodes]
        if max(ranks) < 0:
            continue
        work = walk(shapes, root, max(ranks) + 1)[1]
        if work > budget:
            continue
        budget -= work
        for i, k in zip(nodes, ranks):
            if k >= 0:
                out[i] = k
    return out


def _refs_from_values(
    kind: np.ndarray, parent: np.ndarray, values: np.ndarray, shapes: Shapes
) -> np.ndarray:
    """Inverse of :func:`_ref_values` (``parent`` already checked: every
    non-product's parent is a product node)."""
    ref = np.array(values, np.int64)
    sub = np.flatnonzero(kind == SUBSHAPE)
    escaped, ranked = sub[ref[sub] < 0], sub[ref[sub] >= 0]
    ref[escaped] = -1 - ref[escaped]
    if not len(ranked):
        return ref
    nshapes = len(shapes[0]) - 1
    roots = ref[parent[ranked]]
    if (roots < 0).any() or (roots >= nshapes).any():
        raise BadReferenceError("PROD: a sub-shape is numbered in a product with no shape")
    need: dict[int, int] = {}
    for r, k in zip(roots.tolist(), ref[ranked].tolist()):
        need[r] = max(need.get(r, 0), k + 1)
    budget = walk_budget(shapes)
    if sum(need.values()) > budget:  # each shape numbered is a step of work
        raise BadReferenceError("PROD: the sub-shapes' walks take more work than SHAP allows")
    for r, upto in need.items():
        order, work = walk(shapes, r, upto, budget)
        budget -= work
        if budget < 0:
            raise BadReferenceError("PROD: the sub-shapes' walks take more work than SHAP allows")
        if len(order) < upto:
            raise BadReferenceError(f"PROD: a sub-shape's place is past the walk of shape {r}")
        at = ranked[roots == r]
        ref[at] = np.asarray(order, np.int64)[ref[at]]
    return ref


def _within(a: np.ndarray, lo: int, hi: int, what: str) -> None:
    if len(a) and (a.min() < lo or a.max() >= hi):
        at = int(np.flatnonzero((a < lo) | (a >= hi))[0])
        raise BadReferenceError(f"PROD: {what} (entry {at}) refers to a missing entry")


def _counted(r: BlockReader, n: int, where: str) -> None:
    if n < 0 or n > r.remaining:
        raise SectionError(f"PROD: {where} count {n} is negative or larger than the section")


def read(data: bytes, nshapes: int, shapes: Shapes | None = None) -> ProductData:
    """Read a ``PROD`` section; check every count, index and string.

    ``nshapes`` is the number of rows of the model's ``SHAP`` table;
    ``shapes``, its references, for the layout of format 2.3 (:func:`write`).

    Raises
    ------
    SectionError
        Arrays, counts, values or strings that do not decode.
    BadReferenceError
        An index outside its table, a node of the wrong kind, or an
        assembly that contains itself.
    """
    r = BlockReader(data, "PROD")
    n, npl, nc, nl, nd = (int(x) for x in r.ints(5))
    for what, k in (("node", n), ("placement", npl), ("colour", nc), ("layer", nl)):
        _counted(r, k, what)
    _counted(r, nd, "dropped")
    kind, parent = r.ints(n), r.ints(n)
    ref = r.ints(n) if shapes is None else r.deltas(n)
    orient, place, flags = r.ints(n), r.ints(n), r.ints(n)
    colour = r.ints(3 * n).reshape(n, 3)
    forms = r.ints(npl)
    placements = r.floats(12 * npl).reshape(npl, 3, 4)
    colours = r.floats(4 * nc).reshape(nc, 4)
    layer_hidden = r.ints(nl)
    per_layer = r.ints(nl)
    if nl and (per_layer.min() < 0 or sum(per_layer.tolist()) > r.remaining):
        raise SectionError("PROD: layer member counts are negative or larger than the section")
    members = r.ints(int(sum(per_layer.tolist())))
    per_field = r.ints(len(HEADER_FIELDS))
    if per_field.min() < 0 or sum(per_field.tolist()) > r.remaining:
        raise SectionError("PROD: header string counts are negative or larger than the section")
    nnamed = int(((flags & NAMED) != 0).sum())
    ns = nnamed + nl + int(sum(per_field.tolist())) + nd
    _counted(r, ns, "string")
    lengths = r.ints(ns)
    if ns and (lengths.min() < 0 or lengths.max() > MAX_STRING):
        raise SectionError(f"PROD: a string is longer than {MAX_STRING} bytes or negative")
    if sum(lengths.tolist()) > r.remaining:
        raise SectionError("PROD: string lengths add up to more than the section holds")
    raw = r.ints(int(sum(lengths.tolist())))
    r.done()
    if len(raw) and (raw.min() < 0 or raw.max() > 255):
        raise SectionError("PROD: a string byte is not a byte")
    blob = raw.astype(np.uint8).tobytes()
    strings, at = [], 0
    for k, ln in enumerate(lengths.tolist()):
        try:
            strings.append(blob[at : at + ln].decode("utf-8"))
        except UnicodeDecodeError:
            raise SectionError(f"PROD: string {k} is not UTF-8") from None
        at += ln
    # values
    if n and (kind.min() < 0 or kind.max() > SUBSHAPE):
        raise SectionError("PROD: unknown node kind")
    if n and (orient.min() < 0 or orient.max() > 3):
        raise SectionError("PROD: orientation out of range")
    if n and (flags.min() < 0 or flags.max() > NAMED | HIDDEN):
        raise SectionError("PROD: unknown node flag")
    if npl and (forms.min() < 0 or forms.max() >= N_FORMS):
        raise SectionError("PROD: unknown placement form")
    with np.errstate(invalid="ignore"):
        if npl and not (np.abs(placements) < MAX_COORD).all():
            raise SectionError("PROD: a placement value is not finite or out of range")
        if nc and not ((colours >= 0) & (colours <= 1)).all():
            raise SectionError("PROD: a colour component is not within [0, 1]")
    if nl and (layer_hidden.min() < 0 or layer_hidden.max() > 1):
        raise SectionError("PROD: a layer flag is not 0 or 1")
    # references
    prod = kind == PRODUCT
    inst = kind == INSTANCE
    if (parent[prod] != -1).any():
        raise BadReferenceError("PROD: a product node has a parent")
    _within(parent[~prod], 0, n, "a node's parent")
    if (~prod).any() and (kind[parent[~prod]] != PRODUCT).any():
        raise BadReferenceError("PROD: a node's parent is not a product")
    if shapes is not None:
        ref = _refs_from_values(kind, parent, ref, shapes)
    _within(ref[prod], -1, nshapes, "a product's shape")
    _within(ref[kind == SUBSHAPE], 0, nshapes, "a sub-shape's shape")
    _within(ref[inst], 0, n, "an instance's product")
    if inst.any() and (kind[ref[inst]] != PRODUCT).any():
        raise BadReferenceError("PROD: an instance refers to a node that is not a product")
    _within(place, -1, npl, "a placement")
    _within(colour.reshape(-1), -1, nc, "a colour")
    _within(members, 0, n, "a layer member")
    _acyclic(kind, parent, ref)
    names = []
    it = iter(strings)
    for f in flags.tolist():
        names.append(next(it) if f & NAMED else "")
    layer_names = [next(it) for _ in range(nl)]
    header = {k: [next(it) for _ in range(c)] for k, c in zip(HEADER_FIELDS, per_field.tolist())}
    dropped = list(it)
    bounds = np.concatenate([[0], np.cumsum(per_layer)]).tolist()
    return ProductData(
        kind=kind,
        parent=parent,
        ref=ref,
        orient=orient,
        place=place,
        flags=flags,
        colour=colour,
        names=names,
        forms=forms,
        placements=placements,
        colours=colours,
        layer_names=layer_names,
        layer_hidden=layer_hidden.astype(bool),
        layer_members=[members[a:b].tolist() for a, b in zip(bounds[:-1], bounds[1:])],
        header={k: v for k, v in header.items() if v},
        dropped=dropped,
    )


def _acyclic(kind: np.ndarray, parent: np.ndarray, ref: np.ndarray) -> None:
    """Raise ``BadReferenceError`` if an assembly contains itself (through instances)."""
    uses: dict[int, list[int]] = {}
    for i in np.flatnonzero(kind == INSTANCE).tolist():
        uses.setdefault(int(parent[i]), []).append(int(ref[i]))
    state: dict[int, int] = {}  # 1 on the path, 2 done
    for start in uses:
        if state.get(start):
            continue
        stack = [(start, iter(uses.get(start, [])))]
        state[start] = 1
        while stack:
            node, it = stack[-1]
            nxt = next(it, None)
            if nxt is None:
                state[node] = 2
                stack.pop()
            elif state.get(nxt) == 1:
                raise BadReferenceError(f"PROD: product node {nxt} contains itself")
            elif not state.get(nxt):
                state[nxt] = 1
                stack.append((nxt, iter(uses.get(nxt, []))))


# ---------------------------------------------------------------- summaries


def depth(p: ProductData) -> int:
    """Levels of the deepest product tree (1: a single part)."""
    memo: dict[int, int] = {}
    kids: dict[int, list[int]] = {}
    for i in np.flatnonzero(p.kind == INSTANCE).tolist():
        kids.setdefault(int(p.parent[i]), []).append(int(p.ref[i]))
    order = _post_order(kids, np.flatnonzero(p.kind == PRODUCT).tolist())
    for x in order:
        memo[x] = 1 + max((memo[c] for c in kids.get(x, [])), default=0)
    return max(memo.values(), default=0)


def _post_order(kids: dict[int, list[int]], roots: list[int]) -> list[int]:
    out, seen = [], set()
    for r in roots:
        if r in seen:
            continue
        stack = [(r, iter(kids.get(r, [])))]
        seen.add(r)
        while stack:
            x, it = stack[-1]
            c = next(it, None)
            if c is None:
                out.append(x)
                stack.pop()
            elif c not in seen:
                seen.add(c)
                stack.append((c, iter(kids.get(c, []))))
    return out


def summary(p: ProductData) -> dict[str, Any]:
    """Counts for ``nurbscomp info``: parts, assemblies, instances, depth,
    coloured nodes, colours, layers, schema, what was dropped."""
    prod = np.flatnonzero(p.kind == PRODUCT)
    assemblies = {int(p.parent[i]) for i in np.flatnonzero(p.kind == INSTANCE).tolist()}
    coloured = Counter(
        KIND_NAMES[int(p.kind[i])] for i in range(len(p)) if (p.colour[i] >= 0).any()
    )
    return {
        "products": len(prod),
        "parts": len(prod) - len(assemblies),
        "assemblies": len(assemblies),
        "instances": int((p.kind == INSTANCE).sum()),
        "sub_shapes": int((p.kind == SUBSHAPE).sum()),
        "depth": depth(p),
        "named": int(((p.flags & NAMED) != 0).sum()),
        "colours": len(p.colours),
        "coloured": dict(sorted(coloured.items())),
        "layers": len(p.layer_names),
        "schema": p.header.get("schema", []),
        "dropped": p.dropped,
    }


def tree(p: ProductData) -> dict[str, Any]:
    """The whole product data as JSON-ready objects (``nurbscomp info --json``)."""

    def colours(i: int) -> dict[str, list[float]]:
        return {
            t: p.colours[c].tolist() for t, c in zip(COLOUR_TYPES, p.colour[i].tolist()) if c >= 0
        }

    def node(i: int) -> dict[str, Any]:
        out: dict[str, Any] = {"node": i, "kind": KIND_NAMES[int(p.kind[i])]}
        if p.flags[i] & NAMED:
            out["name"] = p.names[i]
        if p.kind[i] == INSTANCE:
            out["product"] = int(p.ref[i])
        elif p.ref[i] >= 0:
            out["shape_row"] = int(p.ref[i])
        if p.place[i] >= 0:
            out["placement"] = p.placements[p.place[i]].tolist()
        if (p.colour[i] >= 0).any():
            out["colours"] = colours(i)
        if p.flags[i] & HIDDEN:
            out["hidden"] = True
        kids = p.children(i)
        if kids:
            out["children"] = [node(c) for c in kids]
        return out

    return {
        "products": [node(int(i)) for i in np.flatnonzero(p.kind == PRODUCT).tolist()],
        "layers": [
            {"name": n, "hidden": bool(h), "members": m}
            for n, h, m in zip(p.layer_names, p.layer_hidden.tolist(), p.layer_members)
        ],
        "header": p.header,
        "dropped": p.dropped,
    }
