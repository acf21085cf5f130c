"""The follower and the leader as LeRobot's loops use them, on twins of the example arm: observation
keys and units (deg at the joint, through the gear), every action through the safety gate (a step
beyond the file's ``max_step`` or a target beyond the model's range is refused and nothing moves;
``max_relative_target`` bounds the step instead), the leader's actions, and the safe state each
leaves its joints in."""

from __future__ import annotations

import math
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

pytest.importorskip("lerobot", reason="LeRobot is not installed here: make test-lerobot runs these")

from lerobot_robot_drempower import DrEmpowerFollower, DrEmpowerFollowerConfig
from lerobot_teleoperator_drempower import DrEmpowerLeader, DrEmpowerLeaderConfig

from drempower import DrEmpowerError, MotorFaultError, SoftLimitError, ValidationError, open_robot
from drempower.client.engine.effects import sleep

from .conftest import ARM, JOINTS, TIMEOUT, idle_on_timeout, served_arms

VIRTUAL = {"clock": "virtual"}


def _arm_file(tmp_path: Path) -> Path:
    """The example arm with a largest step of 0.05 rad on the elbow and a range of -1..1 rad on the wrist pitch."""
    text = (
        ARM.read_text()
        .replace('file = "arm6.xml"', f'file = "{ARM.parent / "arm6.xml"}"')
        .replace(
            '[joints.elbow]\nbus = "arm"\nid = 3\n',
            '[joints.elbow]\nbus = "arm"\nid = 3\nlimits = { max_step = 0.05 }\n',
        )
        .replace(
            '[joints.wrist_pitch]\nbus = "arm"\nid = 5\n',
            '[joints.wrist_pitch]\nbus = "arm"\nid = 5\nlimits = { position = [-1.0, 1.0] }\n',
        )
    )
    assert text.count("max_step") == 1 and text.count("position = [-1.0, 1.0]") == 1
    path = tmp_path / "arm.toml"
    path.write_text(text)
    return path


@pytest.fixture
def follower(tmp_path: Path) -> Iterator[DrEmpowerFollower]:
    robot = DrEmpowerFollower(
        DrEmpowerFollowerConfig(
            calibration_dir=tmp_path,
            robot_file=str(_arm_file(tmp_path)),
            sim=VIRTUAL,
            observe_speeds=True,
            observe_torques=True,
        )
    )
    robot.connect()
    yield robot
    if robot.is_connected:
        robot.disconnect()


def _settle(robot: Any, seconds: float = 1.5) -> None:
    robot.bus("arm").run(sleep(seconds))


def _pose(action: dict[str, float]) -> dict[str, float]:
    return {f"{j}.pos": action.get(j, 0.0) for j in JOINTS}


def test_observation_in_degrees_at_the_joints(tmp_path: Path) -> None:
    cfg = DrEmpowerFollowerConfig(
        calibration_dir=tmp_path, robot_file=str(ARM), sim=VIRTUAL, observe_speeds=True, observe_torques=True
    )
    follower = DrEmpowerFollower(cfg)
    follower.connect()
    try:
        _observe(follower)
    finally:
        follower.disconnect()


def _observe(follower: DrEmpowerFollower) -> None:
    assert list(follower.action_features) == [f"{j}.pos" for j in JOINTS]
    assert list(follower.observation_features) == [f"{j}{k}" for j in JOINTS for k in (".pos", ".vel", ".torque")]
    target = _pose({"shoulder": 20.0, "elbow": 30.0, "wrist_pitch": -15.0})
    sent = follower.send_action(target)
    assert sent == target
    assert follower.robot is not None
    _settle(follower.robot)
    obs = follower.get_observation()
    twin = follower.robot.twin
    assert twin is not None
    for j in JOINTS:  # the shoulder's 2:1 gear is undone: deg at the joint, as the model's angle
        assert obs[f"{j}.pos"] == pytest.approx(math.degrees(twin.joint_position(j)), abs=0.05)
        assert obs[f"{j}.pos"] == pytest.approx(target[f"{j}.pos"], abs=0.3)
        assert abs(obs[f"{j}.vel"]) < 1.0
    assert abs(obs["shoulder.torque"]) > 1.0  # holding the arm out against gravity


def test_a_step_beyond_max_step_is_refused_by_the_gate_and_nothing_moves(follower: DrEmpowerFollower) -> None:
    assert follower.robot is not None
    before = follower.get_observation()
    with pytest.raises(SoftLimitError, match=r"max_step .* \(set by .*arm.toml: \[joints.elbow\] limits\)"):
        follower.send_action(_pose({"base_yaw": 10.0, "elbow": 10.0}))  # 10 deg > 0.05 rad = 2.86 deg
    _settle(follower.robot)
    after = follower.get_observation()
    for j in JOINTS:  # not the base either: the gate checks every joint before anything is sent
        assert after[f"{j}.pos"] == pytest.approx(before[f"{j}.pos"], abs=0.05)
    follower.send_action(_pose({"base_yaw": 10.0, "elbow": 2.5}))  # within the step
    _settle(follower.robot)
    assert follower.get_observation()["elbow.pos"] == pytest.approx(2.5, abs=0.3)


def test_max_relative_target_bounds_the_step(tmp_path: Path) -> None:
    cfg = DrEmpowerFollowerConfig(
        calibration_dir=tmp_path, robot_file=str(_arm_file(tmp_path)), sim=VIRTUAL, max_relative_target={"elbow": 2.0}
    )
    robot = DrEmpowerFollower(cfg)
    robot.connect()
    try:
        sent = robot.send_action(_pose({"base_yaw": 10.0, "elbow": 10.0}))
        assert sent == _pose({"base_yaw": 10.0, "elbow": 2.0})  # the base has no bound here
        assert robot.robot is not None
        _settle(robot.robot)  # the elbow gets there: the gate's max_step counts from where the motor is
        sent = robot.send_action(_pose({"base_yaw": 10.0, "elbow": 10.0}))
        assert sent["elbow.pos"] == pytest.approx(4.0)  # from the last target
        assert robot.robot is not None
        _settle(robot.robot)
        assert robot.get_observation()["elbow.pos"] == pytest.approx(4.0, abs=0.3)
    finally:
        robot.disconnect()


def test_a_target_beyond_a_range_is_refused(follower: DrEmpowerFollower, caplog: pytest.LogCaptureFixture) -> None:
    """The model's range where the robot file gives none (checked by the plugin), the file's by the gate."""
    _, high, _ = follower.ranges["shoulder"]
    with pytest.raises(SoftLimitError, match=rf"shoulder.pos {high + 1:g} deg .*range of model joint 'shoulder'"):
        follower.send_action(_pose({"shoulder": high + 1}))
    assert "wrist_pitch" not in follower.ranges and "elbow" in follower.ranges  # max_step alone is no range
    with pytest.raises(
        SoftLimitError, match=r"motor 5: position .* \(set by .*arm.toml: \[joints.wrist_pitch\] limits\)"
    ):
        follower.send_action(_pose({"wrist_pitch": 60.0}))  # 1.05 rad
    caplog.set_level("INFO")
    follower.calibrate()  # nothing to ask: says where each zero and range come from
    said = caplog.text
    assert "shoulder: motor 2 on bus arm; zero: the motor's, gear 2, offset 0 rad; range -114.6..114.6 deg" in said
    assert "wrist_pitch: motor 5 on bus arm; zero: the motor's, gear 1, offset 0 rad; range -57.3..57.3 deg" in said


def test_actions_with_a_missing_or_unknown_key_or_not_a_number(follower: DrEmpowerFollower) -> None:
    action = _pose({})
    del action["elbow.pos"]
    with pytest.raises(ValidationError, match=r"action: no 'elbow.pos' \(expected base_yaw.pos, "):
        follower.send_action(action)
    with pytest.raises(ValidationError, match=r"action 'knee.pos': not a joint driven"):
        follower.send_action({**_pose({}), "knee.pos": 1.0})
    with pytest.raises(ValidationError, match=r"action elbow.pos=nan: expected a finite angle in deg"):
        follower.send_action(_pose({"elbow": float("nan")}))


def test_leader_actions_are_its_joint_positions(tmp_path: Path) -> None:
    leader = DrEmpowerLeader(DrEmpowerLeaderConfig(calibration_dir=tmp_path, robot_file=str(ARM), sim=VIRTUAL))
    assert leader.compensate  # the file names a model
    leader.connect()
    try:
        assert leader.robot is not None
        twin = leader.robot.twin
        assert twin is not None
        first = leader.get_action()
        assert list(first) == [f"{j}.pos" for j in JOINTS]
        cycles = leader._cycles
        twin.push_joint("elbow", torque=1.0, duration=0.2)
        _settle(leader.robot, 3.0)  # pushed, it moves, slows down and stays
        got = leader.get_action()
        assert leader._cycles - cycles >= 300  # teach mode's 100 cycles per s went on while the test let time pass
        assert got["elbow.pos"] - first["elbow.pos"] > 5.0
        for j in JOINTS:
            assert got[f"{j}.pos"] == pytest.approx(math.degrees(twin.joint_position(j)), abs=0.5)
        _settle(leader.robot, 1.0)
        assert leader.get_action() == pytest.approx(got, abs=0.5)  # where it was left
        leader.send_feedback({})  # no feedback features: an empty feedback is fine, any other refused
        with pytest.raises(ValidationError, match=r"feedback=\['elbow.pos'\]: .* takes no feedback"):
            leader.send_feedback({"elbow.pos": 1.0})
    finally:
        leader.disconnect()


def test_a_leader_whose_teach_mode_stopped_says_so(tmp_path: Path) -> None:
    leader = DrEmpowerLeader(
        DrEmpowerLeaderConfig(calibration_dir=tmp_path, robot_file=str(ARM), sim=VIRTUAL, compensate=False)
    )
    leader.connect()
    assert leader.robot is not None
    leader.robot.close()  # the buses go away under teach mode
    assert leader._thread is not None
    leader._thread.join(10)
    with pytest.raises(DrEmpowerError, match=r"leader .*arm6.toml: teach mode stopped"):
        leader.get_action()
    with pytest.raises(DrEmpowerError):
        leader.disconnect()  # the joints cannot be reached to release them: said, not hidden
    assert not leader.is_connected


def test_disconnect_leaves_each_joint_as_its_on_timeout_says(tmp_path: Path) -> None:
    with served_arms(tmp_path, ("arm",)) as arms:
        idle_on_timeout(arms["arm"].robot_file, "wrist_roll")
        robot = DrEmpowerFollower(
            DrEmpowerFollowerConfig(calibration_dir=tmp_path, robot_file=str(arms["arm"].robot_file), timeout=TIMEOUT)
        )
        robot.connect()
        robot.send_action(_pose({"elbow": 10.0}))
        robot.disconnect()
        with open_robot(arms["arm"].robot_file, stop_on_close=False, timeout=TIMEOUT) as check:
            states = {j: check.joint(j).read_property("axis0.current_state") for j in JOINTS}
    assert states == {j: (1 if j == "wrist_roll" else 8) for j in JOINTS}  # 1 idle, 8 closed loop


def test_temperatures_are_observed_and_a_fault_ends_the_step_with_its_fix(tmp_path: Path) -> None:
    cfg = DrEmpowerFollowerConfig(calibration_dir=tmp_path, robot_file=str(ARM), sim=VIRTUAL, observe_temperatures=True)
    follower = DrEmpowerFollower(cfg)
    follower.connect()
    try:
        assert list(follower.observation_features) == [f"{j}{k}" for j in JOINTS for k in (".pos", ".temp")]
        robot = follower.robot
        assert robot is not None
        sim = robot.bus("arm").transport.bus  # type: ignore[attr-defined]
        elbow = robot.joint("elbow").id
        sim.motors[elbow].thermal.winding = 88.0
        obs = follower.get_observation()
        assert obs["elbow.temp"] == pytest.approx(88.0, abs=0.5)
        assert obs["base_yaw.temp"] < 40.0
        sim.motors[elbow].thermal.winding = 101.0  # the firmware trips: the elbow idles
        _settle(robot, 0.02)
        with pytest.raises(MotorFaultError, match=r"joint elbow.*motor_thermistor.error OVER_TEMP.*Fix:"):
            follower.get_observation()
        with pytest.raises(DrEmpowerError):  # the fault, or the gate's refusal of the idle elbow: nothing moves
            follower.send_action(_pose({}))
    finally:
        follower.disconnect()
