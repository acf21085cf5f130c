"""The plugins' configurations: LeRobot's discovery finds both types; wrong input is refused when the
configuration is made (from Python or LeRobot's command-line parser), naming the field, the value and
what is allowed, before any bus is opened."""

from __future__ import annotations

from pathlib import Path

import pytest

pytest.importorskip("lerobot", reason="LeRobot is not installed here: make test-lerobot runs these")

import draccus
from lerobot.robots import RobotConfig
from lerobot.teleoperators import TeleoperatorConfig
from lerobot.utils.import_utils import register_third_party_plugins

from drempower import ConfigError, FieldRangeError

from .conftest import ARM, REPO_ROOT

PENDULUM = REPO_ROOT / "examples" / "robots" / "pendulum.toml"


def test_lerobot_discovery_registers_both_types() -> None:
    register_third_party_plugins()
    follower = RobotConfig.get_choice_class("drempower")
    leader = TeleoperatorConfig.get_choice_class("drempower_leader")
    assert follower.__module__ == "lerobot_robot_drempower.config_drempower_follower"
    assert leader.__module__ == "lerobot_teleoperator_drempower.config_drempower_leader"


def _follower(**options: object) -> object:
    from lerobot_robot_drempower import DrEmpowerFollowerConfig

    return DrEmpowerFollowerConfig(**{"robot_file": str(ARM), **options})


def _leader(**options: object) -> object:
    from lerobot_teleoperator_drempower import DrEmpowerLeaderConfig

    return DrEmpowerLeaderConfig(**{"robot_file": str(ARM), **options})


@pytest.mark.parametrize("make", [_follower, _leader], ids=["follower", "leader"])
def test_an_unknown_joint_is_named_with_the_files_joints(make: object) -> None:
    with pytest.raises(ConfigError, match=r"joints: 'knee' is not a joint of .*arm6.toml \(its joints: base_yaw, "):
        make(joints=["elbow", "knee"])  # type: ignore[operator]


@pytest.mark.parametrize("make", [_follower, _leader], ids=["follower", "leader"])
def test_a_robot_file_without_the_joint(make: object) -> None:
    with pytest.raises(ConfigError, match=r"joints: 'elbow' is not a joint of .*pendulum.toml \(its joints: swing\)"):
        make(robot_file=str(PENDULUM), joints=["elbow"])  # type: ignore[operator]


@pytest.mark.parametrize("make", [_follower, _leader], ids=["follower", "leader"])
def test_robot_file_missing_unreadable_and_options(make: object, tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match=r"robot_file: missing"):
        make(robot_file="")  # type: ignore[operator]
    with pytest.raises(ConfigError, match=r"cannot read robot file .*nowhere.toml"):
        make(robot_file=str(tmp_path / "nowhere.toml"))  # type: ignore[operator]
    with pytest.raises(ConfigError, match=r"joints: 'elbow' is given twice"):
        make(joints=["elbow", "elbow"])  # type: ignore[operator]
    with pytest.raises(ConfigError, match=r"sim: unknown option 'speed' \(options: bitrate, clock, "):
        make(sim={"speed": 2})  # type: ignore[operator]
    with pytest.raises(ConfigError, match=r"timeout=0: expected a time above 0 s"):
        make(timeout=0)  # type: ignore[operator]


def test_follower_options() -> None:
    with pytest.raises(ConfigError, match=r"bandwidth=400: the position filter's bandwidth is 0..300 1/s"):
        _follower(bandwidth=400)
    with pytest.raises(ConfigError, match=r"max_relative_target=-1: expected a step above 0 deg"):
        _follower(max_relative_target=-1)
    with pytest.raises(ConfigError, match=r"max_relative_target: 'swing' is not a joint driven \(joints: elbow\)"):
        _follower(joints=["elbow"], max_relative_target={"swing": 5.0})
    with pytest.raises(ConfigError, match=r"max_relative_target\[elbow\]=nan: expected a step above 0 deg"):
        _follower(max_relative_target={"elbow": float("nan")})


def test_leader_options(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match=r"rate=0: teach cycles per s are 0..1000"):
        _leader(rate=0)
    with pytest.raises(ConfigError, match=r"kd=-0.1: the damping is a value of 0 Nm s/rad or more"):
        _leader(kd=-0.1)
    with pytest.raises(FieldRangeError, match=r"kd=400"):
        _leader(kd=400)
    plain = tmp_path / "plain.toml"
    plain.write_text('[buses.can0]\ninterface = "sim"\n[joints.swing]\nbus = "can0"\nid = 1\n')
    with pytest.raises(ConfigError, match=r"compensate=True: .*plain.toml names no \[model\]"):
        _leader(robot_file=str(plain), compensate=True)


def test_lerobot_command_line_parses_and_refuses() -> None:
    """LeRobot's own parser (draccus) fills the fields from ``--robot.*`` options and stops at a bad one."""
    register_third_party_plugins()
    from lerobot_robot_drempower import DrEmpowerFollowerConfig

    args = [f"--robot_file={ARM}", "--joints=[shoulder, elbow]", "--sim={clock: virtual}", "--max_relative_target=5"]
    cfg = draccus.parse(DrEmpowerFollowerConfig, args=args)
    assert (cfg.joints, cfg.sim, cfg.max_relative_target) == (["shoulder", "elbow"], {"clock": "virtual"}, 5.0)
    cfg = draccus.parse(DrEmpowerFollowerConfig, args=[f"--robot_file={ARM}", "--max_relative_target={elbow: 2.5}"])
    assert cfg.max_relative_target == {"elbow": 2.5}
    with pytest.raises(draccus.utils.ParsingError) as refused:
        draccus.parse(DrEmpowerFollowerConfig, args=[f"--robot_file={ARM}", "--joints=[knee]"])
    assert isinstance(refused.value.__cause__, ConfigError)
    assert "joints: 'knee' is not a joint of" in str(refused.value.__cause__)
