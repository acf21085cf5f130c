"""Transport to the in-process simulator (:mod:`drempower.sim`)."""

from __future__ import annotations

import os
import queue
import time
import weakref
from collections.abc import Callable, Iterable
from dataclasses import replace
from typing import Any

from ..errors import ValidationError
from ..protocol.ids import Frame, timed
from ..robotfile import RobotSpec, load_robot
from ..sim import SimBus, SimRunner
from .base import QueuedTransport
from .capabilities import Capabilities
from .fds import close_fds, drain, nonblocking_pipe

__all__ = ["SimTransport", "CLOCKS", "FOREVER"]

CLOCKS = ("wall", "virtual")
"""The clocks of :class:`SimTransport`: wall time (a runner thread), or the simulated bus's own time."""
FOREVER = 60.0
"""The simulated time (s) a receive without a timeout lets pass on the virtual clock before it gives up."""


class SimTransport(QueuedTransport):
    """Simulated motors ``motors`` on their own :class:`~drempower.sim.SimBus`, run in real time.

    ``time_scale`` > 1 runs the simulation faster than real time. Pass ``bus`` to use an
    existing SimBus (``motors`` and the SimBus options are then ignored); ``time_scale=0``
    starts no runner, so the caller advances the bus's clock itself. Other keyword
    arguments go to SimBus (``bitrate``, ``faults``, ``seed``, ``config_dir``...).

    ``clock="virtual"`` runs no thread at all: the SimBus's simulated time is the
    client's clock. Whenever the client would wait (for a reply, a timeout, a sleep,
    a move to end) it advances the simulated bus instead, by exactly as long, so a
    2 s move returns in milliseconds of wall time with every timeout, retry and
    sleep behaving as on real time. Time passes only while a call waits: between
    calls the motors stand still in time. The default ``clock="wall"`` runs the
    simulation on wall time (scaled by ``time_scale``).

    ``robot`` (a robot file or :class:`~drempower.robot.RobotSpec`) simulates the motors
    of its bus ``robot_bus`` (default: its only bus), coupled to its physics model when
    it names one (see :mod:`drempower.sim.twin`).
    """

    default_timeout = 0.5
    """The simulator runs in the client's interpreter, so give replies a little more room than on a bus."""

    def __init__(
        self,
        motors: Iterable[int] = (1,),
        *,
        time_scale: float = 1.0,
        clock: str = "wall",
        bus: SimBus | None = None,
        robot: str | os.PathLike[str] | RobotSpec | None = None,
        robot_bus: str | None = None,
        **simbus_kwargs: Any,
    ) -> None:
        if "ids" in simbus_kwargs:  # SimBus's own name for them
            ids = simbus_kwargs["ids"]
            raise ValidationError(f"ids={ids!r}: the simulated motors are given as motors= (e.g. motors=[1, 2])")
        if clock not in CLOCKS:
            allowed = ", ".join(map(repr, CLOCKS))
            raise ValidationError(f"clock={clock!r}: must be one of {allowed}")
        virtual = clock == "virtual"
        if virtual and time_scale != 1.0:
            raise ValidationError(
                f"time_scale={time_scale!r}: takes no value with clock='virtual' (simulated time passes as the "
                "client waits); leave it out"
            )
        if time_scale < 0:
            raise ValidationError(f"time_scale={time_scale!r}: must be >= 0 (0: the caller advances the clock)")
        if virtual and bus is not None and bus.clock_sync is not None:
            raise ValidationError("clock='virtual': the SimBus given is already run by a SimRunner; stop it first")
        if robot is not None:
            if bus is not None:
                raise ValidationError("pass robot= or bus=, not both")
            bus = _robot_bus(robot, robot_bus, simbus_kwargs)
        elif robot_bus is not None:
            raise ValidationError(f"robot_bus={robot_bus!r} needs robot= (a robot file)")
        self.bus = bus if bus is not None else SimBus(ids=motors, **simbus_kwargs)
        """The simulated bus."""
        self.virtual_clock = virtual
        super().__init__()
        self.wire_bitrate = self.bus.bitrate
        self._capture: list[Frame] | None = None
        self._signal_w: int | None = None
        self._signal_r: int | None = None
        self._sink = self._deliver
        self.bus.add_listener(self._sink, host_frames=True)
        self._time_scale = time_scale if time_scale > 0 and not virtual else 0.0
        self._mono0, self._sim0 = time.monotonic(), self.bus.now
        self._runner = SimRunner(self.bus, time_scale).start() if time_scale > 0 and not virtual else None
        ids = ",".join(str(m.node_id) for m in self.bus.motors.values())
        pace = "virtual clock" if virtual else f"time x{time_scale:g}" if time_scale > 0 else "manual clock"
        rate = f"{self.bus.bitrate} bit/s" if self.bus.bitrate else "instant delivery"
        self.description = f"simulator: motors {ids} ({rate}, {pace})"

    @property
    def motor_ids(self) -> frozenset[int]:
        """The ids of the simulated motors (the client refuses broadcast reads when there are several)."""
        return frozenset(m.node_id for m in self.bus.motors.values())

    @property
    def capabilities(self) -> Capabilities:
        """The simulator's: it confirms what is on the wire, answers inside a send with instant delivery,
        knows its motors and, with ``clock="virtual"``, runs on its own time."""
        return replace(
            super().capabilities,
            confirms_sent=True,
            answers_in_send=self.instant,
            motor_ids=self.motor_ids,
        )

    def clock(self) -> SimTransport | None:
        """This transport itself with ``clock="virtual"`` (:meth:`now`, :meth:`advance`), else None."""
        return self if self.virtual_clock else None

    def __enter__(self) -> SimTransport:
        return self

    def _deliver(self, frame: Frame) -> None:
        scale = self._time_scale
        if scale:  # the frame's own time: the simulator's, on the host's scale (it may fall behind a busy host)
            frame = timed(frame, self._mono0 + (self.bus.now - self._sim0) / scale)
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

    # ------------------------------------------------------------------ the virtual clock

    def now(self) -> float:
        """The simulated bus's time (s): the client's clock with ``clock="virtual"``."""
        return self.bus.now

    def advance(self, seconds: float, until: Callable[[], bool] | None = None) -> bool:
        """Let up to ``seconds`` of simulated time pass, ending early (at the time it happened) once a
        frame is queued for :meth:`read_nowait` or ``until()`` is true. Returns True when it ended early."""
        if seconds <= 0 or self._closed:
            return False
        q = self._queue

        def stop() -> bool:
            return not q.empty() or (until is not None and until())

        return self.bus.advance(seconds, stop)

    def recv(self, timeout: float | None = None) -> Frame | None:
        """Next received frame, or None after ``timeout`` s (or once closed); with ``clock="virtual"`` the
        wait lets simulated time pass (``timeout=None``: at most :data:`FOREVER`)."""
        if not self.virtual_clock:
            return super().recv(timeout)
        if self._closed:
            return None
        return self.wait_frame(FOREVER if timeout is None else max(timeout, 0.0))

    def wait_frame(self, timeout: float) -> Frame | None:
        """The next received frame, or None after ``timeout`` s (simulated time with ``clock="virtual"``)."""
        if not self.virtual_clock:
            return super().wait_frame(timeout)
        if self._queue.empty():
            self.advance(timeout)
        return super().wait_frame(0.0)

    def wait_sent(self, timeout: float) -> bool | None:
        """Wait until every frame sent through this transport has been transmitted on the simulated bus.

        True once they have, False when ``timeout`` s passed first, None with a manual
        clock (nothing advances the bus while we wait). With ``clock="virtual"`` the
        wait lets simulated time pass.
        """
        bus = self.bus
        if bus.bitrate is None:
            return True
        origin = self._sink
        if self.virtual_clock:
            with bus.lock:
                if bus.host_pending(origin) == 0:
                    return True
                self.bus.advance(timeout, lambda: bus.host_pending(origin) == 0)
                return bus.host_pending(origin) == 0
        if self._runner is None:
            return None
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


def _robot_bus(robot: str | os.PathLike[str] | RobotSpec, name: str | None, kwargs: dict[str, Any]) -> SimBus:
    """The simulated bus ``name`` of robot ``robot``, coupled to its model when it has one."""
    from ..sim.robot_buses import simulated_buses

    spec = robot if isinstance(robot, RobotSpec) else load_robot(robot)
    if name is None:
        if len(spec.buses) != 1:
            raise ValidationError(f"robot={spec.source}: it has buses {', '.join(spec.buses)}: give robot_bus=NAME")
        (name,) = spec.buses
    elif name not in spec.buses:
        raise ValidationError(f"robot_bus={name!r}: not a bus of {spec.source} ({', '.join(spec.buses)})")
    bus = simulated_buses(spec, {name: kwargs}).get(name)
    if bus is None:
        bus = SimBus(sorted(j.id for j in spec.joints_on(name)), **kwargs)
    return bus
