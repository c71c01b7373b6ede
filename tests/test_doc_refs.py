"""Every code reference in the docs still exists (issue 31): a backticked
``module.name`` (``codec.NetCode.bound``, ``serialize.RANGE_*``, optionally
prefixed ``nurbscomp.``) whose first part is a module of the package resolves
to a module, attribute or dataclass field; a backticked ``file.py`` or
``file.md`` is a file of the repository."""

from __future__ import annotations

import dataclasses
import importlib
import pkgutil
import re
from pathlib import Path

import pytest

import nurbscomp

ROOT = Path(__file__).resolve().parent.parent
#: design.md is the notes the project started from, kept as they were (they
#: name other projects' files too).
DOCS = sorted(p for p in ROOT.glob("docs/*.md") if p.name != "design.md") + [ROOT / "README.md"]
MODULES = {m.name.split(".", 1)[1] for m in pkgutil.walk_packages(nurbscomp.__path__, "nurbscomp.")}
TOPS = {m.split(".")[0] for m in MODULES}
SPAN = re.compile(r"`([^`\n]+)`")
DOTTED = re.compile(r"^(?:nurbscomp\.)?([A-Za-z_]\w*(?:\.[A-Za-z_*][\w*]*)+)(?:\(.*\))?$")
FILE = re.compile(r"^([\w./-]+\.(?:py|md))(?::\d+)?$")
FOLDERS = (
    "",
    "nurbscomp",
    "nurbscomp/encode",
    "nurbscomp/rules",
    "nurbscomp/codec",
    "nurbscomp/serialize",
    "nurbscomp/stages",
    "nurbscomp/occ",
    "nurbscomp/text",
    "docs",
    "tests",
    "benchmarks",
)


def _has(obj: object, name: str) -> bool:
    if name.endswith("*"):
        return any(a.startswith(name[:-1]) for a in dir(obj))
    if hasattr(obj, name):
        return True
    fields = dataclasses.fields(obj) if dataclasses.is_dataclass(obj) else ()  # type: ignore[arg-type]
    return any(f.name == name for f in fields) or name in getattr(obj, "__annotations__", {})


def resolves(dotted: str) -> bool:
    """``dotted`` (without ``nurbscomp.``) names a module, then attributes."""
    parts = dotted.split(".")
    for k in range(len(parts), 0, -1):
        if ".".join(parts[:k]) in MODULES:
            obj: object = importlib.import_module("nurbscomp." + ".".join(parts[:k]))
            break
    else:
        return False
    for a in parts[k:]:
        if a == "py" or not _has(obj, a):
            return a == "py"
        if a.endswith("*"):
            return True
        obj = getattr(obj, a, None)
    return True


def references() -> list[tuple[str, str]]:
    """(where, span) of every backticked code reference in the docs."""
    out = []
    for doc in DOCS:
        for i, line in enumerate(doc.read_text().splitlines(), 1):
            for span in SPAN.findall(line):
                s = span.strip()
                m = DOTTED.match(s)
                if (m and m.group(1).split(".")[0] in TOPS) or FILE.match(s):
                    out.append((f"{doc.name}:{i}", s))
    return out


def test_the_docs_reference_code() -> None:
    """The scan finds references (so that an empty scan cannot pass)."""
    refs = references()
    assert len(refs) > 50
    assert any(s.startswith("codec.") for _, s in refs)


def test_every_reference_exists() -> None:
    stale = []
    for where, s in references():
        f = FILE.match(s)
        if f and f.group(1).startswith("../"):
            continue  # outside the repository (the shared paper and corpus): a clone may lack it
        if f:
            ok = any((ROOT / d / f.group(1)).exists() for d in FOLDERS)
        else:
            m = DOTTED.match(s)
            assert m
            ok = resolves(m.group(1))
        if not ok:
            stale.append(f"{where} {s}")
    assert not stale, "stale references in the docs:\n" + "\n".join(stale)


@pytest.mark.parametrize("bad", ["codec.no_such_name", "serialize.NO_SUCH_*", "nosuchmodule.x"])
def test_a_missing_name_is_found(bad: str) -> None:
    assert not resolves(bad)


#: Phrases that define by pointing at code.  The normative sections of
#: docs/format.md (§1, the file, and §2, the sections) define every step in
#: their text; a function may be named only as what implements it ("implemented
#: by `x.y`", a heading's names, a parenthesis after the definition).
DEFINED_BY_CODE = [
    r"\bas `[\w.]+`(?:'s)? (?:does|says|gives|computes|writes|reads|returns)\b",
    r"\bsee `[A-Za-z_]+\.[\w.]+`",
    r"\border of `[\w.]+`",
    r"`[\w.]+`'s (?:order|rule|layout|definition)",
    r"\bindex into `[a-z_]+\.[A-Z_]+`",
    r"\b(?:is|are) `[a-z_]+\.[a-z_][\w.]*`",
    r"\b(?:decoded|defined|specified|given|evaluated|applied) by `[a-z_]+\.[\w.]+`",
    r"\bthe (?:arithmetic|steps|rules?) of `[a-z_]+\.[\w.]+`",
]


def normative(text: str) -> list[tuple[int, str]]:
    """(line number, line) of docs/format.md's §1 and §2, headings left out."""
    out, inside = [], False
    for n, line in enumerate(text.splitlines(), 1):
        if line.startswith("## "):
            inside = line.startswith(("## 1.", "## 2."))
        elif inside and not line.startswith("#"):
            out.append((n, line))
    return out


def test_format_defines_nothing_by_reference_to_code() -> None:
    lines = normative((ROOT / "docs" / "format.md").read_text())
    assert len(lines) > 500
    # a phrase may wrap: look at each line joined with the next
    joined = [(n, a + " " + b) for (n, a), (_, b) in zip(lines, [*lines[1:], (0, "")])]
    bad = [
        f"line {n}: {m.group(0)!r}"
        for n, text in joined
        for pattern in DEFINED_BY_CODE
        for m in [re.search(pattern, text)]
        if m
    ]
    assert bad == []


@pytest.mark.parametrize(
    "text",
    [
        "the integer layout per method is the order of `codec._code`:",
        "each pole moves along the normal (`x`), as `dmap.apply` does",
        "the slope, an index into `codec.SLOPES`",
        "the steps are `decode.apply`, in order",
        "Each code is decoded by `codec.decode_net` with the row's shape",
    ],
)
def test_defined_by_code_is_caught(text: str) -> None:
    assert any(re.search(p, text) for p in DEFINED_BY_CODE)


def test_implemented_by_is_allowed() -> None:
    text = "(Implemented by `joins.boundary` and `joins.joined_sides`.) decoded as §2.4.1 defines"
    assert not any(re.search(p, text) for p in DEFINED_BY_CODE)


#: The functions issue 31 found standing in for definitions: in §1 and §2 they
#: may only be named as what implements a rule the text defines.
CITED = ["codec._code", "dmap.apply", "coons.periodic_flat", "rules.joins.boundary",
         "rules.joins.anchors", "rules.joins.copy_matrix", "codec.SLOPES"]  # fmt: skip


def test_cited_functions_only_as_implementations() -> None:
    lines = normative((ROOT / "docs" / "format.md").read_text())
    text = " ".join(line for _, line in lines)
    for name in CITED:
        for m in re.finditer(re.escape(f"`{name}`"), text):
            before = text[max(0, m.start() - 120) : m.start()]
            assert "mplemented by" in before, f"{name}: ...{before[-80:]}"


def _module_refs_outside_implementations(lines: list[tuple[int, str]]) -> list[str]:
    """Backticked ``module.name`` references of the package in ``lines`` that
    are neither inside a parenthesis nor in a table row nor within 150
    characters after "implemented by": a name standing in a sentence where a
    definition should be."""
    tops = {m.split(".")[0] for m in MODULES}
    out = []
    paragraphs: list[list[tuple[int, str]]] = [[]]
    for n, line in lines:
        if not line.strip():
            paragraphs.append([])
        else:
            paragraphs[-1].append((n, line))
    for para in paragraphs:
        # a table's cells name what implements each row: left out
        text = " ".join(line for _, line in para if not line.lstrip().startswith("|"))
        first = para[0][0] if para else 0
        for m in re.finditer(r"`(?:nurbscomp\.)?([a-z_]+)\.[\w.*]+`", text):
            if m.group(1) not in tops:
                continue
            before = text[: m.start()]
            depth = 0
            for ch in before:
                depth += (ch == "(") - (ch == ")")
            if depth > 0 or "mplemented by" in before[-150:]:
                continue
            out.append(f"paragraph at line {first}: {text[max(0, m.start() - 60) : m.end()]}")
    return out


def test_normative_sections_name_modules_only_as_implementations() -> None:
    """docs/format.md §1 and §2 name a module's function or constant only in
    a parenthesis, a table, or after "implemented by" (issue 31's "a test
    greps for module names inside the normative sections")."""
    lines = normative((ROOT / "docs" / "format.md").read_text())
    assert _module_refs_outside_implementations(lines) == []


def test_a_module_standing_for_a_definition_is_found() -> None:
    bad = [(1, "The steps are `decode.apply`, in order."), (2, "")]
    good = [(3, "The steps, in order (`decode.apply`)."), (4, "Implemented by `decode.apply`.")]
    assert len(_module_refs_outside_implementations(bad)) == 1
    assert _module_refs_outside_implementations(good) == []
