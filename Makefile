# Two commands do all the set-up on a fresh machine:
#   make demo   create the environment, install femref, run the built-in default scene
#   make test   create the environment if needed, run the test suite
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

.PHONY: demo test test-slow bench snapshot env clean

$(STAMP): pyproject.toml
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install -q --upgrade pip
	$(BIN)/python -m pip install -q -e '.[dev]'
	bash scripts/install-offscreen-gl.sh || true
	bash scripts/install-chromium.sh || true
	touch $(STAMP)

env: $(STAMP)

demo: $(STAMP)
	mkdir -p results
	$(BIN)/femref run -o results/default.h5

# One BLAS thread per test process: the suite's products are small, and on a busy machine OpenBLAS's
# spinning threads made network training 2-10x slower (tests that need more threads set their own).
TEST_ENV := OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1 MKL_NUM_THREADS=1

# The linter first (its rules and why: pyproject.toml [tool.ruff]), then the suite.
test: $(STAMP)
	$(BIN)/ruff check .
	$(TEST_ENV) $(BIN)/python -m pytest -q

test-slow: $(STAMP)
	$(TEST_ENV) $(BIN)/python -m pytest -q -m slow

bench: $(STAMP)
	$(BIN)/python benchmarks/bench_fem.py

# Every case and the gallery's headlines into a new folder, before and after a refactor (docs/design.md §9.3):
#   make snapshot SNAPSHOT=build/before; ...; make snapshot SNAPSHOT=build/after
#   .venv/bin/python scripts/snapshot.py compare build/before build/after
SNAPSHOT ?= build/snapshot
snapshot: $(STAMP)
	$(BIN)/python scripts/snapshot.py take $(SNAPSHOT)

clean:
	rm -rf $(VENV) results .pytest_cache
