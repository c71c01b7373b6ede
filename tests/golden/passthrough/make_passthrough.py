"""Write the format 1.2 passthrough golden file.

``python -m tests.golden.passthrough.make_passthrough`` writes
``tessellated.step`` (AP242 tessellated geometry only: a valid STEP file with
no B-rep, the ``TESSELLATED`` file of ``tests/test_cli.py``) and the
container ``compress`` made of it, ``tessellated.step.nzc``.  Like the other
golden files, it is written once (only when missing) and never regenerated:
``tests/test_passthrough.py`` checks that every later reader gives back the
exact bytes.
"""

from __future__ import annotations

from pathlib import Path

from nurbscomp import pipeline

HERE = Path(__file__).resolve().parent
SOURCE = HERE / "tessellated.step"
GOLDEN = HERE / "tessellated.step.nzc"


def main() -> None:
    if not SOURCE.exists():
        from tests.test_cli import TESSELLATED

        SOURCE.write_bytes(TESSELLATED)
    if not GOLDEN.exists():
        pipeline.compress_file(SOURCE, GOLDEN)
        print(f"wrote {GOLDEN.name}")


if __name__ == "__main__":
    main()
