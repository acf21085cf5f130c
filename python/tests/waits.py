"""Waiting in tests for what another thread or process does on a wall clock, bounded."""

from __future__ import annotations

import time
from collections.abc import Callable


def eventually(condition: Callable[[], object], limit: float = 10.0, step: float = 0.01) -> bool:
    """True once ``condition()`` is true, False after ``limit`` s (generous: a loaded machine is slow)."""
    deadline = time.monotonic() + limit
    while True:
        if condition():
            return True
        if time.monotonic() >= deadline:
            return False
        time.sleep(step)
