"""The bridge's log: repeated lines rate-limited, standard error written without blocking.

The bridge logs from Zenoh's receive threads (a malformed sample, a refused
command) and from its safety paths. A stderr that nobody reads (a full pipe, a
frozen terminal) blocks a write, and with it every thread that logs after it:
the services, estop included, stopped answering. So:

* :class:`RateLimit` lets one line of each kind (its format string) through per
  interval and tells how many were held back in the next line of that kind;
* :class:`StderrLines` only queues a line (bounded, dropping and counting when
  full); one daemon thread writes the queue to file descriptor 2 with
  ``os.write``, outside every lock of Python's logging and of ``sys.stderr``.
"""

from __future__ import annotations

import logging
import os
import threading
import time
from collections import deque
from collections.abc import Callable

__all__ = ["RATE_INTERVAL", "QUEUE_LINES", "RateLimit", "StderrLines"]

RATE_INTERVAL = 1.0
"""s between two lines of one kind."""
QUEUE_LINES = 1000
"""Lines held while stderr is not taking them; beyond, new lines are dropped and counted."""


class RateLimit(logging.Filter):
    """One record of each kind (logger, level, format string) per ``interval`` s.

    The next record of a kind after its interval carries how many were held
    back: ``... (and 41 more like it in 1.0 s)``. Memory is one entry per kind
    (the bridge's format strings), whatever the traffic.
    """

    def __init__(self, interval: float = RATE_INTERVAL, clock: Callable[[], float] = time.monotonic) -> None:
        super().__init__()
        self.interval = interval
        self._clock = clock
        self._lock = threading.Lock()
        self._kinds: dict[tuple[str, int, str], tuple[float, int]] = {}
        """Per kind: when a record last went through, records held back since."""

    def filter(self, record: logging.LogRecord) -> bool:
        kind = (record.name, record.levelno, str(record.msg))
        now = self._clock()
        with self._lock:
            last, held = self._kinds.get(kind, (None, 0))
            if last is not None and now - last < self.interval:
                self._kinds[kind] = (last, held + 1)
                return False
            self._kinds[kind] = (now, 0)
        if held and last is not None:
            record.msg = f"{record.msg} (and {held} more like it in {now - last:.1f} s)"
        return True

    def held(self) -> int:
        """Records held back and not yet told."""
        with self._lock:
            return sum(h for _, h in self._kinds.values())


class StderrLines(logging.Handler):
    """A log handler (and :meth:`line` for plain lines) that queues for standard error and never blocks.

    :meth:`start` starts the writer thread; :meth:`flush_for` waits a bounded
    time for the queue to be written (at exit). A failed write (stderr closed)
    drops the lines.
    """

    def __init__(self, level: int = logging.WARNING, limit: int = QUEUE_LINES, fd: int = 2) -> None:
        super().__init__(level)
        self._fd = fd
        self._limit = limit
        self._lines: deque[str] = deque()
        self._dropped = 0
        self._busy = False
        self._cv = threading.Condition()
        self._thread: threading.Thread | None = None

    @property
    def dropped(self) -> int:
        """Lines dropped because the queue was full (reset when told)."""
        return self._dropped

    def start(self) -> StderrLines:
        with self._cv:
            if self._thread is None:
                self._thread = threading.Thread(target=self._write_loop, name="drempower stderr", daemon=True)
                self._thread.start()
        return self

    def line(self, text: str) -> None:
        """Queue ``text`` (a newline is added); never blocks, never raises."""
        with self._cv:
            if len(self._lines) >= self._limit:
                self._dropped += 1
                return
            self._lines.append(text)
            self._cv.notify_all()

    def emit(self, record: logging.LogRecord) -> None:
        try:
            text = self.format(record)
        except Exception:  # a bad format string is the caller's bug; it must not reach stderr's lock
            text = f"{record.name}: {record.msg!r} (unformattable log record)"
        self.line(text)

    def handleError(self, record: logging.LogRecord) -> None:
        pass  # logging's default prints a traceback to sys.stderr: the write this handler exists to avoid

    def flush_for(self, timeout: float) -> bool:
        """Wait at most ``timeout`` s for the queued lines to be written; True when they were."""
        end = time.monotonic() + timeout
        with self._cv:
            while self._lines or self._busy:
                left = end - time.monotonic()
                if left <= 0:
                    return False
                self._cv.wait(min(left, 0.05))
        return True

    def _write_loop(self) -> None:
        while True:
            with self._cv:
                while not self._lines:
                    self._cv.wait()
                batch = list(self._lines)
                self._lines.clear()
                dropped, self._dropped = self._dropped, 0
                self._busy = True
            if dropped:
                batch.append(f"drempower: {dropped} log lines dropped (standard error was not taking them)")
            data = ("\n".join(batch) + "\n").encode("utf-8", "replace")
            try:
                while data:
                    data = data[os.write(self._fd, data) :]
            except OSError:
                pass  # stderr closed or gone: the lines are lost, nothing waits on them
            with self._cv:
                self._busy = False
                self._cv.notify_all()
