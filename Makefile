# Two commands do all the set-up on a fresh machine:
#   make demo   create the environment, install femref with its core dependencies only, run the built-in default scene
#   make test   create the environment if needed, add the test extras, off-screen GL and Chromium, run the test suite
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
# Two environments in one venv: the demo's (femref and its core dependencies) and the test's (the dev extra, off-screen
# GL for pyvista, Chromium for the report's browser test). `make test` after `make demo` adds only the test's part.
DEMO_STAMP := $(VENV)/.installed-demo
TEST_STAMP := $(VENV)/.installed-test

.PHONY: demo test test-slow bench snapshot env clean

# The pip that venv bundles (Python >= 3.11) installs an editable pyproject package; upgrading it cost seconds.
$(BIN)/python:
	$(PYTHON) -m venv $(VENV)

# --no-compile: the ~7000 modules of the dependencies are not byte-compiled at install (22 s of CPU); Python compiles
# those a command imports on first use.
$(DEMO_STAMP): pyproject.toml | $(BIN)/python
	@$(BIN)/python -c "import tomllib; d = tomllib.load(open('pyproject.toml', 'rb'))['project']['dependencies']; \
	print('installing femref (editable) and its core dependencies:', ', '.join(d)); \
	print('not installed by make demo: the test extras, off-screen GL, Chromium (make test adds them)')"
	$(BIN)/python -m pip install -q --no-compile -e .
	touch $(DEMO_STAMP)

$(TEST_STAMP): pyproject.toml | $(BIN)/python
	@echo "installing femref (editable) with the dev extra (pyproject.toml [project.optional-dependencies] dev)"
	$(BIN)/python -m pip install -q -e '.[dev]'
	bash scripts/install-offscreen-gl.sh || true
	bash scripts/install-chromium.sh || true
	touch $(DEMO_STAMP) $(TEST_STAMP)

env: $(TEST_STAMP)

# The impact kernels are compiled on their own line, saying so (an editable install builds no wheel to carry them
# compiled: scripts/femref_build.py); the run then loads them. Compiled already: it says so in about a second.
demo: $(DEMO_STAMP)
	mkdir -p results
	$(BIN)/python scripts/compile_kernels.py
	$(BIN)/femref run -o results/default.h5

# One BLAS thread per test process: the suite's products are small, and on a busy machine OpenBLAS's
# spinning threads made network training 2-10x slower (tests that need more threads set their own).
TEST_ENV := OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1 MKL_NUM_THREADS=1
# Two test processes (pytest-xdist), a test file's tests in one of them (its module fixtures made once): the
# suite is ~340 s of CPU, one process on the 2-core box took 339 s idle, two take ~175 s.
TEST_PROCESSES := -n 2 --dist loadfile

# The linter first (its rules and why: pyproject.toml [tool.ruff]), then the suite.
test: $(TEST_STAMP)
	$(BIN)/ruff check .
	$(TEST_ENV) $(BIN)/python -m pytest -q $(TEST_PROCESSES)

test-slow: $(TEST_STAMP)
	$(TEST_ENV) $(BIN)/python -m pytest -q -m slow $(TEST_PROCESSES)

bench: $(DEMO_STAMP)
	$(BIN)/python benchmarks/bench_fem.py

# Every case and the gallery's headlines into a new folder, before and after a refactor (docs/design.md §9.3):
#   make snapshot SNAPSHOT=build/before; ...; make snapshot SNAPSHOT=build/after
#   .venv/bin/python scripts/snapshot.py compare build/before build/after
SNAPSHOT ?= build/snapshot
snapshot: $(TEST_STAMP)
	$(BIN)/python scripts/snapshot.py take $(SNAPSHOT)

clean:
	rm -rf $(VENV) results .pytest_cache
