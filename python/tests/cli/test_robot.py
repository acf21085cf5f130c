"""``--robot FILE``: joint names where motor ids go, commands across buses, ``drempower sim --robot``."""

from __future__ import annotations

import io
import threading
import time
import uuid
from pathlib import Path

import pytest

from drempower.cli import build_parser, sim
from drempower.robot import open_robot

from .conftest import Cli

ROBOT = """
[buses.left]
interface = "sim"
[buses.right]
interface = "sim"
[joints.shoulder]
bus = "left"
id = 1
[joints.hip]
bus = "left"
id = 2
[joints.elbow]
bus = "right"
id = 1
"""


@pytest.fixture
def robot_file(tmp_path: Path) -> str:
    path = tmp_path / "robot.toml"
    path.write_text(ROBOT)
    return str(path)


def test_state_get_set_idle_take_joint_names(cli: Cli, robot_file: str) -> None:
    r = cli("state", "shoulder,hip", "--robot", robot_file, "--json")
    assert r.code == 0 and [rec["id"] for rec in r.records()] == [1, 2]
    r = cli("get", "elbow", "axis0.config.can_node_id", "--robot", robot_file, "--json")
    assert r.code == 0 and r.records()[0]["value"] == 1
    r = cli("set", "hip", "stall_current_limit", "3.5", "--robot", robot_file, "--json")
    assert r.code == 0, r.err
    assert [(rec["id"], rec["value"]) for rec in r.records()] == [(2, 3.5)]  # read back from the motor
    r = cli("idle", "shoulder", "--robot", robot_file, "--json")
    assert r.code == 0 and r.records()[0]["state"] == "idle"
    r = cli("state", "shoulder", "elbow", "--robot", robot_file, "--json")  # two buses: one reading each
    assert r.code == 0 and [(rec["bus"], rec["joint"], rec["id"]) for rec in r.records()] == [
        ("left", "shoulder", 1),
        ("right", "elbow", 1),
    ]
    r = cli("state", "shoulder", "elbow", "--robot", robot_file)
    assert r.code == 0 and r.out.index("bus left (shoulder=1):") < r.out.index("bus right (elbow=1):")
    rows = [line.split()[0] for line in r.out.splitlines() if not line.startswith(("bus ", "joint "))]
    assert rows == ["shoulder", "elbow"]  # joints by name, never `1` twice for joints on two buses


def test_monitor_takes_joints_of_one_bus(cli: Cli, robot_file: str) -> None:
    r = cli("monitor", "hip", "shoulder", "--robot", robot_file, "--duration", "0.3", "--rate", "10", "--json")
    assert r.code == 0, r.err
    assert {rec["id"] for rec in r.records()} == {1, 2}
    r = cli("monitor", "hip", "elbow", "--robot", robot_file, "--duration", "0.3")
    assert r.code == 2 and "monitor runs on one bus" in r.err and "left: shoulder, hip; right: elbow" in r.err


def test_move_across_buses_is_synchronised_and_reports_the_skew(cli: Cli, robot_file: str) -> None:
    r = cli("move", "shoulder,elbow", "30,-20", "--robot", robot_file, "--wait", "--json")
    assert r.code == 0, r.err
    recs = {rec["joint"]: rec for rec in r.records()}
    assert recs["shoulder"]["position_deg"] == pytest.approx(30.0, abs=0.1)
    assert recs["elbow"]["position_deg"] == pytest.approx(-20.0, abs=0.1)
    assert recs["shoulder"]["move_time_s"] == recs["elbow"]["move_time_s"] > 0
    assert recs["shoulder"]["start_skew_us"] >= 0
    r = cli("move", "shoulder,elbow", "1,2,3", "--robot", robot_file)
    assert r.code == 2 and "2 joints but 3 angle values" in r.err


def test_stop_reaches_every_bus(cli: Cli, robot_file: str) -> None:
    r = cli("stop", "--robot", robot_file, "--json")
    assert r.code == 0 and {rec["bus"] for rec in r.records()} == {"left", "right"}
    assert all(rec["broadcast"] for rec in r.records())
    r = cli("stop", "hip", "elbow", "--robot", robot_file, "--json")
    assert r.code == 0 and [(rec["bus"], rec["id"]) for rec in r.records()] == [("left", 2), ("right", 1)]


def test_commands_without_joint_names(cli: Cli, robot_file: str, tmp_path: Path) -> None:
    r = cli("scan", "--robot", robot_file, "--json")
    assert r.code == 0, r.err
    assert sorted((rec["bus"], rec["id"]) for rec in r.records()) == [("left", 1), ("left", 2), ("right", 1)]
    r = cli("backup", "1", str(tmp_path / "b.json"), "--robot", robot_file)
    assert r.code == 2 and "backup takes no joint names" in r.err and not (tmp_path / "b.json").exists()


def test_joint_name_mistakes_are_usage_errors(cli: Cli, robot_file: str, tmp_path: Path) -> None:
    r = cli("state", "elbow", "--sim", "1")
    assert r.code == 2 and "need --robot FILE" in r.err
    r = cli("state", "knee", "--robot", robot_file)
    assert r.code == 2 and "joint 'knee': not in" in r.err and "shoulder, hip, elbow" in r.err
    r = cli("state", "1", "--robot", robot_file)
    assert r.code == 2 and "ambiguous with a robot of several buses" in r.err
    r = cli("state", "elbow", "--robot", robot_file, "--sim", "1")
    assert r.code == 2 and "--robot and --sim conflict" in r.err
    r = cli("state", "elbow", "--robot", str(tmp_path / "none.toml"))
    assert r.code == 2 and "cannot read robot file" in r.err and "Traceback" not in r.err


def test_sim_serves_one_bus_per_entry(tmp_path: Path) -> None:
    link = tmp_path / "left-adapter"
    channel = f"drempower-sim-robot-{uuid.uuid4().hex}"
    path = tmp_path / "served.toml"
    path.write_text(
        f"""
[buses.left]
interface = "adapter"
channel = "{link}"
timeout = 2
[buses.right]
interface = "virtual"
channel = "{channel}"
timeout = 2
[joints.a]
bus = "left"
id = 2
[joints.b]
bus = "right"
id = 5
"""
    )
    args = build_parser().parse_args(["sim", "--robot", str(path), "--time-scale", "20", "--json"])
    out, stop = io.StringIO(), threading.Event()
    thread = threading.Thread(target=sim.run, args=(args, out, stop))
    thread.start()
    try:
        deadline = time.monotonic() + 5.0
        while '"running"' not in out.getvalue() and time.monotonic() < deadline:
            time.sleep(0.01)
        assert link.is_symlink()
        with open_robot(path, stop_on_close=False) as robot:
            assert robot.get_states()["a"].node == 2
            move = robot.set_angles({"a": 10.0, "b": -10.0}, speed=60.0, param=300.0)
            done = robot.positions_done(timeout=10)
            assert done["a"].angle == pytest.approx(10.0, abs=0.1) and done["b"].angle == pytest.approx(-10.0, abs=0.1)
            assert move.skew >= 0
    finally:
        stop.set()
        thread.join(10)
    assert not thread.is_alive() and not link.exists() and not link.is_symlink()
    assert '"stopped": true' in out.getvalue()


def test_sim_robot_refuses_its_own_bus_options(tmp_path: Path, cli: Cli, robot_file: str) -> None:
    r = cli("sim", "--robot", robot_file, "--ids", "1,2", "--duration", "0.1")
    assert r.code == 2 and "--ids does not go with it" in r.err


@pytest.mark.parametrize("option", ["retries = 3", "stop_on_close = true", "timeout = 0.5"])
def test_bus_options_of_the_robot_file_do_not_collide_with_the_commands_own(
    cli: Cli, tmp_path: Path, option: str
) -> None:
    path = tmp_path / "robot.toml"
    path.write_text(ROBOT.replace('[buses.left]\ninterface = "sim"', f'[buses.left]\ninterface = "sim"\n{option}'))
    r = cli("state", "shoulder,hip", "--robot", str(path), "--json")
    assert r.code == 0, r.err
    assert [rec["id"] for rec in r.records()] == [1, 2]
    r = cli("move", "shoulder", "10", "--wait", "--robot", str(path), "--json")
    assert r.code == 0 and r.records()[0]["done"] is True, r.err
    r = cli("move", "shoulder,elbow", "20", "--robot", str(path), "--json")  # across buses: open_robot
    assert r.code == 0, r.err
    r = cli("speed", "shoulder", "5", "--duration", "0.2", "--robot", str(path))
    assert r.code == 0 and "after 0.2 s: motor 1 held" in r.err, r.err  # the joint holds (its on_timeout)
    r = cli("sniff", "--duration", "0.1", "--robot", str(path), "--json")
    assert "TypeError" not in r.err and "unexpected keyword" not in r.err, r.err


def test_tables_name_joints_and_unnamed_motors_motor_id(cli: Cli, tmp_path: Path) -> None:
    path = tmp_path / "one.toml"
    path.write_text('[buses.arm]\ninterface = "sim"\n[joints.wrist]\nbus = "arm"\nid = 1\n')
    r = cli("get", "wrist", "vbus_voltage", "--robot", str(path))
    assert r.code == 0 and r.out.splitlines()[0].split()[0] == "joint" and r.out.splitlines()[1].split()[0] == "wrist"
    r = cli("state", "1", "2", "--robot", str(path), "--timeout", "0.2")  # motor 2: no joint, and silent
    assert r.code == 1 and [line.split()[0] for line in r.out.splitlines()[1:]] == ["wrist", "motor_2"]
