"""Run a :class:`~drempower.sim.bus.SimBus` in real time (or faster) on a thread.

The runner sleeps until the next thing that must happen at its own time (the
end of the frame on the wire, a scheduled event, a motor timer) or until a host
sends a frame; before a host frame enters the bus the clock is brought up to
wall time, so every frame is delivered at its completion time rather than on a
fixed tick. With nothing due it wakes every :data:`_IDLE_PERIOD` to keep the
motors' physics current.
"""

from __future__ import annotations

import threading
import time
from types import TracebackType

from ..errors import ValidationError
from .bus import SimBus

__all__ = ["SimRunner"]

_IDLE_PERIOD = 0.02
"""Longest sleep (wall s) when nothing is due."""
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
        self._stop = False
        self._wake = threading.Event()
        self._last = time.monotonic()
        self._thread: threading.Thread | None = None

    @property
    def running(self) -> bool:
        return self._thread is not None and self._thread.is_alive()

    def start(self) -> SimRunner:
        """Start advancing the bus (no-op when already running)."""
        if not self.running:
            self._stop = False
            with self.bus.lock:
                self._last = time.monotonic()
                self.bus.clock_sync = self._sync
                self.bus.on_activity = self._wake.set
            self._thread = threading.Thread(target=self._run, name="drempower-sim", daemon=True)
            self._thread.start()
        return self

    def stop(self) -> None:
        """Stop advancing and wait for the thread to end."""
        self._stop = True
        self._wake.set()
        if self._thread is not None:
            self._thread.join()
            self._thread = None
        with self.bus.lock:
            if self.bus.clock_sync == self._sync:
                self.bus.clock_sync = None
                self.bus.on_activity = None

    def _sync(self) -> None:
        """Advance the bus by the wall time since the last advance (call with the bus lock held)."""
        now = time.monotonic()
        elapsed = min(now - self._last, _MAX_CATCH_UP)
        self._last = now
        if elapsed > 0:
            self.bus.advance(elapsed * self.time_scale)

    def _run(self) -> None:
        bus, wake, scale = self.bus, self._wake, self.time_scale
        while not self._stop:
            wake.clear()
            with bus.lock:
                self._sync()
                ahead = (bus.next_due() - bus.now) / scale
            wake.wait(min(_IDLE_PERIOD, max(ahead, 0.0)))

    def __enter__(self) -> SimRunner:
        return self.start()

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.stop()
