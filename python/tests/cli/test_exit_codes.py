"""Exit codes across subcommands (2: usage or validation, 1: a failure on the bus), the CLI's own words in
refusals, ASCII digits only, subtrees and stdout for get and backup, files that cannot be read."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from drempower.sim import SimBus

from .conftest import Cli


@pytest.mark.parametrize(
    ("argv", "code"),
    [
        (("set", "1", "can_node_id", "5"), 2),  # refused before anything is sent: use set-id
        (("set", "1", "vbus_voltage", "3"), 2),
        (("set", "1", "stall_current_limit", "-5"), 2),
        (("get", "1", "no_such_parameter"), 2),
        (("move", "1", "1e9"), 2),
        (("speed", "1,2", "1,2,3"), 2),
        (("move", "\u0661", "10"), 2),  # Arabic-Indic one: not motor 1
        (("move", "1", "\u0661\u0660"), 2),
        (("get", "1", "can.config.timeout_ms", "--retries", "\u0662"), 2),
        (("set", "1", "can.config.timeout_ms", "\u0661\u0660\u0660"), 2),
        (("state", "4"), 1),  # no answer: a failure on the bus
        (("get", "4", "vbus_voltage"), 1),
        (("errors", "4"), 1),
        (("move", "4", "10"), 1),
    ],
)
def test_exit_codes_are_consistent(cli: Cli, sim: SimBus, argv: tuple[str, ...], code: int) -> None:
    r = cli(*argv, "--sim", "1,2")
    assert r.code == code, r.err
    assert "Traceback" not in r.err


def test_refusals_word_the_commands_own_flags(cli: Cli, sim: SimBus, tmp_path: Path) -> None:
    r = cli("set", "1", "stall_current_limit", "-5", "--sim", "1")
    assert "--force writes it anyway" in r.err and "force=True" not in r.err
    path = tmp_path / "b.json"
    assert cli("backup", "2", str(path), "--sim", "2").code == 0
    r = cli("restore", "1", str(path), "--sim", "1")
    assert r.code == 2 and "(--force restores it)" in r.err and "force=True" not in r.err


def test_unicode_digits_send_nothing(cli: Cli, sim: SimBus) -> None:
    before = sim.motors[1].param("axis0.controller.input_pos")
    r = cli("move", "\u0661", "10", "--sim", "1")
    assert r.code == 2 and "'\u0661'" in r.err
    assert sim.motors[1].param("axis0.controller.input_pos") == before


def test_get_reads_a_whole_subtree(cli: Cli, sim: SimBus) -> None:
    recs = cli("get", "1", "axis0.controller.config", "--json", "--sim", "1").records()
    names = [r["name"] for r in recs]
    assert len(names) > 5 and all(n.startswith("axis0.controller.config.") for n in names)
    assert "axis0.controller.config.pos_gain" in names and all(r["value"] != "no answer" for r in recs)
    table = cli("get", "1", "axis0.controller.config.", "--sim", "1")
    assert table.code == 0 and len(table.out.splitlines()) == len(names) + 1


def test_backup_to_stdout_and_restore_from_stdin(
    cli: Cli, sim: SimBus, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    r = cli("backup", "1", "-", "--sim", "1")
    assert r.code == 0 and "written to stdout" in r.err and not Path("-").exists()
    doc = json.loads(r.out)
    assert doc["node"] == 1 and len(doc["parameters"]) > 100
    import io

    monkeypatch.setattr("sys.stdin", io.StringIO(r.out))
    r = cli("diff", "1", "-", "--sim", "1")
    assert r.code == 0 and "configuration matches -" in r.out


def test_deeply_nested_json_is_one_line(cli: Cli, sim: SimBus, tmp_path: Path) -> None:
    path = tmp_path / "deep.json"
    path.write_text("[" * 100_000 + "]" * 100_000)
    for command in ("restore", "diff"):
        r = cli(command, "1", str(path), "--sim", "1")
        assert r.code == 2 and "Traceback" not in r.err and len(r.err.splitlines()) == 1, r.err
        assert "deep.json" in r.err


def test_sim_config_dir_with_deeply_nested_json(cli: Cli, tmp_path: Path) -> None:
    (tmp_path / "motor-1.json").write_text("[" * 100_000 + "]" * 100_000)
    r = cli("sim", "--ids", "1", "--config-dir", str(tmp_path))
    assert r.code == 2 and "Traceback" not in r.err and "motor-1.json" in r.err, r.err


@pytest.mark.parametrize(
    ("argv", "words"),
    [
        (("-i", "slcan", "-c", "/dev/null", "--bitrate", "123"), "bitrate=123; slcan sets 10000"),
        (("-i", "slcan", "-c", "/dev/null@fast"), "serial rate 'fast' is not a number"),
    ],
)
def test_a_transport_option_it_cannot_use_is_a_usage_error(cli: Cli, argv: tuple[str, ...], words: str) -> None:
    """A bad option of the connection is the user's mistake (exit 2), not a failure on the bus (exit 1)."""
    r = cli("state", "1", *argv)
    assert r.code == 2 and words in r.err and "Traceback" not in r.err
