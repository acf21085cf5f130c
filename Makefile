# drempower: the two commands of the README, and a few helpers.
#   make demo   run the main job (simulated motors; no hardware needed)
#   make test   run every test (Python: pytest, ruff, mypy; C: ctest, sanitizers)

PYTHON ?= python3
VENV   ?= .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed
LINTED := ../tools ../bench $(addprefix ../,$(wildcard examples))

.PHONY: demo test test-python test-c lint bench generate clean

$(STAMP): python/pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e 'python[dev]'
	touch $(STAMP)

demo: $(STAMP)
	$(BIN)/drempower demo

test: test-python test-c

test-python: $(STAMP)
	cd python && ../$(BIN)/python -m pytest -q
	cd python && ../$(BIN)/ruff check src tests $(LINTED)
	cd python && ../$(BIN)/ruff format --check src tests
	cd python && ../$(BIN)/mypy

test-c:
	@if [ -f c/scripts/test.sh ]; then bash c/scripts/test.sh; else echo "no C library yet"; fi

bench: $(STAMP)
	$(BIN)/python bench/bench_codec.py
	@for b in bench/bench_sim.py bench/bench_client.py bench/bench_bridge.py; do [ -f $$b ] && $(BIN)/python $$b || true; done

generate: $(STAMP)
	$(BIN)/python tools/generate.py
	$(BIN)/python tools/gen_vectors.py

clean:
	rm -rf $(VENV) build .pytest_cache python/.pytest_cache python/.mypy_cache python/.ruff_cache
