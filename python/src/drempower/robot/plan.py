"""Synchronised moves over several buses, planned without I/O of their own (shared by both robot APIs).

A move is validated for every bus before anything is sent. In Q mode every
motor of every bus gets the same move time: the longest any motor needs
(PROTOCOL.md 3.4.3, from each motor's traj_mode and, for absolute moves, its
freshly read position), rounded up to the 0.01 s the preset carries. Each bus
then sends its presets and its start; the robot measures when each start frame
was handed to its transport.
"""

from __future__ import annotations

import math
import threading
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

from ..client.engine.commands import PositionMode, make_angles, position_mode, q_move_time
from ..client.engine.effects import Op, read_states
from ..errors import FieldRangeError, ValidationError
from ..protocol.ids import Frame
from ..protocol.messages import S16_MAX, Message, Start
from .config import RobotSpec
from .joint import Gearing
from .names import per_bus

__all__ = [
    "Target",
    "SyncMove",
    "StartClock",
    "angle_targets",
    "joint_targets",
    "check_targets",
    "q_time",
    "bus_batch",
    "round_move_time",
]


@dataclass(frozen=True)
class Target:
    """One motor's part of a move, in wire units: ``angle`` deg (absolute, or relative), ``speed`` r/min and
    ``param`` as :meth:`~drempower.client.api.bus_sync.Bus.set_angles` takes them."""

    joint: str
    id: int
    angle: float
    speed: float
    param: float


@dataclass(frozen=True)
class SyncMove:
    """What a synchronised move did.

    ``move_time`` (s) is the common Q-mode time (None in T and P modes);
    ``starts`` maps each bus to :func:`time.monotonic` when its start frame was
    handed to the transport; ``skew`` (s) is the spread of those times.
    """

    move_time: float | None
    starts: Mapping[str, float]

    @property
    def skew(self) -> float:
        """Latest minus earliest start frame (s); 0 with one bus."""
        t = list(self.starts.values())
        return max(t) - min(t) if t else 0.0


def _batch(
    targets: Sequence[Target], mode: PositionMode, relative: bool, move_time: float
) -> tuple[list[Message], Start]:
    presets: list[Message] = []
    start: Start | None = None
    for t in targets:
        try:
            p, start = make_angles([t.id], [t.angle], t.speed, t.param, mode, move_time=move_time, relative=relative)
        except FieldRangeError as exc:
            raise FieldRangeError(f"{exc.field} (joint {t.joint})", exc.value, exc.low, exc.high) from None
        except ValidationError as exc:
            raise ValidationError(f"joint {t.joint}: {exc}") from None
        presets += p
    assert start is not None
    for m in presets:
        m.encode()
    return presets, start


def _finite(value: object, what: str) -> None:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise ValidationError(f"{what}={value!r}: expected a finite number")


def angle_targets(spec: RobotSpec, angles: Mapping[str, float], speed: float, param: float) -> dict[str, list[Target]]:
    """``{joint: motor deg}`` with one speed and param (wire units), as targets by bus."""
    return {
        bus: [Target(n, spec.joints[n].id, a, speed, param) for n, a in group.items()]
        for bus, group in per_bus(spec, angles).items()
    }


def joint_targets(
    spec: RobotSpec, positions: Mapping[str, float], speed: float, accel: float, relative: bool
) -> dict[str, list[Target]]:
    """``{joint: rad}`` with ``speed`` rad/s and ``accel`` rad/s² at each joint, as Q-mode targets by bus."""
    _finite(speed, "speed (rad/s)")
    _finite(accel, "accel (rad/s²)")
    out: dict[str, list[Target]] = {}
    for bus, group in per_bus(spec, positions).items():
        out[bus] = []
        for n, p in group.items():
            _finite(p, f"position of joint {n} (rad)")
            g = Gearing(spec.joints[n])
            angle = g.motor_step(p) if relative else g.motor_angle(p)
            out[bus].append(Target(n, spec.joints[n].id, angle, abs(g.motor_speed(speed)), abs(g.motor_speed(accel))))
    return out


def check_targets(per_bus: Mapping[str, Sequence[Target]], mode: int) -> PositionMode:
    """Validate every value of every bus (raises before anything is sent); returns the mode."""
    m = position_mode(mode)
    if not per_bus:
        raise ValidationError("a synchronised move needs at least one joint")
    for targets in per_bus.values():
        _batch(targets, m, False, 1.0)
    return m


def q_time(modes: Mapping[int, int], targets: Sequence[Target], relative: bool, timeout: float | None) -> Op[float]:
    """The longest Q-mode time (s, unrounded) the motors of one bus need for their part, given each
    motor's Q-mode profile (``modes``, from the bus's ``traj_modes``); absolute moves read positions."""
    if relative:
        dists = [abs(t.angle) for t in targets]
    else:
        states = yield from read_states([t.id for t in targets], timeout)
        dists = [abs(t.angle - st.angle) for t, st in zip(targets, states, strict=True) if st is not None]
    return max(q_move_time(d, t.speed, t.param, modes[t.id]) for t, d in zip(targets, dists, strict=True))


def round_move_time(t: float) -> float:
    """``t`` rounded up to the 0.01 s a Q preset carries; raises when it does not fit."""
    move_time = max(0.01, math.ceil(round(t * 100, 6)) / 100)
    if move_time > S16_MAX:
        raise FieldRangeError(
            "move time", move_time, 0.01, S16_MAX, "s; the Q preset carries at most 327.67 s: raise speed or accel"
        )
    return move_time


def bus_batch(
    targets: Sequence[Target], mode: PositionMode, relative: bool, move_time: float | None
) -> tuple[list[Message], Start]:
    """The presets and start one bus sends."""
    return _batch(targets, mode, relative, 1.0 if move_time is None else move_time)


def is_start(frame: Frame) -> bool:
    """A start command (0x08, sys_num 0x10..0x15)?"""
    return frame[0] & 0x1F == 0x08 and 0x10 <= frame[1][0] <= 0x15


class StartClock:
    """A bus's ``on_sent`` hook that notes when the sending thread last handed a start frame over."""

    def __init__(self) -> None:
        self._local = threading.local()

    def __call__(self, frame: Frame, when: float) -> None:
        if frame[0] & 0x1F == 0x08 and 0x10 <= frame[1][0] <= 0x15:
            self._local.when = when

    def take(self) -> float | None:
        """The time noted in this thread (monotonic s), then forget it."""
        when: float | None = getattr(self._local, "when", None)
        self._local.when = None
        return when
