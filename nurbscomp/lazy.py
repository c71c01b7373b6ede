"""Modules imported on first use, so that a command starts fast.

OCP (OpenCASCADE) takes 1.5-3 s and ~350 MB to import; ``--help``,
``--version``, ``info`` and passthrough containers never need it.
"""

from __future__ import annotations

import importlib
from types import ModuleType
from typing import Any


class LazyModule:
    """Stands for the module ``name``; imports it on the first attribute read.

    Every read goes to the real module, so a test that patches an attribute of
    the real module (``monkeypatch.setattr(occ, "write_shape", …)``) is seen here.
    """

    def __init__(self, name: str) -> None:
        self._name = name

    def module(self) -> ModuleType:
        """The real module, imported now if it was not yet."""
        return importlib.import_module(self._name)

    def __getattr__(self, attr: str) -> Any:
        return getattr(self.module(), attr)


def lazy_module(name: str) -> Any:
    """A :class:`LazyModule` for ``name`` (typed ``Any``: declare the real module
    under ``TYPE_CHECKING`` for the type checker)."""
    return LazyModule(name)
