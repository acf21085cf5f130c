"""Small helpers for the file descriptors the transports and the driver wait on (wake-up pipes, sockets)."""

from __future__ import annotations

import os
import select
import socket
import time

__all__ = ["close_fds", "drain", "drain_close", "nonblocking_pipe"]


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


_DONTWAIT = getattr(socket, "MSG_DONTWAIT", 0)
"""A receive that does not wait, where the system has the flag (after ``select`` said readable)."""


CLOSE_DRAIN = 0.5
"""How long (s) :func:`drain_close` waits at most for the peer to close its side."""


def drain_close(sock: socket.socket, seconds: float = CLOSE_DRAIN) -> None:
    """Close a TCP connection without losing what it still has to send: send the end of the stream, read
    (and drop) until the peer closes its side, at most ``seconds`` s, then close. A socket closed with
    unread data is reset, and the reset drops the frames it had queued (the stops of ``stop_on_close``)."""
    try:
        sock.shutdown(socket.SHUT_WR)
        deadline = time.monotonic() + seconds
        while (left := deadline - time.monotonic()) > 0:
            if not select.select([sock], [], [], left)[0]:
                break
            try:
                if not sock.recv(65536, _DONTWAIT):
                    break  # the peer closed its side: everything sent was taken
            except (BlockingIOError, InterruptedError):
                continue
    except (OSError, ValueError):  # not connected any more: nothing to keep
        pass
    finally:
        sock.close()
