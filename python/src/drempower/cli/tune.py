"""``drempower tune JOINT --bandwidth HZ``: gains from the joint's identified dynamics, a step before and after."""

from __future__ import annotations

import argparse
import sys
from typing import Any

from ._confirm import add_yes_arg, confirm
from ._connect import add_connection_args, positive
from ._output import add_json_arg, clean, json_line
from .identify import joint_spec

GROUP = "motion"
"""Where ``drempower --help`` lists this module's subcommands."""


def register(sub: Any) -> None:
    p = sub.add_parser(
        "tune",
        help="tune a joint's position controller for a bandwidth, from its identified dynamics",
        description=(
            "Identify the joint (a gentle excitation, as drempower identify), compute pos_gain, vel_gain, "
            "vel_integrator_gain and the T-mode filter bandwidth for --bandwidth HZ, step the joint with its "
            "present gains, write the new ones (in RAM, after confirmation) and step it again, printing rise "
            "time, overshoot and settling before and after. --save stores them in the motor's flash. "
            "JOINT may be a motor id (the motor alone, gear 1). Example: drempower tune elbow --bandwidth 2 "
            "--robot arm.toml --yes"
        ),
    )
    p.add_argument("joint", metavar="JOINT", help="the joint's name in the robot file, or a motor id")
    p.add_argument("--bandwidth", type=positive, required=True, metavar="HZ", help="closed-loop bandwidth, Hz")
    p.add_argument("--step", type=positive, default=0.15, metavar="RAD", help="the verification step (default 0.15)")
    p.add_argument(
        "--amplitude",
        type=positive,
        default=0.3,
        metavar="RAD",
        help="peak excursion of the identification's excitation (default 0.3; lower it for a joint's speed limit)",
    )
    p.add_argument("--save", action="store_true", help="save the new gains in the motor's flash")
    add_yes_arg(p)
    add_json_arg(p)
    add_connection_args(p)
    p.set_defaults(func=run, robot_whole=True)


def _step_text(what: str, s: Any) -> str:
    return f"  {what:<7} rise {s.rise:.3f} s, overshoot {100 * s.overshoot:.1f} %, settling {s.settling:.3f} s"


def run(args: argparse.Namespace) -> int:
    spec, joint = joint_spec(args, "tune")
    where = "in RAM, then saved" if args.save else "in RAM"
    confirm(
        args,
        f"tune joint {joint}",
        f"it is excited (+-{args.amplitude:g} rad), stepped by {args.step:g} rad twice, new gains {where}",
    )
    from ..robot import open_robot

    with open_robot(spec, timeout=args.timeout, stop_on_close=False) as robot:
        report = robot.joint(joint).tune(args.bandwidth, step=args.step, amplitude=args.amplitude)
        if args.save:
            robot.joint(joint).save_config()
    if args.json:
        sys.stdout.write(json_line({**report.as_dict(), "saved": args.save}) + "\n")
        return 0
    g = report.gains
    print(clean(f"joint {report.joint} at {report.bandwidth:g} Hz (inertia {report.identified.inertia:.4g} kg m^2):"))
    print(
        f"  pos_gain {g.pos_gain:.4g}, vel_gain {g.vel_gain:.4g}, vel_integrator_gain {g.vel_integrator_gain:.4g}, "
        f"T-mode bandwidth {g.bandwidth:.4g} 1/s{' (saved)' if args.save else ' (in RAM; --save stores them)'}"
    )
    print(_step_text("before", report.before))
    print(_step_text("after", report.after))
    return 0
