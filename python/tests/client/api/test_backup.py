"""Configuration backup to JSON and restore."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

import drempower
from drempower.client import Bus, ConfigBackup
from drempower.protocol import parameters
from drempower.protocol.parameters import parameter

from ..scripted import FakeMotors, ScriptedTransport


def test_backup_and_restore(bus: Bus, motors: FakeMotors, tmp_path: Path) -> None:
    motors.params[1].update({38012: 200.0, 32108: 20.0, 35104: 2, 1: 24.0})
    path = tmp_path / "m1.json"
    b = bus.motor(1).backup(path)
    doc = json.loads(path.read_text())
    assert doc["format"] == "drempower-config-backup" and doc["node"] == 1
    rec = {p["name"]: p for p in doc["parameters"]}
    assert len(rec) == len(list(parameters()))
    assert rec["axis0.output_shaft.vel_limit"] == {
        "name": "axis0.output_shaft.vel_limit",
        "address": 38012,
        "type": "f32",
        "unit": "rpm",
        "access": "rw",
        "value": 200.0,
    }
    assert b.failed == [] and b.values()["vbus_voltage"] == 24.0

    motors.params[2].update({38012: 50.0, 35104: 1})
    dry = bus.motor(2).restore(path, dry_run=True, force=True)
    assert ("axis0.output_shaft.vel_limit", 50.0, 200.0) in dry.written
    assert motors.params[2][38012] == 50.0

    with pytest.raises(drempower.ValidationError, match="the backup is of motor 1, not motor 2"):
        bus.motor(2).restore(path)
    report = bus.motor(2).restore(ConfigBackup.load(path), save=True, force=True)
    assert report.ok and report.saved
    written = {name for name, _, _ in report.written}
    assert {"axis0.output_shaft.vel_limit", "axis0.controller.config.pos_gain"} <= written
    assert "axis0.trap_traj.config.traj_mode" in written and bus._core.session.known.traj_mode[2] == 2
    assert motors.params[2][38012] == 200.0 and motors.params[2][31001] == 2  # the id is not restored
    for skipped in ("vbus_voltage", "axis0.config.can_node_id", "axis0.requested_state", "axis0.controller.input_pos"):
        assert skipped in report.skipped
    again = bus.motor(2).restore(path, force=True)
    assert again.written == [] and again.ok


def test_backup_of_a_silent_motor_fails_fast(bus: Bus) -> None:
    with pytest.raises(drempower.TimeoutError):
        bus.motor(9).backup()


def test_restore_reports_failures(motors: FakeMotors, tmp_path: Path) -> None:
    t = ScriptedTransport(motors, virtual=True)  # timeouts on the scripted clock: no wall time, any load
    realistic = {
        "axis0.config.extra_setting.gear_ratio": 10.0,
        "axis0.motor.config.pole_pairs": 14,
        "axis0.motor.config.direction": 1,
        "axis0.encoder.config.cpr": 32768,
    }
    for name, value in realistic.items():  # the fake motor reads 0 where a real one holds these
        motors.params[1][parameter(name).address] = value
    with Bus(t, timeout=0.25, stop_on_close=False) as bus:
        motors.params[1][38013] = 9.0
        b = bus.motor(1).backup()
        motors.params[1][38013] = 1.0

        def refuse(f: object) -> list[object]:
            if f.arbitration_id & 0x1F == 0x1F:  # type: ignore[attr-defined]
                return []
            return motors(f)  # type: ignore[arg-type]

        t.respond = refuse  # type: ignore[assignment]
        report = bus.motor(1).restore(b, save=True)
    assert not report.ok and not report.saved
    assert report.failed == [("axis0.output_shaft.torque_lim", "reads 1.0 after writing 9.0")]


def test_load_rejects_other_files(tmp_path: Path) -> None:
    p = tmp_path / "x.json"
    p.write_text('{"format": "something else"}')
    with pytest.raises(drempower.ValidationError):
        ConfigBackup.load(p)
    with pytest.raises(drempower.ValidationError):
        ConfigBackup.load(tmp_path / "missing.json")
