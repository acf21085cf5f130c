"""Small helpers for the file descriptors the transports and the driver wait on (wake-up pipes)."""

from __future__ import annotations

import os

__all__ = ["close_fds", "drain", "nonblocking_pipe"]


def nonblocking_pipe() -> tuple[int, int]:
    """A pipe whose both ends never block: (read end, write end)."""
    r, w = os.pipe()
    os.set_blocking(r, False)
    os.set_blocking(w, False)
    return r, w


def drain(fd: int) -> None:
    """Read a non-blocking descriptor until it is empty (or closed)."""
    try:
        while os.read(fd, 512):
            pass
    except OSError:  # empty (non-blocking) or closed
        pass


def close_fds(*fds: int) -> None:
    """Close each descriptor, ignoring those already closed."""
    for fd in fds:
        try:
            os.close(fd)
        except OSError:
            pass
