"""The 6-joint arm on its physics twin: hold a pose, soften the elbow, push the forearm.

Needs MuJoCo (pip install 'drempower[physics]'). Runs the twin of
examples/robots/arm6.toml in this process, on the virtual clock by default
(--wall: in real time). The same code drives the real arm: open the robot file
of the real buses instead (the twin's file differs only in its buses).
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import drempower
from drempower.client.engine.effects import sleep

ROBOT = Path(__file__).resolve().parent / "robots" / "arm6.toml"


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--wall", action="store_true", help="run the twin in real time (default: the virtual clock)")
    p.add_argument("--kp", type=float, default=30.0, help="the elbow's stiffness while pushed, Nm/rad")
    p.add_argument("--force", type=float, default=10.0, help="the push on the forearm, N (downwards)")
    args = p.parse_args()
    sim = {} if args.wall else {"clock": "virtual"}
    with drempower.open_robot(ROBOT, sim=sim) as robot:
        twin = robot.twin
        if twin is None:
            raise SystemExit("the twin needs MuJoCo: pip install 'drempower[physics]'")
        bus = robot.bus("arm")
        pose = {"shoulder": 0.5, "elbow": 1.0, "wrist_pitch": 0.4}
        for name, angle in pose.items():
            robot.joint(name).set_position(angle)
        bus.run(sleep(2.0))
        elbow = robot.joint("elbow")
        held = elbow.get_joint_state()
        print(f"pose held: elbow at {math.degrees(held.position):.2f} deg, {held.torque:.2f} Nm against gravity")
        target = elbow.gearing.motor_angle(held.position)
        elbow.impedance_control(target, 0.0, elbow.gearing.motor_torque(held.torque), args.kp, 2.0)
        twin.push(body="forearm", force=(0.0, 0.0, -args.force), duration=1.5)
        bus.run(sleep(1.0))
        pushed = elbow.get_joint_state()
        moved = pushed.position - held.position
        print(f"pushed with {args.force:g} N: elbow moved {math.degrees(moved):+.2f} deg, {pushed.torque:.2f} Nm")
        print(f"  stiffness seen at the joint: {(held.torque - pushed.torque) / moved:.1f} Nm/rad (kp {args.kp:g})")
        bus.run(sleep(1.5))
        back = elbow.get_joint_state()
        print(f"released: elbow back at {math.degrees(back.position):.2f} deg")


if __name__ == "__main__":
    main()
