"""``move``, ``speed``, ``torque``, ``impedance`` and stopping on Ctrl-C."""

from __future__ import annotations

import pytest

from drempower.client import Bus
from drempower.protocol import Frame
from drempower.protocol.enums import AxisState
from drempower.sim import SimBus

from ..waits import eventually
from .conftest import Cli


def test_move_q_and_wait(cli: Cli, sim: SimBus) -> None:
    r = cli("move", "1", "90", "--mode", "q", "--speed", "30", "--accel", "100", "--wait", "--sim", "1")
    assert r.code == 0
    assert r.out.splitlines()[1].split() == ["1", "90.00", "90.00", "yes"]
    assert sim.motors[1].position == pytest.approx(90, abs=0.01)


def test_synchronised_move_of_three_motors(cli: Cli, sim: SimBus) -> None:
    r = cli("move", "1,2,3", "90,-45,180", "--speed", "30", "--accel", "100", "--wait", "--json", "--sim", "1,2,3")
    assert r.code == 0
    assert [(rec["id"], rec["target_deg"]) for rec in r.records()] == [(1, 90), (2, -45), (3, 180)]
    for node, target in ((1, 90), (2, -45), (3, 180)):
        assert sim.motors[node].position == pytest.approx(target, abs=0.01)


def test_one_value_for_several_motors_and_relative_moves(cli: Cli, sim: SimBus) -> None:
    assert cli("move", "2,3", "-20", "--accel", "100", "--wait", "--sim", "2,3").code == 0
    r = cli("move", "2,3", "-10,30", "--relative", "--accel", "100", "--wait", "--json", "--sim", "2,3")
    assert [rec["target_deg"] for rec in r.records()] == pytest.approx([-30, 10], abs=0.05)
    assert sim.motors[2].position == pytest.approx(-30, abs=0.05)
    assert sim.motors[3].position == pytest.approx(10, abs=0.05)


def test_move_without_wait_reports_the_plan(cli: Cli, sim: SimBus) -> None:
    r = cli("move", "1", "60", "--speed", "10", "--accel", "20", "--sim", "1")
    assert r.code == 0
    assert r.out == "motor 1: moving to 60.00 deg (mode q, about 1.5 s)\n"
    (rec,) = cli("move", "1", "0", "--mode", "t", "--json", "--sim", "1").records()
    assert rec == {"id": 1, "target_deg": 0.0, "mode": "t", "move_time_s": None}


@pytest.mark.parametrize(
    ("args", "target"), [(("--mode", "t", "--bandwidth", "50"), 30.0), (("--mode", "p", "--torque-ff", "0"), -30.0)]
)
def test_move_t_and_p_modes(cli: Cli, sim: SimBus, args: tuple[str, ...], target: float) -> None:
    r = cli("move", "3", str(target), *args, "--wait", "--wait-timeout", "5", "--sim", "3")
    assert r.code == 0, r.err
    assert sim.motors[3].position == pytest.approx(target, abs=0.5)


def test_options_of_another_mode_are_refused(cli: Cli) -> None:
    r = cli("move", "1", "90", "--mode", "t", "--accel", "5", "--sim", "1")
    assert r.code == 2 and "drempower move: error: --accel applies to mode q, not t" in r.err


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (("move", "1,2,3", "10,20", "--sim", "1,2,3"), "3 motors but 2 angle values"),
        (("move", "1,2", "90,1,2", "--sim", "1,2"), "2 motors but 3 angle values"),
        (("speed", "1,2", "1,2,3", "--sim", "1,2"), "2 motors but 3 speed values"),
        (("impedance", "1,2,3", "1,2", "--kp", "1", "--kd", "1", "--sim", "1,2,3"), "3 motors but 2 position values"),
    ],
)
def test_value_count_must_match(cli: Cli, host_frames: list[Frame], argv: tuple[str, ...], message: str) -> None:
    r = cli(*argv)
    assert r.code == 2
    assert r.err.startswith(f"usage: drempower {argv[0]} ")
    assert f"drempower {argv[0]}: error: {message}: give one for all or one each" in r.err
    assert host_frames == []


def test_out_of_range_values_are_refused_before_sending(cli: Cli, host_frames: list[Frame]) -> None:
    r = cli("move", "1", "90", "--speed", "400", "--sim", "1")
    assert r.code == 2 and "argument --speed: 400 is out of range: allowed 0.01..327.67 (r/min)\n" in r.err
    assert host_frames == []


_ZERO = "the motor takes steps of 0.01: it would get 0)\n"
"""How a rate that would reach the motor as 0 is refused (row move's, speed's or torque's words)."""


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (
            ("move", "1", "45", "--accel", "0.001"),
            "argument --accel: 0.001 is out of range: allowed 0.01..327.67 ((r/min)/s; " + _ZERO,
        ),
        (
            ("move", "1", "45", "--speed", "0.004"),
            "argument --speed: 0.004 is out of range: allowed 0.01..327.67 (r/min; " + _ZERO,
        ),
        (
            ("move", "1", "45", "--speed", "0.005"),
            "argument --speed: 0.005 is out of range: allowed 0.01..327.67 (r/min; " + _ZERO,
        ),
        (
            ("move", "1", "45", "--mode", "t", "--bandwidth", "0.001"),
            "argument --bandwidth: 0.001 is out of range: allowed 0.01..300 (1/s; " + _ZERO,
        ),
        (
            ("speed", "1", "10", "--ramp", "0.001"),
            "argument --ramp: 0.001 is out of range: allowed 0.01..327.67 ((r/min)/s; " + _ZERO,
        ),
        (
            ("torque", "1", "0.5", "--ramp", "0.0049"),
            "argument --ramp: 0.0049 is out of range: allowed 0.01..327.67 (Nm/s; " + _ZERO,
        ),
        (("move", "1", "45", "--accel", "nan"), "argument --accel: expected a finite number, got 'nan'"),
    ],
)
def test_rates_that_would_reach_the_motor_as_0_are_refused(
    cli: Cli, host_frames: list[Frame], argv: tuple[str, ...], message: str
) -> None:
    """Speeds, accelerations, bandwidths and ramps travel as s16 x 0.01: anything that rounds to 0 is refused."""
    r = cli(*argv, "--sim", "1")
    assert r.code == 2 and message in r.err
    assert host_frames == []


def test_the_smallest_rate_that_reaches_the_motor_is_taken(cli: Cli, sim: SimBus) -> None:
    r = cli("speed", "1", "1", "--ramp", "0.006", "--json", "--sim", "1")
    assert r.code == 0 and r.records() == [{"id": 1, "speed_rpm": 1.0}]


@pytest.mark.parametrize(
    ("argv", "option", "field"),
    [
        (("speed", "1", "10", "--torque-ff", "400"), "--torque-ff", "param="),
        (("speed", "1", "1e40"), "RPM", "speed="),
        (("torque", "1", "-1e40"), "NM", "torque="),
        (("move", "1", "1e40"), "ANGLES", "position="),
        (("move", "1", "0", "--mode", "p", "--speed-ff", "400"), "--speed-ff", "speed="),
        (("move", "1", "0", "--mode", "p", "--torque-ff", "-400"), "--torque-ff", "param="),
        (("impedance", "1", "0", "--kp", "1", "--kd", "1", "--vel", "400"), "--vel", "speed="),
        (("impedance", "1", "0", "--kp", "1", "--kd", "1", "--tff", "400"), "--tff", "torque_ff="),
        (("impedance", "1", "0", "--kp", "400", "--kd", "1"), "--kp", "kp="),
        (("impedance", "1", "0", "--kp", "1", "--kd", "-1"), "--kd", "kd="),
        (("impedance", "1", "1e40", "--kp", "1", "--kd", "1"), "POS", "position="),
    ],
)
def test_out_of_range_errors_name_the_option_typed(
    cli: Cli, host_frames: list[Frame], argv: tuple[str, ...], option: str, field: str
) -> None:
    r = cli(*argv, "--sim", "1")
    assert r.code == 2
    assert f"drempower {argv[0]}: error: argument {option}: " in r.err and "is out of range: allowed" in r.err
    assert field not in r.err
    assert host_frames == []


def test_motion_refused_while_estopped(cli: Cli, sim: SimBus) -> None:
    cli("stop", "--sim", "1,2,3")
    r = cli("move", "1", "90", "--sim", "1")
    assert r.code == 1
    assert "ESTOP_REQUESTED" in r.err and "drempower clear 1" in r.err
    cli("clear", "1", "--sim", "1")
    r = cli("speed", "1", "10", "--sim", "1")
    assert (
        r.code == 1
        and "motor 1 is idle (not in closed loop): enable it first (run `drempower enable 1 --sim 1`)" in r.err
    )


def test_speed_of_two_motors(cli: Cli, sim: SimBus) -> None:
    r = cli("speed", "1,2", "30,-30", "--sim", "1,2")
    assert r.code == 0 and r.out == "motors 1, 2: speed 30.00, -30.00 rpm\n"

    def settled() -> bool:  # the simulated motors reach the speed on their own time (the command returns first)
        recs = cli("state", "1,2", "--sim", "1,2", "--json").records()
        return recs[0]["speed_rpm"] == pytest.approx(30, abs=1) and recs[1]["speed_rpm"] == pytest.approx(-30, abs=1)

    assert eventually(settled)


def test_speed_with_ramp_for_a_while_then_idle(cli: Cli, sim: SimBus) -> None:
    r = cli("speed", "3", "20", "--ramp", "100", "--duration", "0.1", "--sim", "3")
    assert r.code == 0
    assert "(ramp 100 rpm/s)" in r.out and "after 0.1 s: motor 3 set to idle" in r.err
    assert sim.motors[3].state is AxisState.IDLE


def test_torque_and_impedance(cli: Cli, sim: SimBus) -> None:
    (rec,) = cli("torque", "2", "-0.5", "--ramp", "10", "--json", "--sim", "2").records()
    assert rec == {"id": 2, "torque_nm": -0.5}
    assert cli("idle", "2", "--sim", "2").code == 0
    assert cli("enable", "2", "--sim", "2").code == 0
    r = cli("impedance", "2", "-20", "--kp", "20", "--kd", "1", "--sim", "2")
    assert r.code == 0 and r.out.startswith("motor 2: position -20.00 deg (kp 20 Nm/rad, kd 1 Nm/(rad/s)")
    r = cli("impedance", "2", "0", "--kp", "400", "--kd", "1", "--sim", "2")
    assert r.code == 2 and "argument --kp: 400 is out of range: allowed 0..327.67" in r.err


def test_impedance_checks_every_motor_before_sending_anything(cli: Cli, host_frames: list[Frame]) -> None:
    r = cli("impedance", "1,2", "30,1e40", "--kp", "5", "--kd", "0.5", "--sim", "1,2")
    assert r.code == 2 and "argument POS: 1e+40 (motor 2) is out of range" in r.err
    assert host_frames == []


def test_impedance_of_several_motors_starts_them_together(cli: Cli, sim: SimBus, host_frames: list[Frame]) -> None:
    r = cli("impedance", "1,2", "20,-20", "--kp", "20", "--kd", "1", "--json", "--sim", "1,2")
    assert r.code == 0 and r.records() == [{"id": 1, "position_deg": 20.0}, {"id": 2, "position_deg": -20.0}]
    motion = [
        (f.arbitration_id >> 5, f.arbitration_id & 0x1F, f.data[0])
        for f in host_frames
        if f.arbitration_id & 0x1F in (0x0C, 0x08)
    ]
    # motor 3 of the bus is not in the move: each motor gets its own start, back to back
    assert motion == [(1, 0x0C, motion[0][2]), (2, 0x0C, motion[1][2]), (1, 0x08, 0x15), (2, 0x08, 0x15)]
    cli("idle", "1,2", "--sim", "1,2")


def test_ctrl_c_sets_the_commanded_motors_idle(cli: Cli, sim: SimBus, monkeypatch: pytest.MonkeyPatch) -> None:
    def interrupted(*args: object, **kwargs: object) -> None:
        raise KeyboardInterrupt

    monkeypatch.setattr(Bus, "positions_done", interrupted)
    r = cli("move", "1,2", "90", "--wait", "--sim", "1,2")
    assert r.code == 130
    assert "interrupted: motors 1, 2 set to idle" in r.err
    assert sim.motors[1].state is AxisState.IDLE and sim.motors[2].state is AxisState.IDLE
    r = cli("move", "3", "90", "--wait", "--no-stop-on-exit", "--sim", "3")
    assert r.code == 130 and "set to idle" not in r.err
    assert sim.motors[3].state is AxisState.CLOSED_LOOP_CONTROL
