"""``drempower speed``, ``torque`` and ``impedance``: velocity, torque and impedance control."""

from __future__ import annotations

import argparse
from typing import Any

from ..client import TorqueMode, VelocityMode
from ..client.engine.commands import make_impedances, make_speeds, make_torques
from . import _readings
from ._connect import add_connection_args, number
from ._motion import add_duration_arg, add_motion_args, add_watchdog_arg, driving, hold, per_motor
from ._output import add_json_arg, emit, fmt, motors_text
from ._robot import named_joints, to_motor, with_units
from ._usage import options_named
from .actions import check_row

GROUP = "motion"
"""Where ``drempower --help`` lists this module's subcommands."""


def register(sub: Any) -> None:
    s = sub.add_parser(
        "speed",
        help="run motors at speeds (r/min), all starting together",
        description="Velocity control. Without --ramp the speed is set at once (with optional torque feed-forward).",
    )
    add_motion_args(s, "RPM", "speeds in r/min")
    ramp = s.add_mutually_exclusive_group()
    ramp.add_argument(
        "--ramp", type=number, metavar="RPM/S", help="reach the speed at this rate, 0.01-327.67 (r/min)/s"
    )
    ramp.add_argument("--torque-ff", type=number, default=0.0, metavar="NM", help="torque feed-forward (default 0)")
    add_watchdog_arg(s)
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
    t.add_argument("--ramp", type=number, metavar="NM/S", help="reach the torque at this rate, 0.01-327.67 Nm/s")
    add_watchdog_arg(t)
    add_duration_arg(t)
    add_json_arg(t)
    add_connection_args(t)
    t.set_defaults(func=run_torque)

    i = sub.add_parser(
        "impedance",
        help="impedance control: torque = tff + kp*(pos - P) + kd*(vel - V), all starting together",
        description=(
            "Impedance (MIT-style) control of each motor: torque = tff + kp*(pos - P) + kd*(vel - V), "
            "with P and V the motor's position and speed. Each motor gets its own POS; the rest is shared. "
            "Every value is checked before anything is sent."
        ),
    )
    add_motion_args(i, "POS", "target positions in deg")
    i.add_argument("--kp", type=number, required=True, metavar="NM/RAD", help="stiffness, 0-327.67 Nm/rad")
    i.add_argument("--kd", type=number, required=True, metavar="NM/(RAD/S)", help="damping, 0-327.67 Nm/(rad/s)")
    i.add_argument("--vel", type=number, default=0.0, metavar="RPM", help="target speed (default 0)")
    i.add_argument("--tff", type=number, default=0.0, metavar="NM", help="torque feed-forward (default 0)")
    add_watchdog_arg(i)
    add_duration_arg(i)
    add_json_arg(i)
    add_connection_args(i)
    i.set_defaults(func=run_impedance)


def _report(args: argparse.Namespace, what: str, unit: str, values: list[float], extra: str) -> None:
    """``motors 1, 2: speed 10.00, 20.00 rpm (...)``, or one JSON object per motor."""
    named = named_joints(args)
    if args.json:
        key = f"{what}_{unit.lower()}"
        emit(
            args,
            (),
            [with_units(args, {"id": i, key: v}, i) for i, v in zip(args.ids, values, strict=True)],
        )
    elif args.ids and all(i in named for i in args.ids):
        joints = ", ".join(named[i].name for i in args.ids)
        print(
            f"joint{'s' if len(args.ids) > 1 else ''} {joints}: {what} {', '.join(fmt(v) for v in values)} {unit}"
            f" at the joint{extra}"
        )
    else:
        print(f"{motors_text(args.ids)}: {what} {', '.join(fmt(v) for v in values)} {unit}{extra}")


_SPEED_OPTIONS = {"speed": "RPM", "torque_ff": "--torque-ff", "ramp": "--ramp"}
"""Row ``speed``'s arguments, by the option that sets them."""


def run_speed(args: argparse.Namespace) -> int:
    given = per_motor(args.ids, args.values, "speed")
    speeds = to_motor(args, args.ids, given, "speed")  # a named joint's r/min is at the joint
    if args.ramp is None:
        mode, param, extra, option = VelocityMode.PASSTHROUGH, args.torque_ff, "", "--torque-ff"
        if param:
            extra = f" (torque feed-forward {param:g} Nm)"
    else:
        mode, param, extra, option = VelocityMode.RAMP, args.ramp, f" (ramp {args.ramp:g} rpm/s)", "--ramp"
    shared = {"mode": int(mode), "duration": args.duration, option.strip("-").replace("-", "_"): param}
    check_row("speed", args.ids, {"speed": speeds}, shared, _SPEED_OPTIONS)
    with options_named({"speed_list": "RPM", "param": option, "param (ramp rate)": "--ramp"}):
        make_speeds(args.ids, speeds, param, mode)  # every value checked before connecting
    with driving(args) as bus:
        _readings.require_ready(bus, args.ids, args)
        bus.set_speeds(args.ids, speeds, param, mode)
        _report(args, "speed", "rpm", given, extra)
        hold(bus, args.duration, args.ids, args.watchdog)
    return 0


def run_torque(args: argparse.Namespace) -> int:
    given = per_motor(args.ids, args.values, "torque")
    torques = to_motor(args, args.ids, given, "torque")  # a named joint's Nm is at the joint
    if args.ramp is None:
        mode, param, extra = TorqueMode.DIRECT, 0.0, ""
    else:
        mode, param, extra = TorqueMode.RAMP, args.ramp, f" (ramp {args.ramp:g} Nm/s)"
    shared = {"mode": int(mode), "duration": args.duration, "ramp": args.ramp}
    check_row("torque", args.ids, {"torque": torques}, shared, {"torque": "NM", "ramp": "--ramp"})
    with options_named({"torque_list": "NM", "param": "--ramp", "param (ramp rate)": "--ramp"}):
        make_torques(args.ids, torques, param, mode)
    with driving(args) as bus:
        _readings.require_ready(bus, args.ids, args)
        bus.set_torques(args.ids, torques, param, mode)
        _report(args, "torque", "Nm", given, extra)
        hold(bus, args.duration, args.ids, args.watchdog)
    return 0


_IMPEDANCE_OPTIONS = {"pos_list": "POS", "vel": "--vel", "tff": "--tff", "kp": "--kp", "kd": "--kd"}
"""Fields of the impedance preset and start, by the option that sets them."""


def run_impedance(args: argparse.Namespace) -> int:
    positions = per_motor(args.ids, args.values, "position")
    gains = {"kp": args.kp, "kd": args.kd, "vel": args.vel, "tff": args.tff}
    check_row("impedance", args.ids, {"pos": positions}, gains, {"pos": "POS", **{k: f"--{k}" for k in gains}})
    with options_named(_IMPEDANCE_OPTIONS):
        # every motor's command is built and encoded before the bus is even opened
        make_impedances(args.ids, positions, args.vel, args.tff, args.kp, args.kd)
    with driving(args) as bus:
        _readings.require_ready(bus, args.ids, args)
        bus.impedance_controls(args.ids, positions, args.vel, args.tff, args.kp, args.kd)  # one start
        extra = f" (kp {args.kp:g} Nm/rad, kd {args.kd:g} Nm/(rad/s), vel {args.vel:g} rpm, tff {args.tff:g} Nm)"
        _report(args, "position", "deg", positions, extra)
        hold(bus, args.duration, args.ids, args.watchdog)
    return 0
