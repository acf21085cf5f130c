"""Timed speed and torque commands end by themselves: the bus schedules their stop.

``set_speed(..., duration=s)`` and ``set_torque(..., duration=s)`` (and the bus's
``set_speeds``/``set_torques``) send their command, then, ``s`` seconds later, speed 0
or torque 0 to the same motors, whatever the caller does meanwhile: no page, loop or
client has to stay alive for the motor to stop. A later motion command of this bus to
a motor cancels that motor's pending stop (it has been told something newer); closing
the bus sends the pending stops at once (whatever ``stop_on_close`` says).

On a virtual clock the stop is an operation of the session, due on its timers (it
fires while simulated time passes); on the wall clock one thread per bus, started with
its first timed command, keeps every pending stop on a :class:`~drempower.client.engine.timers.Timers`
heap and sends each when due (no thread per command). The stop is armed before its
command is sent: when it cannot be (no thread can start), the command is refused and
nothing is sent.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Sequence

from ...errors import DrEmpowerError, ValidationError
from ...protocol.limits import MOTION_CMDS
from ...protocol.messages import Message, PresetC, PresetV, Torque, Velocity
from ..driver.bus_driver import BusDriver
from ..engine.effects import Op, Send, sleep
from ..engine.timers import Timers

__all__ = ["TimedStops", "check_duration"]


def check_duration(duration: object) -> float | None:
    """``duration`` (s, > 0 and finite) or None; a :class:`ValidationError` naming it otherwise."""
    if duration is None:
        return None
    if isinstance(duration, bool) or not isinstance(duration, (int, float)) or not (0 < duration < math.inf):
        raise ValidationError(f"duration={duration!r}: expected seconds > 0 (or None: until the next command)")
    return float(duration)


def _stops(msgs: Sequence[Message]) -> list[Message]:
    """Speed 0 for every motor given a speed, torque 0 for every motor given a torque."""
    out: list[Message] = []
    for m in msgs:
        if isinstance(m, (Velocity, PresetV)):
            out.append(Velocity(m.node, 0.0))
        elif isinstance(m, (Torque, PresetC)):
            out.append(Torque(m.node, 0.0))
    return out


class TimedStops:
    """The pending stops of one bus's timed commands, one per motor (the latest command's)."""

    def __init__(self, core: BusDriver) -> None:
        self._core = core
        self._lock = threading.Lock()
        self._serial: dict[int, int] = {}
        """Per motor, the number of its latest pending stop (a stop fires only if still the latest)."""
        self._stops: dict[int, Message] = {}
        """Per motor, its pending stop (sent at once when the bus closes first)."""
        self._next = 0
        self._timers = Timers()
        """The wall clock's pending stops (time.monotonic), fired by the bus's stop thread."""
        self._wake = threading.Condition(self._lock)
        self._thread: threading.Thread | None = None
        self._closing = False
        self._firing: list[Message] = []
        """The stops the stop thread's timers found due, to send once the lock is let go."""

    def arm(self, duration: float | None) -> None:
        """Make sure a stop ``duration`` s from now can be kept (None: no stop), before the command is
        sent: on the wall clock the bus's stop thread runs. Raises :class:`DrEmpowerError` when it
        cannot start (then the command must not be sent)."""
        if duration is None or self._core.virtual:
            return
        with self._lock:
            if self._thread is not None and self._thread.is_alive():
                return
            if self._closing:
                raise DrEmpowerError("the bus is closing: no timed command is started any more")
            t = threading.Thread(target=self._run, name="drempower timed stops", daemon=True)
            try:
                t.start()
            except RuntimeError as exc:
                raise DrEmpowerError(f"the timed stop could not be armed ({exc}): nothing was sent") from None
            self._thread = t

    def commanded(self, msgs: Sequence[Message], duration: float | None) -> None:
        """Note motion ``msgs`` just sent: they cancel their motors' pending stops; with ``duration``
        (s, armed first by :meth:`arm`) their speeds/torques get a stop that many seconds from now."""
        if duration is None and not self._serial:
            return  # the hot path: nothing pending, nothing to schedule
        with self._lock:
            for m in msgs:
                if m.cmd in MOTION_CMDS:
                    self._serial.pop(m.node, None)
                    self._stops.pop(m.node, None)
            if duration is None:
                return
            stops = _stops(msgs)
            if not stops:
                return
            self._next += 1
            mine = self._next
            for s in stops:
                self._serial[s.node] = mine
                self._stops[s.node] = s
            if not self._core.virtual:
                self._timers.add(time.monotonic() + duration, lambda: self._fire(stops, mine))
                self._wake.notify()
                return
        self._core.submit(self._later(duration, stops, mine))

    def cancel(self, nodes: Sequence[int]) -> None:
        """Motors told something newer: their pending stops will not be sent."""
        if self._serial:
            with self._lock:
                for n in nodes:
                    self._serial.pop(n, None)
                    self._stops.pop(n, None)

    def flush(self) -> None:
        """Send every pending stop now (the bus is closing: a timed command never outlives it)."""
        with self._lock:
            due = list(self._stops.values())
            self._stops.clear()
            self._serial.clear()
            self._timers.clear()
            self._closing = True
            self._wake.notify()
        if due and not self._core.closed:
            try:
                self._core.send_many(due)
            except DrEmpowerError:
                pass

    def pending(self) -> set[int]:
        """The motors with a stop still to come."""
        with self._lock:
            return set(self._serial)

    def _due(self, stops: Sequence[Message], mine: int) -> list[Message]:
        """The stops still due (their motor was told nothing newer), taken off the pending ones (the
        lock held)."""
        due = [s for s in stops if self._serial.get(s.node) == mine]
        for s in due:
            del self._serial[s.node]
            self._stops.pop(s.node, None)
        return due

    def _later(self, duration: float, stops: Sequence[Message], mine: int) -> Op[None]:
        yield from sleep(duration)
        with self._lock:
            due = self._due(stops, mine)
        if due:
            yield Send(due)

    def _fire(self, stops: Sequence[Message], mine: int) -> None:
        """A wall-clock stop's timer (in the stop thread, the lock held): queue what is still due."""
        self._firing.extend(self._due(stops, mine))

    def _run(self) -> None:
        """The stop thread: sleep until the earliest pending stop, send the ones due; end on close."""
        while True:
            with self._lock:
                while not self._closing:
                    due = self._timers.next_due()
                    now = time.monotonic()
                    if due is not None and due <= now:
                        break
                    self._wake.wait(None if due is None else due - now)
                if self._closing:
                    return
                self._timers.fire_due(time.monotonic())
                send, self._firing = self._firing, []
            if send and not self._core.closed:
                try:
                    self._core.send_many(send)
                except DrEmpowerError:  # closed meanwhile: closing applied stop_on_close
                    pass
