"""The import graph (issue 31): no cycles, OCP only in ``occ/``, click only in
``cli.py``, and every import runs from a higher layer to a lower one.

Imports inside functions count (they are how a lazy import hides a cycle);
``if TYPE_CHECKING:`` blocks do not (they never run)."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PKG = Path(__file__).resolve().parent.parent / "nurbscomp"

#: Layers, lowest first; a module may import its own layer and those below.
#: ``decode``, ``encode`` and ``occ`` are side by side: none imports another,
#: but for :data:`SIDEWAYS` (what both sides run lives below them, in
#: ``codec``, ``rules`` and the format layer; the wiring sees all three).
LAYERS: list[tuple[str, set[str]]] = [
    (
        "base",
        {
            "errors", "formats", "units", "model", "lazy", "signals", "_version", "report",
            "bspline", "coons", "dct", "dmap", "spatial", "streams", "entropy", "budget",
            "topocode", "product", "heatmap", "nearby", "memo",
        },
    ),
    ("codec", {"codec", "codec.coder", "codec.search", "rules.joins"}),
    ("format", {"container", "serialize", "serialize.limits", "serialize.geometry",
                "serialize.topology", "serialize.vertices", "serialize.edges", "serialize.nets",
                "serialize.meta", "serialize.sections", "text", "text.coding", "text.step",
                "text.iges", "text.numbers", "text.columns",
                "rules", "rules.nets", "rules.ranges", "writer"}),
    ("sides", {"decode", "encode", "encode.analytic", "encode.assembly", "encode.nets",
               "encode.pcurves", "encode.validity", "encode.coincide", "encode.weights",
               "encode.knots", "encode.removal", "encode.deviation", "encode.offsets",
               "encode.placed", "encode.canonical",
               "occ", "occ.cq", "occ.exchange",
               "occ.files", "occ.geometry", "occ.isolated", "occ.lists", "occ.measure",
               "occ.mesh", "occ.topology", "occ.xcaf", "occ.bintools", "occ.approx"}),
    ("wiring", {"paths", "passthrough", "stages", "stages.common", "stages.decompress",
                "stages.compress", "stages.evaluate", "pipeline", "_api", "batch", "", "cli",
                "__main__"}),
]  # fmt: skip
#: Imports across the sides that stay allowed: the validity stage builds and
#: checks shapes with OCCT.
SIDEWAYS = {("encode.validity", "occ")}
#: Wrong-way imports not yet removed: none (the net bases and edge-range rules
#: both sides run are in ``rules``, the writer's tables in ``writer``).
KNOWN: set[str] = set()


def module_names() -> dict[str, Path]:
    out = {}
    for p in PKG.rglob("*.py"):
        parts = p.relative_to(PKG).with_suffix("").parts
        name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        out[name] = p
    return out


def _runtime_nodes(tree: ast.AST):
    """Every node but those under ``if TYPE_CHECKING:``."""
    todo = [tree]
    while todo:
        node = todo.pop()
        yield node
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.If) and ast.unparse(child.test).endswith("TYPE_CHECKING"):
                todo.extend(child.orelse)
                continue
            todo.append(child)


def imports(name: str, path: Path, names: set[str]) -> tuple[set[str], set[str]]:
    """(modules of the package, top-level outside packages) that ``name`` imports."""
    pkg = name if path.name == "__init__.py" else name.rpartition(".")[0]
    inside, outside = set(), set()
    for node in _runtime_nodes(ast.parse(path.read_text())):
        found: list[str] = []
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = pkg.split(".") if pkg else []
                base = base[: len(base) - node.level + 1]
                mod = ".".join(base + ([node.module] if node.module else []))
                found = [f"{mod}.{a.name}".strip(".") for a in node.names] + [mod]
            elif node.module and node.module.split(".")[0] == "nurbscomp":
                mod = node.module.partition(".")[2]
                found = [f"{mod}.{a.name}".strip(".") for a in node.names] + [mod]
            elif node.module:
                outside.add(node.module.split(".")[0])
        elif isinstance(node, ast.Import):
            for a in node.names:
                if a.name.split(".")[0] == "nurbscomp":
                    found.append(a.name.partition(".")[2])
                else:
                    outside.add(a.name.split(".")[0])
        for f in found:  # `from . import x` names module x if there is one, else the package
            if f in names:
                inside.add(f)
                if isinstance(node, ast.ImportFrom):
                    break
    inside.discard(name)
    return inside, outside


def graph() -> tuple[dict[str, set[str]], dict[str, set[str]]]:
    names = module_names()
    inside, outside = {}, {}
    for n, p in names.items():
        inside[n], outside[n] = imports(n, p, set(names))
    return inside, outside


def cycles(edges: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components of more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    out: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        for w in sorted(edges[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in sorted(edges):
        if v not in index:
            visit(v)
    return out


def test_every_module_has_a_layer() -> None:
    placed = set().union(*(m for _, m in LAYERS))
    assert set(module_names()) <= placed, set(module_names()) - placed


def test_no_import_cycle() -> None:
    assert cycles(graph()[0]) == []


def wrong_way(edges: dict[str, set[str]]) -> set[str]:
    layer = {m: i for i, (_, mods) in enumerate(LAYERS) for m in mods}
    sides = next(i for i, (n, _) in enumerate(LAYERS) if n == "sides")
    wrong = set()
    for a, targets in edges.items():
        for b in targets:
            across = layer[a] == layer[b] == sides and a.split(".")[0] != b.split(".")[0]
            if layer[b] > layer[a] or (across and (a, b) not in SIDEWAYS):
                wrong.add(f"{a} -> {b}")
    return wrong


def test_imports_run_downwards() -> None:
    assert wrong_way(graph()[0]) == KNOWN


def test_a_wrong_way_import_is_found() -> None:
    assert wrong_way({"codec": {"pipeline"}, "occ.files": {"encode.nets"}}) == {
        "codec -> pipeline",
        "occ.files -> encode.nets",
    }


def test_ocp_only_in_occ_and_click_only_in_cli() -> None:
    _, outside = graph()
    for m, tops in outside.items():
        if not (m == "occ" or m.startswith("occ.")):
            assert not tops & {"OCP", "cadquery"}, m
        if m != "cli":
            assert "click" not in tops, m


@pytest.mark.parametrize(
    "edges, found",
    [({"a": {"b"}, "b": {"a"}, "c": set()}, [["a", "b"]]), ({"a": {"b"}, "b": set()}, [])],
)
def test_a_cycle_is_found(edges: dict[str, set[str]], found: list[list[str]]) -> None:
    assert cycles(edges) == found
