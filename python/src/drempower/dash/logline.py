"""The dashboard's log on standard error, which never blocks the caller.

A stderr nobody reads (a full pipe) blocks a write, and a closed one fails it;
the dashboard's stop paths log, so they must not wait on either. :func:`log`
only appends the line to a bounded queue; one writer thread writes the queue
to file descriptor 2. When the queue is full, lines are dropped and counted
(the count is written once the writer can write again); a failed write drops
the line.
"""

from __future__ import annotations

import os
import threading
import time
from collections import deque

__all__ = ["flush", "log", "write"]

QUEUE_LINES = 1000
"""Lines held while stderr is not taking them; beyond, new lines are dropped and counted."""

_lines: deque[str] = deque()
_dropped = 0
_lock = threading.Lock()
_ready = threading.Condition(_lock)
_writer: threading.Thread | None = None
_busy = False


def write(line: str) -> None:
    """Queue ``line`` (a newline is added) for standard error; never blocks, never raises."""
    global _dropped, _writer
    with _lock:
        if len(_lines) >= QUEUE_LINES:
            _dropped += 1
            return
        _lines.append(line)
        if _writer is None:
            _writer = threading.Thread(target=_write_loop, name="dash stderr", daemon=True)
            _writer.start()
        _ready.notify_all()


def log(text: str) -> None:
    """One line on standard error with the wall-clock time (control actions, stops); never blocks."""
    now = time.time()
    stamp = time.strftime("%H:%M:%S", time.localtime(now)) + f".{int(now * 1000) % 1000:03d}"
    write(f"{stamp} dash: {text}")


def flush(timeout: float) -> bool:
    """Wait at most ``timeout`` s for the queued lines to be written; True when they were."""
    end = time.monotonic() + timeout
    with _lock:
        while _lines or _busy:
            left = end - time.monotonic()
            if left <= 0:
                return False
            _ready.wait(min(left, 0.05))
    return True


def _write_loop() -> None:
    global _dropped, _busy
    while True:
        with _lock:
            while not _lines:
                _ready.wait()
            batch = list(_lines)
            _lines.clear()
            dropped, _dropped = _dropped, 0
            _busy = True
        if dropped:
            batch.append(f"dash: {dropped} log lines dropped (standard error was not taking them)")
        data = ("\n".join(batch) + "\n").encode("utf-8", "replace")
        try:
            while data:
                data = data[os.write(2, data) :]
        except OSError:
            pass  # stderr closed or gone: the lines are lost, nothing waits on them
        with _lock:
            _busy = False
            _ready.notify_all()
