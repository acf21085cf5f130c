"""Commands made from rows of the table of actions (:mod:`drempower.cli.actions`) behave as the table says."""

from __future__ import annotations

from pathlib import Path

import pytest

from drempower import actions, open_bus
from drempower.errors import MotorIdleError, ValidationError
from drempower.protocol import Frame
from drempower.protocol.enums import AxisState
from drempower.protocol.ids import split_arbitration_id
from drempower.protocol.limits import MOTION_CMDS
from drempower.sim import SimBus

from .conftest import Cli


def test_the_generated_motion_command_refuses_an_idle_motor_and_sends_nothing(
    cli: Cli, sim: SimBus, host_frames: list[Frame]
) -> None:
    """``drempower step`` (a row no hand-written command took) passes the safety gate: an idle motor is
    refused in the library's words, exit 1, and no motion frame is sent; ``--enable`` enables it first."""
    assert cli("idle", "1", "--sim", "1").code == 0
    before = len(host_frames)
    r = cli("step", "1", "30", "--sim", "1")
    assert r.code == 1 and r.out == ""
    with pytest.raises(MotorIdleError) as api, open_bus("sim", motors=[1], clock="virtual") as b:
        b.motor(1).idle()  # the same refusal from the API
        actions.run(b, "step", {"id": 1, "angle": 30})
    assert r.err == f"drempower: error: {api.value}\n"
    cmds = [split_arbitration_id(f.arbitration_id)[1] for f in host_frames[before:]]
    assert cmds and not MOTION_CMDS & set(cmds), cmds  # the state was read; nothing moved
    assert sim.motors[1].state == AxisState.IDLE
    r = cli("step", "1", "30", "--enable", "--sim", "1")
    assert r.code == 0 and r.out.startswith("motor 1: step sent (move time ") and r.out.endswith(" s)\n"), r
    assert sim.motors[1].state == AxisState.CLOSED_LOOP_CONTROL
    (rec,) = cli("step", "1", "-30", "--sim", "1", "--json").records()
    assert rec["action"] == "step" and rec["unit"] == "s" and rec["result"] > 0, rec
    assert r.out == f"motor 1: step{actions.outcome('step', rec['result'])}\n"  # the same distance, the same time


def test_row_stop_is_run_by_its_table_name_and_holds(cli: Cli, sim: SimBus) -> None:
    """``drempower stop`` is the emergency stop; row ``stop`` (speed 0, closed loop kept) is ``actions stop``."""
    assert cli("speed", "1", "30", "--sim", "1").code == 0
    assert sim.motors[1].drive.in_vel != 0.0
    r = cli("actions", "stop", "1", "--sim", "1")
    assert r.code == 0 and r.out == "motor 1: stop sent\n", r
    assert sim.motors[1].state == AxisState.CLOSED_LOOP_CONTROL
    assert sim.motors[1].drive.in_vel == 0.0


@pytest.mark.parametrize(
    ("argv", "row", "args", "option"),
    [
        (("speed", "1", "500"), "speed", {"id": 1, "speed": 500}, "RPM: 500 (motor 1)"),
        (("torque", "1,2", "1,-400"), "torque", {"id": 2, "torque": -400}, "NM: -400 (motor 2)"),
        (("move", "1", "1e9"), "move", {"id": 1, "angle": 1e9}, "ANGLES: 1e+09 (motor 1)"),
        (("move", "1", "-1e9", "--relative"), "step", {"id": 1, "angle": -1e9}, "ANGLES: -1e+09 (motor 1)"),
        (
            ("impedance", "1", "0", "--kp", "5", "--kd", "400"),
            "impedance",
            {"id": 1, "pos": 0, "kp": 5, "kd": 400},
            "--kd: 400",
        ),
    ],
)
def test_the_hand_written_commands_refuse_with_the_tables_range_and_unit(
    cli: Cli, host_frames: list[Frame], argv: tuple[str, ...], row: str, args: dict[str, object], option: str
) -> None:
    """``move``, ``speed``, ``torque`` and ``impedance`` check their values by the table's rows: the range
    and unit of the refusal are the API's, the field named as the user typed it; nothing is sent."""
    r = cli(*argv, "--sim", "1,2")
    with pytest.raises(ValidationError) as api:
        actions.validate(row, args)
    words = str(api.value).split(" is out of range", 1)[1]
    assert r.code == 2 and r.err.endswith(f"error: argument {option} is out of range{words}\n"), r.err
    assert host_frames == []


def test_a_command_from_the_table_takes_a_joints_name_with_robot(cli: Cli, tmp_path: Path) -> None:
    """With ``--robot`` the ID may be a joint's name (on any bus of the file); text that is neither a
    number nor a name is refused in the table's words; a name without ``--robot`` says what is missing."""
    robot = tmp_path / "robot.toml"
    robot.write_text(
        '[buses.left]\ninterface = "sim"\n[buses.right]\ninterface = "sim"\n'
        '[joints.shoulder]\nbus = "left"\nid = 1\n[joints.elbow]\nbus = "right"\nid = 1\n',
        encoding="utf-8",
    )
    r = cli("step", "elbow", "5", "--enable", "--robot", str(robot))
    assert r.code == 0 and r.out.startswith("joint elbow: step sent (move time "), r
    r = cli("actions", "state", "shoulder", "--json", "--robot", str(robot))
    assert r.code == 0 and r.records()[0]["joint"] == "shoulder" and r.records()[0]["result"]["node"] == 1, r
    r = cli("step", "1,2", "5", "--sim", "1")
    assert r.code == 2 and r.err.endswith("error: argument ID: id='1,2': expected a whole number\n"), r
    r = cli("step", "elbow", "5", "--sim", "1")
    assert r.code == 2 and r.err.endswith("error: joint names (elbow) need --robot FILE\n"), r
