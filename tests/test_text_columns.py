"""Columns of byte strings (nurbscomp.text.columns), the text decoders' layout."""

from __future__ import annotations

import numpy as np
import pytest

from nurbscomp.errors import CorruptError
from nurbscomp.text import columns


def test_ints_print_as_python_does():
    vals = [0, 1, 9, 10, 99, 100, 12345, 10**17, 10**18 - 1, 10**18, 2**63 - 1]
    col = columns.ints(np.array(vals, dtype=np.int64), b"#")
    assert col.items() == [b"#%d" % v for v in vals]
    assert columns.ints(np.zeros(0, np.int64), b"#").items() == []
    with pytest.raises(CorruptError):
        columns.ints(np.array([3, -1]), b"#")


def test_split_take_concat_join():
    col = columns.split(b"a,bb,,ccc", 4, "items")
    assert col.items() == [b"a", b"bb", b"", b"ccc"]
    with pytest.raises(CorruptError):
        columns.split(b"a,bb", 3, "items")
    with pytest.raises(CorruptError):
        columns.split(b"a", 0, "items")
    assert columns.split(b"", 0, "items").items() == []
    both = columns.concat([col, columns.of_items([b"x", b"yz"])])
    assert both.items() == [b"a", b"bb", b"", b"ccc", b"x", b"yz"]
    picked = columns.take(both, np.array([5, 0, 0, 3, 2]))
    assert columns.join(picked) == b"yzaaccc"
    assert columns.join(columns.take(both, np.array([2]))) == b""
