"""``drempower health`` and the health keys of ``monitor --fields``."""

from __future__ import annotations

from pathlib import Path

import pytest

from drempower.sim import SimBus
from drempower.sim.thermal import ThermalModel

from ..conftest import REPO_ROOT
from .conftest import Cli


def _warm(sim: SimBus, node: int, winding: float) -> None:
    """Motor ``node`` in a room as warm as ``winding`` (so it stays there while the simulator runs)."""
    t = sim.motors[node].thermal
    t.model = ThermalModel(ambient_c=winding, board_idle_w=0.0)
    t.winding = t.board = winding


def test_one_row_per_motor_with_the_health_keys(cli: Cli, sim: SimBus) -> None:
    _warm(sim, 2, 97.5)
    r = cli("health", "1", "2", "--json", "--sim", "1,2,3")
    assert r.code == 0, r.err
    one, two = r.records()
    for rec in (one, two):
        assert set(rec) >= {"id", "motor_temp_c", "driver_temp_c", "current_limit_a", "derating", "errors"}
    assert one["derating"] == 0.0 and one["current_limit_a"] == 15.0 and one["errors"] == []
    assert two["motor_temp_c"] == pytest.approx(97.5, abs=0.1)
    assert two["derating"] == pytest.approx(0.5, abs=0.02)


def test_a_tripped_motor_is_named_with_its_error_and_fix_and_exits_1(cli: Cli, sim: SimBus) -> None:
    sim.motors[3].thermal.board = 120.0
    sim.advance(0.02)
    r = cli("health", "--sim", "1,2,3")
    assert r.code == 1
    lines = r.out.splitlines()
    assert lines[0].split() == ["motor", "motor/degC", "driver/degC", "limit/A", "derating", "errors"]
    assert "fet_thermistor.OVER_TEMP" in lines[3]
    assert any(line.startswith("motor 3: axis0.fet_thermistor.error OVER_TEMP") and "Fix:" in line for line in lines)


def test_joints_by_name_with_a_robot_file(cli: Cli) -> None:
    r = cli("health", "swing", "--robot", str(REPO_ROOT / "examples" / "robots" / "pendulum.toml"), "--json")
    assert r.code == 0, r.err
    (rec,) = r.records()
    assert rec["joint"] == "swing" and rec["id"] == 1


def test_bad_ids_exit_2(cli: Cli, tmp_path: Path) -> None:
    r = cli("health", "64", "--sim", "1")
    assert r.code == 2 and "1..63" in r.err


def test_monitor_fields_take_the_health_keys(cli: Cli, sim: SimBus) -> None:
    _warm(sim, 1, 96.0)
    r = cli(
        "monitor", "1", "--fields", "motor_temp_c,driver_temp_c,current_limit_a,derating,errors",
        "--duration", "0.25", "--json", "--sim", "1,2,3",
    )  # fmt: skip
    assert r.code == 0, r.err
    rec = r.records()[0]
    assert rec["motor_temp_c"] == pytest.approx(96.0, abs=0.1)
    assert rec["driver_temp_c"] == pytest.approx(96.0, abs=0.1)
    assert rec["current_limit_a"] == pytest.approx(12.0, abs=0.3)
    assert rec["derating"] == pytest.approx(0.2, abs=0.02)
    assert rec["errors"] == "none"
    r = cli("monitor", "1", "--fields", "temperature_c", "--duration", "0.1", "--sim", "1,2,3")
    assert r.code == 2 and "health key" in r.err


def test_watch_prints_each_event_once_with_what_it_did(cli: Cli, sim: SimBus) -> None:
    _warm(sim, 2, 92.0)  # 3 K below the firmware's derating: the supervisor's "overheat"
    r = cli("health", "--watch", "--duration", "2.5", "--json", "--sim", "1,2,3")
    assert r.code == 0, r.err
    events = r.records()
    assert [(e["motor"], e["kind"], e["action"]) for e in events] == [(2, "overheat", "none")]  # warn: the default
    assert "winding at 92.0 degC, 3.0 K below the firmware's derating" in events[0]["message"]
    _warm(sim, 3, 101.0)  # the firmware trips
    r = cli("health", "3", "--watch", "--duration", "1.5", "--sim", "1,2,3")
    assert r.code == 1  # a fault
    assert "error  motor 3: axis0.motor_thermistor.error OVER_TEMP" in r.out and "Fix:" in r.out
    r = cli("health", "--duration", "1", "--sim", "1,2,3")
    assert r.code == 2 and "--duration goes with --watch" in r.err
