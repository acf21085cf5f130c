# drempower: the two commands of the README, and a few helpers.
#   make demo   run the main job (simulated motors; no hardware needed)
#   make test   run every test (Python: pytest, ruff, mypy; C: ctest, sanitizers)

PYTHON ?= python3
VENV   ?= .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed
DEVSTAMP := $(VENV)/.installed-dev
LINTED := ../tools ../bench $(addprefix ../,$(wildcard examples))

.PHONY: demo test test-python test-c lint bench generate clean

# the main job needs only the package and its core dependencies (python-can, pyserial)
$(STAMP): python/pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e python
	touch $(STAMP)

# the tests add the development tools (pytest, ruff, mypy, build...)
$(DEVSTAMP): $(STAMP)
	$(BIN)/python -m pip install --quiet -e 'python[dev]'
	touch $(DEVSTAMP)

demo: $(STAMP)
	$(BIN)/drempower demo

test: test-python test-c

test-python: $(DEVSTAMP)
	cd python && ../$(BIN)/python -m pytest -q
	cd python && ../$(BIN)/ruff check src tests $(LINTED)
	cd python && ../$(BIN)/ruff format --check src tests
	cd python && ../$(BIN)/mypy

test-c:
	@if [ -f c/scripts/test.sh ]; then bash c/scripts/test.sh; else echo "no C library yet"; fi

bench: $(STAMP)
	$(BIN)/python bench/bench_codec.py
	@for b in bench/bench_sim.py bench/bench_client.py; do [ -f $$b ] && $(BIN)/python $$b || true; done

generate: $(DEVSTAMP)
	$(BIN)/python tools/generate.py
	$(BIN)/python tools/gen_vectors.py

clean:
	rm -rf $(VENV) build .pytest_cache python/.pytest_cache python/.mypy_cache python/.ruff_cache
