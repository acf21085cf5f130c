"""Values the command line reads as numbers and refuses by name; ``zero`` refuses a moving motor."""

from __future__ import annotations

import pytest

import drempower
from drempower.protocol import Frame, SysCmd, SystemCommand, decode_command
from drempower.sim import SimBus

from .conftest import Cli


@pytest.mark.parametrize(
    ("angles", "message"),
    [
        ("-inf", "argument ANGLES: '-inf': NaN and infinity cannot be sent"),
        ("-5,-inf", "argument ANGLES: '-5,-inf': NaN and infinity cannot be sent"),
        ("1e6", "argument ANGLES: 1e+06 (motor 1) is out of range: allowed -720000..720000 (deg"),
        ("-1e6", "argument ANGLES: -1e+06 (motor 1) is out of range: allowed -720000..720000 (deg"),
    ],
)
def test_move_reads_negative_and_huge_angles_as_angles(
    cli: Cli, host_frames: list[Frame], angles: str, message: str
) -> None:
    ids = "1,2" if "," in angles else "1"
    r = cli("move", ids, angles, "--sim", ids)
    assert r.code == 2, r.err
    assert r.err.strip().splitlines()[-1].startswith("drempower move: error: argument ANGLES: ")
    assert message in r.err and "Traceback" not in r.err
    assert host_frames == []


def test_a_negative_angle_still_moves(cli: Cli, sim: SimBus) -> None:
    r = cli("move", "1", "-5", "--accel", "100", "--wait", "--sim", "1")
    assert r.code == 0, r.err
    assert sim.motors[1].position == pytest.approx(-5, abs=0.05)


def _zeroes(frames: list[Frame]) -> list[int]:
    out = []
    for f in frames:
        msg = decode_command(f.arbitration_id, f.data)
        if isinstance(msg, SystemCommand) and msg.op == SysCmd.SET_ZERO_POSITION:
            out.append(msg.node)
    return out


def test_zero_refuses_a_moving_motor_unless_forced(cli: Cli, sim: SimBus, host_frames: list[Frame]) -> None:
    with drempower.open_bus("sim", motors=[1], stop_on_close=False) as bus:
        bus.motor(1).set_speed(30)
    r = cli("zero", "1", "--sim", "1")
    assert r.code == 1
    assert "drempower: error: motor 1 is turning at" in r.err and "add --force to zero it anyway" in r.err
    assert _zeroes(host_frames) == []
    cli("zero", "1", "--force", "--sim", "1")
    assert _zeroes(host_frames) == [1]


def test_zero_refuses_a_motor_in_the_middle_of_a_move(cli: Cli, sim: SimBus, host_frames: list[Frame]) -> None:
    assert cli("move", "2", "3000", "--speed", "300", "--accel", "300", "--sim", "2").code == 0
    r = cli("zero", "2", "--sim", "2")
    assert r.code == 1 and "motor 2 is" in r.err and "zero needs it at rest" in r.err
    assert _zeroes(host_frames) == []


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (("state", "1", "--timeout", "inf"), "argument --timeout: expected a finite number > 0, got 'inf'"),
        (("state", "1", "--timeout", "1e12"), "argument --timeout: expected at most 86400 s (one day), got '1e12'"),
        (("move", "1", "10", "--wait", "--wait-timeout", "1e12"), "argument --wait-timeout: expected at most 86400 s"),
        (("move", "1", "10", "--wait", "--wait-timeout", "nan"), "argument --wait-timeout: expected a finite number"),
    ],
)
def test_times_are_refused_before_anything_is_sent(
    cli: Cli, host_frames: list[Frame], args: tuple[str, ...], message: str
) -> None:
    r = cli(*args, "--sim", "1")
    assert r.code == 2 and message in r.err
    assert host_frames == []
