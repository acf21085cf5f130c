"""Transport to the in-process simulator (:mod:`drempower.sim`)."""

from __future__ import annotations

import os
import queue
import weakref
from collections.abc import Iterable
from typing import Any

from ..errors import ValidationError
from ..protocol.ids import Frame
from ..sim import SimBus, SimRunner
from .base import QueuedTransport
from .fds import close_fds, drain, nonblocking_pipe

__all__ = ["SimTransport"]


class SimTransport(QueuedTransport):
    """Simulated motors ``motors`` on their own :class:`~drempower.sim.SimBus`, run in real time.

    ``time_scale`` > 1 runs the simulation faster than real time. Pass ``bus`` to use an
    existing SimBus (``motors`` and the SimBus options are then ignored); ``time_scale=0``
    starts no runner, so the caller advances the bus's clock itself. Other keyword
    arguments go to SimBus (``bitrate``, ``faults``, ``seed``, ``config_dir``...).
    """

    default_timeout = 0.5
    """The simulator runs in the client's interpreter, so give replies a little more room than on a bus."""

    def __init__(
        self,
        motors: Iterable[int] = (1,),
        *,
        time_scale: float = 1.0,
        bus: SimBus | None = None,
        **simbus_kwargs: Any,
    ) -> None:
        if time_scale < 0:
            raise ValidationError(f"time_scale={time_scale!r}: must be >= 0 (0: the caller advances the clock)")
        self.bus = bus if bus is not None else SimBus(ids=motors, **simbus_kwargs)
        """The simulated bus."""
        super().__init__()
        self.wire_bitrate = self.bus.bitrate
        self._capture: list[Frame] | None = None
        self._signal_w: int | None = None
        self._signal_r: int | None = None
        self._sink = self._deliver
        self.bus.add_listener(self._sink, host_frames=True)
        self._runner = SimRunner(self.bus, time_scale).start() if time_scale > 0 else None
        ids = ",".join(str(m.node_id) for m in self.bus.motors.values())
        pace = f"time x{time_scale:g}" if time_scale > 0 else "manual clock"
        rate = f"{self.bus.bitrate} bit/s" if self.bus.bitrate else "instant delivery"
        self.description = f"simulator: motors {ids} ({rate}, {pace})"

    @property
    def motor_ids(self) -> frozenset[int]:
        """The ids of the simulated motors (the client refuses broadcast reads when there are several)."""
        return frozenset(m.node_id for m in self.bus.motors.values())

    def __enter__(self) -> SimTransport:
        return self

    def _deliver(self, frame: Frame) -> None:
        capture = self._capture
        if capture is not None:  # set only while send_collect holds the bus's lock: this is its answer
            capture.append(frame)
        else:
            self._queue.put(frame)
            w = self._signal_w
            if w is not None:
                try:
                    os.write(w, b"\0")
                except OSError:  # full: a byte is already waiting; closed: nobody reads
                    pass

    def fileno(self) -> int | None:
        """A pipe that turns readable when a frame is queued (made on first use; frames are then taken
        with :meth:`read_nowait`, which empties it)."""
        if self._signal_r is None:
            r, w = nonblocking_pipe()
            weakref.finalize(self, close_fds, r, w)
            self._signal_r, self._signal_w = r, w
            if not self._queue.empty():
                os.write(w, b"\0")
        return self._signal_r

    def read_nowait(self) -> list[Frame]:
        """The frames queued so far (empties the :meth:`fileno` pipe first, so a frame queued meanwhile
        leaves it readable)."""
        r = self._signal_r
        if r is not None:
            drain(r)
        out: list[Frame] = []
        q = self._queue
        while True:
            try:
                f = q.get_nowait()
            except queue.Empty:
                return out
            if f is None:  # closed: leave the wake-up in place
                q.put(None)
                return out
            out.append(f)

    @property
    def instant(self) -> bool:
        """True when the simulated bus delivers at once (no bit rate): :meth:`send_collect` returns the answers."""
        return self.bus.bitrate is None

    def send(self, frame: Frame) -> None:
        self.bus.send(frame, self._sink)

    def send_collect(self, frame: Frame) -> list[Frame]:
        """Send ``frame`` and return the frames queued for :meth:`recv` before it, then those the bus
        delivered to this transport meanwhile (with instant delivery: the motors' answers), in order."""
        out: list[Frame] = []
        bus = self.bus
        with bus.lock:  # no other thread delivers while it is held
            q = self._queue
            while not q.empty():
                f = q.get_nowait()
                if f is None:  # closed: leave the wake-up for the receive thread
                    q.put(None)
                    break
                out.append(f)
            self._capture = out
            try:
                bus.send(frame, self._sink)
            finally:
                self._capture = None
        return out

    def wait_sent(self, timeout: float) -> bool | None:
        """Wait until every frame sent through this transport has been transmitted on the simulated bus.

        True once they have, False when ``timeout`` s passed first, None with a manual
        clock (nothing advances the bus while we wait).
        """
        bus = self.bus
        if bus.bitrate is None:
            return True
        if self._runner is None:
            return None
        origin = self._sink
        with bus.tx_done:
            return bus.tx_done.wait_for(lambda: bus.host_pending(origin) == 0, timeout)

    def close(self) -> None:
        if self._closed:
            return
        self._closed = True
        self.bus.remove_listener(self._sink)
        if self._runner is not None:
            self._runner.stop()
        self._wake()
        if self._signal_w is not None:
            try:
                os.write(self._signal_w, b"\0")
            except OSError:
                pass
