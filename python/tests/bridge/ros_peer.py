"""A ROS 2 peer speaking rmw_zenoh's formats, and the twin arm served by a bridge, for the ros2_control tests."""

from __future__ import annotations

import re
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from drempower.bridge import rmw, rosmsg
from drempower.bridge.server import Bridge, BridgeOptions
from drempower.protocol.enums import AxisState
from drempower.robot.config import RobotSpec, load_robot
from drempower.transports.sim import SimTransport

from ..conftest import REPO_ROOT
from .conftest import free_port, session, wait_for
from .test_bridge import _call

ARM = REPO_ROOT / "examples" / "robots" / "arm6.toml"
JOINTS = ["base_yaw", "shoulder", "elbow", "wrist_roll", "wrist_pitch", "flange_roll"]


def arm_file(tmp: Path, on_timeout: str | None = None, limits: str | None = None) -> Path:
    """A copy of the example arm's robot file in ``tmp`` (its model by absolute path), each joint with
    ``on_timeout`` and ``limits`` (a TOML inline table) when given."""
    text = ARM.read_text().replace('file = "arm6.xml"', f'file = "{ARM.parent / "arm6.xml"}"')
    keys = (("on_timeout", on_timeout and f'"{on_timeout}"'), ("limits", limits))
    extra = "".join(f"\n{k} = {v}" for k, v in keys if v)
    text = re.sub(r"(\nid = \d+)", lambda m: m.group(1) + extra, text)
    out = tmp / "arm.toml"
    out.write_text(text)
    return out


@dataclass
class Arm:
    bridge: Bridge
    sim: SimTransport
    spec: RobotSpec
    endpoint: str
    frames: list[tuple[float, Any]]
    """(perf_counter s, frame) of every frame the bridge put on the sim bus."""

    def motor(self, name: str) -> Any:
        return self.sim.bus.motors[self.spec.joints[name].id]

    def position(self, name: str) -> float:
        """Joint ``name``'s position (rad) from its simulated motor."""
        j = self.spec.joints[name]
        return float(np.radians(self.motor(name).position) / j.gear + j.offset)

    def enable(self, ros: Any) -> None:
        resp, _ = _call(ros, self.bridge.service_keys["enable"], 1)
        assert resp.success, resp.message
        wait_for(lambda: all(self.motor(n).state == AxisState.CLOSED_LOOP_CONTROL for n in JOINTS))


@contextmanager
def served_arm(path: Path = ARM, **options: Any) -> Iterator[Arm]:
    """The twin arm of robot file ``path`` behind a bridge on a free 127.0.0.1 port."""
    pytest.importorskip("mujoco", reason="the twin arm needs MuJoCo: pip install 'drempower[physics]'")
    spec = load_robot(path)
    sim = SimTransport(robot=spec, robot_bus="arm")
    frames: list[tuple[float, Any]] = []
    send = sim.send

    def recording(frame: Any) -> None:
        frames.append((time.perf_counter(), frame))
        send(frame)

    sim.send = recording  # type: ignore[method-assign]
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    sess = session(listen=[endpoint])
    bridge = Bridge({"arm": sim}, sess, BridgeOptions(dict(spec.joints), prefix=f"arm{free_port()}", **options))
    try:
        yield Arm(bridge, sim, spec, endpoint, frames)
    finally:
        bridge.close()
        sess.close()
        sim.close()


def joint_state(names: list[str], position: list[float], velocity: list[float] | None = None) -> bytes:
    """A sensor_msgs/msg/JointState in CDR, as TopicBasedSystem publishes (effort 0 when not given)."""
    t = rosmsg.typestore().types
    now = time.time_ns()
    msg = t[rosmsg.JOINT_STATE](
        header=t["std_msgs/msg/Header"](
            stamp=t["builtin_interfaces/msg/Time"](sec=now // 1_000_000_000, nanosec=now % 1_000_000_000),
            frame_id="",
        ),
        name=list(names),
        position=np.array(position, dtype=np.float64),
        velocity=np.array(velocity if velocity is not None else [0.0] * len(names), dtype=np.float64),
        effort=np.zeros(len(names), dtype=np.float64),
    )
    return rosmsg.encode(msg, rosmsg.JOINT_STATE)


def publisher_token(ros: Any, topic: str, typename: str, entity: int = 10, node: str = "topic_based") -> Any:
    """Declare the rmw_zenoh liveliness token of a publisher (MP) of ``topic`` from session ``ros``."""
    return ros.liveliness().declare_token(
        rmw.entity_token(
            0,
            str(ros.zid()),
            0,
            entity,
            "MP",
            "",
            node,
            topic,
            rosmsg.dds_type_name(typename),
            rosmsg.ros_type_hash(typename),
        )
    )


class ActionClient:
    """A FollowJointTrajectory client speaking rmw_zenoh's action mapping from session ``ros``."""

    def __init__(self, ros: Any, keys: dict[str, str]) -> None:
        from drempower.bridge import rosaction

        self.ros, self.keys = ros, keys
        self.types = rosaction.typestore().types
        self.t = rosaction.FOLLOW_JOINT_TRAJECTORY
        self.gid = bytes(range(200, 216))
        self.seq = 0
        self.feedback: list[tuple[float, Any]] = []
        self.status: list[Any] = []
        self._subs = [
            ros.declare_subscriber(keys["feedback"], self._on_feedback),
            ros.declare_subscriber(
                keys["status"],
                lambda s: self.status.append(rosmsg.decode(s.payload.to_bytes(), rosaction.GOAL_STATUS_ARRAY)),
            ),
        ]

    def _on_feedback(self, sample: Any) -> None:
        att = rmw.Attachment.decode(sample.attachment.to_bytes())
        assert att.sequence_number >= 1
        self.feedback.append((time.monotonic(), rosmsg.decode(sample.payload.to_bytes(), self.t + "_FeedbackMessage")))

    def call(self, role: str, typename: str, msg: Any, timeout: float = 10.0) -> Any:
        import zenoh

        self.seq += 1
        seq = self.seq  # calls may overlap (a get_result waits while a cancel goes)
        att = rmw.Attachment(seq, time.time_ns(), self.gid).encode()
        replies = list(
            self.ros.get(
                self.keys[role],
                payload=rosmsg.encode(msg, typename + "_Request"),
                attachment=att,
                target=zenoh.QueryTarget.ALL_COMPLETE,
                timeout=timeout,
            )
        )
        assert len(replies) == 1 and replies[0].ok is not None, replies
        back = rmw.Attachment.decode(replies[0].ok.attachment.to_bytes())
        assert back.sequence_number == seq and back.gid == self.gid
        return rosmsg.decode(replies[0].ok.payload.to_bytes(), typename + "_Response")

    def uuid(self, gid: bytes) -> Any:
        return self.types["unique_identifier_msgs/msg/UUID"](uuid=np.frombuffer(gid, dtype=np.uint8).copy())

    def goal(
        self,
        names: list[str],
        times: list[float],
        rows: list[list[float]],
        *,
        path_tolerance: float = 0.0,
        goal_tolerance: float = 0.0,
        goal_time: float = 0.0,
        path_velocity: float = 0.0,
        start_at: int = 0,
    ) -> Any:
        """A goal: ``times`` (s from start), ``rows`` (rad), tolerances (rad, rad/s, s); ``start_at``:
        the trajectory's ``header.stamp`` (ns since the epoch, 0: now)."""
        T = self.types

        def duration(s: float) -> Any:
            return T["builtin_interfaces/msg/Duration"](sec=int(s), nanosec=round((s - int(s)) * 1e9))

        stamp = T["builtin_interfaces/msg/Time"](sec=start_at // 1_000_000_000, nanosec=start_at % 1_000_000_000)
        header = T["std_msgs/msg/Header"](stamp=stamp, frame_id="")
        empty = np.array([], dtype=np.float64)
        points = [
            T["trajectory_msgs/msg/JointTrajectoryPoint"](
                positions=np.array(r, dtype=np.float64),
                velocities=empty,
                accelerations=empty,
                effort=empty,
                time_from_start=duration(t),
            )
            for t, r in zip(times, rows, strict=True)
        ]

        def tol(x: float, v: float = 0.0) -> list[Any]:
            jt = T["control_msgs/msg/JointTolerance"]
            return [jt(name=n, position=x, velocity=v, acceleration=0.0) for n in names] if x or v else []

        return T[self.t + "_Goal"](
            trajectory=T["trajectory_msgs/msg/JointTrajectory"](header=header, joint_names=names, points=points),
            multi_dof_trajectory=T["trajectory_msgs/msg/MultiDOFJointTrajectory"](
                header=header, joint_names=[], points=[]
            ),
            path_tolerance=tol(path_tolerance, path_velocity),
            component_path_tolerance=[],
            goal_tolerance=tol(goal_tolerance),
            component_goal_tolerance=[],
            goal_time_tolerance=duration(goal_time),
        )

    def send(self, goal: Any, gid: bytes) -> bool:
        req = self.types[self.t + "_SendGoal_Request"](goal_id=self.uuid(gid), goal=goal)
        return bool(self.call("send_goal", self.t + "_SendGoal", req).accepted)

    def result(self, gid: bytes, timeout: float = 30.0) -> Any:
        req = self.types[self.t + "_GetResult_Request"](goal_id=self.uuid(gid))
        return self.call("get_result", self.t + "_GetResult", req, timeout)

    def cancel(self, gid: bytes) -> Any:
        from drempower.bridge import rosaction

        T = self.types
        info = T["action_msgs/msg/GoalInfo"](
            goal_id=self.uuid(gid), stamp=T["builtin_interfaces/msg/Time"](sec=0, nanosec=0)
        )
        return self.call("cancel_goal", rosaction.CANCEL_GOAL, T[rosaction.CANCEL_GOAL + "_Request"](goal_info=info))
