"""``drempower teach``: gravity-compensated, low-stiffness joints to move by hand; --record saves the path."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Mapping
from typing import Any

from ._connect import add_connection_args, positive
from ._output import add_json_arg, clean, json_line
from ._usage import UsageError

GROUP = "motion"
"""Where ``drempower --help`` lists this module's subcommands."""


def register(sub: Any) -> None:
    p = sub.add_parser(
        "teach",
        help="teach mode: gravity-compensated joints to move by hand, the path streamed or recorded",
        description=(
            "Hold every joint of a robot against gravity (torques from the robot's model, the physics extra) "
            "with no stiffness, so a person can move it; stream the joints' positions (--json), and save the "
            "path taught with --record (.csv, .json or .mcap; drempower play plays it back). Ctrl-C ends; "
            "the joints then hold where they are. Example: drempower teach --robot arm.toml --record path.csv"
        ),
    )
    p.add_argument("--seconds", type=positive, metavar="S", help="end after S s (default: at Ctrl-C, keeping the path)")
    p.add_argument("--record", metavar="FILE", help="save the path taught (.csv, .json or .mcap)")
    p.add_argument("--rate", type=positive, default=100.0, metavar="HZ", help="cycles per s (default 100)")
    p.add_argument("--kd", type=float, default=0.05, help="the motors' damping, Nm s/rad (default 0.05)")
    p.add_argument("--no-compensation", action="store_true", help="no gravity torque (the arm falls)")
    add_json_arg(p)
    add_connection_args(p)
    p.set_defaults(func=run, robot_whole=True)


def run(args: argparse.Namespace) -> int:
    spec = getattr(args, "robot_spec", None)
    if spec is None:
        raise UsageError("teach needs --robot FILE with a [model] (gravity compensation comes from it)")
    if spec.model is None and not args.no_compensation:
        raise UsageError(f"{spec.source}: no [model]: gravity compensation needs one (or --no-compensation)")
    if args.record is not None and not args.record.lower().endswith((".csv", ".json", ".mcap")):
        raise UsageError(f"--record {args.record}: a .csv, .json or .mcap file")
    from ..robot import open_robot

    def show(t: float, pos: Mapping[str, float]) -> None:
        if args.json:
            sys.stdout.write(json_line({"t": round(t, 4), **{k: round(v, 5) for k, v in pos.items()}}) + "\n")

    with open_robot(spec, timeout=args.timeout, stop_on_close=False) as robot:
        path = robot.teach(args.seconds, rate=args.rate, kd=args.kd, compensate=not args.no_compensation, on_state=show)
        if args.record is not None:
            path.save(args.record)
    if args.record is not None:
        print(clean(f"recorded {path.duration:.2f} s of {len(path.joints)} joints to {args.record}"))
    return 0
