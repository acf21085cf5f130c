"""What a signal handler hands over when it interrupted its own thread's bus work: the stops it asks for run
in threads of their own, which take the bus as soon as the interrupted code lets it go (see
:meth:`BusDriver.estop <drempower.client.driver.bus_driver.BusDriver.estop>` and ``close``)."""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable
from typing import Any

__all__ = ["Handoff"]

_log = logging.getLogger("drempower.client")
_monotonic = time.monotonic


class Handoff:
    """The threads doing what signal handlers handed over on one bus (``describe()`` names the bus):
    estops and the close. A close waits for them first (:meth:`wait`), but not for good."""

    __slots__ = ("_describe", "closer", "threads")

    def __init__(self, describe: Callable[[], str]) -> None:
        self._describe = describe
        self.threads: list[threading.Thread] = []
        """Every thread handed something, in the order they were made."""
        self.closer: threading.Thread | None = None
        """The thread closing the bus for a signal handler, once there is one."""

    def later(self, what: Callable[..., None], *args: Any, **kwargs: Any) -> threading.Thread:
        """Run ``what`` in a thread of its own: it takes the bus lock as soon as the interrupted code lets it
        go (carrying on, or unwinding from the handler's ``SystemExit``). A close waits for it first, but
        not for good: code a signal cuts short may leave a lock of a library held for good."""

        def run() -> None:
            try:
                what(*args, **kwargs)
            except Exception:  # a later close tries again
                _log.exception("stopping %s for a signal handler failed", self._describe())

        name = f"drempower stop ({self._describe()})"
        thread = threading.Thread(target=run, name=name, daemon=True)
        thread.start()
        self.threads.append(thread)
        return thread

    def closing(self) -> bool:
        """True while a thread handed the close runs."""
        return self.closer is not None and self.closer.is_alive()

    def wait(self, timeout: float) -> None:
        """Wait, ``timeout`` s at most in all, for the threads of :meth:`later` (but the calling one), those
        handed over meanwhile included."""
        end = _monotonic() + timeout
        me = threading.current_thread()
        while (left := end - _monotonic()) > 0:
            waiting = [t for t in self.threads if t is not me and t.is_alive()]
            if not waiting:
                return
            waiting[0].join(left)
