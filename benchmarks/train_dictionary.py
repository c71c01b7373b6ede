"""How format 2.4's zstd dictionary (``nurbscomp/data/nzc-2.4.dict``, coder 4
of docs/format.md §1.3), format 2.11's (``nzc-2.11.dict``, coder 5) and 2.12's
(``nzc-2.12.dict``, coder 6: the same script on the code of 2.11 and of
2.12) were made; kept to be read, not rerun: the format
fixes the file's bytes (its SHA-256 is ``entropy.DICT_SHA256``), not how they
were made, and a dictionary made again from other containers would be another
coder.

    python -m tests.stress.files STRESS            # the generated stress corpus
    python benchmarks/train_dictionary.py STRESS OUT.dict

Each generated STEP and IGES file of one kind and format (the first of its
kind) is compressed at 0.01 mm, and zstd's trainer (``zstandard
.train_dictionary``, 64 KiB) is given the containers' bodies (every section,
decoded, concatenated): what containers share (META's keys, array headers,
common values) then costs a small file next to nothing.  The 11 corpus files
take no part in it."""

from __future__ import annotations

import re
import sys
import tempfile
from pathlib import Path

import zstandard

from nurbscomp import container, pipeline

SIZE = 64 * 1024


def first_of_each_kind(folder: Path) -> list[Path]:
    seen: dict[tuple[str, str], Path] = {}
    for p in sorted(folder.iterdir()):
        stem, _, fmt = p.name.partition(".")
        kind = re.sub(r"_\d+$", "", stem)
        if fmt in ("step", "brep.igs", "faces.igs"):
            seen.setdefault((kind, fmt), p)
    return list(seen.values())


def main(folder: str, out: str) -> None:
    bodies = []
    with tempfile.TemporaryDirectory() as tmp:
        for p in first_of_each_kind(Path(folder)):
            dst = Path(tmp) / f"{p.name}.nzc"
            try:
                pipeline.compress_file(p, dst, tol=0.01, force=True)
            except Exception as e:  # a file the codec refuses adds nothing
                print(f"{p.name}: {e}", file=sys.stderr)
                continue
            c = container.unpack(dst.read_bytes())
            bodies.append(b"".join(c.get(t) for t in c.tags()))
    d = zstandard.train_dictionary(SIZE, bodies)
    Path(out).write_bytes(d.as_bytes())
    print(f"{len(bodies)} containers, dictionary of {len(d.as_bytes())} bytes")


if __name__ == "__main__":
    main(*sys.argv[1:3])
