"""Several buses as one robot: joints by name, one synchronised move across buses, SI units at the joints.

python3 examples/robot.py                       # examples/robot.toml: two simulated buses
python3 examples/robot.py --robot my_robot.toml # your buses and joints
"""

from __future__ import annotations

import argparse
from pathlib import Path

import drempower


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__)
    p.add_argument("--robot", default=str(Path(__file__).with_name("robot.toml")), help="robot file (TOML)")
    p.add_argument("--time-scale", type=float, default=1.0, help="simulator speed-up (sim buses only)")
    args = p.parse_args()
    with drempower.open_robot(args.robot, sim={"time_scale": args.time_scale}) as robot:
        print(robot)
        targets = {"shoulder": 0.8, "hip": -0.4, "elbow": 1.2}  # rad at each joint
        move = robot.move_joints(targets, speed=2.0, accel=10.0, enable=True)  # enables idle joints first
        print(f"moving {targets}: {move.move_time:.2f} s; start frames {move.skew * 1e6:.0f} us apart")
        robot.positions_done(timeout=(move.move_time or 0) + 5)
        for name, js in robot.joint_states().items():
            print(f"  {name:8s} {js.position:7.3f} rad  (motor {js.motor.angle:8.2f} deg)")
        move = robot.set_angles({"shoulder": 0.0, "hip": 0.0, "elbow": 0.0}, speed=30, param=60)  # wire units
        robot.positions_done(timeout=(move.move_time or 0) + 5)
        print("back at motor 0 deg:", {n: round(st.angle, 2) for n, st in robot.get_states().items()})


if __name__ == "__main__":
    main()
