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


def pytest_addoption(parser: pytest.Parser) -> None:
    parser.addoption(
        "--fast-tier",
        action="store_true",
        help="run as the fast tier (make test-fast): a test that starts a process or sleeps fails, naming what it did",
    )


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
