#!/usr/bin/env python3
"""follow speed: the achieved rate and client CPU of ``follow`` for 6 joints at 200, 500 and 1000 Hz,
on the twin arm and on the plain simulator, beside the bus limit.

Run: ``python3 bench/bench_follow.py [--seconds S]``. Prints figures; asserts nothing.

* twin: ``examples/robots/arm6.toml`` (MuJoCo at a 1 kHz step, a 1 Mbit/s bus) in real time;
* plain simulator: six simulated motors on a 1 Mbit/s bus, and with instant delivery (no bit rate:
  no bus limit, so the client's own ceiling shows);
* bus limit: the highest rate the bus carries for the six motors' cycle (command and state reply
  each, every motor answering its command with its state), from the bits on the wire; a rate above it
  is refused before anything moves, and the line says so;
* client CPU: CPU time of the thread running ``follow`` (the simulator runs on its own threads) per
  second of trajectory, in percent of one core.
"""

from __future__ import annotations

import argparse
import math
import os
import platform
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "python" / "src"))

import drempower
from drempower.errors import ValidationError
from drempower.motion import Trajectory, follow_bus
from drempower.motion.plan import Lane, Units, bus_rate_limit

ROOT = Path(__file__).resolve().parent.parent
ARM = ROOT / "examples" / "robots" / "arm6.toml"
JOINTS = ("base_yaw", "shoulder", "elbow", "wrist_roll", "wrist_pitch", "flange_roll")
RATES = (200.0, 500.0, 1000.0)
MOVE = (0.3, 0.2, -0.3, 0.4, 0.3, -0.4)
"""rad each joint goes and comes back."""


def path(seconds: float, names: tuple[str, ...], scale: float) -> Trajectory:
    goal = [d * scale for d in MOVE]
    tr = Trajectory.from_waypoints([[0.0] * 6, goal, [0.0] * 6], max_speed=10.0, max_accel=40.0, joints=names)
    return tr.scaled(tr.duration / seconds)


def limit_text(bitrate: int | None, reply: bool) -> str:
    ids = list(range(1, 7))
    lane = Lane("b", list(JOINTS), ids, [Units()] * 6, list(range(6)), ["hold"] * 6, bitrate, dict.fromkeys(ids, reply))
    top, bits = bus_rate_limit(lane, "position")
    return "none (instant delivery)" if top is None else f"{top:.0f} Hz ({bits} bits a cycle at {bitrate} bit/s)"


def line(what: str, rate: float, run: object) -> None:
    print(f"  {what:<26} {rate:6.0f} Hz: {run}")


def measure(follow: object, tr: Trajectory, rate: float) -> str:
    began = time.thread_time()
    try:
        report = follow(tr, rate=rate)  # type: ignore[operator]
    except ValidationError as exc:
        return f"refused: {exc}"
    cpu = time.thread_time() - began
    worst = max(report.max_error.values())
    return (
        f"achieved {report.rate:7.1f} Hz, {report.late:4d} late of {report.cycles}, client CPU "
        f"{100 * cpu / report.duration:5.1f} % of a core, largest error {worst:.4f}"
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seconds", type=float, default=2.0, help="length of each trajectory (s)")
    args = ap.parse_args()
    print(
        f"follow, 6 joints, {args.seconds:g} s each; {platform.python_implementation()} {platform.python_version()}, "
        f"{os.cpu_count()} CPUs"
    )
    print(f"bus limit at 1 Mbit/s: {limit_text(1_000_000, True)}")
    try:
        import mujoco  # noqa: F401

        have_twin = True
    except ImportError:
        have_twin = False
        print("twin: skipped (MuJoCo is not installed: pip install 'drempower[physics]')")
    if have_twin:
        print("twin arm (real time):")
        for rate in RATES:
            with drempower.open_robot(ARM, stop_on_close=False) as robot:
                for j in robot.joints.values():
                    j.enable_reply_state()
                st = robot.joint_states()
                start = [st[n].position for n in JOINTS]
                tr = path(args.seconds, JOINTS, 1.0)
                tr = Trajectory(
                    tr.times,
                    [[s + p for s, p in zip(start, row, strict=True)] for row in tr.positions],
                    tr.velocities,
                    joints=JOINTS,
                )
                line("follow (T mode)", rate, measure(robot.follow, tr, rate))
    for label, bitrate in (("plain simulator, 1 Mbit/s", 1_000_000), ("plain simulator, instant", None)):
        print(f"{label} (real time):")
        for rate in RATES:
            with drempower.open_bus("sim", motors=list(range(1, 7)), bitrate=bitrate, stop_on_close=False) as bus:
                ids = list(range(1, 7))
                for i in ids:
                    bus.motor(i).enable_reply_state()
                at = [bus.motor(i).get_state().angle for i in ids]
                tr = path(args.seconds, tuple(map(str, ids)), math.degrees(1.0))
                tr = Trajectory(
                    tr.times,
                    [[a + p for a, p in zip(at, row, strict=True)] for row in tr.positions],
                    tr.velocities,
                    joints=tr.joints,
                )
                line(
                    "follow_bus (T mode)",
                    rate,
                    measure(lambda t, rate, b=bus, i=ids: follow_bus(b, i, t, rate=rate), tr, rate),
                )


if __name__ == "__main__":
    main()
