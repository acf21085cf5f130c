"""``drempower bridge`` serves TopicBasedSystem's topics and the FollowJointTrajectory action, named by options
or the robot file's ``[ros2_control]``."""

from __future__ import annotations

import json
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from drempower.errors import ConfigError
from drempower.robot.config import load_robot

from .conftest import free_port

pytestmark = pytest.mark.timeout(60)

_ROBOT = """
[buses.arm]
interface = "sim"
[joints.a]
bus = "arm"
id = 1
[joints.b]
bus = "arm"
id = 2
[ros2_control]
joint_commands_topic = "/arm/joint_commands"
command_interfaces = ["position", "velocity"]
action = "arm_controller/follow_joint_trajectory"
"""


def _bridge(*extra: str) -> subprocess.CompletedProcess[str] | dict[str, object]:
    argv = [sys.executable, "-m", "drempower", "bridge", "--json", "--prefix", f"cli{free_port()}"]
    argv += ["--connect", f"tcp/127.0.0.1:{free_port()}", *extra]
    proc = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert proc.stdout is not None
    line = proc.stdout.readline()
    if not line:
        _, err = proc.communicate(timeout=20)
        return subprocess.CompletedProcess(argv, proc.returncode, "", err)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=20)
    assert proc.returncode == 128 + signal.SIGTERM, err
    record: dict[str, object] = json.loads(line)
    return record


def test_the_defaults_are_topic_based_systems(tmp_path: Path) -> None:
    record = _bridge("--sim", "1,2")
    assert isinstance(record, dict)
    assert str(record["joint_commands"]).startswith("0/robot_joint_commands/sensor_msgs::msg::dds_::JointState_/")
    assert str(record["robot_joint_states"]).startswith("0/robot_joint_states/sensor_msgs::msg::dds_::JointState_/")
    assert str(record["action_send_goal"]).startswith(
        "0/follow_joint_trajectory/_action/send_goal/control_msgs::action::dds_::FollowJointTrajectory_SendGoal_/"
    )
    assert str(record["action_status"]).startswith(
        "0/follow_joint_trajectory/_action/status/action_msgs::msg::dds_::GoalStatusArray_/RIHS01_6c1684b0"
    )
    off = _bridge("--sim", "1,2", "--no-ros2-control")
    assert isinstance(off, dict) and "joint_commands" not in off and "action_send_goal" not in off


def test_names_from_the_robot_file_and_the_options(tmp_path: Path) -> None:
    path = tmp_path / "robot.toml"
    path.write_text(_ROBOT)
    assert load_robot(path).ros2_control["command_interfaces"] == ["position", "velocity"]
    record = _bridge("--robot", str(path), "--joint-states", "/arm/states")
    assert isinstance(record, dict)
    assert str(record["joint_commands"]).startswith("0/arm/joint_commands/")
    assert str(record["robot_joint_states"]).startswith("0/arm/states/")
    assert str(record["action_get_result"]).startswith("0/arm_controller/follow_joint_trajectory/_action/get_result/")


def test_bad_settings_are_usage_errors(tmp_path: Path) -> None:
    run = _bridge("--sim", "1", "--command-interfaces", "velocity,effort")
    assert isinstance(run, subprocess.CompletedProcess)
    assert run.returncode == 2 and "velocity and effort without position" in run.stderr
    assert "Traceback" not in run.stderr
    path = tmp_path / "robot.toml"
    path.write_text(_ROBOT.replace('action = "arm_controller', 'acton = "arm_controller'))
    with pytest.raises(ConfigError, match=r"\[ros2_control\]: unknown key 'acton'"):
        load_robot(path)
    path.write_text(_ROBOT.replace('["position", "velocity"]', '["position", "speed"]'))
    run = _bridge("--robot", str(path))
    assert isinstance(run, subprocess.CompletedProcess)
    assert run.returncode == 2 and "ros2_control: command_interfaces: 'speed'" in run.stderr, run.stderr
    assert "Traceback" not in run.stderr
