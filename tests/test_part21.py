"""The second STEP reader (``tests/part21.py``) itself: it accepts what the
standard allows and refuses what it does not.  Every decompressed STEP of the
corpus and the samples goes through it in ``conftest.assert_step_keeps_floor``."""

from __future__ import annotations

import pytest

from . import part21
from .conftest import SAMPLES

GOOD = b"""ISO-10303-21;
HEADER;
/* a comment */ FILE_DESCRIPTION(('a ''quoted'' \\X2\\00E9\\X0\\ name'),'2;1');
FILE_NAME('x','2026-01-01T00:00:00',(''),(''),'','','');
FILE_SCHEMA(('AUTOMOTIVE_DESIGN { 1 0 10303 214 1 1 1 1 }'));
ENDSEC;
DATA;
#1=CARTESIAN_POINT('',(0.,-1.5E-3,+2.));
#2=DIRECTION('',(0.E0,0.E0,1.E0));
#3=AXIS2_PLACEMENT_3D('',#1,#2,$);
#4=(LENGTH_UNIT()NAMED_UNIT(*)SI_UNIT(.MILLI.,.METRE.));
#5=MEASURE_REPRESENTATION_ITEM('',LENGTH_MEASURE(1.),#4);
#6=B_SPLINE_CURVE_WITH_KNOTS('',3,(#1,#1,#1,#1),.UNSPECIFIED.,.F.,.F.,(4,4),(0.,1.),
.UNSPECIFIED.);
#7=!USER_THING("0F3",(#6,(#5)),'long string split
over a line');
ENDSEC;
END-ISO-10303-21;
"""


def test_a_well_formed_file_is_read() -> None:
    x = part21.read(GOOD)
    assert x.header == ["FILE_DESCRIPTION", "FILE_NAME", "FILE_SCHEMA"]
    assert sorted(x.entities) == list(range(1, 8))
    assert x.entities[4] == ["LENGTH_UNIT", "NAMED_UNIT", "SI_UNIT"]
    assert x.references == 9


@pytest.mark.parametrize(
    "old, new",
    [
        (b"#3=AXIS2_PLACEMENT_3D('',#1,#2,$);", b"#3=AXIS2_PLACEMENT_3D('',#1,#9,$);"),  # undefined
        (b"#2=DIRECTION", b"#1=DIRECTION"),  # defined twice
        (b"(0.E0,0.E0,1.E0));", b"(0.E0,0.E0,1.E0);"),  # unbalanced
        (b"(4,4),(0.,1.)", b"(4,4),(0.,1.,)"),  # empty list item
        (b"LENGTH_MEASURE(1.)", b"LENGTH_MEASURE(1.))"),
        (b"'x'", b"'x\x01'"),  # control character in a string
        (b"'x'", b"'x\\q'"),  # a lone backslash
        (b"'x'", b"'it's'"),  # an apostrophe not doubled
        (b"#5=", b"#5 ="[:-1]),  # no '='
        (b"END-ISO-10303-21;\n", b""),  # truncated
        (b"END-ISO-10303-21;\n", b"END-ISO-10303-21;\n#8=X();"),  # after the end
        (b"FILE_NAME(", b"FILE_NAMES("),  # header records
        (b"DATA;", b"DATA"),
        (b"0.,-1.5E-3", b"0.,-1,5E-3"),  # a comma where a decimal point is due -> bad token order
        (b".MILLI.", b".MILLI"),
    ],
)
def test_a_broken_file_is_refused(old: bytes, new: bytes) -> None:
    assert old in GOOD
    with pytest.raises(part21.Part21Error):
        part21.read(GOOD.replace(old, new, 1))


def test_the_samples_are_read() -> None:
    for p in sorted(SAMPLES.glob("*.step")):
        assert part21.read_file(p).entities, p.name
