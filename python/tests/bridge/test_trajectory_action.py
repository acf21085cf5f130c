"""FollowJointTrajectory on the bridge: goals, feedback, cancel and error codes on the twin arm over rmw_zenoh."""

from __future__ import annotations

import math
import threading
import time
import uuid
from pathlib import Path

import pytest

from drempower.bridge import rosaction
from drempower.bridge.joint_topics import JointTopics
from drempower.bridge.trajectory_action import TrajectoryAction
from drempower.bridge.typehash import type_hash
from drempower.protocol.enums import AxisState
from drempower.protocol.limits import MOTION_CMDS

from .conftest import session, wait_for
from .ros_peer import JOINTS, ActionClient, arm_file, joint_state, served_arm

pytestmark = pytest.mark.timeout(120)

FIBONACCI = "example_interfaces/action/Fibonacci"
GOLDEN = {
    f"{FIBONACCI}_SendGoal_Request": "RIHS01_3d088942b413247db536576f0286768c6be8fcd5d0c9a5d544f359fba090a238",
    f"{FIBONACCI}_GetResult_Request": "RIHS01_c8a4f5e7d13b81286ee1043e2ecd084281cecf1ff06aaa799464f5f15479f003",
    f"{FIBONACCI}_FeedbackMessage": "RIHS01_c1de71afd52e49a89c53d8262366884185bc0a02f78ce051c4e46b0a7fe59bb2",
    "action_msgs/srv/CancelGoal_Request": "RIHS01_3d3c84653c1f96918086887e1dcb236faec88b81a5b14fd4cf4840065bcdf8af",
    "action_msgs/msg/GoalStatusArray": "RIHS01_6c1684b00f177d37438febe6e709fc4e2b0d4248dca4854946f9ed8b30cda83e",
}
"""Jazzy's hashes of example_interfaces' Fibonacci action types, as published by an independent implementation."""


def test_action_types_hash_as_rosidl_does() -> None:
    store = rosaction.typestore()
    rosaction.register_action(store, FIBONACCI, "int32 order\n---\nint32[] sequence\n---\nint32[] sequence\n")
    for name, want in GOLDEN.items():
        assert type_hash(store, name) == want, name


def _gid() -> bytes:
    return uuid.uuid4().bytes


def test_a_goal_follows_a_six_joint_path_with_feedback(tmp_path: Path) -> None:
    with served_arm() as arm, session(connect=[arm.endpoint]) as ros:
        action = TrajectoryAction(arm.bridge)
        assert action.keys["send_goal"].startswith(
            "0/follow_joint_trajectory/_action/send_goal/control_msgs::action::dds_::FollowJointTrajectory_SendGoal_/"
        )
        client = ActionClient(ros, action.keys)
        arm.enable(ros)
        time.sleep(0.2)
        start = [arm.position(n) for n in JOINTS]
        mid = [s + d for s, d in zip(start, [0.3, -0.2, 0.3, 0.4, -0.3, 0.5], strict=True)]
        end = [s + d for s, d in zip(start, [0.5, -0.3, 0.5, 0.8, -0.5, 1.0], strict=True)]
        gid = _gid()
        goal = client.goal(JOINTS, [1.0, 2.0, 3.0], [mid, end, end], path_tolerance=0.1, goal_tolerance=0.01)
        t0 = time.monotonic()
        assert client.send(goal, gid)
        res = client.result(gid)
        took = time.monotonic() - t0
        assert res.status == rosaction.STATUS["SUCCEEDED"], res.result.error_string
        assert res.result.error_code == 0
        for n, x in zip(JOINTS, end, strict=True):
            assert arm.position(n) == pytest.approx(x, abs=0.01)
        assert 3.0 <= took < 6.0
        fb = [(t, m) for t, m in client.feedback if bytes(bytearray(m.goal_id.uuid)) == gid]
        span = fb[-1][0] - fb[0][0]
        rate = (len(fb) - 1) / span
        worst = {n: max(abs(float(m.feedback.error.positions[k])) for _, m in fb) for k, n in enumerate(JOINTS)}
        print(
            f"\nFollowJointTrajectory on the twin arm: feedback {rate:.1f} Hz over {span:.2f} s; largest tracking "
            "error " + ", ".join(f"{n} {math.degrees(e):.2f} deg" for n, e in worst.items())
        )
        assert rate >= 10
        assert list(fb[0][1].feedback.joint_names) == JOINTS
        assert max(worst.values()) < 0.1
        wait_for(lambda: any(s.status_list and s.status_list[-1].status == 4 for s in client.status))
        action.close()


def test_a_cancel_stops_the_arm(tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    with served_arm() as arm, session(connect=[arm.endpoint]) as ros:
        action = TrajectoryAction(arm.bridge)
        topics = JointTopics(arm.bridge)
        pub = ros.declare_publisher(topics.commands_key)
        client = ActionClient(ros, action.keys)
        arm.enable(ros)
        start = [arm.position(n) for n in JOINTS]
        end = [s + 1.0 for s in start]
        gid = _gid()
        assert client.send(client.goal(JOINTS, [4.0], [end]), gid)
        got: list[object] = []
        waiter = threading.Thread(target=lambda: got.append(client.result(gid)))
        waiter.start()
        time.sleep(0.5)
        topics.busy = action.running
        pub.put(joint_state(JOINTS, start))  # the topics wait while a goal runs
        wait_for(lambda: topics.refused == 1)
        assert "is executing" in caplog.text
        time.sleep(0.5)
        resp = client.cancel(gid)
        assert resp.return_code == 0 and len(resp.goals_canceling) == 1
        waiter.join(10)
        res = got[0]
        assert res.status == rosaction.STATUS["CANCELED"]  # type: ignore[attr-defined]
        time.sleep(0.5)
        held = [arm.position(n) for n in JOINTS]
        time.sleep(0.5)
        for n, h, s, e in zip(JOINTS, held, start, end, strict=True):
            assert arm.position(n) == pytest.approx(h, abs=0.01)  # it stays where it stopped
            assert s + 0.05 < h < e - 0.3  # stopped on the way
        assert client.cancel(gid).return_code == 3  # ERROR_GOAL_TERMINATED
        action.close()
    # the bridge's end holds what it drove (the joints' on_timeout, hold by default): the arm is not dropped
    assert all(arm.motor(n).state == AxisState.CLOSED_LOOP_CONTROL for n in JOINTS)


def test_bad_goals_end_with_their_error_codes(tmp_path: Path) -> None:
    limits = "{ position = [-1.0, 1.0] }"
    with served_arm(arm_file(tmp_path, limits=limits)) as arm, session(connect=[arm.endpoint]) as ros:
        action = TrajectoryAction(arm.bridge)
        client = ActionClient(ros, action.keys)
        arm.enable(ros)
        start = [arm.position(n) for n in JOINTS]
        mark = len(arm.frames)
        cases = [
            (client.goal(["base_yaw", "nose"], [1.0], [[0.1, 0.1]]), "INVALID_JOINTS", "'nose'"),
            (client.goal(JOINTS, [1.0], [[1.5, *start[1:]]]), "INVALID_GOAL", "outside its limits"),
            (client.goal(JOINTS, [1.0, 0.5], [start, start]), "INVALID_GOAL", "increasing"),
        ]
        for goal, code, words in cases:
            gid = _gid()
            assert client.send(goal, gid)
            res = client.result(gid)
            assert res.status == rosaction.STATUS["ABORTED"]
            assert res.result.error_code == rosaction.ERROR[code], res.result.error_string
            assert words in res.result.error_string
        motion = set(MOTION_CMDS)
        assert not [f for _, f in arm.frames[mark:] if f.arbitration_id & 0x1F in motion]
        # a path the arm cannot follow within a tight path tolerance
        gid = _gid()
        fast = [s + 0.8 if k == 1 else s for k, s in enumerate(start)]
        assert client.send(client.goal(JOINTS, [0.2], [fast], path_tolerance=0.005), gid)
        res = client.result(gid)
        assert res.result.error_code == rosaction.ERROR["PATH_TOLERANCE_VIOLATED"], res.result.error_string
        # the goal not reached within goal_time_tolerance
        gid = _gid()
        near = [s + 0.2 for s in start]
        goal = client.goal(JOINTS, [0.3], [near], goal_tolerance=1e-6, goal_time=0.2)
        assert client.send(goal, gid)
        res = client.result(gid)
        assert res.result.error_code == rosaction.ERROR["GOAL_TOLERANCE_VIOLATED"], res.result.error_string
        action.close()


def test_a_goal_to_idle_motors_is_refused_and_a_cancel_holds_idle_on_timeout_joints(tmp_path: Path) -> None:
    with served_arm(arm_file(tmp_path, "idle")) as arm, session(connect=[arm.endpoint]) as ros:
        action = TrajectoryAction(arm.bridge)
        client = ActionClient(ros, action.keys)
        arm.bridge.bus.idle(range(1, 7))  # as after an estop
        wait_for(lambda: all(arm.motor(n).state == AxisState.IDLE for n in JOINTS))
        start = [arm.position(n) for n in JOINTS]
        gid = _gid()
        mark = len(arm.frames)
        assert client.send(client.goal(JOINTS, [1.0], [[s + 0.2 for s in start]]), gid)
        res = client.result(gid)
        assert res.result.error_code == rosaction.ERROR["INVALID_GOAL"]
        assert res.result.error_string == (  # the words of the bridge's command topics
            "motors 1, 2, 3, 4, 5, 6 are idle (not in closed loop): enable them first "
            "(call the enable service, or drempower enable 1,2,3,4,5,6)"
        )
        assert not [f for _, f in arm.frames[mark:] if f.arbitration_id & 0x1F in set(MOTION_CMDS)]
        arm.enable(ros)
        time.sleep(0.5)
        start = [arm.position(n) for n in JOINTS]
        gid = _gid()
        assert client.send(client.goal(JOINTS, [3.0], [[s + 0.6 for s in start]]), gid)
        time.sleep(1.0)
        client.cancel(gid)
        assert client.result(gid).status == rosaction.STATUS["CANCELED"]
        assert all(arm.motor(n).state == AxisState.CLOSED_LOOP_CONTROL for n in JOINTS)  # held, not idled
        action.close()


def test_liveliness_tokens_of_the_action_and_the_topics(tmp_path: Path) -> None:
    with served_arm() as arm, session(connect=[arm.endpoint]) as ros:
        action = TrajectoryAction(arm.bridge, "arm_controller/follow_joint_trajectory")
        JointTopics(arm.bridge)

        def tokens() -> list[list[str]]:
            return [str(r.ok.key_expr).split("/") for r in ros.liveliness().get("@ros2_lv/0/**", timeout=2)]

        wait_for(lambda: len(tokens()) >= 15)
        mine = {(t[5], t[9]): t for t in tokens() if len(t) == 13}
        fq = "%arm_controller%follow_joint_trajectory%_action%"
        for role, kind in (("send_goal", "SS"), ("cancel_goal", "SS"), ("get_result", "SS")):
            t = mine[(kind, fq + role)]
            assert action.keys[role] == f"0/{'/'.join(t[9].split('%')[1:])}/{t[10]}/{t[11]}"
            assert t[12] == "::,10:,:,:,,"
        assert mine[("SS", fq + "cancel_goal")][10] == "action_msgs::srv::dds_::CancelGoal_"
        assert mine[("MP", fq + "feedback")][10] == "control_msgs::action::dds_::FollowJointTrajectory_FeedbackMessage_"
        status = mine[("MP", fq + "status")]
        assert status[10:12] == ["action_msgs::msg::dds_::GoalStatusArray_", GOLDEN["action_msgs/msg/GoalStatusArray"]]
        assert status[12] == ":1:,1:,:,:,,"  # transient local, keep last 1
        assert mine[("MS", "%robot_joint_commands")][10] == "sensor_msgs::msg::dds_::JointState_"
        assert mine[("MP", "%robot_joint_states")][8] == "drempower_bridge"
        action.close()


def test_a_new_goal_preempts_the_one_executing(tmp_path: Path) -> None:
    """As joint_trajectory_controller: the old goal holds and ends CANCELED, the new one starts from there."""
    with served_arm() as arm, session(connect=[arm.endpoint]) as ros:
        action = TrajectoryAction(arm.bridge)
        client = ActionClient(ros, action.keys)
        arm.enable(ros)
        time.sleep(0.2)
        start = [arm.position(n) for n in JOINTS]
        first, second = _gid(), _gid()
        assert client.send(client.goal(JOINTS, [4.0], [[s + 1.0 for s in start]]), first)
        got: list[object] = []
        waiter = threading.Thread(target=lambda: got.append(client.result(first)))
        waiter.start()
        time.sleep(1.0)
        back = [s - 0.2 for s in start]
        assert client.send(client.goal(JOINTS, [1.5], [back], goal_tolerance=0.01), second)
        waiter.join(10)
        old = got[0]
        assert old.status == rosaction.STATUS["CANCELED"]  # type: ignore[attr-defined]
        assert "preempted by goal" in old.result.error_string  # type: ignore[attr-defined]
        res = client.result(second)
        assert res.status == rosaction.STATUS["SUCCEEDED"], res.result.error_string
        for n, x in zip(JOINTS, back, strict=True):
            assert arm.position(n) == pytest.approx(x, abs=0.01)
        action.close()


def test_a_stamp_ahead_delays_the_start_and_a_velocity_tolerance_stops_a_fast_path(tmp_path: Path) -> None:
    with served_arm() as arm, session(connect=[arm.endpoint]) as ros:
        action = TrajectoryAction(arm.bridge)
        client = ActionClient(ros, action.keys)
        arm.enable(ros)
        time.sleep(0.2)
        start = [arm.position(n) for n in JOINTS]
        gid = _gid()
        mark = len(arm.frames)
        t0 = time.monotonic()
        at = time.time_ns() + 800_000_000  # 0.8 s ahead
        assert client.send(client.goal(JOINTS, [0.5], [[s + 0.1 for s in start]], start_at=at), gid)
        time.sleep(0.5)
        assert not [f for _, f in arm.frames[mark:] if f.arbitration_id & 0x1F in set(MOTION_CMDS)]
        res = client.result(gid)
        assert res.status == rosaction.STATUS["SUCCEEDED"], res.result.error_string
        assert time.monotonic() - t0 >= 0.8 + 0.5
        # 0.5 rad in 0.5 s moves a joint at ~1.5 rad/s at its fastest: beyond a velocity tolerance of 0.3 rad/s
        here = [arm.position(n) for n in JOINTS]
        gid = _gid()
        far = [h + 0.5 if k == 0 else h for k, h in enumerate(here)]
        assert client.send(client.goal(JOINTS, [0.5], [far], path_velocity=0.3), gid)
        res = client.result(gid)
        assert res.result.error_code == rosaction.ERROR["PATH_TOLERANCE_VIOLATED"], res.result.error_string
        assert "speed" in res.result.error_string and "base_yaw" in res.result.error_string
        assert arm.position("base_yaw") < here[0] + 0.45  # stopped on the way
        action.close()


def test_a_late_status_subscriber_gets_the_last_status(tmp_path: Path) -> None:
    """The status topic is transient local: a subscriber joining after a goal ended still learns how it ended."""
    from zenoh import ext

    from drempower.bridge import rosmsg

    with served_arm() as arm, session(connect=[arm.endpoint]) as ros:
        action = TrajectoryAction(arm.bridge)
        client = ActionClient(ros, action.keys)
        arm.enable(ros)
        time.sleep(0.2)
        here = [arm.position(n) for n in JOINTS]
        gid = _gid()
        assert client.send(client.goal(JOINTS, [0.3], [here]), gid)
        assert client.result(gid).status == rosaction.STATUS["SUCCEEDED"]
        seen: list[object] = []
        late = ext.declare_advanced_subscriber(
            ros,
            action.keys["status"],
            lambda s: seen.append(rosmsg.decode(s.payload.to_bytes(), rosaction.GOAL_STATUS_ARRAY)),
            history=ext.HistoryConfig(detect_late_publishers=True),
        )
        wait_for(lambda: bool(seen))
        last = seen[-1].status_list  # type: ignore[attr-defined]
        assert bytes(bytearray(last[-1].goal_info.goal_id.uuid)) == gid
        assert last[-1].status == rosaction.STATUS["SUCCEEDED"]
        late.undeclare()
        action.close()
