"""TopicBasedSystem's topics on the bridge: JointState commands drive the twin arm through rmw_zenoh's formats."""

from __future__ import annotations

import math
import statistics
import time
from pathlib import Path
from typing import Any

import pytest

from drempower.bridge import rosmsg
from drempower.bridge.joint_topics import JointTopics, check_interfaces
from drempower.protocol.enums import AxisState
from drempower.protocol.ids import Cmd
from drempower.protocol.limits import MOTION_CMDS

from .conftest import session, wait_for
from .ros_peer import JOINTS, arm_file, joint_state, publisher_token, served_arm

pytestmark = pytest.mark.timeout(90)

TARGET = [0.3, -0.2, 0.4, 0.5, -0.3, 0.6]
"""rad per joint of the arm."""


def _stream(pub: Any, start: list[float], end: list[float], seconds: float, rate: float = 50.0) -> None:
    """Publish a straight line from ``start`` to ``end`` as ros2_control would (positions only change)."""
    steps = max(1, int(seconds * rate))
    for k in range(1, steps + 1):
        pub.put(joint_state(JOINTS, [a + (b - a) * k / steps for a, b in zip(start, end, strict=True)]))
        time.sleep(1 / rate)


def test_a_joint_state_stream_moves_the_twin_arm_and_silence_holds(tmp_path: Path) -> None:
    with served_arm() as arm, session(connect=[arm.endpoint]) as ros:
        topics = JointTopics(arm.bridge)
        assert topics.commands_key.startswith("0/robot_joint_commands/sensor_msgs::msg::dds_::JointState_/RIHS01_")
        states: list[Any] = []
        ros.declare_subscriber(
            topics.states_key, lambda s: states.append(rosmsg.decode(s.payload.to_bytes(), rosmsg.JOINT_STATE))
        )
        token = publisher_token(ros, topics.commands_topic, rosmsg.JOINT_STATE)
        pub = ros.declare_publisher(topics.commands_key)
        arm.enable(ros)
        start = [arm.position(n) for n in JOINTS]
        _stream(pub, start, TARGET, 1.0)
        wait_for(lambda: all(abs(arm.position(n) - x) < 0.02 for n, x in zip(JOINTS, TARGET, strict=True)), limit=5)
        assert topics.received >= 40 and topics.refused == 0
        # silence from a live publisher: the last command stands, well past the watchdog's 0.5 s
        time.sleep(1.5)
        assert topics.fired == 0
        for n, x in zip(JOINTS, TARGET, strict=True):
            assert arm.position(n) == pytest.approx(x, abs=0.02)
            assert arm.motor(n).state == AxisState.CLOSED_LOOP_CONTROL
        # the states topic carries every joint at the joint (rad)
        last = states[-1]
        assert list(last.name) == JOINTS
        assert [float(p) for p in last.position] == pytest.approx(TARGET, abs=0.02)
        token.undeclare()
        pub.undeclare()
    # the bridge's end holds what its topics drove (the joints' on_timeout, hold by default): not dropped
    assert all(arm.motor(n).state == AxisState.CLOSED_LOOP_CONTROL for n in JOINTS)


def test_command_to_frame_latency(tmp_path: Path) -> None:
    """From the Zenoh put of a JointState to the first position frame on the sim bus (figure printed)."""
    with served_arm() as arm, session(connect=[arm.endpoint]) as ros:
        topics = JointTopics(arm.bridge)
        token = publisher_token(ros, topics.commands_topic, rosmsg.JOINT_STATE)
        pub = ros.declare_publisher(topics.commands_key)
        arm.enable(ros)
        pos = [arm.position(n) for n in JOINTS]
        delays: list[float] = []
        for _ in range(60):
            pos[0] += 0.001
            mark = len(arm.frames)
            t0 = time.perf_counter()
            pub.put(joint_state(JOINTS, pos))
            wait_for(
                lambda m=mark: any(f.arbitration_id == (1 << 5 | Cmd.POSITION_T) for _, f in arm.frames[m:]),
                limit=2,
                step=0.0005,
            )
            sent = next(t for t, f in arm.frames[mark:] if f.arbitration_id == (1 << 5 | Cmd.POSITION_T))
            delays.append(sent - t0)
            time.sleep(0.01)
        med, p95 = statistics.median(delays), sorted(delays)[int(0.95 * len(delays))]
        n = len(delays)
        print(f"\nJointState command to motor frame: median {med * 1e3:.2f} ms, p95 {p95 * 1e3:.2f} ms (n={n})")
        assert topics.received == 60
        token.undeclare()


@pytest.mark.parametrize("on_timeout", ["idle", "hold"])
def test_a_vanished_publisher_does_each_joints_on_timeout(tmp_path: Path, on_timeout: str) -> None:
    with served_arm(arm_file(tmp_path, on_timeout)) as arm, session(connect=[arm.endpoint]) as ros:
        topics = JointTopics(arm.bridge)
        token = publisher_token(ros, topics.commands_topic, rosmsg.JOINT_STATE)
        pub = ros.declare_publisher(topics.commands_key)
        arm.enable(ros)
        start = [arm.position(n) for n in JOINTS]
        _stream(pub, start, [s + 0.1 for s in start], 0.3)
        wait_for(lambda: topics.received >= 10)
        time.sleep(0.8)  # silence: held
        assert topics.fired == 0 and all(arm.motor(n).state == AxisState.CLOSED_LOOP_CONTROL for n in JOINTS)
        mark = len(arm.frames)
        token.undeclare()  # the ros2_control node went away
        wait_for(lambda: topics.fired == 1, limit=3)
        if on_timeout == "idle":
            wait_for(lambda: all(arm.motor(n).state == AxisState.IDLE for n in JOINTS), limit=2)
        else:
            ids = {(i << 5 | Cmd.VELOCITY) for i in range(1, 7)}
            wait_for(lambda: ids <= {f.arbitration_id for _, f in arm.frames[mark:]}, limit=2)
            assert all(arm.motor(n).state == AxisState.CLOSED_LOOP_CONTROL for n in JOINTS)
        pub.undeclare()


def test_unknown_names_and_limits_are_refused_with_nothing_sent(tmp_path: Path, caplog: Any) -> None:
    limits = "{ position = [-1.0, 1.0] }"
    with served_arm(arm_file(tmp_path, limits=limits)) as arm, session(connect=[arm.endpoint]) as ros:
        topics = JointTopics(arm.bridge)
        pub = ros.declare_publisher(topics.commands_key)
        arm.enable(ros)
        mark = len(arm.frames)
        pub.put(joint_state(["base_yaw", "nose"], [0.1, 0.1]))
        pub.put(joint_state(["base_yaw"], [1.5]))  # beyond the soft limit
        wait_for(lambda: topics.refused == 2)
        time.sleep(0.1)
        motion = set(MOTION_CMDS)
        assert not [f for _, f in arm.frames[mark:] if f.arbitration_id & 0x1F in motion]
        text = caplog.text
        assert "unknown joint 'nose'" in text
        pub.put(joint_state(["base_yaw"], [0.2]))  # a subset of the joints is a command to those
        wait_for(lambda: topics.received == 1)
        wait_for(lambda: abs(arm.position("base_yaw") - 0.2) < 0.02, limit=5)


def test_interfaces_are_checked() -> None:
    assert check_interfaces(["effort", "position"]) == ("position", "effort")
    for bad, word in ((["speed"], "'speed'"), ([], "none given"), (["velocity", "effort"], "without position")):
        with pytest.raises(ValueError, match=word):
            check_interfaces(bad)


def test_velocity_interface_runs_the_joint(tmp_path: Path) -> None:
    with served_arm() as arm, session(connect=[arm.endpoint]) as ros:
        topics = JointTopics(arm.bridge, "/cmd", "/st", interfaces=["velocity"])
        assert topics.commands_topic == "/cmd" and "0/st/" in topics.states_key
        pub = ros.declare_publisher(topics.commands_key)
        arm.enable(ros)
        before = arm.position("base_yaw")
        pub.put(joint_state(["base_yaw"], [0.0], velocity=[0.5]))
        wait_for(lambda: abs(arm.motor("base_yaw").speed) > 1.0)
        time.sleep(0.5)
        moved = arm.position("base_yaw") - before
        assert 0.1 < moved < 0.5 + 0.1
        pub.put(joint_state(["base_yaw"], [0.0], velocity=[0.0]))
        wait_for(lambda: abs(arm.motor("base_yaw").speed) < 0.5)
        assert math.isfinite(moved)


def test_a_token_after_the_first_command_still_counts(tmp_path: Path) -> None:
    with served_arm(arm_file(tmp_path, "idle")) as arm, session(connect=[arm.endpoint]) as ros:
        topics = JointTopics(arm.bridge)
        pub = ros.declare_publisher(topics.commands_key)
        arm.enable(ros)
        pub.put(joint_state(JOINTS, [arm.position(n) for n in JOINTS]))
        wait_for(lambda: topics.received == 1)
        token = publisher_token(ros, topics.commands_topic, rosmsg.JOINT_STATE)
        time.sleep(1.0)  # twice the timeout of a publisher without a token: held, since its token is there
        assert topics.fired == 0 and all(arm.motor(n).state == AxisState.CLOSED_LOOP_CONTROL for n in JOINTS)
        token.undeclare()
        wait_for(lambda: all(arm.motor(n).state == AxisState.IDLE for n in JOINTS), limit=3)
        pub.undeclare()


def test_joint_commands_are_refused_in_the_words_of_the_tables_rows_and_the_gate(tmp_path: Path) -> None:
    """The same words as the bridge's own command topics: the row of the actions table, the safety gate
    with the ROS 2 caller's fix; the refusal is kept for /rosout; nothing sent."""
    with served_arm() as arm, session(connect=[arm.endpoint]) as ros:
        topics = JointTopics(arm.bridge, interfaces=["velocity"])
        pub = ros.declare_publisher(topics.commands_key)
        arm.bridge.bus.idle(range(1, 7))  # as after an estop
        wait_for(lambda: all(arm.motor(n).state == AxisState.IDLE for n in JOINTS))
        mark = len(arm.frames)

        def put_until_refused(msg: bytes) -> None:
            """Put ``msg`` until the topics refuse it (the first put may come before Zenoh matched them)."""
            seen = topics.refused
            t0 = time.monotonic()
            while topics.refused == seen:
                assert time.monotonic() - t0 < 5.0, "not refused within 5 s"
                pub.put(msg)
                put_at = time.monotonic()
                while topics.refused == seen and time.monotonic() - put_at < 0.5:
                    time.sleep(0.01)

        put_until_refused(joint_state(["base_yaw"], [0.0], velocity=[0.5]))
        idle = arm.bridge.last_refusal or ""
        assert "is idle (not in closed loop): enable it first (call the enable service" in idle, idle
        arm.enable(ros)
        pub.put(joint_state(["base_yaw"], [0.0], velocity=[1e6]))
        wait_for(lambda: topics.refused == 2)
        far = arm.bridge.last_refusal or ""
        assert "joint 'base_yaw' (velocity 1e+06 rad/s): speed=" in far and "-327.68..327.67" in far, far
        pub.put(joint_state(["base_yaw"], [0.0], velocity=[math.nan]))
        wait_for(lambda: topics.refused == 3)
        assert "expected a finite number" in (arm.bridge.last_refusal or "")
        time.sleep(0.1)
        assert not [f for _, f in arm.frames[mark:] if f.arbitration_id & 0x1F in set(MOTION_CMDS)]
