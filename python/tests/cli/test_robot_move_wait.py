"""``drempower move --robot FILE ... --wait`` exits 1 when a joint stops away from its target."""

from __future__ import annotations

from pathlib import Path

import drempower

from .conftest import Cli


def test_move_robot_wait_exits_1_when_a_joint_stops_at_its_limit(cli: Cli, tmp_path: Path) -> None:
    saved = tmp_path / "right"
    with drempower.open_bus("sim", motors=[1], config_dir=saved, stop_on_close=False) as bus:
        bus.motor(1).set_angle_range(-20, 20)
        bus.motor(1).save_config()
    robot = tmp_path / "robot.toml"
    robot.write_text(
        '[buses.left]\ninterface = "sim"\ntime_scale = 20.0\n'
        f'[buses.right]\ninterface = "sim"\ntime_scale = 20.0\nconfig_dir = "{saved.as_posix()}"\n'
        '[joints.shoulder]\nbus = "left"\nid = 1\n[joints.elbow]\nbus = "right"\nid = 1\n'
    )
    r = cli("move", "shoulder,elbow", "30,60", "--robot", str(robot), "--speed", "60", "--accel", "200", "--wait")
    assert r.code == 1, (r.out, r.err)
    assert "motor 1" in r.err and "target 60.00 deg" in r.err and "reached 20.0" in r.err
    assert len(r.err.strip().splitlines()) == 1
    r = cli("move", "shoulder,elbow", "30,15", "--robot", str(robot), "--speed", "60", "--accel", "200", "--wait")
    assert r.code == 0, r.err
