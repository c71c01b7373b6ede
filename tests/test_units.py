import pytest

from nurbscomp.units import parse_length


@pytest.mark.parametrize(
    "text, mm",
    [
        ("0.01", 0.01),
        ("10um", 0.01),
        ("0.5 um", 0.0005),
        ("1e-3", 0.001),
        ("0.001in", 0.0254),
        ("2mil", 0.0508),
        ("1cm", 10.0),
        ("10m", 10000.0),
        ("3MM", 3.0),
    ],
)
def test_lengths(text: str, mm: float) -> None:
    assert parse_length(text) == pytest.approx(mm)


@pytest.mark.parametrize("text", ["", "abc", "0", "-1", "1parsec", "1e400", "nan"])
def test_bad_lengths(text: str) -> None:
    with pytest.raises(ValueError):
        parse_length(text)
