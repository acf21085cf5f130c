"""Shared test helpers."""

from __future__ import annotations

import os
import subprocess
import time
from pathlib import Path

import pytest
from hypothesis import settings

REPO_ROOT = Path(__file__).resolve().parents[2]
"""The repository root (holds spec/, tools/, c/, python/)."""

# No per-example deadline: a stalled CI machine must not fail a correct property.
settings.register_profile("default", deadline=None)
# A long search, run by hand: HYPOTHESIS_PROFILE=thorough pytest tests
settings.register_profile("thorough", deadline=None, max_examples=5000)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "default"))


# The core tests of the client, the robot layer and the CLI, run a second time on simulated firmware that
# keeps bits 3-4 of the command a state frame answers (spec/PROTOCOL.md 1.6): `make test` runs
# `pytest -m status_bits --sim-status-bits kept` after the whole suite.
STATUS_BITS_CORE = (
    "tests/client/api/test_motor.py",
    "tests/client/engine/test_batch.py",
    "tests/client/api/test_move_done.py",
    "tests/client/engine/test_other_hosts.py",
    "tests/client/engine/test_status_bits.py",
    "tests/client/api/test_async.py",
    "tests/robot/test_robot.py",
    "tests/robot/test_safety.py",
    "tests/cli/test_read.py",
    "tests/cli/test_motion.py",
    "tests/cli/test_doctor.py",
)


def pytest_addoption(parser: pytest.Parser) -> None:
    parser.addoption(
        "--fast-tier",
        action="store_true",
        help="run as the fast tier (make test-fast): a test that starts a process or sleeps fails, naming what it did",
    )

    parser.addoption(
        "--sim-status-bits",
        choices=("zero", "kept"),
        default=None,
        help="simulated motors given no profile send state frames with bits 3-4 zero or kept (default zero)",
    )


def pytest_configure(config: pytest.Config) -> None:
    config.addinivalue_line("markers", "status_bits: a core test run on both status-bits profiles by `make test`")
    bits = config.getoption("--sim-status-bits")
    if bits is not None:
        from drempower.sim import firmware

        firmware.DEFAULT = firmware.Firmware(status_bits=bits)


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    root = Path(__file__).resolve().parents[1]
    core = {root / p for p in STATUS_BITS_CORE}
    for item in items:
        if item.path in core:
            item.add_marker(pytest.mark.status_bits)


@pytest.fixture(autouse=True)
def _fast_tier(request: pytest.FixtureRequest, monkeypatch: pytest.MonkeyPatch) -> None:
    """In the fast tier, starting a process (a browser too) or sleeping fails the test at once."""
    if not request.config.getoption("--fast-tier"):
        return
    real_sleep = time.sleep

    def no_process(*args: object, **kwargs: object) -> None:
        pytest.fail(f"the fast tier starts no process ({args[1] if len(args) > 1 else kwargs.get('args')!r})")

    def no_sleep(seconds: float) -> None:
        if seconds > 0:
            pytest.fail(f"the fast tier does not sleep (time.sleep({seconds!r})): use the virtual clock")
        real_sleep(0)

    monkeypatch.setattr(subprocess.Popen, "__init__", no_process)
    monkeypatch.setattr(time, "sleep", no_sleep)
