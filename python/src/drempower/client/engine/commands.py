"""Command builders with the vendor library's parameter meanings (no I/O).

``make_*`` functions validate their arguments and return protocol messages;
the bus and motor ``set_*`` methods send them. Units: degrees, r/min, Nm,
(r/min)/s, Nm/s, 1/s, seconds; impedance gains Kp Nm/rad, Kd Nm/(rad/s).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from enum import IntEnum
from typing import Any

from ...errors import FieldRangeError, ValidationError
from ...protocol.enums import TorqueMode, TrajMode, VelocityMode
from ...protocol.ids import MAX_NODE, StartKind
from ...protocol.limits import MIN_MOTOR, check_speed, check_torque, is_motor
from ...protocol.messages import (
    S16_MAX,
    Message,
    PositionP,
    PositionQ,
    PositionT,
    PresetC,
    PresetD,
    PresetP,
    PresetQ,
    PresetT,
    PresetV,
    Start,
    StartImpedance,
    Torque,
    Velocity,
    check_f32,
    check_s16,
)

__all__ = [
    "PositionMode",
    "AxisMode",
    "VelocityMode",
    "TorqueMode",
    "TrajMode",
    "MAX_BANDWIDTH",
    "MAX_ANGLE",
    "make_angle",
    "make_speed",
    "make_torque",
    "make_impedance",
    "make_angles",
    "make_speeds",
    "make_torques",
    "make_impedances",
    "q_move_time",
    "position_mode",
    "velocity_mode",
    "torque_mode",
    "check_ids",
    "as_list",
]

MAX_BANDWIDTH = 300.0
"""Largest T-mode input-filter bandwidth (1/s) the vendor documents."""
MAX_ANGLE = 720_000.0
"""Largest target or step magnitude (deg): the vendor's (-360~360)*n, n < 2000; the domain of
``axis0.output_shaft.input_pos`` in ``spec/parameters.csv``."""


class PositionMode(IntEnum):
    """``mode`` of set_angle(s)/step_angle(s), numbered as in the vendor library."""

    T = 0
    """Trajectory tracking: stream targets; ``param`` = input-filter bandwidth (1/s)."""
    Q = 1
    """Trapezoid / S-curve move: ``speed`` = cruise r/min, ``param`` = accel (r/min)/s."""
    P = 2
    """Position with feed-forward: ``speed`` = speed FF r/min, ``param`` = torque FF Nm."""


class AxisMode(IntEnum):
    """``mode`` of set_mode, numbered as in the vendor library."""

    IDLE = 1
    CLOSED_LOOP = 2


def position_mode(mode: int) -> PositionMode:
    """``mode`` as a :class:`PositionMode` (0/1/2 or the enum)."""
    try:
        return PositionMode(mode)
    except ValueError:
        raise ValidationError(f"mode={mode!r}: position modes are 0 (T), 1 (Q), 2 (P)") from None


def velocity_mode(mode: int) -> VelocityMode:
    """``mode`` of set_speed(s): 1 = feed-forward; 2 (or 0, as the vendor's docs use it) = ramp."""
    if mode == 1:
        return VelocityMode.PASSTHROUGH
    if mode in (0, 2):
        return VelocityMode.RAMP
    raise ValidationError(f"mode={mode!r}: speed modes are 1 (feed-forward) and 2 (ramp; 0 is accepted too)")


def torque_mode(mode: int) -> TorqueMode:
    """``mode`` of set_torque(s): 1 = direct; 6 (or 0) = ramp."""
    if mode == 1:
        return TorqueMode.DIRECT
    if mode in (0, 6):
        return TorqueMode.RAMP
    raise ValidationError(f"mode={mode!r}: torque modes are 1 (direct) and 6 (ramp; 0 is accepted too)")


def _no_bools(**values: object) -> None:
    """Refuse True/False given for a number (the actions table refuses them too): a ValidationError naming it."""
    for field, value in values.items():
        if isinstance(value, bool):
            raise ValidationError(f"{field}={value!r}: expected a number, not a truth value")
        if isinstance(value, (list, tuple)):
            for v in value:
                if isinstance(v, bool):
                    raise ValidationError(f"{field}: {v!r} is no number, but a truth value")


def _finite(value: float, field: str) -> float:
    try:
        if math.isfinite(value):
            return float(value)
    except TypeError:
        pass
    raise ValidationError(f"{field}={value!r}: expected a finite number")


def _positive(value: float, field: str, high: float = S16_MAX) -> float:
    """A value > 0 that stays > 0 on the wire (s16 x 0.01: it must round to 0.01 or more)."""
    v = _finite(value, field)
    if not (round(v * 100) >= 1 and v <= high):
        raise FieldRangeError(field, value, 0.01, high, "must be > 0 after rounding to the wire's 0.01 step")
    return v


def _bandwidth(param: float) -> float:
    """The T-mode input-filter bandwidth, 0 < bw <= 300 1/s (a negative one is refused, not made positive)."""
    return _positive(param, "param (bandwidth)", MAX_BANDWIDTH)


def _angle(value: float, field: str) -> float:
    """An angle (deg) within +-MAX_ANGLE, named ``field`` when refused."""
    v = check_f32(value, field)
    if not -MAX_ANGLE <= v <= MAX_ANGLE:
        raise FieldRangeError(field, value, -MAX_ANGLE, MAX_ANGLE, "deg; the vendor's (-360~360)*n, n < 2000")
    return v


def _torque_param(param: float, mode: TorqueMode) -> float:
    """The ramp rate of mode 6 (> 0 Nm/s); mode 1 ignores ``param`` and sends 0, but it must still be a number."""
    if mode is TorqueMode.DIRECT:
        _finite(param, "param")
        return 0.0
    return _positive(param, "param (ramp rate)")


def _t_speed(speed: float) -> float:
    """The speed a T-mode frame carries (unused by the motor): its magnitude, in range."""
    return check_s16(abs(_finite(speed, "speed")), "speed")


def _gains(kp: float, kd: float) -> tuple[float, float]:
    """Impedance gains Kp Nm/rad and Kd Nm/(rad/s), each 0..327.67."""
    for value, field in ((kp, "kp"), (kd, "kd")):
        if not 0 <= _finite(value, field) <= S16_MAX:
            raise FieldRangeError(field, value, 0, S16_MAX, "impedance gains are >= 0")
    return float(kp), float(kd)


def as_list(values: object, field: str) -> list[Any]:
    """``values`` (any iterable but a string) as a list; :class:`ValidationError` naming ``field`` otherwise."""
    if isinstance(values, (str, bytes)) or not isinstance(values, Iterable):
        raise ValidationError(f"{field}={values!r}: expected a list")
    return list(values)


def check_ids(ids: Sequence[int], values: Sequence[float] | None = None, what: str = "values") -> list[int]:
    """Validate a list of motor ids (1..63, distinct) and, if given, a same-length value list."""
    out = as_list(ids, "id_list")
    if not out:
        raise ValidationError("id_list is empty")
    for i in out:
        if not is_motor(i):
            raise FieldRangeError("id", i, MIN_MOTOR, MAX_NODE, "multi-motor commands address motors 1..63")
    if len(set(out)) != len(out):
        raise ValidationError(f"id_list {out} names a motor twice")
    if values is not None:
        if len(values) != len(out):
            raise ValidationError(f"id_list has {len(out)} motors but {what} has {len(values)} values")
        for v in values:
            _finite(v, what)
    return out


def make_angle(
    node: int, angle: float, speed: float = 0.0, param: float = 0.0, mode: int = PositionMode.T
) -> PositionT | PositionQ | PositionP:
    """Absolute move of one motor to ``angle`` deg (vendor ``set_angle``).

    mode T: ``param`` = input-filter bandwidth 0 < bw <= 300 1/s (``speed`` unused);
    mode Q: ``speed`` > 0 r/min cruise, ``param`` > 0 (r/min)/s accel;
    mode P: ``speed`` = speed feed-forward r/min, ``param`` = torque feed-forward Nm.
    """
    _no_bools(angle=angle, speed=speed, param=param)
    m = position_mode(mode)
    angle = _angle(angle, "angle")
    if m is PositionMode.T:
        return PositionT(node, angle, _bandwidth(param), _t_speed(speed))
    if m is PositionMode.Q:
        return PositionQ(node, angle, _positive(speed, "speed"), _positive(param, "param (accel)"))
    return PositionP(node, angle, check_s16(speed, "speed"), check_s16(param, "param"))


def make_speed(node: int, speed: float, param: float = 0.0, mode: int = VelocityMode.PASSTHROUGH) -> Velocity:
    """Run at ``speed`` r/min (vendor ``set_speed``).

    mode 1: ``param`` = torque feed-forward Nm (sent as 0 when speed is 0, as the
    vendor does); mode 2: ``param`` = ramp rate (r/min)/s.
    """
    _no_bools(speed=speed, param=param)
    m = velocity_mode(mode)
    speed = check_speed(check_f32(speed, "speed"), "speed", speed)
    if m is VelocityMode.RAMP:
        param = _positive(param, "param (ramp rate)")
    else:
        ff = check_s16(param, "param")  # checked even when speed 0 makes it unused
        param = 0.0 if speed == 0 else ff
    return Velocity(node, speed, param, m)


def make_torque(node: int, torque: float, param: float = 0.0, mode: int = TorqueMode.DIRECT) -> Torque:
    """Apply ``torque`` Nm (vendor ``set_torque``). mode 1: direct; mode 6: ramp at ``param`` Nm/s."""
    _no_bools(torque=torque, param=param)
    m = torque_mode(mode)
    torque = check_torque(check_f32(torque, "torque"), "torque", torque)
    return Torque(node, torque, _torque_param(param, m), m)


def make_impedance(
    node: int, pos: float, vel: float = 0.0, tff: float = 0.0, kp: float = 0.0, kd: float = 0.0
) -> tuple[PresetD, StartImpedance]:
    """Impedance control (vendor ``impedance_control``): preset and start addressed to ``node``.

    ``pos`` deg, ``vel`` r/min, ``tff`` Nm; ``kp`` Nm/rad and ``kd`` Nm/(rad/s),
    both 0..327.67. The control law is ``tff + kp*(pos - P) + kd*(vel - V)``.
    """
    _no_bools(pos=pos, vel=vel, tff=tff, kp=kp, kd=kd)
    preset = PresetD(node, _angle(pos, "pos"), check_s16(vel, "vel"), check_s16(tff, "tff"))
    return preset, StartImpedance(node, *_gains(kp, kd))


def make_impedances(
    ids: Sequence[int],
    positions: Sequence[float],
    vel: float = 0.0,
    tff: float = 0.0,
    kp: float = 0.0,
    kd: float = 0.0,
) -> tuple[list[Message], StartImpedance]:
    """Presets and the one start of impedance control of several motors at once.

    Each motor holds its own ``positions`` deg; ``vel`` r/min, ``tff`` Nm and the
    gains ``kp`` Nm/rad, ``kd`` Nm/(rad/s) (0..327.67, carried by the start) are shared.
    """
    _no_bools(pos_list=as_list(positions, "pos_list"), vel=vel, tff=tff, kp=kp, kd=kd)
    nodes = check_ids(ids, positions, "pos_list")
    v, t = check_s16(vel, "vel"), check_s16(tff, "tff")
    start = StartImpedance(0, *_gains(kp, kd))
    presets: list[Message] = [
        PresetD(n, _angle(p, f"pos_list (motor {n})"), v, t) for n, p in zip(nodes, positions, strict=True)
    ]
    return presets, start


def q_move_time(distance: float, speed: float, accel: float, traj_mode: int = TrajMode.TRAPEZOID) -> float:
    """Time (s) of a Q move of ``distance`` deg at cruise ``speed`` r/min and ``accel`` (r/min)/s.

    PROTOCOL.md 3.4.3 (1 r/min = 6 deg/s): trapezoid
    ``T = 2*sqrt(d/(6a))`` if ``d <= 6v^2/a`` else ``v/a + d/(6v)``; S-curve
    ``T = 4*sqrt(a*d/12)/a`` if ``d <= 12v^2/a`` else ``d/(6v) + 2v/a``.
    """
    d, v, a = abs(distance), speed, accel
    if traj_mode == TrajMode.S_CURVE:
        if d <= 12 * v * v / a:
            return 4 * math.sqrt(a * d / 12) / a
        return d / (6 * v) + 2 * v / a
    if traj_mode != TrajMode.TRAPEZOID:
        raise ValidationError(f"traj_mode={traj_mode!r}: 1 (trapezoid) or 2 (S-curve)")
    if d <= 6 * v * v / a:
        return 2 * math.sqrt(d / (6 * a))
    return v / a + d / (6 * v)


def make_angles(
    ids: Sequence[int],
    angles: Sequence[float],
    speed: float = 10.0,
    param: float = 10.0,
    mode: int = PositionMode.Q,
    *,
    move_time: float | None = None,
    relative: bool = False,
) -> tuple[list[Message], Start]:
    """Presets and the start (to broadcast) of a synchronised move (vendor ``set_angles``/``step_angles``).

    mode T: ``speed`` unused, ``param`` = bandwidth; mode Q: every motor gets
    ``move_time`` (s, required) and accel ``param``; mode P: ``speed`` = speed
    feed-forward r/min, ``param`` = torque feed-forward Nm. ``relative`` makes
    the angles offsets from the current positions. Every value is checked here,
    so an out-of-range one raises before a single frame exists.
    """
    _no_bools(angle_list=as_list(angles, "angle_list"), speed=speed, param=param)
    nodes = check_ids(ids, angles, "angle_list")
    targets = [_angle(a, f"angle_list (motor {n})") for n, a in zip(nodes, angles, strict=True)]
    m = position_mode(mode)
    presets: list[Message]
    if m is PositionMode.T:
        bw, sp = _bandwidth(param), _t_speed(speed)
        presets = [PresetT(n, a, bw, sp) for n, a in zip(nodes, targets, strict=True)]
        kind = StartKind.T
    elif m is PositionMode.Q:
        if move_time is None:
            raise ValidationError("a Q-mode synchronised move needs its move_time")
        _positive(speed, "speed")
        accel = _positive(param, "param (accel)")
        t = _positive(move_time, "move time (s)")
        presets = [PresetQ(n, a, t, accel) for n, a in zip(nodes, targets, strict=True)]
        kind = StartKind.Q
    else:
        sff, tff = check_s16(speed, "speed"), check_s16(param, "param")
        presets = [PresetP(n, a, sff, tff) for n, a in zip(nodes, targets, strict=True)]
        kind = StartKind.P
    return presets, Start(0, kind, relative)


def make_speeds(
    ids: Sequence[int], speeds: Sequence[float], param: float = 0.0, mode: int = VelocityMode.PASSTHROUGH
) -> tuple[list[Message], Start]:
    """Presets and start of a synchronised speed change (vendor ``set_speeds``); one param/mode for all."""
    _no_bools(speed_list=as_list(speeds, "speed_list"), param=param)
    nodes = check_ids(ids, speeds, "speed_list")
    m = velocity_mode(mode)
    prm = _positive(param, "param (ramp rate)") if m is VelocityMode.RAMP else check_s16(param, "param")
    presets: list[Message] = []
    for n, s in zip(nodes, speeds, strict=True):
        v = check_speed(check_f32(s, f"speed_list (motor {n})"), f"speed_list (motor {n})", s)
        presets.append(PresetV(n, v, 0.0 if (m is VelocityMode.PASSTHROUGH and v == 0) else prm, m))
    return presets, Start(0, StartKind.V)


def make_torques(
    ids: Sequence[int], torques: Sequence[float], param: float = 0.0, mode: int = TorqueMode.DIRECT
) -> tuple[list[Message], Start]:
    """Presets and start of a synchronised torque change (vendor ``set_torques``); one param/mode for all."""
    _no_bools(torque_list=as_list(torques, "torque_list"), param=param)
    nodes = check_ids(ids, torques, "torque_list")
    m = torque_mode(mode)
    prm = _torque_param(param, m)
    presets: list[Message] = [
        PresetC(n, check_torque(check_f32(t, f"torque_list (motor {n})"), f"torque_list (motor {n})", t), prm, m)
        for n, t in zip(nodes, torques, strict=True)
    ]
    return presets, Start(0, StartKind.C)
