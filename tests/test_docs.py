"""Every fenced Python example of docs/api.md runs, each in an empty folder
holding ``part.step`` (a copy of ``samples/loft.step``), twice in a row in that
folder: an example may not fail on what its own first run left there (a file
it writes without ``force=True``)."""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import pytest

from .conftest import SAMPLES

API_MD = SAMPLES.parent / "docs" / "api.md"
BLOCKS = re.findall(r"^```python\n(.*?)^```", API_MD.read_text(), re.S | re.M)


def test_examples_found() -> None:
    """Every ```` ```python ```` fence of the page is an example the tests run."""
    assert len(BLOCKS) >= 8
    assert len(BLOCKS) == API_MD.read_text().count("```python")


@pytest.mark.slow
@pytest.mark.parametrize("n", range(len(BLOCKS)))
def test_example_runs_twice(n: int, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    shutil.copy(SAMPLES / "loft.step", tmp_path / "part.step")
    monkeypatch.chdir(tmp_path)
    code = compile(BLOCKS[n], f"{API_MD.name} example {n}", "exec")
    for run in (1, 2):  # the second in what the first left
        exec(code, {"__name__": f"api_md_{n}_run_{run}"})


@pytest.mark.slow
def test_docstring_examples_run() -> None:
    """The ``Examples`` sections of the API's docstrings (doctest)."""
    import doctest

    from nurbscomp import _api

    failed, tried = doctest.testmod(_api, optionflags=doctest.ELLIPSIS)
    assert tried >= 6 and failed == 0
