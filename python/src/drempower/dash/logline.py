"""The dashboard's log: the ``drempower.dash`` logger, which the command writes to stderr without blocking.

In a program (or a test) that serves a dashboard, the lines are ordinary
``logging`` records at INFO. The ``drempower dash`` command calls
:func:`to_stderr`: then they go to standard error through
:data:`drempower.logline.STDERR`, a queue written by a thread of its own, so a
stderr nobody reads never holds up a stop path or a signal handler.
"""

from __future__ import annotations

import logging
import time

from ..logline import STDERR

__all__ = ["flush", "log", "to_stderr", "write"]

_LOG = logging.getLogger("drempower.dash")


def to_stderr() -> None:
    """Write the dashboard's log lines to standard error, never blocking (the command's setting)."""
    if STDERR not in _LOG.handlers:
        _LOG.addHandler(STDERR)
    _LOG.setLevel(logging.INFO)
    _LOG.propagate = False


def write(line: str) -> None:
    """Queue ``line`` (a newline is added) for standard error; never blocks, never raises."""
    STDERR.line(line)


def log(text: str) -> None:
    """One line of the dashboard's log with the wall-clock time (control actions, stops); never blocks."""
    now = time.time()
    stamp = time.strftime("%H:%M:%S", time.localtime(now)) + f".{int(now * 1000) % 1000:03d}"
    _LOG.info("%s dash: %s", stamp, text)


def flush(timeout: float) -> bool:
    """Wait at most ``timeout`` s for the queued lines to be written; True when they were."""
    return STDERR.flush_for(timeout)
