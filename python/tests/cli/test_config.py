"""``set``, ``set-id``, ``set-bitrate``, ``save``, ``reboot``, ``backup``, ``restore`` and ``diff``."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from drempower.sim import SimBus

from ..waits import eventually
from .conftest import Cli

STALL = "axis0.config.extra_setting.stall_current_limit"


def test_set_then_get(cli: Cli, sim: SimBus) -> None:
    r = cli("set", "1", "stall_current_limit", "3.5", "enable_damp_idle", "on", "--sim", "1")
    assert r.code == 0
    rows = [line.split() for line in r.out.splitlines()[1:]]
    assert rows[0] == ["1", STALL, "10", "3.5", "A"]
    assert rows[1] == ["1", "axis0.config.extra_setting.enable_damp_idle", "0", "1"]
    (rec,) = cli("get", "1", STALL, "--json", "--sim", "1").records()
    assert rec == {"id": 1, "name": STALL, "address": 31209, "value": 3.5, "unit": "A"}
    assert sim.motors[1].param(STALL) == 3.5


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (("vbus_voltage", "3"), "vbus_voltage is read-only"),
        (("can_node_id", "4"), "use `drempower set-id`"),
        (("can.config.baud_rate", "500000"), "use `drempower set-bitrate`"),
        (("axis0.controller.input_pos", "1"), "add --force"),
        (("enable_damp_idle", "maybe"), "is a flag"),
        (("can.config.timeout_ms", "1.5"), "takes a whole number (u32)"),
    ],
)
def test_set_refuses(cli: Cli, args: tuple[str, ...], message: str) -> None:
    r = cli("set", "1", *args, "--sim", "1")
    assert r.code == 2 and message in r.err  # a refusal is a validation error, as a value out of its domain


def test_set_needs_name_value_pairs(cli: Cli) -> None:
    r = cli("set", "1", "can.config.timeout_ms", "--sim", "1")
    assert r.code == 2 and r.err.startswith("usage: drempower set ")
    assert "drempower set: error: give NAME VALUE pairs; the last name has no value" in r.err


def test_save_and_reboot_keep_the_value(cli: Cli, sim: SimBus) -> None:
    cli("set", "1,2", STALL, "4", "--sim", "1,2")
    assert cli("save", "1", "--sim", "1").out == "motor 1: save sent\n"  # the protocol has no answer to it
    r = cli("reboot", "1", "2", "--wait", "--sim", "1,2")
    assert r.code == 0 and r.out == "motors 1, 2: rebooted and answering\n"
    recs = cli("get", "1,2", STALL, "--json", "--sim", "1,2").records()
    assert [rec["value"] for rec in recs] == [4, 10]
    assert cli("reboot", "2", "--sim", "1,2").out == "motor 2: reboot sent\n"  # not waited for: not "rebooted"


def test_save_reboot_set_id_and_set_bitrate_json(cli: Cli, sim: SimBus) -> None:
    r = cli("save", "1", "2", "--json", "--sim", "1,2")
    assert r.code == 0 and [(rec["id"], rec["command"], rec["sent"]) for rec in r.records()] == [
        (1, "save", True),
        (2, "save", True),
    ]
    (rec,) = cli("reboot", "1", "--wait", "--json", "--sim", "1").records()
    assert rec == {"id": 1, "broadcast": False, "command": "reboot", "sent": True, "answering": True}
    (rec,) = cli("reboot", "all", "--json", "--sim", "1").records()
    assert rec == {"id": 0, "broadcast": True, "command": "reboot", "sent": True, "answering": None}
    # the motors answer again once booted (a command line that starts quickly asks before that)
    assert eventually(lambda: cli("state", "2", "3", "--sim", "2,3").code == 0)
    (rec,) = cli("set-bitrate", "2", "500k", "--json", "--sim", "2").records()
    assert rec == {"id": 2, "link": "can", "bitrate": 500000, "saved": True, "applies": "after a reboot"}
    (rec,) = cli("set-id", "3", "7", "--json", "--sim", "3").records()
    assert rec == {"id": 3, "new_id": 7, "saved": True}
    r = cli("set", "1", STALL, "4", "--save", "--json", "--sim", "1")
    assert [rec.get("command") for rec in r.records()] == [None, "save"]


def test_set_with_save(cli: Cli, sim: SimBus) -> None:
    r = cli("set", "3", "can.config.heartbeat_ms", "0x10", "--save", "--sim", "3")
    assert r.code == 0 and r.out.endswith("motor 3: save sent\n")
    cli("reboot", "all", "--sim", "3")
    assert sim.motors[3].param("can.config.heartbeat_ms") == 16


def test_set_id(cli: Cli, sim: SimBus) -> None:
    r = cli("set-id", "3", "7", "--sim", "3")
    assert r.code == 0 and r.out == "motor 3 is now motor 7 (saved)\n"
    assert sim.motors[3].node_id == 7
    assert cli("state", "7", "--sim", "3").code == 0
    assert cli("set-id", "7", "64", "--sim", "3").code == 2
    r = cli("set-id", "4", "5", "--sim", "3", "--timeout", "0.25")
    assert r.code == 1 and re.search(r"\b4\b", r.err)


def test_set_bitrate(cli: Cli, sim: SimBus) -> None:
    r = cli("set-bitrate", "2", "500k", "--sim", "2")
    assert r.code == 0 and r.out == "motor 2: CAN bitrate 500000 bit/s saved; it applies after a reboot\n"
    assert sim.motors[2].param("can.config.baud_rate") == 500000
    r = cli("set-bitrate", "2", "300k", "--sim", "2")
    assert r.code == 2 and "CAN bitrates are 125000, 250000, 500000, 1000000" in r.err
    assert cli("set-bitrate", "2", "fast", "--sim", "2").code == 2


def test_backup_diff_restore(cli: Cli, sim: SimBus, tmp_path: Path) -> None:
    path = tmp_path / "motor1.json"
    r = cli("backup", "1", str(path), "--sim", "1")
    assert r.code == 0 and r.out.startswith("motor 1: ") and str(path) in r.out
    doc = json.loads(path.read_text())
    assert doc["node"] == 1 and any(p["name"] == STALL for p in doc["parameters"])
    assert cli("diff", "1", str(path), "--sim", "1").out == f"motor 1: configuration matches {path}\n"

    cli("set", "1", STALL, "2.5", "--sim", "1")
    r = cli("diff", "1", str(path), "--sim", "1")
    assert r.out.splitlines()[1].split() == [STALL, "2.5", "10", "A"]
    (rec,) = cli("diff", "1", str(path), "--json", "--sim", "1").records()
    assert rec == {"name": STALL, "motor": 2.5, "backup": 10, "unit": "A"}

    r = cli("restore", "1", str(path), "--save", "--sim", "1")
    assert r.code == 0
    assert r.out.splitlines()[1].split() == [STALL, "2.5", "10", "A"]
    assert r.out.splitlines()[-1].startswith("motor 1: 1 written,") and r.out.endswith("saved\n")
    assert sim.motors[1].param(STALL) == 10
    assert cli("diff", "1", str(path), "--sim", "1").out.endswith("configuration matches " + str(path) + "\n")


def test_backup_diff_restore_json(cli: Cli, sim: SimBus, tmp_path: Path) -> None:
    path = tmp_path / "motor2.json"
    (rec,) = cli("backup", "2", str(path), "--json", "--sim", "2").records()
    assert rec["id"] == 2 and rec["file"] == str(path) and rec["parameters"] > 100 and rec["unreadable"] == []
    (rec,) = cli("diff", "2", str(path), "--json", "--sim", "2").records()
    assert rec == {"id": 2, "file": str(path), "matches": True}
    (rec,) = cli("restore", "2", str(path), "--json", "--sim", "2").records()
    assert rec["id"] == 2 and rec["written"] == 0 and rec["unchanged"] > 0 and rec["saved"] is False
    cli("set", "2", STALL, "2.5", "--sim", "2")
    changed, summary = cli("restore", "2", str(path), "--save", "--json", "--sim", "2").records()
    assert changed == {"name": STALL, "was": 2.5, "now": 10, "unit": "A"}
    assert summary["written"] == 1 and summary["saved"] is True


def test_restore_of_a_bad_file(cli: Cli, tmp_path: Path) -> None:
    path = tmp_path / "bad.json"
    path.write_text("{}")
    r = cli("restore", "1", str(path), "--sim", "1")
    assert r.code == 2 and "not a drempower-config-backup" in r.err
    r = cli("backup", "1", str(tmp_path / "missing" / "x.json"), "--sim", "1")
    assert r.code == 2 and "cannot write" in r.err


def test_set_bitrate_refuses_a_rate_the_motor_lacks_before_connecting(cli: Cli) -> None:
    r = cli("set-bitrate", "1", "300k", "--serial", "/nonexistent/ttyACM9")  # never opened
    assert r.code == 2 and "argument BITRATE: 300000: CAN bitrates are 125000, 250000, 500000, 1000000" in r.err
    r = cli("set-bitrate", "1", "1M", "--link", "uart", "--serial", "/nonexistent/ttyACM9")
    assert r.code == 2 and "UART rates are 9600, 19200, 57600, 115200" in r.err
