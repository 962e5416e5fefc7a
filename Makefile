# Two commands do all the set-up on a fresh machine:
#   make demo   create the environment, install femref, run the built-in default scene
#   make test   create the environment if needed, run the test suite
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

.PHONY: demo test test-slow bench env clean

$(STAMP): pyproject.toml
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install -q --upgrade pip
	$(BIN)/python -m pip install -q -e '.[dev]'
	bash scripts/install-offscreen-gl.sh || true
	touch $(STAMP)

env: $(STAMP)

demo: $(STAMP)
	$(BIN)/femref run -o results/default.h5

test: $(STAMP)
	$(BIN)/python -m pytest -q

test-slow: $(STAMP)
	$(BIN)/python -m pytest -q -m slow

bench: $(STAMP)
	$(BIN)/python benchmarks/bench_fem.py

clean:
	rm -rf $(VENV) results .pytest_cache
