# Set-up and checks.  `make install` then `make test` is all a new machine needs.
VENV   := .venv
PY     := $(VENV)/bin/python
PIP    := $(VENV)/bin/pip

.PHONY: install test test-fast lint samples bench bench-product fuzz fuzz-text stress stress-big clean

# The package's bytecode is compiled here as well: where the environment sets
# PYTHONDONTWRITEBYTECODE, Python would otherwise compile every module again in
# each process (about 0.3 s of every `nurbscomp` run).
install: $(VENV)/bin/nurbscomp
	@$(PY) -m compileall -q nurbscomp $(VENV)/lib/python3*/site-packages/__editable__*.py

$(VENV)/bin/nurbscomp: pyproject.toml
	python3 -m venv $(VENV)
	$(PIP) install --quiet --upgrade pip
	$(PIP) install --quiet -e '.[dev]'
	@$(VENV)/bin/nurbscomp --version

# The whole suite, corpus round trips included, on every core (pytest-xdist;
# TEST_JOBS=0 runs it in this process).  The corpus is ../shared/corpus, or the
# folder NURBSCOMP_CORPUS names; without it the corpus tests are skipped and
# the run says so.  pytest exits 5 when no test ran, which fails this target
# as it should.  test-fast leaves out the tests marked slow (the corpus tiers,
# worker pools, CLI round trips, long fuzzing; each over about 3 s): under two
# minutes on 2 cores.  Both leave out the tests marked long (a minute or
# more each: end-to-end cases on corpus-sized generated inputs), which
# `make stress` runs, so that `make test` stays under ten minutes.
TEST_JOBS ?= auto
test: install
	$(PY) -m pytest -q -n $(TEST_JOBS) --dist worksteal -m "not long"

test-fast: install
	$(PY) -m pytest -q -n $(TEST_JOBS) --dist worksteal -m "not slow and not long"

lint: install
	$(VENV)/bin/ruff check nurbscomp tests samples benchmarks
	$(VENV)/bin/ruff format --check nurbscomp tests samples benchmarks
	$(VENV)/bin/mypy nurbscomp

samples: install
	$(PY) samples/make_samples.py

# Benchmarks against the lossless peers, a naive quantizer and OCCT (issue 4):
# rewrites docs/benchmarks.md, docs/benchmarks.png and the README's "How small,
# how fast" figures, all from one run over ../shared/corpus.  Minutes, not part
# of `make test`.  matplotlib (the `bench` extra) draws the plot.  It also
# times `--help`, `--version` and `info` (goal < 0.5 s) and the corpus as one
# batch with -j 1 and -j 2 (goal >= 1.8x on 2 cores).  The cost of product
# data (bench-product) goes to docs/benchmarks-product.md, the bytes of each
# container section (issue 28) to docs/benchmarks-sections.md, byte-exact
# lossless against xz -9e and OCCT's read (issue 29) to docs/benchmarks-exact.md,
# a generated assembly of 800 parts (~30 MB of STEP, issue 30's scale row) to
# docs/benchmarks-scale.md.
bench: install
	@$(PY) -c "import matplotlib" 2>/dev/null || $(PIP) install --quiet -e '.[bench]'
	$(PY) benchmarks/bench.py
	$(PY) benchmarks/product_cost.py > docs/benchmarks-product.md
	$(PY) benchmarks/sections.py > docs/benchmarks-sections.md
	$(PY) benchmarks/exact.py > docs/benchmarks-exact.md
	$(PY) benchmarks/scale.py > docs/benchmarks-scale.md

# What product data (format 1.2's PROD: tree, names, colours, layers, header)
# costs per file of the corpus and the assembly sample, lossless (issue 12).
bench-product: install
	$(PY) benchmarks/product_cost.py

# The long fuzzing run (issue 5): mutated containers (raw, and re-packed with
# valid CRCs) must decode or fail with a FormatError; each case in a worker
# process with a time limit, so a crash or a hang is reported, not fatal.
# Then (issue 11) as many structure-aware cases: decoded models edited (shared
# and deep nesting, instances, huge nets, extreme values and matrices, cycles,
# META abuse) and packed again; each must decode within the budget or fail
# with one FormatError, in 10 s and 1 GiB.  Minutes on 2 cores; not part of
# `make test` (tests/test_fuzz.py is the short run).
FUZZ_CASES ?= 10000
FUZZ_SEED  ?= 1
fuzz: install
	$(PY) -m tests.fuzz --cases $(FUZZ_CASES) --seed $(FUZZ_SEED)
	$(PY) -m tests.fuzz --structure --cases $(FUZZ_CASES) --seed $(FUZZ_SEED)

# The byte-exact text models (issue 29): mutated STEP and IGES sources (byte
# flips, truncations, unbalanced parentheses, binary garbage, 10^5 nested
# lists, huge numbers, non-ASCII, deleted ';', odd line breaks) must each come
# back byte-exact through nurbscomp.text, and damaged payloads fail with a
# FormatError; each case in a worker process with a time limit.  Minutes; not
# part of `make test` (tests/test_text_step.py runs 200 cases).
fuzz-text: install
	$(PY) -m tests.fuzz_text --cases $(FUZZ_CASES) --seed $(FUZZ_SEED)

# The tests marked long (left out of make test), then the stress corpus (issue 10): ~230 generated shapes (fillets, shells, lofts,
# sweeps, periodic, rational and degenerate B-spline faces, trimmed faces with
# holes, instances, sewn shells, analytic faces, booleans, thick and offset
# solids, NURBS-converted solids) written as STEP, IGES BRep and
# IGES faces, each compressed at 0.001, 0.01 and 0.1 mm, decoded and checked
# (no crash, same counts, within tol, valid, no new free edges).  Minutes; not
# part of `make test` (tests/test_stress.py is the short run).  STRESS_ARGS=
# passes options: `--only periodic`, `--limit 40`, `--jobs 2`, `--out DIR`.
# Then the extreme cases (issue 27: far from the origin, thin walls, extreme
# tolerances, non-finite values, instances), through the command line as a
# user runs it; `make stress-big` adds the slow tier (a 700 x 700 net, 5,000
# placed instances: minutes).
STRESS_ARGS ?=
stress: install
	$(PY) -m pytest -q -n $(TEST_JOBS) -m long
	$(PY) -m tests.stress.run $(STRESS_ARGS)
	$(PY) -m tests.stress.extreme

stress-big: install
	$(PY) -m tests.stress.extreme --big --only "$(ONLY)"

clean:
	rm -rf $(VENV) build *.egg-info .pytest_cache
