"""``drempower teach``: gravity-compensated, low-stiffness joints to move by hand; --record saves the path."""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Mapping
from typing import Any

from ._connect import add_connection_args, positive
from ._output import LiveView, add_json_arg, clean, is_terminal, json_line
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

    pace = Pace(args.rate, LiveView(sys.stderr) if is_terminal(sys.stderr) and not args.json else None)

    def show(t: float, pos: Mapping[str, float]) -> None:
        pace.cycle(t, pos)
        if args.json:
            sys.stdout.write(json_line({"t": round(t, 4), **{k: round(v, 5) for k, v in pos.items()}}) + "\n")

    with open_robot(spec, timeout=args.timeout, stop_on_close=False) as robot:
        try:
            path = robot.teach(
                args.seconds, rate=args.rate, kd=args.kd, compensate=not args.no_compensation, on_state=show
            )
        finally:
            pace.end()
        if args.record is not None:
            path.save(args.record)
    if args.record is not None:
        print(clean(f"recorded {path.duration:.2f} s of {len(path.joints)} joints to {args.record}"))
    return 0


SLOW = 0.9
"""Below this share of the rate asked, teach says so (once, and at the end)."""


class Pace:
    """The rate teach keeps: a live line on a terminal (time, cycles per s, each joint in deg) and a
    warning on stderr once it runs below :data:`SLOW` of the rate asked (a slow adapter, a busy host)."""

    def __init__(self, rate: float, view: LiveView | None) -> None:
        self.rate = rate
        self.view = view
        self.count = 0
        self.t = 0.0
        self._shown = -1.0
        self._window: list[float] = []
        self.warned = False

    def achieved(self) -> float:
        """Cycles per s over the last second (the whole run until one has passed)."""
        w = self._window
        return (len(w) - 1) / (w[-1] - w[0]) if len(w) > 1 and w[-1] > w[0] else 0.0

    def cycle(self, t: float, pos: Mapping[str, float]) -> None:
        self.count += 1
        self.t = t
        w = self._window
        w.append(t)
        while w and w[0] < t - 1.0:
            w.pop(0)
        if t >= 1.0 and not self.warned and self.achieved() < SLOW * self.rate:
            self.warned = True
            self._say(
                f"drempower teach: running at {self.achieved():.0f} Hz of {self.rate:g} asked: the bus or the host "
                "cannot keep up (a lower --rate, a faster adapter or fewer joints per bus)"
            )
        if self.view is not None and t - self._shown >= 0.2:
            self._shown = t
            joints = "  ".join(f"{k} {math.degrees(v):7.2f}" for k, v in pos.items())
            self.view.draw([f"teach {t:7.1f} s  {self.achieved():5.0f} Hz of {self.rate:g}  deg: {joints}"])

    def end(self) -> None:
        """At the end: the rate kept over the whole run, when it was below what was asked."""
        if self.t > 0 and self.count > 1:
            mean = (self.count - 1) / self.t
            if mean < SLOW * self.rate:
                self._say(
                    f"drempower teach: {self.count} cycles in {self.t:.1f} s: {mean:.0f} Hz of {self.rate:g} asked"
                )

    def _say(self, text: str) -> None:
        if self.view is not None:
            self.view.draw([])  # the live line gives way to the message
        print(clean(text), file=sys.stderr, flush=True)
