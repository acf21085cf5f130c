"""Corners of the topic watch: a publisher without a token after one with a token came and went is
watched by the timeout; a JointState naming some joints (or none) puts only those under its watch."""

from __future__ import annotations

import time
from pathlib import Path

import pytest

from drempower.bridge import rosmsg
from drempower.bridge.joint_topics import JointTopics
from drempower.protocol.enums import AxisState

from .conftest import session, wait_for
from .ros_peer import JOINTS, arm_file, joint_state, publisher_token, served_arm

pytestmark = pytest.mark.timeout(90)


def test_a_later_publisher_without_a_token_is_watched(tmp_path: Path) -> None:
    with served_arm(arm_file(tmp_path, "idle")) as arm, session(connect=[arm.endpoint]) as ros:
        topics = JointTopics(arm.bridge)
        token = publisher_token(ros, topics.commands_topic, rosmsg.JOINT_STATE)
        pub = ros.declare_publisher(topics.commands_key)
        arm.enable(ros)
        pub.put(joint_state(JOINTS, [arm.position(n) for n in JOINTS]))
        wait_for(lambda: topics.received == 1)
        token.undeclare()  # the publisher with a token goes: its joints idle
        wait_for(lambda: all(arm.motor(n).state == AxisState.IDLE for n in JOINTS), limit=3)
        arm.enable(ros)
        pub.put(joint_state(JOINTS, [arm.position(n) for n in JOINTS]))  # a later one, no token
        wait_for(lambda: topics.received == 2)
        t0 = time.monotonic()
        wait_for(lambda: all(arm.motor(n).state == AxisState.IDLE for n in JOINTS), limit=3)
        print(f"a token-less publisher's joints idled {time.monotonic() - t0:.2f} s after its last command")
        pub.undeclare()


def test_a_command_naming_some_joints_watches_only_those(tmp_path: Path) -> None:
    with served_arm(arm_file(tmp_path, "idle")) as arm, session(connect=[arm.endpoint]) as ros:
        topics = JointTopics(arm.bridge)
        pub = ros.declare_publisher(topics.commands_key)
        arm.enable(ros)
        pub.put(joint_state([], []))  # an empty JointState: no joint is this publisher's
        first = JOINTS[:1]
        pub.put(joint_state(first, [arm.position(first[0])]))
        wait_for(lambda: topics.received >= 1)
        wait_for(lambda: arm.motor(first[0]).state == AxisState.IDLE, limit=3)  # no token: the timeout
        time.sleep(0.3)
        others = [n for n in JOINTS if n not in first]
        assert all(arm.motor(n).state == AxisState.CLOSED_LOOP_CONTROL for n in others)
        pub.undeclare()


def test_a_stray_position_command_during_a_goal_is_refused_and_the_goal_goes_on(tmp_path: Path) -> None:
    from drempower.bridge import rosaction
    from drempower.bridge.trajectory_action import TrajectoryAction

    from .ros_peer import ActionClient
    from .test_bridge import _command
    from .test_trajectory_action import _gid

    with served_arm() as arm, session(connect=[arm.endpoint]) as ros:
        action = TrajectoryAction(arm.bridge)
        client = ActionClient(ros, action.keys)
        pub = ros.declare_publisher(arm.bridge.command_keys["position_commands"])
        arm.enable(ros)
        time.sleep(0.2)
        start = [arm.position(n) for n in JOINTS]
        end = [s + 0.3 for s in start]
        gid = _gid()
        assert client.send(client.goal(JOINTS, [2.0], [end]), gid)
        time.sleep(0.5)
        pub.put(_command(start))  # a stray command from another node
        wait_for(lambda: arm.bridge.refused >= 1)
        assert "is executing" in (arm.bridge.last_refusal or "")
        res = client.result(gid)
        assert res.status == rosaction.STATUS["SUCCEEDED"], res.result.error_string
        for n, x in zip(JOINTS, end, strict=True):
            assert arm.position(n) == pytest.approx(x, abs=0.02)
        action.close()
