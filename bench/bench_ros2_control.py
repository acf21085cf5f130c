#!/usr/bin/env python3
"""ros2_control faces of the bridge on the twin arm, over Zenoh on 127.0.0.1.

Run: ``python3 bench/bench_ros2_control.py [--commands N]`` (needs the ``bridge`` and
``physics`` extras). Prints figures beside their floor; asserts nothing.

1. Command-to-frame latency of TopicBasedSystem's path: from a plain Zenoh ``put``
   of a ``sensor_msgs/msg/JointState`` (CDR) on ``/robot_joint_commands`` to the
   first position frame on the simulated bus of ``examples/robots/arm6.toml``.
2. FollowJointTrajectory on the same arm: a 3 s path of three points on six joints;
   the feedback rate and each joint's largest tracking error (feedback ``error``)
   beside the follow cycle's floor.
"""

from __future__ import annotations

import argparse
import math
import platform
import socket
import statistics
import sys
import threading
import time
import uuid
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "python" / "src"))

import numpy as np

from drempower.bridge import rmw, rosaction, rosmsg
from drempower.bridge.joint_topics import JointTopics
from drempower.bridge.server import Bridge, BridgeOptions
from drempower.bridge.trajectory_action import TrajectoryAction
from drempower.protocol.ids import Cmd
from drempower.protocol.messages import FastRead
from drempower.robot.config import load_robot
from drempower.transports.sim import SimTransport
from drempower.transports.zenoh_config import open_session

ROOT = Path(__file__).resolve().parent.parent
JOINTS = ["base_yaw", "shoulder", "elbow", "wrist_roll", "wrist_pitch", "flange_roll"]


def free_endpoint() -> str:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return f"tcp/127.0.0.1:{s.getsockname()[1]}"


def joint_state(position: list[float]) -> bytes:
    t = rosmsg.typestore().types
    msg = t[rosmsg.JOINT_STATE](
        header=t["std_msgs/msg/Header"](stamp=t["builtin_interfaces/msg/Time"](sec=0, nanosec=0), frame_id=""),
        name=JOINTS,
        position=np.array(position, dtype=np.float64),
        velocity=np.zeros(6),
        effort=np.zeros(6),
    )
    return rosmsg.encode(msg, rosmsg.JOINT_STATE)


def positions(bridge: Bridge) -> list[float]:
    """Where the arm's joints are (rad), read through the bridge's bus."""
    states = bridge.bus.request([FastRead(j.id) for j, _, _ in bridge._joints])
    return [g.joint_state(st).position for (_, g, _), st in zip(bridge._joints, states, strict=True)]


def call(ros: Any, key: str, typename: str, msg: Any, timeout: float = 30.0) -> Any:
    import zenoh

    att = rmw.Attachment(1, time.time_ns(), bytes(16)).encode()
    payload = rosmsg.encode(msg, typename + "_Request")
    reply = list(ros.get(key, payload=payload, attachment=att, target=zenoh.QueryTarget.ALL_COMPLETE, timeout=timeout))
    return rosmsg.decode(reply[0].ok.payload.to_bytes(), typename + "_Response")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--commands", type=int, default=200, help="JointState commands timed (default 200)")
    args = ap.parse_args()
    print(f"Python {platform.python_version()} on {platform.machine()}, Zenoh over TCP on 127.0.0.1, twin arm")
    spec = load_robot(ROOT / "examples" / "robots" / "arm6.toml")
    sim = SimTransport(robot=spec, robot_bus="arm")
    frames: list[tuple[float, int]] = []
    send = sim.send

    def recording(frame: Any) -> None:
        frames.append((time.perf_counter(), frame.arbitration_id))
        send(frame)

    sim.send = recording  # type: ignore[method-assign]
    endpoint = free_endpoint()
    session = open_session([], [endpoint], scout=False, gossip=False)
    bridge = Bridge({"arm": sim}, session, BridgeOptions(dict(spec.joints), prefix="bench"))
    topics = JointTopics(bridge)
    action = TrajectoryAction(bridge)
    ros = open_session([endpoint], [], scout=False, gossip=False)
    try:
        trigger = rosmsg.typestore().types[rosmsg.TRIGGER + "_Request"](structure_needs_at_least_one_member=0)
        call(ros, bridge.service_keys["enable"], rosmsg.TRIGGER, trigger)
        time.sleep(0.3)
        pub = ros.declare_publisher(topics.commands_key)
        start = positions(bridge)
        print("1. JointState on /robot_joint_commands -> the position frame on the simulated bus")
        pos, delays = list(start), []
        wanted = 1 << 5 | Cmd.POSITION_T
        for _ in range(args.commands):
            pos[0] += 0.0005
            mark = len(frames)
            t0 = time.perf_counter()
            pub.put(joint_state(pos))
            deadline = t0 + 2
            while time.perf_counter() < deadline:
                hit = next((t for t, a in frames[mark:] if a == wanted), None)
                if hit is not None:
                    delays.append(hit - t0)
                    break
                time.sleep(0.0002)
            time.sleep(0.005)
        s = sorted(delays)
        print(
            f"   median {statistics.median(s) * 1e3:.2f} ms   p95 {s[int(len(s) * 0.95)] * 1e3:.2f} ms   "
            f"(n={len(s)} of {args.commands})   floor: one 8-byte frame at 1 Mbit/s, 0.13 ms"
        )
        print("2. FollowJointTrajectory: three points on six joints over 3 s, follow at 100 Hz, feedback at 20 Hz")
        T = rosaction.typestore().types
        at = positions(bridge)
        steps = [0.3, -0.2, 0.3, 0.4, -0.3, 0.5]
        rows = [[a + d for a, d in zip(at, steps, strict=True)], [a + 2 * d for a, d in zip(at, steps, strict=True)]]
        rows.append(rows[-1])
        empty = np.array([], dtype=np.float64)

        def point(r: list[float], sec: int) -> Any:
            return T["trajectory_msgs/msg/JointTrajectoryPoint"](
                positions=np.array(r),
                velocities=empty,
                accelerations=empty,
                effort=empty,
                time_from_start=T["builtin_interfaces/msg/Duration"](sec=sec, nanosec=0),
            )

        header = T["std_msgs/msg/Header"](stamp=T["builtin_interfaces/msg/Time"](sec=0, nanosec=0), frame_id="")
        goal = T[rosaction.FOLLOW_JOINT_TRAJECTORY + "_Goal"](
            trajectory=T["trajectory_msgs/msg/JointTrajectory"](
                header=header, joint_names=JOINTS, points=[point(r, k + 1) for k, r in enumerate(rows)]
            ),
            multi_dof_trajectory=T["trajectory_msgs/msg/MultiDOFJointTrajectory"](
                header=header, joint_names=[], points=[]
            ),
            path_tolerance=[],
            component_path_tolerance=[],
            goal_tolerance=[],
            component_goal_tolerance=[],
            goal_time_tolerance=T["builtin_interfaces/msg/Duration"](sec=0, nanosec=0),
        )
        feedback: list[tuple[float, Any]] = []
        lock = threading.Lock()

        def on_feedback(sample: Any) -> None:
            msg = rosmsg.decode(sample.payload.to_bytes(), rosaction.FOLLOW_JOINT_TRAJECTORY + "_FeedbackMessage")
            with lock:
                feedback.append((time.monotonic(), msg))

        sub = ros.declare_subscriber(action.keys["feedback"], on_feedback)
        gid = T["unique_identifier_msgs/msg/UUID"](uuid=np.frombuffer(uuid.uuid4().bytes, dtype=np.uint8).copy())
        t = rosaction.FOLLOW_JOINT_TRAJECTORY
        call(ros, action.keys["send_goal"], t + "_SendGoal", T[t + "_SendGoal_Request"](goal_id=gid, goal=goal))
        res = call(ros, action.keys["get_result"], t + "_GetResult", T[t + "_GetResult_Request"](goal_id=gid))
        sub.undeclare()
        span = feedback[-1][0] - feedback[0][0]
        print(f"   result status {res.status} (4: succeeded), error code {res.result.error_code}")
        print(f"   feedback {(len(feedback) - 1) / span:.1f} Hz over {span:.2f} s   floor 10 Hz")
        for k, name in enumerate(JOINTS):
            worst = max(abs(float(m.feedback.error.positions[k])) for _, m in feedback)
            print(f"   {name:12s} largest tracking error {math.degrees(worst):5.2f} deg   floor 0")
    finally:
        ros.close()
        action.close()
        topics.close()
        bridge.close()
        session.close()
        sim.close()


if __name__ == "__main__":
    main()
