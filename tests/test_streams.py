"""Round trips of the typed-array blocks, and their refusal of damaged bytes."""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from nurbscomp.errors import CorruptError
from nurbscomp.streams import BlockReader, BlockWriter, unzigzag, zigzag

ints = st.lists(st.integers(-(2**62), 2**62), max_size=200)
floats = st.lists(st.floats(allow_nan=False), max_size=200)


@given(ints)
def test_zigzag_round_trip(xs: list[int]) -> None:
    a = np.array(xs, np.int64)
    assert (unzigzag(zigzag(a)) == a).all()


@given(st.lists(st.tuples(st.booleans(), ints, floats), max_size=6))
def test_block_round_trip(arrays: list[tuple[bool, list[int], list[float]]]) -> None:
    w = BlockWriter()
    for is_int, xs, fs in arrays:
        w.ints(xs) if is_int else w.floats(fs)
    r = BlockReader(bytes(w), "T")
    for is_int, xs, fs in arrays:
        if is_int:
            assert r.ints().tolist() == xs
        else:
            got = r.floats()
            assert got.tobytes() == np.array(fs, "<f8").tobytes()
    r.done()


def test_truncated_block_is_refused() -> None:
    w = BlockWriter()
    w.floats([1.0, 2.0, 3.0])
    data = bytes(w)
    for cut in range(len(data)):
        with pytest.raises(CorruptError):
            r = BlockReader(data[:cut], "T")
            r.floats()
            r.done()


def test_count_mismatch_is_refused() -> None:
    w = BlockWriter()
    w.ints([1, 2, 3])
    with pytest.raises(CorruptError):
        BlockReader(bytes(w), "T").ints(4)
