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

Steps are measured from what the motor will actually do: ``max_step`` and a relative
move's position range take the motor's measured position (the firmware adds a
relative step to it, and an absolute target is reached from it), from the state
cache when a state at most :data:`FRESH_STATE` s old is there, else read once (a
fast read) before anything is sent. A loop whose motors answer each command with
their state (``cycle``, ``enable_reply_state``) pays no read for it.

**Parameter writes that command motion** (:data:`MOTION_PARAMETERS`: the output
shaft's ``input_pos``/``input_vel``/``input_torque``, the rotor-side inputs and
current setpoint, the control and input modes, step/dir, calibration states) pass
the same gate in ``write_property``, whatever the front end: the output shaft's
inputs as a position, speed or torque command; the others, whose effect the limits
(in output-shaft units) cannot vouch for, are refused on a motor with soft limits
(:class:`~drempower.errors.MotionParameterError`).

What is known costs nothing: a motor is known to be in closed loop once this bus
enabled it or read it so, until a state frame shows its error bit, or this bus
sends it an idle request, an estop, a clear, a reboot or a configuration reset. A
motor not known so is read once (``axis0.current_state``, one request for every
motor of the command), so a control loop or a 1 kHz stream pays one read, not one
per command. A command to every motor (node 0) is checked as one command to each
motor the bus knows (:meth:`~drempower.client.api.busbase.BusBase.known_motors`), and
refused when the bus knows none.

The raw paths, which this gate does not see, are ``bus.send``/``send_many``
(messages, checked against their parameter's domain only), ``bus.send_batch`` (the
layers above pass :meth:`pass_gate` first), ``bus.send_frames`` and
``compat.send_command``. A robot and the bridge's remote face offer no raw path.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Protocol

from ...errors import MotionParameterError, MotorIdleError, SoftLimitError, ValidationError
from ...protocol.addresses import AXIS0_CURRENT_STATE, AXIS0_REQUESTED_STATE
from ...protocol.enums import AxisState, VelocityMode
from ...protocol.ids import SysCmd
from ...protocol.limits import OPEN_LOOP_SYS_CMDS
from ...protocol.messages import (
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
from ...protocol.parameters import DataType, Parameter, parameter
from .commands import PositionMode, make_angles, position_mode
from .effects import Op, Send, read_states, request
from .state import MotorState

__all__ = [
    "FRESH_STATE",
    "Intent",
    "Limit",
    "LIMIT_UNITS",
    "MOTION_PARAMETERS",
    "MotionGate",
    "intents_of",
    "move_intent",
    "move_intents",
    "path_intents",
]


class _States(Protocol):
    """Where the latest state of each motor is (the bus's state cache)."""

    def get(self, node: int) -> MotorState | None: ...


_CLOSED = int(AxisState.CLOSED_LOOP_CONTROL)
_FORGETS = OPEN_LOOP_SYS_CMDS
"""System commands after which a motor is no longer known to be in closed loop."""

FRESH_STATE = 0.02
"""The oldest (s, on the bus's clock) a cached state may be for the gate to measure a step from it."""

MOTION_PARAMETERS: Mapping[str, str] = {
    "axis0.output_shaft.input_pos": "position",
    "axis0.output_shaft.input_vel": "speed",
    "axis0.output_shaft.input_torque": "torque",
    "axis0.controller.input_pos": "rotor-side input",
    "axis0.controller.input_vel": "rotor-side input",
    "axis0.controller.input_torque": "rotor-side input",
    "axis0.motor.current_control.Id_setpoint": "current setpoint",
    "axis0.controller.config.control_mode": "control mode",
    "axis0.controller.config.input_mode": "input mode",
    "axis0.config.enable_step_dir": "step/dir input",
    "axis0.requested_state": "axis state",
}
"""The writable parameters whose writes command motion (``spec/parameters.csv``), by what they command:
``position``/``speed``/``torque`` are checked as that command of the output shaft; the others are
refused on a motor with soft limits (the limits cannot vouch for them) and, for a rotor-side input or
current setpoint, need closed loop. ``axis0.requested_state`` is motion for the calibration states only
(1 idle and 8 closed loop are ``idle``/``enable``)."""

_IDLE = int(AxisState.IDLE)

LIMIT_UNITS = {"position": "deg", "speed": "r/min", "torque": "Nm", "accel": "(r/min)/s", "max_step": "deg"}
"""The soft limits a motor can have, with their units (motor side, output shaft)."""


@dataclass(frozen=True, slots=True)
class Intent:
    """What one motion command asks of one motor, in motor units (None: not part of it).

    ``position`` deg is a target, or a step from where the motor is when ``relative``;
    ``speed`` r/min, ``torque`` Nm and ``accel`` (r/min)/s are checked by magnitude. ``after``
    (deg) is the target of the point before on a path (:func:`path_intents`): the step is
    measured from it instead of from where the motor is.
    """

    node: int
    position: float | None = None
    relative: bool = False
    speed: float | None = None
    torque: float | None = None
    accel: float | None = None
    after: float | None = None


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


def param_kind(p: Parameter, value: float) -> str | None:
    """What writing ``value`` to parameter ``p`` commands (a :data:`MOTION_PARAMETERS` kind), or None."""
    kind = MOTION_PARAMETERS.get(p.name)
    if kind == "axis state" and value in (_IDLE, _CLOSED):
        return None
    return kind


def path_intents(msgs: Iterable[Message]) -> list[Intent]:
    """The intents of the commands of a path, in the order they will be sent: each motor's first
    position is measured from where the motor is, each later one from the position before it."""
    before: dict[int, float] = {}
    out: list[Intent] = []
    for it in intents_of(msgs):
        position = it.position
        if position is not None and not it.relative:
            out.append(dataclasses.replace(it, after=before.get(it.node)))
            before[it.node] = position
        else:
            out.append(it)
    return out


class MotionGate:
    """What one bus knows of its motors' axis state, their soft limits and last targets (no I/O)."""

    def __init__(self, now: Callable[[], float] = time.monotonic) -> None:
        self._closed: set[int] = set()
        self._idled: dict[int, int] = {}
        """Motors this bus itself asked out of closed loop (axis state asked) and has not enabled since: a read
        of their state may overtake that request on the wire (a lower CAN id wins arbitration), so a read
        saying closed loop is not believed."""
        self._limits: dict[int, dict[str, Limit]] = {}
        self._now = now
        self._estopped: set[int] = set()
        """Motors this bus emergency-stopped and did not clear since (0: every motor): an enable alone
        does not bring them back."""
        self._released: dict[int, float] = {}
        """Per motor (0: every motor), when (s, ``now``) it was last released, stopped or enabled: a state
        from before says nothing of where it is now (it may have been turned by hand meanwhile)."""

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

    def param_intents(self, nodes: Sequence[int], prop: str | int, value: float) -> list[Intent]:
        """The intents of writing ``value`` to parameter ``prop`` of motors ``nodes`` (none when it commands
        no motion); raises :class:`MotionParameterError` for a write the limits cannot vouch for."""
        p = parameter(prop)
        kind = param_kind(p, value)
        if kind is None:
            return []
        if kind == "position":
            return [Intent(n, float(value)) for n in nodes]
        if kind == "speed":
            return [Intent(n, speed=float(value)) for n in nodes]
        if kind == "torque":
            return [Intent(n, torque=float(value)) for n in nodes]
        for n in nodes:
            table = self._limits.get(n)
            if table:
                where = next(iter(table.values())).where
                raise MotionParameterError(n, p.name, value, kind, where)
        return [Intent(n) for n in nodes] if kind in ("rotor-side input", "current setpoint") else []

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
            self._released[n] = self._now()
            if n == 0:
                self._closed.clear()
            else:
                self._closed.discard(n)

    def estopped(self, nodes: Iterable[int]) -> None:
        """Motors (0 = every motor) this bus just emergency-stopped: they ignore an enable until cleared."""
        self.forget(nodes)
        self._estopped.update(nodes)

    def note_sent(self, msgs: Iterable[Message]) -> None:
        """Learn from what this bus sent: enables and idle requests, estops and other system commands."""
        for m in msgs:
            if isinstance(m, WriteParam):
                if m.address == AXIS0_REQUESTED_STATE:
                    self._released[m.node] = self._now()
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
                if m.op == SysCmd.ESTOP:
                    self._estopped.add(m.node)
                elif m.op in (SysCmd.CLEAR_ERRORS, SysCmd.REBOOT):
                    if m.node == 0:
                        self._estopped.clear()
                    else:
                        self._estopped.discard(m.node)

    def clear(self, msgs: Sequence[Message], states: _States) -> bool:
        """True when ``msgs`` pass without a look at their values: no soft limits anywhere and every
        motor known in closed loop (the fast path of a control loop)."""
        if self._limits:
            return False
        closed = self._closed
        for m in msgs:
            n = m.node
            if n not in closed:
                return False  # unknown, or every motor (0): the gate looks
            st = states.get(n)
            if st is not None and st.error:
                return False
        return True

    # ------------------------------------------------------------------ the checks

    def needs(
        self, intents: Sequence[Intent], states: _States, now: float | None = None
    ) -> tuple[list[int], list[int]]:
        """Pure checks of ``intents`` (raises SoftLimitError), then what must be read before they pass:
        ``(motors whose axis state is unknown, motors whose position is needed)``; ``now`` (s, the bus's
        clock) dates the cached states (None: none is fresh)."""
        unknown: list[int] = []
        positions: list[int] = []
        for it in intents:
            n = it.node
            table = self._limits.get(n)
            if table:
                _check_values(n, it, table)
                wants = it.position is not None and it.after is None
                wants = wants and ("max_step" in table or (it.relative and "position" in table))
                if wants and n not in positions and self._fresh_angle(n, states, now) is None:
                    positions.append(n)
            if not self.is_closed(n, states.get(n)) and n not in unknown:
                unknown.append(n)
        return unknown, positions

    def check_positions(
        self,
        intents: Sequence[Intent],
        states: _States,
        now: float | None = None,
        read: Mapping[int, MotorState] | None = None,
    ) -> None:
        """Check relative targets and ``max_step`` against the motors' measured positions: the states
        just ``read``, else the fresh ones of ``states`` (see :data:`FRESH_STATE`; ``now`` None takes
        them as just read); a path's point against the point before. Raises SoftLimitError."""
        for it in intents:
            table = self._limits.get(it.node)
            if not table or it.position is None:
                continue
            last = it.after
            if last is None:
                st = None if read is None else read.get(it.node)
                last = self._fresh_angle(it.node, states, now) if st is None else st.angle
            if last is None:
                continue
            step = it.position if it.relative else it.position - last
            lim = table.get("max_step")
            if lim is not None and abs(step) > lim.high * (1 + 1e-12):  # (a limit converted from rad: its rounding)
                raise SoftLimitError(it.node, "max_step", step, -lim.high, lim.high, "deg", lim.where)
            lim = table.get("position")
            if lim is not None and it.relative and not lim.low <= last + step <= lim.high:
                raise SoftLimitError(it.node, "position", last + step, lim.low, lim.high, "deg", lim.where)

    def check_path(self, msgs: Iterable[Message]) -> None:
        """A path's commands one after another, streamed (no list of them): each one's values against the
        limits, each position's step from the position before it (the first one's from the motor is the
        gate's to check, :func:`path_intents`); raises SoftLimitError."""
        before: dict[int, float] = {}
        for m in msgs:
            for it in intents_of((m,)):
                table = self._limits.get(it.node)
                if not table:
                    continue
                _check_values(it.node, it, table)
                if it.position is None or it.relative:
                    continue
                last = before.get(it.node)
                before[it.node] = it.position
                if last is not None:
                    self.check_positions([dataclasses.replace(it, after=last)], _NO_STATES)

    def check_values(self, intents: Sequence[Intent]) -> None:
        """The limits ``intents``' own values meet (no position needed); raises SoftLimitError."""
        for it in intents:
            table = self._limits.get(it.node)
            if table:
                _check_values(it.node, it, table)

    def _fresh_angle(self, node: int, states: _States, now: float | None) -> float | None:
        """The measured angle (deg) of motor ``node`` when its cached state is fresh: at most
        :data:`FRESH_STATE` s old at ``now`` (None: taken as just read) and newer than its last release."""
        st = states.get(node)
        if st is None:
            return None
        if now is not None and now - st.timestamp > FRESH_STATE:
            return None
        since = max(self._released.get(node, -math.inf), self._released.get(0, -math.inf))
        if st.timestamp <= since and now is not None:
            return None
        return st.angle

    def passage(
        self,
        intents: Sequence[Intent],
        states: _States,
        enable: bool,
        timeout: float | None = None,
        now: float | None = None,
        closed_loop: bool = True,
    ) -> Op[None] | None:
        """None when ``intents`` may go at once; else the operation that reads what is missing, checks,
        and enables when asked (raises before any motion frame exists). ``now``: see :meth:`needs`;
        ``closed_loop`` False: the soft limits only."""
        unknown, positions = self.needs(intents, states, now)
        if not closed_loop:
            unknown = []
        if not unknown and not positions:
            if any(self._limits.get(it.node) for it in intents):
                self.check_positions(intents, states, now)
            return None
        return self._pass(intents, unknown, positions, enable, timeout, states, now)

    def _pass(
        self,
        intents: Sequence[Intent],
        unknown: list[int],
        positions: list[int],
        enable: bool,
        timeout: float | None,
        states: _States,
        now: float | None,
    ) -> Op[None]:
        read: dict[int, MotorState] = {}
        if positions:
            got = yield from read_states(positions, timeout)
            read = {st.node: st for st in got if st is not None}
        self.check_positions(intents, states, now, read)
        if not unknown:
            return None
        if enable:
            stopped = [n for n in unknown if n in self._estopped or 0 in self._estopped]
            if stopped:
                fix = "after clearing its errors: it was emergency-stopped (clear_error(), then enable=True)"
                raise MotorIdleError(stopped, fix=fix)
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


class _NoStates:
    """No state at all (a path's later points are measured from the point before)."""

    def get(self, node: int) -> MotorState | None:
        return None


_NO_STATES = _NoStates()


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
