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
