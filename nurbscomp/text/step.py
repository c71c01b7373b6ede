"""The STEP text model (issue 29): placeholder until the model lands.

``encode(data)`` returns the model's payload, or None where the text is not
STEP it can model; ``decode(payload, limit)`` inverts it.
"""

from __future__ import annotations


def encode(data: bytes) -> bytes | None:
    """None: no model yet, the plain stream is kept."""
    return None


def decode(payload: bytes, limit: int) -> bytes:
    """Never called while :func:`encode` returns None."""
    raise NotImplementedError
