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
