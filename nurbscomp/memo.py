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
    (None, numbers, tuples of them, bytes) by its ``repr``.  The arrays'
    bytes are hashed in order, followed by the ``repr`` of the list of the
    parts with each array replaced by its (dtype number, shape): the shapes
    fix where each array's bytes end, so that no two sequences of parts meet.
    One hash update of one joined buffer: the encoder asks some 180,000 of
    these for the corpus at 0.01 mm, and per-part updates cost twice as much."""
    meta: list[Any] = []
    chunks: list[bytes] = []
    for a in parts:
        if isinstance(a, np.ndarray):
            meta.append((a.dtype.num, a.shape))
            chunks.append(a.tobytes())
        else:
            meta.append(a)
    chunks.append(repr(meta).encode())
    return hashlib.blake2b(b"".join(chunks), digest_size=20).digest()


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
