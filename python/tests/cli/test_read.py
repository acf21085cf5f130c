"""``scan``, ``state``, ``monitor``, ``get`` and ``errors``."""

from __future__ import annotations

import csv
from collections.abc import Sequence
from pathlib import Path

import pytest

from drempower.cli import _output, _readings, monitor
from drempower.client import Bus
from drempower.protocol import AxisError, FastRead, Frame, decode_frame
from drempower.sim import SimBus

from .conftest import Cli


def test_scan_lists_every_motor(cli: Cli) -> None:
    r = cli("scan", "--sim", "1,2,5")
    assert r.code == 0
    lines = r.out.splitlines()
    assert lines[0].split() == ["id", "hw", "fw", "state", "position/deg", "vbus/V", "errors"]
    assert [line.split()[0] for line in lines[1:]] == ["1", "2", "5"]
    assert all("closed_loop" in line for line in lines[1:])


def test_scan_json_and_progress_on_a_terminal(cli: Cli, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(_output, "is_terminal", lambda stream: True)
    r = cli("scan", "--sim", "2", "--ids", "1-3", "--json")
    (rec,) = r.records()
    assert rec["id"] == 2 and rec["state"] == "closed_loop" and rec["errors"] == ""
    assert isinstance(rec["fw_version"], int) and isinstance(rec["hw_version"], int)
    assert "scanning 3 ids" in r.err and "reading motor 2 (1/1)" in r.err


def test_scan_finding_nothing_fails(cli: Cli) -> None:
    r = cli("scan", "--sim", "1", "--ids", "4-6", "--timeout", "0.25")
    assert r.code == 1
    assert r.out == "" and "no motor answered" in r.err


def test_state_table_and_json(cli: Cli) -> None:
    r = cli("state", "1", "2", "--sim", "1,2")
    assert r.code == 0
    head, *rows = r.out.splitlines()
    assert head.split() == ["id", "position/deg", "speed/rpm", "torque/Nm", "done", "state", "vbus/V", "errors"]
    assert [row.split()[:2] for row in rows] == [["1", "0.00"], ["2", "0.00"]]
    recs = cli("state", "1-2", "--sim", "1,2", "--json").records()
    assert [rec["id"] for rec in recs] == [1, 2]
    assert recs[0]["done"] is True and recs[0]["vbus_v"] > 0 and recs[0]["state"] == "closed_loop"


def test_state_of_a_silent_motor_names_it(cli: Cli) -> None:
    r = cli("state", "1", "4", "--sim", "1", "--timeout", "0.25")
    assert r.code == 1
    assert r.err == "drempower: no answer from motor 4\n"


def test_monitor_plain_lines_and_csv(cli: Cli, sim: SimBus, tmp_path: Path) -> None:
    sim.motors[2].inject_error(AxisError.OVER_TEMP)
    log = tmp_path / "monitor.csv"
    r = cli("monitor", "1", "2", "--sim", "1,2", "--rate", "20", "--duration", "0.2", "--csv", str(log))
    assert r.code == 0
    lines = r.out.splitlines()
    assert lines[0].split()[:3] == ["time/s", "id", "position/deg"]
    assert "time/s" not in "".join(lines[1:])
    assert len(lines) - 1 >= 2 and (len(lines) - 1) % 2 == 0
    assert "OVER_TEMP" in lines[2]
    rows = list(csv.DictReader(log.open()))
    assert len(rows) == len(lines) - 1
    assert rows[0]["id"] == "1" and rows[1]["errors"] == "OVER_TEMP"


def test_monitor_redraws_in_place_on_a_terminal(cli: Cli, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr("drempower.cli.monitor.is_terminal", lambda stream: True)
    r = cli("monitor", "1", "--sim", "1", "--rate", "20", "--duration", "0.15")
    assert r.code == 0
    assert r.out.count("\x1b[2F") >= 2


def test_monitor_json(cli: Cli) -> None:
    recs = cli("monitor", "3", "--sim", "3", "--rate", "50", "--duration", "0.1", "--json").records()
    assert recs and all(rec["id"] == 3 for rec in recs)
    assert recs[0]["time_s"] <= recs[-1]["time_s"]


class FakeClock:
    """``time.monotonic`` and ``time.sleep`` of a clock that moves only when told."""

    def __init__(self) -> None:
        self.now = 0.0

    def monotonic(self) -> float:
        return self.now

    def sleep(self, seconds: float) -> None:
        self.now += seconds


def test_monitor_duration_is_wall_clock_time(cli: Cli, monkeypatch: pytest.MonkeyPatch) -> None:
    """Readings that take longer than 1/RATE do not stretch --duration."""
    clock = FakeClock()
    read = _readings.read

    def slow_read(bus: Bus, ids: Sequence[int], *, missing_ok: bool = False) -> list[_readings.Reading]:
        clock.now += 0.4
        return read(bus, ids, missing_ok=missing_ok)

    monkeypatch.setattr(monitor, "time", clock)
    monkeypatch.setattr(_readings, "read", slow_read)
    recs = cli("monitor", "1", "--sim", "1", "--rate", "10", "--duration", "1", "--json").records()
    assert [rec["time_s"] for rec in recs] == [0.0, 0.4, 0.8]


def test_monitor_asks_a_silent_motor_only_for_its_state(cli: Cli, sim: SimBus, host_frames: list[Frame]) -> None:
    r = cli("monitor", "1", "4", "--sim", "1,2,3", "--duration", "0.01", "--timeout", "0.25", "--json")
    assert r.code == 0
    assert [(rec["id"], rec["errors"], rec["state"]) for rec in r.records()] == [
        (1, "", "closed_loop"),
        (4, "no answer", None),
    ]
    to_4 = [decode_frame(f.arbitration_id, f.data, "host")[1] for f in host_frames if f.arbitration_id >> 5 == 4]
    assert to_4 and all(isinstance(msg, FastRead) for msg in to_4)


def test_get_shows_units(cli: Cli) -> None:
    r = cli("get", "1", "vbus_voltage", "38013", "stall_current_limit", "--sim", "1")
    assert r.code == 0
    rows = [line.split() for line in r.out.splitlines()[1:]]
    assert rows[0][1:3] == ["vbus_voltage", "1"] and rows[0][-1] == "V"
    assert rows[1][1] == "axis0.output_shaft.torque_lim" and rows[1][-1] == "Nm"
    assert rows[2][1] == "axis0.config.extra_setting.stall_current_limit" and rows[2][-1] == "A"


def test_get_json_of_several_motors(cli: Cli) -> None:
    recs = cli("get", "1,2", "axis0.config.can_node_id", "--sim", "1,2", "--json").records()
    assert [(rec["id"], rec["value"]) for rec in recs] == [(1, 1), (2, 2)]


@pytest.mark.parametrize(
    ("name", "message"),
    [("vel_limit", "could be any of"), ("no_such_thing", "unknown parameter"), ("axis0.errr", "did you mean")],
)
def test_get_unknown_or_ambiguous_names(cli: Cli, name: str, message: str) -> None:
    r = cli("get", "1", name, "--sim", "1")
    assert r.code == 2 and message in r.err


def test_errors_explains_flags(cli: Cli, sim: SimBus) -> None:
    assert cli("errors", "1", "--sim", "1,2,3").out == "motor 1: no errors\n"
    sim.motors[2].inject_error(AxisError.OVER_TEMP)
    r = cli("errors", "2", "--sim", "1,2,3")
    assert r.code == 0
    assert "axis0.error = 0x00040000" in r.out and "OVER_TEMP:" in r.out and "what to do: Let the motor cool" in r.out
    (rec,) = cli("errors", "2", "--sim", "1,2,3", "--json").records()
    assert {f["flag"] for f in rec["errors"]} >= {"OVER_TEMP"}
