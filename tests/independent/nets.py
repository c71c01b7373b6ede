"""§2.4 SNET/CNET, §2.9 pins, §2.10 joins of docs/format.md."""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from .reader import Model


def decode(m: Model) -> None:
    pass
