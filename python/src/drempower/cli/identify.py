"""``drempower identify JOINT``: excite a joint gently and estimate its inertia, friction and gravity term."""

from __future__ import annotations

import argparse
import sys
from typing import Any

from ..errors import ValidationError
from ._confirm import add_yes_arg, confirm
from ._connect import add_connection_args, positive
from ._output import add_json_arg, clean, json_line
from ._usage import UsageError

GROUP = "motion"
"""Where ``drempower --help`` lists this module's subcommands."""


def register(sub: Any) -> None:
    p = sub.add_parser(
        "identify",
        help="estimate a joint's inertia, viscous and Coulomb friction and gravity term",
        description=(
            "Move one joint of a robot gently around where it is (a sum of sines in impedance mode, within "
            "its limits, stopping on any error) and fit torque = inertia * acceleration + viscous * velocity + "
            "coulomb * sign(velocity) + gravity terms at the joint. Prints the estimates and the fit quality "
            "(R^2). Example: drempower identify elbow --robot arm.toml --yes"
        ),
    )
    p.add_argument("joint", metavar="JOINT", help="the joint's name in the robot file")
    p.add_argument("--amplitude", type=positive, default=0.3, metavar="RAD", help="peak excursion (default 0.3 rad)")
    p.add_argument("--seconds", type=positive, default=6.0, metavar="S", help="excitation length (default 6 s)")
    p.add_argument("--kp", type=float, default=5.0, help="the motor's stiffness during the excitation, Nm/rad")
    p.add_argument("--kd", type=float, default=0.2, help="the motor's damping during the excitation, Nm s/rad")
    p.add_argument("--max-torque", type=positive, metavar="NM", help="stop when the joint torque exceeds this")
    add_yes_arg(p)
    add_json_arg(p)
    add_connection_args(p)
    p.set_defaults(func=run, robot_whole=True)


def run(args: argparse.Namespace) -> int:
    spec = getattr(args, "robot_spec", None)
    if spec is None:
        raise UsageError("identify needs --robot FILE (the joint's gear and limits come from it)")
    if args.joint not in spec.joints:
        raise UsageError(f"joint {args.joint!r}: no such joint (joints: {', '.join(spec.joints)})")
    confirm(
        args,
        f"excite joint {args.joint}",
        f"it moves up to {args.amplitude:g} rad either way from where it is for {args.seconds:g} s",
    )
    from ..motion.routines_sync import identify
    from ..robot import open_robot

    with open_robot(spec, timeout=args.timeout, stop_on_close=False) as robot:
        try:
            got = identify(
                robot,
                args.joint,
                amplitude=args.amplitude,
                seconds=args.seconds,
                kp=args.kp,
                kd=args.kd,
                max_torque=args.max_torque,
            )
        except ValidationError as exc:
            raise UsageError(str(exc)) from None
    if args.json:
        d = got.as_dict()
        sys.stdout.write(
            json_line({k: d[k] for k in ("joint", "inertia", "viscous", "coulomb", "gravity", "fit")}) + "\n"
        )
        return 0
    print(clean(f"joint {got.joint} ({got.samples} samples, fit R^2 {got.fit:.4f}):"))
    print(f"  inertia  {got.inertia:.5g} kg m^2")
    print(f"  viscous  {got.viscous:.5g} Nm s/rad")
    print(f"  coulomb  {got.coulomb:.5g} Nm")
    print(f"  gravity  {got.gravity:.5g} Nm (peak; sin {got.gravity_sin:.4g}, cos {got.gravity_cos:.4g})")
    return 0
