"""``drempower identify JOINT``: excite a joint gently and estimate its inertia, friction and gravity term."""

from __future__ import annotations

import argparse
import os
import sys
from typing import TYPE_CHECKING, Any

from ..protocol.limits import MAX_NODE, MIN_MOTOR, is_motor
from ._confirm import add_yes_arg, confirm
from ._connect import add_connection_args, connection_kwargs, positive
from ._output import add_json_arg, clean, json_line
from ._usage import UsageError

if TYPE_CHECKING:
    from ..robot.config import RobotSpec

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
            "(R^2). --write puts them where the robot's twin uses them: the robot file's "
            "[joints.JOINT.identified] table, or with a path ending in .xml a copy of the model with the joint's "
            "armature, damping and frictionloss. Examples: drempower identify elbow --robot arm.toml --yes "
            "--write; drempower identify 1 --sim 1 --yes --json (a motor id: the motor alone, gear 1)"
        ),
    )
    p.add_argument("joint", metavar="JOINT", help="the joint's name in the robot file, or a motor id")
    p.add_argument("--amplitude", type=positive, default=0.3, metavar="RAD", help="peak excursion (default 0.3 rad)")
    p.add_argument("--seconds", type=positive, default=6.0, metavar="S", help="excitation length (default 6 s)")
    p.add_argument("--kp", type=float, default=5.0, help="the motor's stiffness during the excitation, Nm/rad")
    p.add_argument("--kd", type=float, default=0.2, help="the motor's damping during the excitation, Nm s/rad")
    p.add_argument("--max-torque", type=positive, metavar="NM", help="stop when the joint torque exceeds this")
    p.add_argument(
        "--write",
        nargs="?",
        const=True,
        metavar="MODEL.xml",
        help="write the result into the robot file (no value) or a copy of its model (a path ending in .xml)",
    )
    add_yes_arg(p)
    add_json_arg(p)
    add_connection_args(p)
    p.set_defaults(func=run, robot_whole=True)


def joint_spec(args: argparse.Namespace, command: str) -> tuple[RobotSpec, str]:
    """The robot (the ``--robot`` file, or the connection's one motor) and the name of ``args.joint`` in it:
    a joint's name, or a motor id (with a robot file: the joint of that id)."""
    from ..robot.config import BusSpec, JointSpec, RobotSpec

    spec: RobotSpec | None = getattr(args, "robot_spec", None)
    name: str = args.joint
    ident = int(name) if name.isdigit() else None
    if spec is not None:
        if name in spec.joints:
            return spec, name
        named = [j.name for j in spec.joints.values() if j.id == ident]
        if len(named) == 1:
            return spec, named[0]
        if len(named) > 1:
            raise UsageError(f"motor id {ident} is joints {', '.join(named)} (one per bus): give the joint's name")
        raise UsageError(f"joint {name!r}: no such joint or motor id (joints: {', '.join(spec.joints)})")
    if ident is None or not is_motor(ident):
        raise UsageError(
            f"{command} {name}: give --robot FILE for a joint's name, or a motor id {MIN_MOTOR}..{MAX_NODE}"
        )
    kw, _ = connection_kwargs(args)
    interface = kw.pop("interface")
    kw.pop("motors", None)
    joint = f"motor_{ident}"
    buses = {"bus": BusSpec("bus", interface, kw)}
    return RobotSpec(buses, {joint: JointSpec(joint, "bus", ident)}, "connection"), joint


def run(args: argparse.Namespace) -> int:
    spec, joint = joint_spec(args, "identify")
    write = args.write
    if write is not None and write is not True and not str(write).endswith(".xml"):
        raise UsageError(f"--write {write}: give no value (the robot file) or a model copy's path ending in .xml")
    if write is not None and spec.source == "connection":
        raise UsageError("--write needs --robot FILE: the identification goes into it or into a copy of its model")
    if write is not None and write is not True and spec.model is None:
        raise UsageError(f"--write {write}: {spec.source} names no [model] to copy")
    confirm(
        args,
        f"excite joint {joint}",
        f"it moves up to {args.amplitude:g} rad either way from where it is for {args.seconds:g} s",
    )
    in_place = write not in (None, True) and spec.model is not None
    if in_place and spec.model is not None and os.path.abspath(write) == os.path.abspath(spec.model.file):
        confirm(args, f"rewrite the model {write} in place", "its joint's armature, damping and frictionloss")
    from ..robot import open_robot

    with open_robot(spec, timeout=args.timeout, stop_on_close=False) as robot:
        got = robot.joint(joint).identify(  # a refusal (limits, a poor fit) is one line: exit 2 or 1
            amplitude=args.amplitude,
            seconds=args.seconds,
            kp=args.kp,
            kd=args.kd,
            max_torque=args.max_torque,
            write=False if write is None else write,
        )
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
    if write is not None:
        where = f"[joints.{joint}.identified] of {spec.source}" if write is True else str(write)
        print(clean(f"written to {where}"))
    return 0
