"""``drempower speed``, ``torque`` and ``impedance``: velocity, torque and impedance control."""

from __future__ import annotations

import argparse
from typing import Any

from ..client import TorqueMode, VelocityMode
from . import _readings
from ._connect import add_connection_args, positive
from ._motion import add_duration_arg, add_motion_args, driving, hold, per_motor
from ._output import add_json_arg, emit, fmt, motors_text


def register(sub: Any) -> None:
    s = sub.add_parser(
        "speed",
        help="run motors at speeds (r/min), all starting together",
        description="Velocity control. Without --ramp the speed is set at once (with optional torque feed-forward).",
    )
    add_motion_args(s, "RPM", "speeds in r/min")
    ramp = s.add_mutually_exclusive_group()
    ramp.add_argument("--ramp", type=positive, metavar="RPM/S", help="reach the speed at this rate, (r/min)/s")
    ramp.add_argument("--torque-ff", type=float, default=0.0, metavar="NM", help="torque feed-forward (default 0)")
    add_duration_arg(s)
    add_json_arg(s)
    add_connection_args(s)
    s.set_defaults(func=run_speed)

    t = sub.add_parser(
        "torque",
        help="apply torques (Nm), all starting together",
        description="Torque control: the torque is applied at once, or reached at --ramp Nm/s.",
    )
    add_motion_args(t, "NM", "torques in Nm")
    t.add_argument("--ramp", type=positive, metavar="NM/S", help="reach the torque at this rate, Nm/s")
    add_duration_arg(t)
    add_json_arg(t)
    add_connection_args(t)
    t.set_defaults(func=run_torque)

    i = sub.add_parser(
        "impedance",
        help="impedance control: torque = tff + kp*(pos - P) + kd*(vel - V)",
        description=(
            "Impedance (MIT-style) control of each motor: torque = tff + kp*(pos - P) + kd*(vel - V), "
            "with P and V the motor's position and speed. Each motor gets its own POS; the rest is shared."
        ),
    )
    add_motion_args(i, "POS", "target positions in deg")
    i.add_argument("--kp", type=float, required=True, metavar="NM/RAD", help="stiffness, 0-327.67 Nm/rad")
    i.add_argument("--kd", type=float, required=True, metavar="NM/(RAD/S)", help="damping, 0-327.67 Nm/(rad/s)")
    i.add_argument("--vel", type=float, default=0.0, metavar="RPM", help="target speed (default 0)")
    i.add_argument("--tff", type=float, default=0.0, metavar="NM", help="torque feed-forward (default 0)")
    add_duration_arg(i)
    add_json_arg(i)
    add_connection_args(i)
    i.set_defaults(func=run_impedance)


def _report(args: argparse.Namespace, what: str, unit: str, values: list[float], extra: str) -> None:
    """``motors 1, 2: speed 10.00, 20.00 rpm (...)``, or one JSON object per motor."""
    if args.json:
        key = f"{what}_{unit.lower()}"
        emit(args, (), [{"id": i, key: v} for i, v in zip(args.ids, values, strict=True)])
    else:
        print(f"{motors_text(args.ids)}: {what} {', '.join(fmt(v) for v in values)} {unit}{extra}")


def run_speed(args: argparse.Namespace) -> int:
    speeds = per_motor(args.ids, args.values, "speed")
    if args.ramp is None:
        mode, param, extra = VelocityMode.PASSTHROUGH, args.torque_ff, ""
        if param:
            extra = f" (torque feed-forward {param:g} Nm)"
    else:
        mode, param, extra = VelocityMode.RAMP, args.ramp, f" (ramp {args.ramp:g} rpm/s)"
    with driving(args) as bus:
        _readings.require_ready(bus, args.ids)
        bus.set_speeds(args.ids, speeds, param, mode)
        _report(args, "speed", "rpm", speeds, extra)
        hold(bus, args.duration)
    return 0


def run_torque(args: argparse.Namespace) -> int:
    torques = per_motor(args.ids, args.values, "torque")
    if args.ramp is None:
        mode, param, extra = TorqueMode.DIRECT, 0.0, ""
    else:
        mode, param, extra = TorqueMode.RAMP, args.ramp, f" (ramp {args.ramp:g} Nm/s)"
    with driving(args) as bus:
        _readings.require_ready(bus, args.ids)
        bus.set_torques(args.ids, torques, param, mode)
        _report(args, "torque", "Nm", torques, extra)
        hold(bus, args.duration)
    return 0


def run_impedance(args: argparse.Namespace) -> int:
    positions = per_motor(args.ids, args.values, "position")
    with driving(args) as bus:
        _readings.require_ready(bus, args.ids)
        for node, pos in zip(args.ids, positions, strict=True):
            bus.motor(node).impedance_control(pos, args.vel, args.tff, args.kp, args.kd)
        extra = f" (kp {args.kp:g} Nm/rad, kd {args.kd:g} Nm/(rad/s), vel {args.vel:g} rpm, tff {args.tff:g} Nm)"
        _report(args, "position", "deg", positions, extra)
        hold(bus, args.duration)
    return 0
