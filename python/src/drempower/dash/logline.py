"""The dashboard's log on standard error, which never blocks the caller (:mod:`drempower.logline`)."""

from __future__ import annotations

import time

from ..logline import STDERR

__all__ = ["flush", "log", "write"]


def write(line: str) -> None:
    """Queue ``line`` (a newline is added) for standard error; never blocks, never raises."""
    STDERR.line(line)


def log(text: str) -> None:
    """One line on standard error with the wall-clock time (control actions, stops); never blocks."""
    now = time.time()
    stamp = time.strftime("%H:%M:%S", time.localtime(now)) + f".{int(now * 1000) % 1000:03d}"
    STDERR.line(f"{stamp} dash: {text}")


def flush(timeout: float) -> bool:
    """Wait at most ``timeout`` s for the queued lines to be written; True when they were."""
    return STDERR.flush_for(timeout)
