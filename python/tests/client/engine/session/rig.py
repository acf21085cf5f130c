"""A :class:`BusSession` on a scripted clock, and scripted motors that answer what it sends."""

from __future__ import annotations

import heapq
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import Any, TypeVar

from drempower.client.engine.effects import Op
from drempower.client.engine.session import BusSession, Operation
from drempower.protocol import FastRead, ParamValue, ReadParam, State, decode_command
from drempower.protocol.ids import Frame
from drempower.protocol.messages import Command

T = TypeVar("T")


@dataclass
class ScriptedMotor:
    """Answers fast reads with a state and parameter reads with ``params`` (0 when unset), ``lag`` s later.

    ``states`` are (angle deg, T bit, E bit) answered to the next fast reads in order; once used up,
    ``angle``, ``done`` and ``error`` are. A ``silent`` motor answers nothing.
    """

    node: int
    angle: float = 0.0
    done: bool = True
    error: bool = False
    params: dict[int, int | float] = field(default_factory=dict)
    states: list[tuple[float, bool, bool]] = field(default_factory=list)
    silent: bool = False
    lag: float = 0.001

    def answer(self, cmd: Command) -> Frame | None:
        if self.silent:
            return None
        if isinstance(cmd, FastRead):
            angle, done, error = self.states.pop(0) if self.states else (self.angle, self.done, self.error)
            return State(self.node, angle, 0.0, 0.0, done, error).encode()
        if isinstance(cmd, ReadParam):
            return ParamValue(self.node, cmd.address, cmd.dtype, self.params.get(cmd.address, 0)).encode()
        return None


class Rig:
    """A session (created at time 0) and its motors; the script moves time only through :meth:`at` / :meth:`run`.

    ``wire`` records every frame taken from the session, decoded, with the time it was taken.
    """

    def __init__(self, motors: Iterable[int] = (1, 2, 3), **options: Any) -> None:
        motors = tuple(motors)
        options.setdefault("motor_ids", motors)  # the bus's motors are known, as the simulator declares them
        self.session = BusSession(**options)
        self.motors = {n: ScriptedMotor(n) for n in motors}
        self.wire: list[tuple[float, Command]] = []
        self._flight: list[tuple[float, int, Frame]] = []

    @property
    def now(self) -> float:
        return self.session.now

    def take(self) -> list[Command]:
        """The frames the session hands over now, decoded; the motors' answers go in flight."""
        out = []
        for f in self.session.data_to_send():
            cmd = decode_command(f.arbitration_id, f.data)
            self.wire.append((self.now, cmd))
            out.append(cmd)
            for n in sorted(self.motors) if cmd.node == 0 else [cmd.node]:
                m = self.motors.get(n)
                reply = None if m is None else m.answer(cmd)
                if m is not None and reply is not None:
                    heapq.heappush(self._flight, (self.now + m.lag, len(self.wire) * 64 + n, reply))
        return out

    def at(self, t: float) -> None:
        """Deliver the answers due by ``t`` (each at its own time), then advance the session to ``t``."""
        while self._flight and self._flight[0][0] <= t:
            due, _, frame = heapq.heappop(self._flight)
            self.session.advance(due)
            self.session.receive(frame, due)
        self.session.advance(t)

    def submit(self, op: Op[T]) -> Operation[T]:
        return self.session.submit(op)

    def run(self, op: Op[T], until: float = 100.0) -> Operation[T]:
        """Submit ``op`` and run the script (frames out, answers in, deadlines) until it is done."""
        opn = self.session.submit(op)
        self.settle(lambda: opn.done, until)
        return opn

    def settle(self, stop: Callable[[], bool] = lambda: False, until: float = 100.0) -> None:
        """Step from event to event (an answer arriving, the session's next deadline) until ``stop()``,
        nothing is left to happen, or time ``until``."""
        while True:
            self.take()
            if stop():
                return
            times = [
                t for t in (self._flight[0][0] if self._flight else None, self.session.next_deadline()) if t is not None
            ]
            if not times or min(times) > until:
                return
            self.at(min(times))

    def sent(self, kind: type | None = None) -> list[tuple[float, Command]]:
        """What was taken so far (of type ``kind``)."""
        return [(t, c) for t, c in self.wire if kind is None or isinstance(c, kind)]
