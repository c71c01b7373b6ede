"""How format 2.4's zstd dictionary (``nurbscomp/data/nzc-2.4.dict``, coder 4
of docs/format.md §1.3), format 2.11's (``nzc-2.11.dict``, coder 5), 2.12's
(``nzc-2.12.dict``, coder 6: the same script on the code of 2.11 and of
2.12), 2.13's (``nzc-2.13.dict``, coder 7, with ``--tol 0.01 0.1``) and 2.19's
(``nzc-2.19.dict``, coder 8, the same on the code of 2.19) were made; kept
to be read, not rerun: the format fixes the file's bytes (its SHA-256 is
``entropy.DICT_SHA256``), not how they were made, and a dictionary made again
from other containers would be another coder.

    python -m tests.stress.files STRESS            # the generated stress corpus
    python benchmarks/train_dictionary.py STRESS OUT.dict [--tol 0.01 0.1]

Each generated STEP and IGES file of one kind and format (the first of its
kind) is compressed at 0.01 mm (coders 4 to 6; at 0.01 and 0.1 mm for coders 7 and 8,
so that the dictionary favours no one tolerance: with coder 6, 37 of 77
generated STEP parts came out larger at 0.1 than at 0.01 mm), and zstd's trainer (``zstandard
.train_dictionary``, 64 KiB) is given the containers' bodies (every section,
decoded, concatenated): what containers share (META's keys, array headers,
common values) then costs a small file next to nothing.  The 11 corpus files
take no part in it."""

from __future__ import annotations

import argparse
import re
import sys
import tempfile
from concurrent.futures import ProcessPoolExecutor
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


def body(job: tuple[Path, float, str]) -> bytes | None:
    """The decoded body (every section, concatenated) of ``p``'s container at ``tol``."""
    p, tol, tmp = job
    dst = Path(tmp) / f"{p.name}.{tol}.nzc"
    try:
        pipeline.compress_file(p, dst, tol=tol, force=True)
    except Exception as e:  # a file the codec refuses adds nothing
        print(f"{p.name}: {e}", file=sys.stderr)
        return None
    c = container.unpack(dst.read_bytes())
    return b"".join(c.get(t) for t in c.tags())


def main(folder: str, out: str, tols: list[float]) -> None:
    with tempfile.TemporaryDirectory() as tmp, ProcessPoolExecutor(2) as pool:
        jobs = [(p, t, tmp) for p in first_of_each_kind(Path(folder)) for t in tols]
        bodies = [b for b in pool.map(body, jobs) if b is not None]
    d = zstandard.train_dictionary(SIZE, bodies)
    Path(out).write_bytes(d.as_bytes())
    print(f"{len(bodies)} containers, dictionary of {len(d.as_bytes())} bytes")


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("folder")
    ap.add_argument("out")
    ap.add_argument("--tol", type=float, nargs="+", default=[0.01])
    a = ap.parse_args()
    main(a.folder, a.out, a.tol)
