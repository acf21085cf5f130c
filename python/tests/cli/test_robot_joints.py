"""``--robot FILE`` on the command line means what it means in Python: a named joint takes joint units
(deg, r/min, Nm at the joint), the file's limits refuse with the same words, JSON names the joint."""

from __future__ import annotations

from pathlib import Path

import pytest

from drempower.sim import SimBus

from .conftest import Cli

ROBOT = """
[buses.arm]
interface = "sim"
[joints.shoulder]
bus = "arm"
id = 1
gear = 2.0
[joints.elbow]
bus = "arm"
id = 2
limits = { position = [-1.0, 1.0], speed = 2.0 }
"""


@pytest.fixture
def arm(tmp_path: Path) -> str:
    path = tmp_path / "arm.toml"
    path.write_text(ROBOT)
    return str(path)


def test_the_files_limits_refuse_a_move_and_a_speed_with_the_python_words(cli: Cli, sim: SimBus, arm: str) -> None:
    r = cli("move", "elbow", "80", "--robot", arm)
    assert r.code == 2, (r.out, r.err)
    assert f"(set by {arm}: [joints.elbow] limits)" in r.err and "Traceback" not in r.err
    assert abs(sim.motors[2].position) < 1  # nothing moved
    r = cli("speed", "elbow", "200", "--robot", arm, "--duration", "0.5")
    assert r.code == 2 and f"(set by {arm}: [joints.elbow] limits)" in r.err, r.err
    r = cli("move", "elbow", "45", "--robot", arm, "--wait", "--speed", "15", "--accel", "100")
    assert r.code == 0, r.err  # inside the limit: 45 deg at the joint, 0.785 rad


def test_a_named_joint_takes_degrees_at_the_joint_a_motor_id_the_motors(cli: Cli, sim: SimBus, arm: str) -> None:
    r = cli("move", "shoulder", "40", "--robot", arm, "--wait", "--json", "--speed", "60", "--accel", "100")
    assert r.code == 0, r.err
    (rec,) = r.records()
    assert rec["joint"] == "shoulder" and rec["units"] == "joint" and rec["target_deg"] == 40.0
    assert rec["position_deg"] == pytest.approx(40, abs=0.5)
    r = cli("state", "1", "--robot", arm, "--json")  # motor 1, by id: motor units
    (rec,) = r.records()
    assert rec["joint"] == "shoulder" and rec["units"] == "motor" and rec["position_deg"] == pytest.approx(80, abs=1)
    r = cli("state", "--robot", arm, "--json")  # every joint, by name: joint units
    got = {x["joint"]: x for x in r.records()}
    assert set(got) == {"shoulder", "elbow"} and got["shoulder"]["units"] == "joint"
    assert got["shoulder"]["position_deg"] == pytest.approx(40, abs=0.5)
    r = cli("move", "shoulder", "40", "--robot", arm, "--wait", "--speed", "60", "--accel", "100")
    assert r.code == 0 and "shoulder" in r.out and "units" in r.out, r.out


def test_ctrl_c_holds_a_joint_that_holds_and_idles_one_that_says_idle(
    cli: Cli, sim: SimBus, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from drempower.client import Bus
    from drempower.sim.motor import AxisState

    path = tmp_path / "arm.toml"
    path.write_text(ROBOT.replace("id = 2\n", 'id = 2\non_timeout = "idle"\n'))

    def interrupted(*args: object, **kwargs: object) -> None:
        raise KeyboardInterrupt

    monkeypatch.setattr(Bus, "positions_done", interrupted)
    r = cli("move", "shoulder,elbow", "10", "--wait", "--robot", str(path), "--speed", "15", "--accel", "100")
    assert r.code == 130, r.err
    assert "interrupted: motor 1 held" in r.err and "interrupted: motor 2 set to idle" in r.err, r.err
    assert sim.motors[1].state is AxisState.CLOSED_LOOP_CONTROL  # the shoulder is not dropped
    assert sim.motors[2].state is AxisState.IDLE


@pytest.mark.parametrize("option", ["--accel", "--speed"])
def test_a_rate_refused_at_the_joint_names_what_was_typed_and_the_joints_range(
    cli: Cli, sim: SimBus, arm: str, option: str
) -> None:
    # 200 (r/min or (r/min)/s) at the 2:1 shoulder is 400 at the motor, beyond the wire's 327.67
    r = cli("move", "shoulder", "10", "--robot", arm, option, "200")
    assert r.code == 2, (r.out, r.err)
    line = r.err.strip().splitlines()[-1]
    assert f"argument {option}: 200 " in line and "at the joint" in line, line
    assert "0.005..163.835" in line, line  # the wire's range through the gear
    assert "400 is" not in line and "Traceback" not in r.err
    assert abs(sim.motors[1].position) < 1  # nothing moved
    r = cli("move", "shoulder", "10", "--robot", arm, option, "160")  # 320 at the motor: taken
    assert r.code == 0, (r.out, r.err)


def test_a_soft_limit_refused_at_a_named_joint_names_the_joint_value(cli: Cli, sim: SimBus, tmp_path: Path) -> None:
    # the shoulder's limit is +-1 rad at the joint: 80 deg there is 160 at the 2:1 motor
    path = tmp_path / "arm.toml"
    path.write_text(ROBOT.replace("gear = 2.0\n", "gear = 2.0\nlimits = { position = [-1.0, 1.0] }\n"))
    r = cli("move", "shoulder", "80", "--robot", str(path))
    assert r.code == 2, (r.out, r.err)
    line = r.err.strip().splitlines()[-1]
    assert "joint shoulder: position 80 deg at the joint is beyond its soft limit -57.2958..57.2958 deg" in line, line
    assert f"(set by {path}: [joints.shoulder] limits)" in line and "Traceback" not in r.err
    assert abs(sim.motors[1].position) < 1  # nothing moved
    r = cli("move", "1", "160", "--robot", str(path))  # by motor id: the motor's degrees, as the motor's words
    assert r.code == 2 and "motor 1: position 160 deg is beyond its soft limit -114.592..114.592 deg" in r.err, r.err


def test_a_rate_refused_across_buses_names_what_was_typed_at_the_joints(cli: Cli, sim: SimBus, tmp_path: Path) -> None:
    # two 2:1 joints on two buses: one synchronised move, its acceleration at the joints
    path = tmp_path / "two.toml"
    path.write_text(
        '[buses.left]\ninterface = "sim"\n[buses.right]\ninterface = "sim"\n'
        '[joints.shoulder]\nbus = "left"\nid = 1\ngear = 2.0\n[joints.elbow]\nbus = "right"\nid = 2\ngear = 2.0\n'
    )
    r = cli("move", "shoulder,elbow", "10", "--robot", str(path), "--accel", "200")
    assert r.code == 2, (r.out, r.err)
    line = r.err.strip().splitlines()[-1]
    assert "argument --accel: 200 at the joint is out of range: allowed 0.005..163.835 at the joint" in line, line
    assert abs(sim.motors[1].position) < 1 and abs(sim.motors[2].position) < 1  # nothing moved
