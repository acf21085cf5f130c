"""A leader arm for LeRobot as a twin, moved by hand from this process: serve it, then type pushes.

Needs MuJoCo (pip install 'drempower[physics]'). Serves the twin of the robot file
(default examples/lerobot/leader_twin.toml: the example arm on socketcand,
127.0.0.1:29537) in real time, so that LeRobot's teleoperator opens the same file
from its own process; each line typed here is a hand on the arm:

    elbow 0.2          push the elbow with 0.2 Nm for 0.3 s (torque at the joint)
    base_yaw -0.2      push the base with -0.2 Nm for 0.3 s
    ?                  print every joint's angle (deg)

In teach mode (the leader's, gravity compensated and damped) a push moves the
joint and the arm stays where it is left. Push gently: the follower's file
refuses a step larger than its max_step (0.25 rad in follower_twin.toml), which
ends LeRobot's loop; 1 Nm on the base for 0.2 s makes steps of some 10 deg at 30 fps.
Ctrl-C (or the end of input) stops.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

from drempower.errors import DrEmpowerError
from drempower.robotfile import load_robot
from drempower.sim.bus import SimBus
from drempower.sim.socketcand import attach_socketcand
from drempower.sim.twin import TwinRunner, couple_robot

LEADER = Path(__file__).resolve().parent / "lerobot" / "leader_twin.toml"


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--robot", type=Path, default=LEADER, help="the leader's robot file (one socketcand bus)")
    p.add_argument("--port", type=int, help="serve on this port instead of the file's (0: a free one)")
    args = p.parse_args()
    spec = load_robot(args.robot)
    ((name, entry),) = spec.buses.items()
    if entry.interface != "socketcand":
        raise SystemExit(f"{args.robot}: [buses.{name}] is {entry.interface!r}: this serves a socketcand bus")
    options = dict(entry.options)
    port = int(options.get("port", 0)) if args.port is None else args.port
    sim = SimBus([j.id for j in spec.joints.values()], bitrate=1_000_000)
    twin = couple_robot(spec, {name: sim})
    if twin is None:
        raise SystemExit(f"{args.robot}: no [model]: a leader twin needs the arm's model")
    with TwinRunner([sim]), attach_socketcand(sim, port, str(options.get("host", "127.0.0.1"))) as server:
        where = f"socketcand {server.host} port {server.port}"
        print(f"leader twin on {where}; type JOINT TORQUE [SECONDS], or ?", flush=True)
        try:
            for line in sys.stdin:
                words = line.split()
                if not words:
                    continue
                if words == ["?"]:
                    with twin.lock:
                        angles = {j: math.degrees(twin.joint_position(j)) for j in spec.joints}
                    print(" ".join(f"{j}={a:.1f}" for j, a in angles.items()), flush=True)
                    continue
                try:
                    joint, torque = words[0], float(words[1])
                    seconds = float(words[2]) if len(words) > 2 else 0.3
                    twin.push_joint(joint, torque, seconds)
                except (IndexError, ValueError, DrEmpowerError) as exc:
                    print(f"not a push: {line.strip()!r} ({exc}); e.g. elbow 0.2 0.3", flush=True)
                    continue
                print(f"pushed {joint} with {torque:g} Nm for {seconds:g} s", flush=True)
        except KeyboardInterrupt:
            pass


if __name__ == "__main__":
    main()
