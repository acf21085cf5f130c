"""The health supervisor: temperatures, derating, stalls and errors watched at a bounded bus cost.

Every ``period`` seconds one :func:`supervise` step reads, for every watched motor,
its state (a fast read) and its health (five parameter reads), all in one exchange:
six requests and six replies per motor, 12 frames of 8 data bytes, about 1.6 ms of
a 1 Mbit/s bus per motor (131 bits per frame at most, with stuffing). At the default
1 s period six motors cost about 1 % of the bus. A faulted motor costs one more
exchange (its seven error words) in the step that finds it. Before the first step,
each motor's torque constant and limit, gear ratio and thermal limits are read once (seven reads).

Per motor, a :class:`Watch` turns the readings into :class:`HealthEvent` s, each
once when its condition begins (and ``recovered`` when all clears):

* ``hot``: the winding or the board at ``warn_c`` (default 80 degC, the long-term
  ceiling of the user manual) or less than ``warn_margin_c`` below the thermistor's
  ``temp_limit_lower``, whichever comes first: a warning.
* ``overheat``: ``act_margin_c`` (default 5 K) below ``temp_limit_lower``, before
  the firmware derates (at lower) and trips (at upper): the joint's ``on_overheat``
  acts (``warn``: nothing, ``hold``: speed 0 in closed loop, ``idle``: released).
* ``derating``: the effective current limit below the configured one: a warning,
  then ``on_overheat`` too.
* ``stall``: the target not reached (T bit 0) while the torque sits at
  ``stall_fraction`` of the (derated) torque limit for ``stall_s``: ``on_stall`` acts.
* ``fault``: an error flag: the event names the motor, the error and its fix.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Literal

from ...errors import FieldRangeError, ValidationError
from ...protocol.addresses import (
    AXIS0_CONFIG_EXTRA_SETTING_GEAR_RATIO,
    AXIS0_FET_THERMISTOR_CONFIG_TEMP_LIMIT_LOWER,
    AXIS0_FET_THERMISTOR_CONFIG_TEMP_LIMIT_UPPER,
    AXIS0_MOTOR_CONFIG_TORQUE_CONSTANT,
    AXIS0_MOTOR_CONFIG_TORQUE_LIM,
    AXIS0_MOTOR_THERMISTOR_CONFIG_TEMP_LIMIT_LOWER,
    AXIS0_MOTOR_THERMISTOR_CONFIG_TEMP_LIMIT_UPPER,
)
from ...protocol.messages import FastRead, Message, ReadParam, Velocity, WriteParam
from ...protocol.parameters import parameter
from .effects import Op, Send, read_params, request
from .health import HEALTH_PARAMETERS, Health
from .ops import dump_error
from .state import MotorState

__all__ = [
    "ACTIONS",
    "FRAMES_PER_MOTOR",
    "HealthEvent",
    "HealthPolicy",
    "Watch",
    "action_messages",
    "prepare",
    "supervise",
]

ACTIONS = ("warn", "hold", "idle")
"""What the supervisor may do to a joint that overheats or stalls."""
Action = Literal["warn", "hold", "idle"]
Level = Literal["ok", "warn", "error"]
FRAMES_PER_MOTOR = 2 * (1 + len(HEALTH_PARAMETERS))
"""Frames one supervisor step puts on the bus per healthy motor (requests and replies)."""


def _positive(name: str, value: float, lo: float, hi: float) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not lo <= value <= hi:
        raise FieldRangeError(name, value, lo, hi)
    return float(value)


def _action(name: str, value: str) -> Action:
    if value not in ACTIONS:
        raise ValidationError(f"{name}={value!r}: expected one of {', '.join(repr(a) for a in ACTIONS)}")
    return value  # type: ignore[return-value]


@dataclass(frozen=True)
class HealthPolicy:
    """When the supervisor warns and acts; ``joints`` overrides ``on_overheat`` per motor id."""

    period: float = 1.0
    """Seconds between steps (0.05..60): the bus cost is :data:`FRAMES_PER_MOTOR` frames per motor and step."""
    warn_c: float = 80.0
    """Warn at this temperature (degC) of the winding or the board."""
    warn_margin_c: float = 15.0
    """... or this many K below the thermistor's temp_limit_lower, whichever is lower."""
    act_margin_c: float = 5.0
    """Act (``on_overheat``) this many K below temp_limit_lower: before the firmware derates and trips."""
    on_overheat: str = "warn"
    stall_s: float = 1.0
    """A stall: the torque at its limit with the target not reached, for this long (s)."""
    stall_fraction: float = 0.95
    """'At its limit': at least this fraction of the derated torque limit."""
    on_stall: str = "warn"
    joints: Mapping[int, str] = field(default_factory=dict)
    """``{motor id: on_overheat}`` for motors that differ from ``on_overheat``."""
    stalls: Mapping[int, str] = field(default_factory=dict)
    """``{motor id: on_stall}`` for motors that differ from ``on_stall``."""

    def __post_init__(self) -> None:
        _positive("period", self.period, 0.05, 60.0)
        _positive("warn_c", self.warn_c, 0.0, 150.0)
        _positive("warn_margin_c", self.warn_margin_c, 0.0, 100.0)
        _positive("act_margin_c", self.act_margin_c, 0.0, 100.0)
        _positive("stall_s", self.stall_s, 0.0, 600.0)
        _positive("stall_fraction", self.stall_fraction, 0.1, 1.0)
        _action("on_overheat", self.on_overheat)
        _action("on_stall", self.on_stall)
        for node, a in self.joints.items():
            _action(f"on_overheat of motor {node}", a)
        for node, a in self.stalls.items():
            _action(f"on_stall of motor {node}", a)

    def overheat_action(self, node: int) -> Action:
        """What overheating motor ``node`` makes the supervisor do."""
        return _action("on_overheat", self.joints.get(node, self.on_overheat))

    def stall_action(self, node: int) -> Action:
        """What a stall of motor ``node`` makes the supervisor do."""
        return _action("on_stall", self.stalls.get(node, self.on_stall))


@dataclass(frozen=True, slots=True)
class HealthEvent:
    """Something the supervisor saw begin (or end) on one motor, and what it did."""

    motor: int
    kind: Literal["hot", "overheat", "derating", "stall", "fault", "recovered"]
    level: Level
    message: str
    fix: str = ""
    action: Literal["none", "hold", "idle"] = "none"
    joint: str | None = None
    at: float = 0.0
    """Bus time (s) of the step that saw it."""

    def __str__(self) -> str:
        who = f"joint {self.joint} (motor {self.motor})" if self.joint else f"motor {self.motor}"
        did = {"none": "", "hold": " Holding it (speed 0).", "idle": " Released it (idle)."}[self.action]
        fix = f" Fix: {self.fix}" if self.fix else ""
        return f"{who}: {self.message}.{did}{fix}"


_THERMAL_RANK = {"hot": 1, "overheat": 2, "derating": 3}


@dataclass
class _Limits:
    kt: float = math.nan
    """Output torque per ampere (Nm/A): rotor torque constant x gear ratio."""
    torque_lim: float = math.inf
    """The configured torque limit at the output (Nm): rotor torque_lim x gear ratio."""
    winding: tuple[float, float] = (95.0, 100.0)
    board: tuple[float, float] = (95.0, 100.0)


class Watch:
    """What the supervisor knows of one motor between steps (pure: no I/O)."""

    __slots__ = ("_active", "_stall_since", "_thermal", "joint", "last", "level", "limits", "node", "policy")

    def __init__(self, node: int, policy: HealthPolicy, joint: str | None = None) -> None:
        self.node = node
        self.policy = policy
        self.joint = joint
        self.limits = _Limits()
        self.level: Level = "ok"
        self.last: Health | None = None
        self._active: set[str] = set()
        self._stall_since: float | None = None
        self._thermal = 0
        """The thermal condition of the last step (:data:`_THERMAL_RANK`): a milder one is not announced again."""

    def configure(self, values: Sequence[float]) -> None:
        """Take the seven values :func:`prepare` reads (torque constant, torque limit, gear ratio, both
        thermistors' limits)."""
        kt, tl, ratio, wl, wu, bl, bu = (float(v) for v in values)
        self.limits = _Limits(kt * ratio, tl * abs(ratio), (wl, wu), (bl, bu))

    def update(self, now: float, health: Health, state: MotorState | None) -> list[HealthEvent]:
        """The events of one step's readings (each condition once, when it begins)."""
        self.last = health
        p, lim = self.policy, self.limits
        found: dict[str, HealthEvent] = {}
        # the node nearest its own derating threshold (temp_limit_lower) decides
        if lim.winding[0] - health.motor_temp_c <= lim.board[0] - health.driver_temp_c:
            where, hottest, lower = "winding", health.motor_temp_c, lim.winding[0]
        else:
            where, hottest, lower = "driver board", health.driver_temp_c, lim.board[0]
        warn_at, act_at = min(p.warn_c, lower - p.warn_margin_c), lower - p.act_margin_c
        overheat = self.policy.overheat_action(self.node)
        act = "none" if overheat == "warn" else overheat
        if health.errors:
            for f in health.faults:
                key = f"fault:{f.word}:{f.flag}"
                text = f"{f.word} {f.flag}: {f.meaning.rstrip('.')}"
                found[key] = HealthEvent(self.node, "fault", "error", text, f.fix, "none", self.joint)
        if health.derating > 0.0:
            found["derating"] = HealthEvent(
                self.node,
                "derating",
                "warn",
                f"the {where} at {hottest:.1f} degC: the firmware derates the current to "
                f"{health.current_limit_a:.2f} A ({health.derating:.1%} less)",
                "Let it cool and lower the load or duty cycle.",
                act,
                self.joint,
            )
        elif hottest >= act_at:
            found["overheat"] = HealthEvent(
                self.node,
                "overheat",
                "warn",
                f"the {where} at {hottest:.1f} degC, {lower - hottest:.1f} K below the firmware's derating",
                "Let it cool and lower the load or duty cycle.",
                act,
                self.joint,
            )
        elif hottest >= warn_at:
            found["hot"] = HealthEvent(
                self.node,
                "hot",
                "warn",
                f"the {where} at {hottest:.1f} degC (warning at {warn_at:.1f} degC)",
                "Watch the duty cycle; stay below 80 degC for long periods.",
                "none",
                self.joint,
            )
        if state is not None and not state.error and math.isfinite(lim.kt) and lim.kt > 0:
            tlim = min(health.current_limit_a * abs(lim.kt), lim.torque_lim)
            pinned = not state.trajectory_done and abs(state.torque) >= p.stall_fraction * tlim
            if pinned:
                since = self._stall_since = now if self._stall_since is None else self._stall_since
                if now - since >= p.stall_s:
                    found["stall"] = HealthEvent(
                        self.node,
                        "stall",
                        "warn",
                        f"stalled: {state.torque:.2f} Nm at its {tlim:.2f} Nm limit for {now - since:.1f} s "
                        "without reaching the target",
                        "Remove the blockage, lower the load or the target, then command it again.",
                        "none" if p.stall_action(self.node) == "warn" else p.stall_action(self.node),  # type: ignore[arg-type]
                        self.joint,
                    )
            else:
                self._stall_since = None
        rank = max((_THERMAL_RANK.get(k, 0) for k in found), default=0)
        out = [
            HealthEvent(e.motor, e.kind, e.level, e.message, e.fix, e.action, e.joint, now)
            for k, e in found.items()
            if k not in self._active and (k not in _THERMAL_RANK or _THERMAL_RANK[k] > self._thermal)
        ]
        self._thermal = rank
        if self._active and not found:
            out.append(HealthEvent(self.node, "recovered", "ok", "healthy again", "", "none", self.joint, now))
        self._active = set(found)
        self.level = "error" if any(e.level == "error" for e in found.values()) else "warn" if found else "ok"
        return out


_LIMIT_PARAMETERS = (
    AXIS0_MOTOR_CONFIG_TORQUE_CONSTANT,
    AXIS0_MOTOR_CONFIG_TORQUE_LIM,
    AXIS0_CONFIG_EXTRA_SETTING_GEAR_RATIO,
    AXIS0_MOTOR_THERMISTOR_CONFIG_TEMP_LIMIT_LOWER,
    AXIS0_MOTOR_THERMISTOR_CONFIG_TEMP_LIMIT_UPPER,
    AXIS0_FET_THERMISTOR_CONFIG_TEMP_LIMIT_LOWER,
    AXIS0_FET_THERMISTOR_CONFIG_TEMP_LIMIT_UPPER,
)


def prepare(watches: Sequence[Watch], timeout: float | None = None) -> Op[None]:
    """Read each watched motor's torque constant and limit, gear ratio, thermal limits (once, before the steps)."""
    for w in watches:
        values = yield from read_params(w.node, _LIMIT_PARAMETERS, timeout)
        w.configure(values)


def action_messages(events: Sequence[HealthEvent]) -> list[Message]:
    """The frames that carry out ``events``' actions: idle (requested_state 1) or hold (speed 0); idle wins."""
    todo: dict[int, str] = {}
    for e in events:
        if e.action != "none" and todo.get(e.motor) != "idle":
            todo[e.motor] = e.action
    return [WriteParam.of(n, "axis0.requested_state", 1) if a == "idle" else Velocity(n, 0.0) for n, a in todo.items()]


def supervise(watches: Sequence[Watch], now: float, timeout: float | None = None) -> Op[list[HealthEvent]]:
    """One step: read every watched motor's state and health in one exchange, update the watches, act.

    Returns the events that began in this step (actions already sent)."""
    msgs: list[Message] = []
    for w in watches:
        msgs.append(FastRead(w.node))
        msgs.extend(ReadParam(w.node, a, parameter(a).dtype) for a in HEALTH_PARAMETERS)
    replies = yield from request(msgs, timeout)
    k = 1 + len(HEALTH_PARAMETERS)
    events: list[HealthEvent] = []
    for i, w in enumerate(watches):
        st, mt, dt, lim, base, axis = replies[i * k : (i + 1) * k]
        errors: dict[str, list[str]] = {}
        if int(axis.value):
            errors = (yield from dump_error(w.node, timeout)).flags
        h = Health(w.node, float(mt.value), float(dt.value), float(lim.value), float(base.value), errors, w.joint)
        events.extend(w.update(now, h, st))
    acts = action_messages(events)
    if acts:
        yield Send(acts)
    return events
