"""A motion command that fails stops what it started; a watchdog too short to work is refused."""

from __future__ import annotations

from drempower.client import open_bus
from drempower.protocol.enums import AxisState
from drempower.protocol.ids import Frame
from drempower.sim import SimBus

from .conftest import Cli


def test_a_move_that_misses_its_target_sets_the_motor_idle(cli: Cli, sim: SimBus) -> None:
    with open_bus("sim", stop_on_close=False) as bus:
        bus.motor(1).set_angle_range(-20, 20)
    r = cli("move", "1", "90", "--speed", "120", "--accel", "300", "--wait", "--sim", "1")
    assert r.code == 1 and "target 90.00 deg" in r.err, r.err
    assert "the command failed: motor 1 set to idle" in r.err, r.err
    assert sim.motors[1].state is AxisState.IDLE


def test_no_stop_on_exit_leaves_a_failed_move_holding(cli: Cli, sim: SimBus) -> None:
    with open_bus("sim", stop_on_close=False) as bus:
        bus.motor(1).set_angle_range(-20, 20)
    r = cli("move", "1", "90", "--speed", "120", "--accel", "300", "--wait", "--no-stop-on-exit", "--sim", "1")
    assert r.code == 1 and "set to idle" not in r.err, r.err
    assert sim.motors[1].state is AxisState.CLOSED_LOOP_CONTROL


def test_a_watchdog_shorter_than_the_commands_own_gaps_is_refused(cli: Cli, host_frames: list[Frame]) -> None:
    for ms in ("2", "99"):
        r = cli("speed", "1", "10", "--watchdog", ms, "--sim", "1")
        assert r.code == 2 and "allowed 100.." in r.err, r.err
    assert not host_frames  # refused before anything was sent
