# drempower: the two commands of the README, and a few helpers.
#   make demo   run the main job (simulated motors; no hardware needed)
#   make test   run every test (Python: pytest, ruff, mypy; C: ctest, sanitizers)

PYTHON ?= python3
VENV   ?= .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed
DEVSTAMP := $(VENV)/.installed-dev
LINTED := ../tools ../bench $(addprefix ../,$(wildcard examples))

.PHONY: demo test test-python test-c lint bench generate clean sysdeps

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

test-python: $(DEVSTAMP) sysdeps
	cd python && ../$(BIN)/python -m pytest -q
	cd python && ../$(BIN)/ruff check src tests $(LINTED)
	cd python && ../$(BIN)/ruff format --check src tests
	cd python && ../$(BIN)/mypy

# System packages some tests drive: Debian's chromium for the dashboard's browser tests (Playwright's own
# browser download is not used), zsh and fish for the completion scripts. Installed with apt-get when run as
# root; otherwise those tests are skipped.
SYSDEPS ?= chromium zsh fish qemu-system-arm gcc-arm-none-eabi libnewlib-arm-none-eabi
sysdeps:
	@missing=""; for c in $(SYSDEPS); do command -v $$c >/dev/null 2>&1 || missing="$$missing $$c"; done; \
	if [ -n "$$missing" ]; then \
	  if [ "$$(id -u)" = 0 ]; then apt-get update -q && DEBIAN_FRONTEND=noninteractive apt-get install -y -q $$missing; \
	  else echo "make: some tests need:$$missing (sudo apt-get install$$missing); they are skipped without them"; fi; \
	fi

test-c:
	@if [ -f c/scripts/test.sh ]; then bash c/scripts/test.sh; else echo "no C library yet"; fi

bench: $(DEVSTAMP)
	$(BIN)/python bench/bench_codec.py
	@for b in bench/bench_table.py bench/bench_idle.py bench/bench_sim.py bench/bench_client.py bench/bench_record.py bench/bench_robot.py bench/bench_dash.py bench/bench_bridge.py bench/bench_twin.py bench/bench_follow.py; do [ -f $$b ] && $(BIN)/python $$b || true; done

generate: $(DEVSTAMP)
	$(BIN)/python tools/generate.py
	$(BIN)/python tools/gen_vectors.py
	$(BIN)/python tools/gen_sync.py

clean:
	rm -rf $(VENV) build .pytest_cache python/.pytest_cache python/.mypy_cache python/.ruff_cache
