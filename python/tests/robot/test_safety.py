"""A robot file's soft limits and watchdog keys: refused commands name the file and the joint."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

import drempower
from drempower.errors import ConfigError, MotorIdleError, SoftLimitError
from drempower.robot.config import load_robot

ROBOT = """
[buses.arm]
interface = "sim"
clock = "virtual"
[joints.shoulder]
bus = "arm"
id = 1
gear = 2.0
limits = { position = [-1.5, 1.5], speed = 2.0, torque = 5.0, accel = 10.0, max_step = 0.2 }
[joints.wrist]
bus = "arm"
id = 2
on_timeout = "idle"
"""


@pytest.fixture
def robot_file(tmp_path: Path) -> Path:
    path = tmp_path / "arm.toml"
    path.write_text(ROBOT)
    return path


def test_the_keys_are_read_with_their_defaults(robot_file: Path) -> None:
    spec = load_robot(robot_file)
    assert spec.joints["shoulder"].limits == {
        "position": (-1.5, 1.5),
        "speed": 2.0,
        "torque": 5.0,
        "accel": 10.0,
        "max_step": 0.2,
    }
    assert spec.joints["shoulder"].on_timeout == "hold"  # an arm's joint holds by default
    assert spec.joints["wrist"].on_timeout == "idle" and spec.joints["wrist"].limits == {}
    assert spec.on_timeout("arm") == {1: "hold", 2: "idle"}  # what the bus's watchdog takes


@pytest.mark.parametrize(
    ("joint", "words"),
    [
        ("limits = { reach = 1 }", "unknown limit 'reach'"),
        ("limits = { position = [1, -1] }", "limits.position=[1, -1]: low is above high"),
        ("limits = { speed = 0 }", "limits.speed=0: a limit is > 0 (rad/s, by magnitude)"),
        ("limits = { torque = 'a' }", "limits.torque='a': expected a finite number"),
        ("on_timeout = 'coast'", "on_timeout='coast': expected 'hold' or 'idle'"),
    ],
)
def test_bad_safety_keys_are_refused(joint: str, words: str, tmp_path: Path) -> None:
    path = tmp_path / "r.toml"
    path.write_text(f"[buses.a]\ninterface='sim'\n[joints.j]\nbus='a'\nid=1\n{joint}\n")
    with pytest.raises(ConfigError) as info:
        load_robot(path)
    assert words in str(info.value) and f"{path}: [joints.j]" in str(info.value)


def test_joint_limits_refuse_before_any_frame_naming_the_file(robot_file: Path) -> None:
    with drempower.open_robot(robot_file) as robot:
        shoulder = robot.joint("shoulder")
        limits = robot.bus("arm").limits(1)
        assert limits["position"].high == pytest.approx(math.degrees(3.0))  # gear 2: 1.5 rad at the joint
        assert limits["speed"].high == pytest.approx(2.0 * 2 * 60 / (2 * math.pi))
        where = f"(set by {robot_file}: [joints.shoulder] limits)"
        with pytest.raises(SoftLimitError) as info:
            shoulder.set_position(1.6)
        words = "motor 1: position 183.346 deg is beyond its soft limit -171.887..171.887 deg"
        assert str(info.value).startswith(words)
        assert str(info.value).endswith(where)
        with pytest.raises(SoftLimitError, match=r"motor 1: speed .* r/min is beyond its soft limit"):
            shoulder.set_velocity(-2.5)
        with pytest.raises(SoftLimitError, match=r"motor 1: torque"):
            shoulder.set_joint_torque(2.6 * 2)  # 5.2 Nm at the joint: 2.6 at the motor... over 2.5
        with pytest.raises(SoftLimitError, match=r"max_step"):
            robot.move_joints({"shoulder": 0.3}, 1.0, 5.0, enable=True)  # 0.3 rad from 0: over 0.2
        robot.move_joints({"shoulder": 0.15, "wrist": 1.0}, 1.0, 5.0, enable=True)  # within: moves
        robot.positions_done(timeout=20)
        assert robot.joint("shoulder").get_joint_state().position == pytest.approx(0.15, abs=0.01)


def test_a_robot_move_to_idle_joints_is_refused(robot_file: Path) -> None:
    with drempower.open_robot(robot_file) as robot:
        robot.joint("wrist").idle()
        with pytest.raises(MotorIdleError, match="motor 2 is idle"):
            robot.move_joints({"shoulder": 0.1, "wrist": 0.5}, 1.0, 5.0)


def test_a_timed_joint_velocity_ends_by_itself(robot_file: Path) -> None:
    from drempower.client.engine.effects import sleep

    with drempower.open_robot(robot_file) as robot:
        wrist = robot.joint("wrist")
        wrist.set_velocity(1.0, duration=0.5, enable=True)
        bus = robot.bus("arm")
        bus.run(sleep(0.3))
        assert wrist.get_joint_state().velocity == pytest.approx(1.0, abs=0.05)
        bus.run(sleep(0.5))
        assert wrist.get_joint_state().velocity == pytest.approx(0.0, abs=0.05)
