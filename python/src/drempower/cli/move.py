"""``drempower move``: position moves of one or several motors (T, Q or P mode), synchronised."""

from __future__ import annotations

import argparse
from typing import Any

from ..client import DEFAULT_MOVE_TIMEOUT, PositionMode
from ..client.engine.commands import make_angles
from . import _readings
from ._connect import add_connection_args, number, seconds
from ._motion import add_motion_args, add_watchdog_arg, driving, per_motor
from ._output import add_json_arg, emit, fmt, motors_text
from ._position import _FIELDS, _MODES, _OPTIONS, _params
from ._robot import named_joints, rate_scale, rates_at_joint, to_joint_angle, to_motor, with_units
from ._usage import options_named
from .actions import check_row

GROUP = "motion"
"""Where ``drempower --help`` lists this module's subcommands."""

_ROW_OPTIONS = {
    "angle": "ANGLES",
    "speed": "--speed",
    "accel": "--accel",
    "bandwidth": "--bandwidth",
    "speed_ff": "--speed-ff",
    "torque_ff": "--torque-ff",
}
"""Row ``move``'s arguments, by the option that sets them."""


def register(sub: Any) -> None:
    p = sub.add_parser(
        "move",
        help="move motors to angles (deg), all starting together",
        description=(
            "Move one or several motors, absolute or --relative, started together by one start command. "
            "Modes: q (default) trapezoid/S-curve profile where the motor moving furthest cruises at --speed "
            "and all arrive together; t trajectory tracking through a filter of --bandwidth; p position with "
            "speed and torque feed-forward. Example: drempower move 1,2,3 90,-45,180 --wait --sim 1,2,3"
        ),
    )
    add_motion_args(p, "ANGLES", "target angles in deg, e.g. 90 or 90,-45,180")
    p.add_argument(
        "--mode", type=str.lower, choices=_MODES, default="q", help="q (default), t or p (T, Q, P: any case)"
    )
    p.add_argument(
        "--speed", type=number, metavar="RPM", help="q: cruise speed of the furthest mover, 0.01-327.67 (default 10)"
    )
    p.add_argument("--accel", type=number, metavar="RPM/S", help="q: acceleration, 0.01-327.67 (r/min)/s (default 10)")
    p.add_argument("--bandwidth", type=number, metavar="1/S", help="t: input filter bandwidth, 0.01-300 (default 20)")
    p.add_argument("--speed-ff", type=number, metavar="RPM", help="p: speed feed-forward (default 0)")
    p.add_argument("--torque-ff", type=number, metavar="NM", help="p: torque feed-forward (default 0)")
    p.add_argument("--relative", action="store_true", help="angles are offsets from where the motors are")
    p.add_argument(
        "--wait",
        action="store_true",
        help="wait until every motor has reached its target; exit 1 saying why when one stops elsewhere",
    )
    p.add_argument("--wait-timeout", type=seconds, metavar="S", help="longest wait (default: from the move time)")
    add_watchdog_arg(p)
    add_json_arg(p)
    add_connection_args(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    ids: list[int] = args.ids
    mode = _MODES[args.mode]
    # a named joint's angle is in deg at the joint (through its gear and offset); a motor id's at the motor
    angles = to_motor(args, ids, per_motor(ids, args.values, "angle"), "step" if args.relative else "angle")
    speed, param = _params(args, mode)
    scale = rate_scale(args, ids) if mode is not PositionMode.T else 1.0
    # rates at the joints: no named joint turns faster than asked (P's torque feed-forward is not a rate)
    speed *= scale
    param *= scale if mode is PositionMode.Q else 1.0
    given = {name: getattr(args, name) for name in _OPTIONS[mode]}
    check_row("step" if args.relative else "move", ids, {"angle": angles}, {"mode": mode.name, **given}, _ROW_OPTIONS)
    rates = _FIELDS[mode] if mode is PositionMode.Q else {"speed": "--speed-ff"}
    with options_named({"angle_list": "ANGLES", **_FIELDS[mode]}), rates_at_joint(scale, rates):
        # every value checked before connecting (the Q move time needs the positions: it is checked when sent)
        make_angles(ids, angles, speed, param, mode, move_time=1.0, relative=args.relative)
    with driving(args) as bus:
        start = {r.id: r.state.angle for r in _readings.require_ready(bus, ids, args) if r.state is not None}
        move = bus.step_angles if args.relative else bus.set_angles
        move_time = move(ids, angles, speed, param, mode)
        targets = [start[i] + a if args.relative else a for i, a in zip(ids, angles, strict=True)]
        shown = [to_joint_angle(args, i, t) for i, t in zip(ids, targets, strict=True)]
        if not args.wait:
            records = [
                with_units(args, {"id": i, "target_deg": round(t, 4), "mode": args.mode, "move_time_s": move_time}, i)
                for i, t in zip(ids, shown, strict=True)
            ]
            if args.json:
                emit(args, (), records)
            else:
                took = "" if move_time is None else f", about {move_time:g} s"
                goal = ", ".join(fmt(t) for t in shown)
                at = " at the joint" if ids and all(i in named_joints(args) for i in ids) else ""
                print(f"{_who(args, ids)}: moving to {goal} deg{at} (mode {args.mode}{took})")
            return 0
        timeout = args.wait_timeout or (DEFAULT_MOVE_TIMEOUT if move_time is None else 2 * move_time + 5)
        final = bus.positions_done(ids, timeout)
    records = [
        with_units(
            args,
            {
                "id": i,
                "target_deg": round(t, 4),
                "position_deg": round(to_joint_angle(args, i, final[i].angle), 4),
                "done": True,
            },
            i,
        )
        for i, t in zip(ids, shown, strict=True)
    ]
    emit(args, ("id", "target/deg", "position/deg", "done", "units")[: len(records[0])], records)
    return 0


def _who(args: argparse.Namespace, ids: list[int]) -> str:
    """``joint shoulder`` for named joints, ``motor 1`` for motor ids."""
    named = named_joints(args)
    if ids and all(i in named for i in ids):
        return f"joint{'s' if len(ids) > 1 else ''} {', '.join(named[i].name for i in ids)}"
    return motors_text(ids)
