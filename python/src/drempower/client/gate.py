"""The safety gate in front of every motion command of the Python API (no I/O in its checks).

Before a motion command leaves, the gate checks, in this order, and refuses with
nothing sent:

1. the **soft limits** of each motor (:meth:`MotionGate.set_limits`, from
   ``bus.set_limits`` or a robot file's ``limits``): position range (deg), speed
   (r/min), torque (Nm), acceleration ((r/min)/s) and the largest step a single
   position command may make from the last known position (``max_step``, deg),
   raising :class:`~drempower.errors.SoftLimitError` naming the limit and where it
   was set;
2. that each motor is **in closed loop**, raising
   :class:`~drempower.errors.MotorIdleError` naming the motor and the fix, unless
   the caller passed ``enable=True`` (then the enable goes first, the command after).

What is known costs nothing: a motor is known to be in closed loop once this bus
enabled it or read it so, until a state frame shows its error bit, or this bus
sends it an idle request, an estop, a clear, a reboot or a configuration reset. A
motor not known so is read once (``axis0.current_state``, one request for every
motor of the command), so a control loop or a 1 kHz stream pays one read, not one
per command. Commands to every motor (node 0) are not gated: no single motor's
state answers for them.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Protocol

from ..errors import MotorIdleError, SoftLimitError, ValidationError
from ..protocol.addresses import AXIS0_CURRENT_STATE, AXIS0_REQUESTED_STATE
from ..protocol.enums import AxisState, VelocityMode
from ..protocol.limits import MOTION_CMDS, OPEN_LOOP_SYS_CMDS
from ..protocol.messages import (
    Message,
    ParamValue,
    PositionP,
    PositionQ,
    PositionT,
    PresetC,
    PresetD,
    PresetP,
    PresetQ,
    PresetT,
    PresetV,
    ReadParam,
    SystemCommand,
    Torque,
    Velocity,
    WriteParam,
)
from ..protocol.parameters import DataType
from .commands import PositionMode, make_angles, position_mode
from .effects import Op, Send, read_states, request
from .state import MotorState

__all__ = ["Intent", "Limit", "MotionGate", "intents_of", "move_intents", "move_intent", "LIMIT_UNITS"]


class _States(Protocol):
    """Where the latest state of each motor is (the bus's state cache)."""

    def get(self, node: int) -> MotorState | None: ...


_CLOSED = int(AxisState.CLOSED_LOOP_CONTROL)
_FORGETS = OPEN_LOOP_SYS_CMDS
"""System commands after which a motor is no longer known to be in closed loop."""

LIMIT_UNITS = {"position": "deg", "speed": "r/min", "torque": "Nm", "accel": "(r/min)/s", "max_step": "deg"}
"""The soft limits a motor can have, with their units (motor side, output shaft)."""


@dataclass(frozen=True, slots=True)
class Intent:
    """What one motion command asks of one motor, in motor units (None: not part of it).

    ``position`` deg is a target, or a step from where the motor is when ``relative``;
    ``speed`` r/min, ``torque`` Nm and ``accel`` (r/min)/s are checked by magnitude.
    """

    node: int
    position: float | None = None
    relative: bool = False
    speed: float | None = None
    torque: float | None = None
    accel: float | None = None


@dataclass(frozen=True, slots=True)
class Limit:
    """One soft limit: ``low``..``high`` in its unit, and where it was set (for the error)."""

    low: float
    high: float
    where: str


def move_intents(
    ids: Sequence[int], angles: Sequence[float], speed: float, param: float, mode: int, *, relative: bool
) -> list[Intent]:
    """The intents of a synchronised move (set_angles/step_angles), its values validated first."""
    make_angles(ids, angles, speed, param, mode, move_time=1.0, relative=relative)  # raises what the move would
    return [move_intent(n, a, speed, param, mode, relative) for n, a in zip(ids, angles, strict=True)]


def move_intent(node: int, angle: float, speed: float, param: float, mode: int, relative: bool) -> Intent:
    """The intent of one motor's position move (``speed``/``param`` as set_angles takes them in ``mode``)."""
    m = position_mode(mode)
    if m is PositionMode.Q:
        return Intent(node, float(angle), relative, speed=speed, accel=param)
    if m is PositionMode.P:
        return Intent(node, float(angle), relative, speed=speed, torque=param)
    return Intent(node, float(angle), relative)


def intents_of(msgs: Iterable[Message]) -> list[Intent]:
    """The intents of motion messages (the others are left out); relative starts are not seen here."""
    out: list[Intent] = []
    for m in msgs:
        if isinstance(m, (PositionT, PresetT)):
            out.append(Intent(m.node, m.position))
        elif isinstance(m, PositionQ):
            out.append(Intent(m.node, m.position, speed=m.speed, accel=m.accel))
        elif isinstance(m, PresetQ):
            out.append(Intent(m.node, m.position, accel=m.accel))
        elif isinstance(m, (PositionP, PresetP)):
            out.append(Intent(m.node, m.position, speed=m.speed_ff, torque=m.torque_ff))
        elif isinstance(m, (Velocity, PresetV)):
            ramp = m.mode == VelocityMode.RAMP
            out.append(Intent(m.node, speed=m.speed, accel=m.param if ramp else None, torque=None if ramp else m.param))
        elif isinstance(m, (Torque, PresetC)):
            out.append(Intent(m.node, torque=m.torque))
        elif isinstance(m, PresetD):
            out.append(Intent(m.node, m.position, speed=m.speed, torque=m.torque_ff))
    return out


class MotionGate:
    """What one bus knows of its motors' axis state, their soft limits and last targets (no I/O)."""

    def __init__(self) -> None:
        self._closed: set[int] = set()
        self._idled: dict[int, int] = {}
        """Motors this bus itself asked out of closed loop (axis state asked) and has not enabled since: a read
        of their state may overtake that request on the wire (a lower CAN id wins arbitration), so a read
        saying closed loop is not believed."""
        self._limits: dict[int, dict[str, Limit]] = {}
        self._targets: dict[int, float] = {}

    # ------------------------------------------------------------------ soft limits

    def set_limits(self, node: int, where: str, **limits: object) -> None:
        """Set soft limits of motor ``node`` (motor units, see :data:`LIMIT_UNITS`); None removes one.

        ``position`` is ``(low, high)``; the others are magnitudes (``speed=30`` allows -30..30).
        """
        table = dict(self._limits.get(node, {}))
        for name, value in limits.items():
            if name not in LIMIT_UNITS:
                raise ValidationError(f"{name!r}: no such limit; the limits are {', '.join(LIMIT_UNITS)}")
            if value is None:
                table.pop(name, None)
                continue
            table[name] = _limit(name, value, where)
        if table:
            self._limits[node] = table
        else:
            self._limits.pop(node, None)

    def limits(self, node: int) -> Mapping[str, Limit]:
        """The soft limits of motor ``node`` (empty when it has none)."""
        return self._limits.get(node, {})

    # ------------------------------------------------------------------ what is known

    def is_closed(self, node: int, state: MotorState | None = None) -> bool:
        """True when motor ``node`` is known to be in closed loop (its latest state shows no error)."""
        return node in self._closed and (state is None or not state.error)

    def learn(self, node: int, axis_state: int) -> None:
        """Record motor ``node``'s axis state as read (``axis0.current_state``)."""
        if axis_state == _CLOSED:
            self._closed.add(node)
        else:
            self._closed.discard(node)

    def learn_replies(self, answers: Iterable[object]) -> None:
        """Learn the axis states among a request's answers (``axis0.current_state`` replies)."""
        for a in answers:
            if isinstance(a, ParamValue) and a.address == AXIS0_CURRENT_STATE and a.node:
                self.learn(a.node, int(a.value))

    def forget(self, nodes: Iterable[int]) -> None:
        """Motors (0 = every motor) no longer known to be in closed loop."""
        for n in nodes:
            if n == 0:
                self._closed.clear()
                self._targets.clear()
            else:
                self._closed.discard(n)
                self._targets.pop(n, None)

    def note_sent(self, msgs: Iterable[Message]) -> None:
        """Learn from what this bus sent: enables and idle requests, stops, position targets."""
        for m in msgs:
            if m.cmd in MOTION_CMDS:
                if not self._limits:
                    continue  # targets serve max_step and relative limits only
                if isinstance(m, (PositionT, PositionQ, PositionP)):
                    if m.node:
                        self._targets[m.node] = m.position
                else:
                    self._targets.pop(m.node, None)
            elif isinstance(m, WriteParam):
                if m.address == AXIS0_REQUESTED_STATE:
                    if m.node == 0:
                        self._closed.clear()
                        self._idled.clear()
                    else:
                        self.learn(m.node, int(m.value))
                        if int(m.value) == _CLOSED:
                            self._idled.pop(m.node, None)
                        else:
                            self._idled[m.node] = int(m.value)
            elif isinstance(m, SystemCommand) and m.op in _FORGETS:
                self.forget((m.node,))

    def note_targets(self, nodes: Sequence[int], targets: Sequence[float]) -> None:
        """Record the absolute targets (deg) a synchronised move sent."""
        for n, t in zip(nodes, targets, strict=True):
            self._targets[n] = float(t)

    def forget_targets(self, nodes: Iterable[int]) -> None:
        """Motors whose last target is no longer known (a relative move, a speed...)."""
        for n in nodes:
            self._targets.pop(n, None)

    def clear(self, msgs: Sequence[Message], states: _States) -> bool:
        """True when ``msgs`` pass without a look at their values: no soft limits anywhere and every
        motor known in closed loop (the fast path of a control loop)."""
        if self._limits:
            return False
        closed = self._closed
        for m in msgs:
            n = m.node
            if n not in closed:
                if n:
                    return False
                continue
            st = states.get(n)
            if st is not None and st.error:
                return False
        return True

    # ------------------------------------------------------------------ the checks

    def needs(self, intents: Sequence[Intent], states: _States) -> tuple[list[int], list[int]]:
        """Pure checks of ``intents`` (raises SoftLimitError), then what must be read before they pass:
        ``(motors whose axis state is unknown, motors whose position is needed)``."""
        unknown: list[int] = []
        positions: list[int] = []
        for it in intents:
            n = it.node
            if n == 0:
                continue
            table = self._limits.get(n)
            if table:
                _check_values(n, it, table)
                wants = it.position is not None and ("max_step" in table or (it.relative and "position" in table))
                if wants and n not in positions and self._last_position(n, states) is None:
                    positions.append(n)
            if not self.is_closed(n, states.get(n)) and n not in unknown:
                unknown.append(n)
        return unknown, positions

    def check_positions(self, intents: Sequence[Intent], states: _States) -> None:
        """Check relative targets and ``max_step`` against the last known positions (raises SoftLimitError)."""
        for it in intents:
            table = self._limits.get(it.node)
            if not table or it.position is None:
                continue
            last = self._last_position(it.node, states)
            if last is None:
                continue
            step = it.position if it.relative else it.position - last
            lim = table.get("max_step")
            if lim is not None and abs(step) > lim.high:
                raise SoftLimitError(it.node, "max_step", step, -lim.high, lim.high, "deg", lim.where)
            lim = table.get("position")
            if lim is not None and it.relative and not lim.low <= last + step <= lim.high:
                raise SoftLimitError(it.node, "position", last + step, lim.low, lim.high, "deg", lim.where)

    def _last_position(self, node: int, states: _States) -> float | None:
        target = self._targets.get(node)
        if target is not None:
            return target
        st = states.get(node)
        return None if st is None else st.angle

    def passage(
        self,
        intents: Sequence[Intent],
        states: _States,
        enable: bool,
        timeout: float | None = None,
    ) -> Op[None] | None:
        """None when ``intents`` may go at once; else the operation that reads what is missing, checks,
        and enables when asked (raises before any motion frame exists)."""
        unknown, positions = self.needs(intents, states)
        if not unknown and not positions:
            if any(self._limits.get(it.node) for it in intents):
                self.check_positions(intents, states)
            return None
        return self._pass(intents, unknown, positions, enable, timeout)

    def _pass(
        self, intents: Sequence[Intent], unknown: list[int], positions: list[int], enable: bool, timeout: float | None
    ) -> Op[None]:
        read: dict[int, MotorState] = {}
        if positions:
            got = yield from read_states(positions, timeout)
            read = {st.node: st for st in got if st is not None}
        self.check_positions(intents, read)
        if not unknown:
            return None
        if enable:
            writes = [WriteParam.of(n, "axis0.requested_state", _CLOSED) for n in unknown]
            yield Send(writes)
            self.note_sent(writes)
            return None
        values = yield from request([ReadParam(n, AXIS0_CURRENT_STATE, DataType.U32) for n in unknown], timeout)
        idle: list[tuple[int, int]] = []
        for n, reply in zip(unknown, values, strict=True):
            state = int(reply.value)
            if n in self._idled:  # this bus asked it out of closed loop: the read may have overtaken that
                state = self._idled[n]
            self.learn(n, state)
            if state != _CLOSED:
                idle.append((n, state))
        if idle:
            raise MotorIdleError([n for n, _ in idle], [s for _, s in idle])
        return None


def _number(name: str, value: object) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ValidationError(f"{name}={value!r}: expected a finite number ({LIMIT_UNITS[name]})")
    return float(value)


def _limit(name: str, value: object, where: str) -> Limit:
    """A :class:`Limit` from ``position=(low, high)`` or a magnitude (``speed=30``)."""
    if name == "position":
        if isinstance(value, (str, bytes)) or not isinstance(value, Sequence) or len(value) != 2:
            raise ValidationError(f"position={value!r}: expected (low, high) in deg")
        low, high = _number(name, value[0]), _number(name, value[1])
        if low > high:
            raise ValidationError(f"position={value!r}: low {low:g} is above high {high:g}")
        return Limit(low, high, where)
    v = _number(name, value)
    if v <= 0:
        raise ValidationError(f"{name}={value!r}: a limit is > 0 ({LIMIT_UNITS[name]}, by magnitude)")
    return Limit(-v, v, where)


def _check_values(node: int, it: Intent, table: Mapping[str, Limit]) -> None:
    """The limits an intent's own values can be checked against (no position needed)."""
    for name, value in (("speed", it.speed), ("torque", it.torque), ("accel", it.accel)):
        lim = table.get(name)
        if lim is not None and value is not None and not lim.low <= value <= lim.high:
            raise SoftLimitError(node, name, value, lim.low, lim.high, LIMIT_UNITS[name], lim.where)
    lim = table.get("position")
    if lim is not None and it.position is not None and not it.relative and not lim.low <= it.position <= lim.high:
        raise SoftLimitError(node, "position", it.position, lim.low, lim.high, "deg", lim.where)
