"""``stop``, ``clear``, ``idle``, ``enable`` and ``zero``."""

from __future__ import annotations

import pytest

from drempower.protocol import AxisError, EncoderError
from drempower.protocol.enums import AxisState
from drempower.sim import SimBus

from .conftest import Cli


def test_stop_broadcasts_an_estop(cli: Cli, sim: SimBus) -> None:
    r = cli("stop", "--sim", "1,2,3")
    assert r.code == 0 and r.out == "emergency stop sent to all motors (broadcast)\n"
    for m in sim.motors.values():
        assert m.axis_error & AxisError.ESTOP_REQUESTED
        assert m.state is AxisState.IDLE
    r = cli("errors", "1", "--sim", "1")
    assert "ESTOP_REQUESTED: An emergency stop was requested" in r.out
    assert "what to do: Clear errors, then request closed loop" in r.out
    assert "then: drempower clear 1 --sim 1 && drempower enable 1 --sim 1" in r.out


def test_stop_json(cli: Cli, sim: SimBus) -> None:
    r = cli("stop", "--json", "--sim", "1,2,3")
    assert r.code == 0 and r.records() == [{"id": 0, "broadcast": True, "command": "estop", "sent": True}]
    r = cli("stop", "2", "3", "--json", "--sim", "2,3")
    assert r.records() == [
        {"id": 2, "broadcast": False, "command": "estop", "sent": True},
        {"id": 3, "broadcast": False, "command": "estop", "sent": True},
    ]


@pytest.mark.parametrize("command", ["clear", "idle", "enable"])
def test_broadcasts_json(cli: Cli, sim: SimBus, command: str) -> None:
    r = cli(command, "all", "--json", "--sim", "1,2,3")
    assert r.code == 0 and r.records() == [{"id": 0, "broadcast": True, "command": command, "sent": True}]


def test_stop_some_motors(cli: Cli, sim: SimBus) -> None:
    assert cli("stop", "2", "--sim", "2").out == "emergency stop sent to motor 2\n"
    assert sim.motors[2].axis_error & AxisError.ESTOP_REQUESTED
    assert not sim.motors[1].axis_error and not sim.motors[3].axis_error


def test_recover_after_estop(cli: Cli, sim: SimBus) -> None:
    cli("stop", "--sim", "1,2")
    r = cli("enable", "1", "--sim", "1")
    assert r.code == 1 and "motor 1 did not enter closed loop (ESTOP_REQUESTED)" in r.err
    r = cli("clear", "1", "2", "--sim", "1,2", "--json")
    assert r.code == 0
    assert [(rec["id"], rec["state"], rec["errors"]) for rec in r.records()] == [(1, "idle", ""), (2, "idle", "")]
    r = cli("enable", "1,2", "--sim", "1,2")
    assert r.code == 0 and r.out.count("closed_loop") == 2
    assert cli("move", "1", "10", "--accel", "100", "--wait", "--sim", "1").code == 0


def test_clear_reports_errors_that_stay(cli: Cli, sim: SimBus) -> None:
    sim.motors[3].inject_error(EncoderError.EDR_BATTERY_LOW)
    r = cli("clear", "3", "--sim", "3")
    assert r.code == 1
    assert "motor 3: errors remain after clearing (ENCODER_FAILED EDR_BATTERY_LOW)" in r.err
    assert "need `drempower zero 3 --sim 3` first" in r.err
    assert cli("zero", "3", "--sim", "3").code == 0
    assert cli("clear", "3", "--sim", "3").code == 0


def test_idle_and_enable_all(cli: Cli, sim: SimBus) -> None:
    r = cli("idle", "all", "--sim", "1,2,3")
    assert r.code == 0 and r.out == "sent to all motors (broadcast)\n"
    assert all(m.state is AxisState.IDLE for m in sim.motors.values())
    assert cli("enable", "all", "--sim", "1,2,3").code == 0
    assert all(m.state is AxisState.CLOSED_LOOP_CONTROL for m in sim.motors.values())


def test_all_stands_alone(cli: Cli) -> None:
    r = cli("idle", "all", "2", "--sim", "2")
    assert r.code == 2 and "`all` stands alone" in r.err


def test_zero_and_save(cli: Cli, sim: SimBus) -> None:
    cli("move", "2", "45", "--accel", "100", "--wait", "--sim", "2")
    r = cli("zero", "2", "--save", "--json", "--sim", "2")
    assert r.code == 0
    (rec,) = r.records()
    assert rec["position_deg"] == pytest.approx(0, abs=0.05)
    cli("reboot", "2", "--wait", "--sim", "2")
    assert sim.motors[2].position == pytest.approx(0, abs=0.05)


def test_errors_tells_to_set_the_zero_before_clearing_encoder_errors(cli: Cli, sim: SimBus) -> None:
    from drempower.protocol.flags import EncoderError

    sim.motors[2].inject_error(EncoderError.EDR_BATTERY_LOW)
    r = cli("errors", "2", "--sim", "2")
    assert "EDR_BATTERY_LOW" in r.out
    assert (
        "then, with the motor at rest: "
        "drempower zero 2 --sim 2 && drempower clear 2 --sim 2 && drempower enable 2 --sim 2" in r.out
    )
