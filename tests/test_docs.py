"""Every fenced Python example of docs/api.md runs, each in an empty folder
holding ``part.step`` (a copy of ``samples/loft.step``)."""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import pytest

from .conftest import SAMPLES

API_MD = SAMPLES.parent / "docs" / "api.md"
BLOCKS = re.findall(r"^```python\n(.*?)^```", API_MD.read_text(), re.S | re.M)


def test_examples_found() -> None:
    assert len(BLOCKS) >= 8


@pytest.mark.parametrize("n", range(len(BLOCKS)))
def test_example_runs(n: int, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    shutil.copy(SAMPLES / "loft.step", tmp_path / "part.step")
    monkeypatch.chdir(tmp_path)
    code = compile(BLOCKS[n], f"{API_MD.name} example {n}", "exec")
    exec(code, {"__name__": f"api_md_{n}"})


def test_docstring_examples_run() -> None:
    """The ``Examples`` sections of the API's docstrings (doctest)."""
    import doctest

    from nurbscomp import _api

    failed, tried = doctest.testmod(_api, optionflags=doctest.ELLIPSIS)
    assert tried >= 6 and failed == 0
