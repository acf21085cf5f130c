"""What a bench user trips over: diff's exit status, unknown names, "-0.00", follow-up commands
that lose the connection options, and an unordered --help."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from drempower.cli import GROUPS, build_parser
from drempower.cli._output import fmt, json_line, number_text
from drempower.sim import SimBus

from .conftest import Cli

STALL = "axis0.config.extra_setting.stall_current_limit"


def test_diff_exit_status_is_that_of_diff(cli: Cli, sim: SimBus, tmp_path: Path) -> None:
    path = tmp_path / "m1.json"
    assert cli("backup", "1", str(path), "--sim", "1").code == 0
    assert cli("diff", "1", str(path), "--sim", "1").code == 0
    cli("set", "1", STALL, "2.5", "--sim", "1")
    r = cli("diff", "1", str(path), "--sim", "1")
    assert r.code == 1 and r.out.splitlines()[1].split() == [STALL, "2.5", "10", "A"]
    assert cli("diff", "1", str(path), "--json", "--sim", "1").code == 1
    # trouble (no such motor) is 2, as diff(1) says for trouble
    r = cli("diff", "5", str(path), "--sim", "1", "--timeout", "0.2")
    assert r.code == 2 and r.err.startswith("drempower: error: motor 5: no answer")


@pytest.mark.parametrize(
    ("name", "close"),
    [
        ("gain", "axis0.controller.config.pos_gain"),
        ("vbus_voltag", "vbus_voltage"),
        ("axis0.controller.config.vel_limt", "axis0.controller.config.vel_limit"),
        ("stall_curent_limit", STALL),
    ],
)
def test_unknown_parameter_suggests_close_names_and_exits_2(cli: Cli, name: str, close: str) -> None:
    r = cli("get", "1", name, "--sim", "1")
    assert r.code == 2 and r.out == ""
    assert f"drempower get: error: unknown parameter {name!r}; did you mean" in r.err
    assert close in r.err.splitlines()[-1]
    assert cli("set", "1", name, "1", "--sim", "1").code == 2


def test_a_name_nothing_is_close_to_has_no_suggestion(cli: Cli) -> None:
    r = cli("get", "1", "zzzzqqq", "--sim", "1")
    assert r.code == 2 and "unknown parameter 'zzzzqqq' (`drempower params WORD` searches the table)" in r.err


@pytest.mark.parametrize(("value", "digits", "text"), [(-0.001, 2, "0.00"), (-0.0, 2, "0.00"), (-0.0, None, "0")])
def test_no_negative_zero(value: float, digits: int | None, text: str) -> None:
    assert fmt(value, digits) == text
    assert number_text(-0.004, 2, 6) == "  0.00" and number_text(-0.006, 2) == "-0.01"
    assert json.loads(json_line({"v": -0.0})) == {"v": 0.0} and json_line({"v": -0.0}) == '{"v": 0.0}'


def test_state_of_a_motor_drifting_below_zero_shows_no_minus(cli: Cli, sim: SimBus) -> None:
    m = sim.motors[1]
    zero, cpr, ratio = (
        "axis0.config.extra_setting.zero_offset_counts",
        "axis0.encoder.config.cpr",
        "axis0.config.extra_setting.gear_ratio",
    )
    m.set_param(zero, m.param(zero) + 1e-4 / 360 * m.param(cpr) * m.param(ratio))  # the zero 0.0001 deg ahead
    assert -2e-4 < m.position < 0
    r = cli("state", "1", "--sim", "1")
    assert "-0.00" not in r.out and r.out.splitlines()[1].split()[1] == "0.00"


def test_follow_up_commands_carry_the_connection_options(cli: Cli, sim: SimBus) -> None:
    cli("stop", "--sim", "1")
    r = cli("move", "1", "90", "--sim", "1", "--timeout", "0.3", "--retries", "2")
    assert r.code == 1
    assert "`drempower clear 1 --sim 1 --timeout 0.3 --retries 2`" in r.err
    r = cli("errors", "1", "--sim", "1")
    assert "then: drempower clear 1 --sim 1 && drempower enable 1 --sim 1" in r.out


def test_follow_up_words_of_a_python_can_connection() -> None:
    from drempower.cli._connect import follow_up

    args = build_parser().parse_args(
        ["state", "1", "-i", "socketcand", "-c", "can0", "-o", "host=127.0.0.1", "-o", "port=29536", "-b", "1M"]
    )
    assert follow_up(args, "clear 1") == (
        "drempower clear 1 -i socketcand -c can0 -b 1000000 -o host=127.0.0.1 -o port=29536"
    )
    args = build_parser().parse_args(["state", "1", "--serial", "/dev/serial/by-id/usb-a b"])
    assert follow_up(args, "enable 1") == "drempower enable 1 --serial '/dev/serial/by-id/usb-a b'"


def test_help_lists_subcommands_in_groups(cli: Cli) -> None:
    r = cli("--help")
    assert r.code == 0
    text = r.out
    headings = [line[:-1] for line in text.splitlines() if line.endswith(":") and not line.startswith(" ")]
    assert [h for h in headings if h in GROUPS] == list(GROUPS)
    section = {h: text.split(f"\n{h}:\n", 1)[1].split("\n\n", 1)[0] for h in GROUPS}
    assert "  scan " in section["bus"] and "  monitor " in section["bus"]
    assert "  move " in section["motion"] and "  stop " in section["motion"]
    assert "  get " in section["parameters"] and "  backup " in section["parameters"]
    assert "  decode " in section["logs and tools"] and "  completion " in section["logs and tools"]
    assert "  sim " in section["simulator"] and "  demo " in section["simulator"]
    (commands,) = [a for a in build_parser()._actions if a.dest == "command"]
    for name in commands.choices:  # every subcommand is listed once
        assert sum(line.split()[:1] == [name] for line in text.splitlines()) == 1, name


def test_a_module_without_group_is_listed_last(monkeypatch: pytest.MonkeyPatch) -> None:
    import types

    import drempower.cli as cli_pkg

    extra = types.ModuleType("drempower.cli.zzextra")
    extra.register = lambda sub: sub.add_parser("frobnicate", help="a command of no group")  # type: ignore[attr-defined]
    real = cli_pkg.importlib.import_module
    infos = list(cli_pkg.pkgutil.iter_modules(cli_pkg.__path__))
    monkeypatch.setattr(cli_pkg.pkgutil, "iter_modules", lambda path: [*infos, types.SimpleNamespace(name="zzextra")])
    monkeypatch.setattr(
        cli_pkg.importlib, "import_module", lambda name: extra if name.endswith(".zzextra") else real(name)
    )
    text = build_parser().format_help()
    assert text.index("\nother commands:\n  frobnicate") > text.index("\nsimulator:\n")


def test_subcommands_of_other_modules_find_their_group(monkeypatch: pytest.MonkeyPatch) -> None:
    import types

    import drempower.cli as cli_pkg

    (commands,) = [a for a in build_parser()._actions if a.dest == "command"]
    absent = [n for n in cli_pkg._GROUP_OF_COMMAND if n not in commands.choices]
    if absent:  # a module without GROUP that registers one of these names
        name = absent[0]
        extra = types.ModuleType(f"drempower.cli.zz{name}")
        extra.register = lambda sub: sub.add_parser(name, help="a new command")  # type: ignore[attr-defined]
        real = cli_pkg.importlib.import_module
        infos = list(cli_pkg.pkgutil.iter_modules(cli_pkg.__path__))
        fake = types.SimpleNamespace(name=f"zz{name}")
        monkeypatch.setattr(cli_pkg.pkgutil, "iter_modules", lambda path: [*infos, fake])
        monkeypatch.setattr(
            cli_pkg.importlib, "import_module", lambda mod: extra if mod.endswith(f".zz{name}") else real(mod)
        )
    text = build_parser().format_help()
    (commands,) = [a for a in build_parser()._actions if a.dest == "command"]
    for name, group in cli_pkg._GROUP_OF_COMMAND.items():
        if name in commands.choices:
            section = text.split(f"\n{group}:\n", 1)[1].split("\n\n", 1)[0]
            assert f"  {name} " in section, name
