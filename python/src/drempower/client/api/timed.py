"""Timed speed and torque commands end by themselves: the bus schedules their stop.

``set_speed(..., duration=s)`` and ``set_torque(..., duration=s)`` (and the bus's
``set_speeds``/``set_torques``) send their command, then, ``s`` seconds later, speed 0
or torque 0 to the same motors, whatever the caller does meanwhile: no page, loop or
client has to stay alive for the motor to stop. A later motion command of this bus to
a motor cancels that motor's pending stop (it has been told something newer); closing
the bus sends the pending stops at once (whatever ``stop_on_close`` says).

On a virtual clock the stop is an operation of the session, due on its timers (it
fires while simulated time passes); on the wall clock a timer thread sends it.
"""

from __future__ import annotations

import math
import threading
from collections.abc import Sequence

from ...errors import DrEmpowerError, ValidationError
from ...protocol.limits import MOTION_CMDS
from ...protocol.messages import Message, PresetC, PresetV, Torque, Velocity
from ..driver.bus_driver import BusDriver
from ..engine.effects import Op, Send, sleep

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

    def commanded(self, msgs: Sequence[Message], duration: float | None) -> None:
        """Note motion ``msgs`` just sent: they cancel their motors' pending stops; with ``duration``
        (s) their speeds/torques get a stop that many seconds from now."""
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
        if self._core.virtual:
            self._core.submit(self._later(duration, stops, mine))
        else:
            t = threading.Timer(duration, self._fire, (stops, mine))
            t.daemon = True
            t.name = "drempower-timed-stop"
            t.start()

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
        """The stops still due (their motor was told nothing newer), taken off the pending ones."""
        with self._lock:
            due = [s for s in stops if self._serial.get(s.node) == mine]
            for s in due:
                del self._serial[s.node]
                self._stops.pop(s.node, None)
        return due

    def _later(self, duration: float, stops: Sequence[Message], mine: int) -> Op[None]:
        yield from sleep(duration)
        due = self._due(stops, mine)
        if due:
            yield Send(due)

    def _fire(self, stops: Sequence[Message], mine: int) -> None:
        due = self._due(stops, mine)
        if due and not self._core.closed:
            try:
                self._core.send_many(due)
            except DrEmpowerError:  # closed meanwhile: closing applied stop_on_close
                pass
