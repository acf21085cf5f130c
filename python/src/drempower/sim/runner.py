"""Run a :class:`~drempower.sim.bus.SimBus` in real time (or faster) on a thread."""

from __future__ import annotations

import threading
import time
from types import TracebackType

from ..errors import ValidationError
from .bus import SimBus

__all__ = ["SimRunner"]

_PERIOD = 0.001
"""Wall-clock period between advances (s)."""
_MAX_CATCH_UP = 0.05
"""Most wall time one advance makes up for (s); beyond it the simulation falls behind."""


class SimRunner:
    """A thread that advances ``bus`` by ``time_scale`` simulated seconds per wall second.

    ``start()``/``stop()``, or use it as a context manager. ``time_scale`` > 1 runs
    faster than real time (as far as the machine keeps up).
    """

    def __init__(self, bus: SimBus, time_scale: float = 1.0) -> None:
        if not time_scale > 0:
            raise ValidationError(f"time_scale={time_scale!r}: must be > 0 simulated seconds per second")
        self.bus = bus
        self.time_scale = time_scale
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    @property
    def running(self) -> bool:
        return self._thread is not None and self._thread.is_alive()

    def start(self) -> SimRunner:
        """Start advancing the bus (no-op when already running)."""
        if not self.running:
            self._stop.clear()
            self._thread = threading.Thread(target=self._run, name="drempower-sim", daemon=True)
            self._thread.start()
        return self

    def stop(self) -> None:
        """Stop advancing and wait for the thread to end."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join()
            self._thread = None

    def _run(self) -> None:
        last = time.monotonic()
        while not self._stop.wait(_PERIOD):
            now = time.monotonic()
            elapsed = min(now - last, _MAX_CATCH_UP)
            last = now
            self.bus.advance(elapsed * self.time_scale)

    def __enter__(self) -> SimRunner:
        return self.start()

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.stop()
