"""Backup files: malformed values, another motor's backup, duplicates, and a restore that moves the id."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from drempower.protocol import Frame
from drempower.sim import SimBus

from .conftest import Cli

STALL = "axis0.config.extra_setting.stall_current_limit"  # f32
TRAJ = "axis0.trap_traj.config.traj_mode"  # u32
ID = "axis0.config.can_node_id"
WRITE = 0x1F


def _backup(cli: Cli, tmp_path: Path, node: int = 1) -> tuple[Path, dict[str, Any]]:
    path = tmp_path / f"motor{node}.json"
    assert cli("backup", str(node), str(path), "--sim", str(node)).code == 0
    doc: dict[str, Any] = json.loads(path.read_text())
    return path, doc


def _record(doc: dict[str, Any], name: str) -> dict[str, Any]:
    (rec,) = [r for r in doc["parameters"] if r["name"] == name]
    return rec


def _set(name: str, value: object) -> Callable[[dict[str, Any]], object]:
    def edit(doc: dict[str, Any]) -> object:
        _record(doc, name)["value"] = value
        return doc

    return edit


def _field(key: str, value: object) -> Callable[[dict[str, Any]], object]:
    def edit(doc: dict[str, Any]) -> object:
        _record(doc, STALL)[key] = value
        return doc

    return edit


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (_set(STALL, "10"), f"{STALL}: value '10' is a string: expected a number (f32)"),
        (_set(STALL, [10]), f"{STALL}: value [10] is a list: expected a number (f32)"),
        (_set(STALL, True), f"{STALL}: value True is a boolean: expected a number (f32)"),
        (_set(TRAJ, 1.5), f"{TRAJ}: value 1.5 is a fraction: expected a whole number (u32)"),
        (_set(TRAJ, 2.0), f"{TRAJ}: value 2.0 is a fraction: expected a whole number (u32)"),
        (_set(TRAJ, -1), f"{TRAJ}: value=-1 is out of range"),
        (_set(STALL, 1e39), f"{STALL}: value=1e+39 is out of range"),
        (_set(TRAJ, 7), f"{TRAJ}: {TRAJ}=7 is out of range"),  # a u32, but no traj_mode
        (_field("address", None), f"{STALL}: name '{STALL}' and address None"),
        (_field("type", "s16"), f"{STALL}: type 's16': this parameter is f32"),
        (_field("extra", 1), f"{STALL}: unknown extra"),
        (lambda doc: [doc], "the top level is a list, not an object"),
        (lambda doc: {**doc, "node": None}, "node=None: expected a motor id 1..63"),
        (lambda doc: {**doc, "parameters": {}}, "parameters: expected a list of records, got an object"),
        (lambda doc: {**doc, "parameters": [*doc["parameters"], 5]}, "record "),
    ],
)
def test_every_malformed_value_is_named_before_anything_is_written(
    cli: Cli,
    sim: SimBus,
    host_frames: list[Frame],
    tmp_path: Path,
    edit: Callable[[dict[str, Any]], object],
    message: str,
) -> None:
    path, doc = _backup(cli, tmp_path)
    cli("set", "1", STALL, "2.5", "--sim", "1")
    path.write_text(json.dumps(edit(doc)))
    host_frames.clear()
    for command, trouble in (("restore", 2), ("diff", 2)):  # a bad file is a validation error (2), as diff(1) says
        r = cli(command, "1", str(path), "--sim", "1")
        assert r.code == trouble and message in r.err and "Traceback" not in r.err, r.err
        assert len(r.err.splitlines()) == 1
    assert [f for f in host_frames if f.arbitration_id & 0x1F == WRITE] == []
    assert sim.motors[1].param(STALL) == 2.5


def test_all_problems_are_listed_at_once(cli: Cli, sim: SimBus, tmp_path: Path) -> None:
    path, doc = _backup(cli, tmp_path)
    _set(STALL, "x")(doc)
    _set(TRAJ, None)(doc)  # null: unread, skipped
    _set("axis0.controller.config.pos_gain", [1])(doc)
    path.write_text(json.dumps(doc))
    r = cli("restore", "1", str(path), "--sim", "1")
    assert r.code == 2 and "2 malformed records" in r.err and STALL in r.err and "pos_gain" in r.err


def test_backup_of_another_motor_or_with_duplicates_needs_force(
    cli: Cli, sim: SimBus, host_frames: list[Frame], tmp_path: Path
) -> None:
    path, doc = _backup(cli, tmp_path, node=2)
    cli("set", "1", STALL, "2.5", "--sim", "1")
    host_frames.clear()
    r = cli("restore", "1", str(path), "--sim", "1")
    assert r.code == 2 and "the backup is of motor 2, not motor 1" in r.err and "(--force restores it)" in r.err
    assert "force=True" not in r.err
    doc["node"] = 1
    doc["parameters"].append({**_record(doc, STALL), "value": 7.0})
    path.write_text(json.dumps(doc))
    r = cli("restore", "1", str(path), "--sim", "1")
    assert r.code == 2 and f"duplicated records: {STALL} (2 times)" in r.err
    assert [f for f in host_frames if f.arbitration_id & 0x1F == WRITE] == []
    assert sim.motors[1].param(STALL) == 2.5
    r = cli("restore", "1", str(path), "--force", "--sim", "1")
    assert r.code == 0, r.err
    assert sim.motors[1].param(STALL) == 7.0  # the last record of a parameter wins


def test_restore_with_link_writes_the_id_last_and_follows_the_motor(
    cli: Cli, sim: SimBus, host_frames: list[Frame], tmp_path: Path
) -> None:
    """A backup of motor 5 restored onto a fresh motor 3: everything at id 3, verified, then the id."""
    cli("set", "1", STALL, "4.5", "--sim", "1")
    path, doc = _backup(cli, tmp_path, node=1)
    doc["node"] = 5
    _set(ID, 5)(doc)
    path.write_text(json.dumps(doc))
    host_frames.clear()
    r = cli("restore", "3", str(path), "--include-link", "--force", "--save", "--json", "--sim", "3")
    assert r.code == 0, r.err
    *changed, summary = r.records()
    assert {"name": ID, "was": 3, "now": 5, "unit": ""} in changed
    assert summary["now_id"] == 5 and summary["saved"] is True
    assert 5 in {m.node_id for m in sim.motors.values()} and sim.motors[3].param(STALL) == 4.5
    writes = [i for i, f in enumerate(host_frames) if f.arbitration_id & 0x1F == WRITE]
    last = host_frames[writes[-1]]
    assert (last.arbitration_id >> 5, int.from_bytes(last.data[:2], "little")) == (3, 31001)  # the id, last
    stall_write = next(i for i in writes if int.from_bytes(host_frames[i].data[:2], "little") == 31209)
    verified = [
        i
        for i, f in enumerate(host_frames)
        if f.arbitration_id == (3 << 5 | 0x1E) and int.from_bytes(f.data[:2], "little") == 31209
    ]
    assert any(stall_write < i < writes[-1] for i in verified)  # read back before the id changed
    after = host_frames[writes[-1] + 1 :]
    assert any(f.arbitration_id >> 5 == 5 for f in after)  # verified, and saved, at the new id
    assert cli("get", "5", ID, "--sim", "5", "--json").records()[0]["value"] == 5


def test_restore_with_link_never_gives_a_motor_an_id_that_is_taken(cli: Cli, sim: SimBus, tmp_path: Path) -> None:
    """Motor 2's backup restored onto motor 1 with --include-link --force: id 2 answers, so the id is not written."""
    path, _ = _backup(cli, tmp_path, node=2)
    r = cli("restore", "1", str(path), "--include-link", "--force", "--sim", "1,2")
    assert r.code == 1 and f"{ID}: not written: id 2 is already taken by another motor" in r.err, r.err
    assert sorted(m.node_id for m in sim.motors.values()) == [1, 2, 3]  # nobody moved to a taken id
