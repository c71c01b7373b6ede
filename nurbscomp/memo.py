"""Bounded memos keyed by a digest of everything a computation reads.

The encoder's validity stage assembles and packs a candidate every round,
and most of its rows are the last round's: the answers that depend on a
row alone are remembered here (``encode.knots.moved``,
``encode.nets.feature_limit``, ``writer._chosen``).  A key is a digest of
the values themselves, not of their identity, so an array changed in place
is a new key.  Nothing here imports OCP.
"""

from __future__ import annotations

import hashlib
from collections.abc import Callable
from typing import Any, Generic, TypeVar

import numpy as np

T = TypeVar("T")


def digest(*parts: Any) -> bytes:
    """A digest of ``parts``: arrays by dtype, shape and bytes, anything else
    (None, numbers, tuples of them, bytes) by its ``repr``; each part closed
    by a separator so that no two sequences of parts meet."""
    h = hashlib.blake2b(digest_size=20)
    for a in parts:
        if isinstance(a, np.ndarray):
            h.update(f"{a.dtype.str}{a.shape}".encode())
            h.update(np.ascontiguousarray(a).data)  # no copy where it is contiguous
        else:
            h.update(repr(a).encode())
        h.update(b"\x00")
    return h.digest()


class Memo(Generic[T]):
    """Answers by key, at most ``limit`` of them: past that the memo starts
    again (the answers of one part's rounds fit many times over)."""

    def __init__(self, limit: int) -> None:
        self.limit = limit
        self.answers: dict[bytes, T] = {}

    def get(self, key: bytes, make: Callable[[], T]) -> T:
        """The answer remembered under ``key``, or ``make()``'s, remembered."""
        got = self.answers.get(key)
        if got is None:
            got = make()
            if len(self.answers) >= self.limit:
                self.answers.clear()
            self.answers[key] = got
        return got

    def clear(self) -> None:
        self.answers.clear()

    def __len__(self) -> int:
        return len(self.answers)
