# drempower: the two commands of the README, and a few helpers.
#   make demo   run the main job (simulated motors; no hardware needed)
#   make test   run every test (Python: pytest, ruff, mypy; C: ctest, sanitizers; the LeRobot plugins)

PYTHON ?= python3
VENV   ?= .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed
DEVSTAMP := $(VENV)/.installed-dev
LINTED := ../tools ../bench $(addprefix ../,$(wildcard examples))

.PHONY: demo docs test test-fast test-python test-c test-lerobot lint bench generate clean sysdeps

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
	@echo "Next: watch and drive simulated motors in a browser: $(BIN)/pip install --quiet -e 'python[dash]' && $(BIN)/drempower dash --sim 1,2,3"

test: test-python docs test-c test-lerobot

# The docs as a site, with the API reference built from the docstrings (MkDocs, mkdocstrings; offline):
# a warning (a broken page link or anchor, a docstring it cannot read) fails the build.
docs: $(DEVSTAMP)
	@mkdir -p build; $(BIN)/mkdocs build --strict 2>build/mkdocs.log \
	  && echo "docs: built into build/site (API reference from the docstrings)" || { cat build/mkdocs.log; exit 1; }

# The fast tier: the protocol, the sans-I/O engine, the actions, the gate, parsing. Run with --fast-tier, a
# test there fails as soon as it starts a process (a browser too) or sleeps (python/tests/conftest.py).
FAST_TESTS := tests/protocol tests/client/session tests/client/test_session_parts.py tests/client/test_gate.py \
	tests/client/test_watchdog.py tests/client/test_arguments.py tests/client/test_domains.py \
	tests/client/test_vectors.py tests/client/test_client_vectors.py tests/client/test_refusals.py \
	tests/client/test_virtual_time.py tests/client/test_batch.py tests/client/test_motor.py \
	tests/robot/test_config.py tests/actions tests/test_layers.py tests/test_naming.py \
	tests/test_errors.py tests/test_cli_params.py tests/cli/test_param_domains.py
# the rest runs on every core (pytest-xdist); PYTEST_WORKERS=0 runs it in one process
PYTEST_WORKERS ?= 2

test-fast: $(DEVSTAMP)
	cd python && ../$(BIN)/python -m pytest -q -p no:cacheprovider --fast-tier $(FAST_TESTS)

test-python: $(DEVSTAMP) sysdeps
	cd python && ../$(BIN)/python -m pytest -q -p no:cacheprovider --fast-tier $(FAST_TESTS)
	cd python && ../$(BIN)/python -m pytest -q -n $(PYTEST_WORKERS) $(addprefix --ignore=,$(FAST_TESTS))
	# the core tests of the client, the robot layer and the CLI again, on firmware that keeps bits 3-4 (PROTOCOL.md 1.6)
	cd python && ../$(BIN)/python -m pytest -q -n $(PYTEST_WORKERS) -m status_bits --sim-status-bits kept
	cd python && ../$(BIN)/ruff check src tests plugins $(LINTED)
	cd python && ../$(BIN)/ruff format --check src tests plugins
	cd python && ../$(BIN)/mypy

# System packages some tests drive: Debian's chromium for the dashboard's browser tests (Playwright's own
# browser download is not used), zsh and fish for the completion scripts, qemu-system-arm and the arm-none-eabi
# toolchain for the C library on a Cortex-M. Debian packages are checked with dpkg (elsewhere by command
# name); installed with apt-get when run as root; otherwise those tests are skipped.
SYSDEPS ?= chromium zsh fish qemu-system-arm gcc-arm-none-eabi libnewlib-arm-none-eabi
sysdeps:
	@missing=""; for p in $(SYSDEPS); do \
	  if command -v dpkg-query >/dev/null 2>&1; then dpkg-query -W -f='$${Status}' $$p 2>/dev/null | grep -q 'ok installed' || missing="$$missing $$p"; \
	  else command -v $$p >/dev/null 2>&1 || missing="$$missing $$p"; fi; \
	done; \
	if [ -n "$$missing" ]; then \
	  if [ "$$(id -u)" = 0 ]; then \
	    echo "make: installing$$missing with apt-get for the tests (chromium: the dashboard's browser tests; zsh, fish: the completion scripts; qemu, arm-none-eabi: the C library on a Cortex-M)"; \
	    log=$$(mktemp); (apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq $$missing) >$$log 2>&1 \
	      || { cat $$log; rm -f $$log; echo "make: apt-get failed (its output above)"; exit 1; }; rm -f $$log; \
	  else echo "make: some tests need:$$missing (sudo apt-get install$$missing); they are skipped without them"; fi; \
	fi

# The LeRobot plugins (python/plugins/) run in a venv of their own: LeRobot would take numpy, packaging and
# setuptools in the development venv back to older versions, and it brings torch (with PyPI's CUDA libraries:
# the venv takes 8.4 GB; about 5 minutes to install). Their tests are
# python/tests/lerobot/, which the main pytest run skips (LeRobot is not installed there).
LEROBOT_VENV ?= .venv-lerobot
LEROBOT ?= lerobot==0.4.4
LRBIN := $(LEROBOT_VENV)/bin
LRSTAMP := $(LEROBOT_VENV)/.installed
PLUGINS := python/plugins/lerobot_robot_drempower python/plugins/lerobot_teleoperator_drempower

$(LRSTAMP): python/pyproject.toml $(addsuffix /pyproject.toml,$(PLUGINS))
	$(PYTHON) -m venv $(LEROBOT_VENV)
	$(LRBIN)/python -m pip install --quiet --upgrade pip
	$(LRBIN)/python -m pip install --quiet -e 'python[physics,dash]' $(addprefix -e ,$(PLUGINS)) '$(LEROBOT)' 'pytest>=8' 'pytest-timeout>=2.3'
	touch $(LRSTAMP)

test-lerobot: $(LRSTAMP)
	cd python && ../$(LRBIN)/python -m pytest -q -W ignore::pytest.PytestConfigWarning --confcutdir=tests/lerobot tests/lerobot

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
	rm -rf $(VENV) $(LEROBOT_VENV) build .pytest_cache python/.pytest_cache python/.mypy_cache python/.ruff_cache
