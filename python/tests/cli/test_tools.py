"""``sniff``, ``bus-load``, ``completion`` and ``demo``."""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import threading

import pytest

from drempower.cli import build_parser, main

from .conftest import SLOW_LINK, Cli


def test_sniff_shows_the_frames_of_another_command(virtual_channel: str, capsys: pytest.CaptureFixture[str]) -> None:
    link = ["-i", "virtual", "-c", virtual_channel]
    codes: list[int] = []
    sniffer = threading.Thread(
        target=lambda: codes.append(main(["sniff", "--count", "6", "--duration", "5", "--json", *link]))
    )
    sniffer.start()
    while sniffer.is_alive():
        assert main(["get", "1", "vbus_voltage", "axis0.error", *link, *SLOW_LINK]) == 0
    sniffer.join()
    out, err = capsys.readouterr()
    records = [json.loads(line) for line in out.splitlines() if line.startswith("{")]
    assert codes == [0] and len(records) == 6 and "6 frames on python-can virtual" in err
    commands = {(r["direction"], r["command"], r.get("parameter")) for r in records}
    assert ("host", "read_param", "vbus_voltage") in commands
    assert ("motor", "param_value", "vbus_voltage") in commands
    assert ("motor", "param_value", "axis0.error") in commands  # a reply of 0, paired with its read
    assert all(r["node"] == 1 and r["time_s"] >= 0 for r in records)


def test_sniff_text_and_duration(virtual_channel: str, cli: Cli) -> None:
    r = cli("sniff", "--duration", "0.1", "-i", "virtual", "-c", virtual_channel)
    assert r.code == 0 and r.out == "" and "0 frames on python-can virtual" in r.err


def test_bus_load_matches_a_hand_calculation(cli: Cli) -> None:
    # One motor at 1000 Hz, no reply state: per cycle a T command 0x039 (bandwidth 300 1/s,
    # data 00 00 00 00 00 00 30 75), a fast read 0x03E and a state reply 0x023 (all zero data).
    # Each standard 8-byte frame: 98 stuffable bits (SOF, 11-bit id, RTR, IDE, r0, DLC 4,
    # data 64, CRC 15) + 13 (CRC and ACK delimiters, ACK slot, EOF 7, intermission 3) = 111,
    # plus stuff bits: 13, 16 and 14, i.e. 124 + 127 + 125 = 376 bits per cycle.
    # Load = 376 * 1000 / 1e6 = 37.6 %; highest rate = 1e6 / 376 = 2659.6 Hz.
    (rec,) = cli("bus-load", "--motors", "1", "--rate", "1000", "--json").records()
    assert rec == {
        "motors": 1,
        "rate_hz": 1000.0,
        "bitrate": 1000000,
        "reply_state": False,
        "frames_per_cycle": 3,
        "bits_per_cycle": 376,
        "load_percent": 37.6,
        "max_rate_hz": 2659.6,
    }
    r = cli("bus-load", "--motors", "1", "--rate", "1000")
    assert "per cycle: 3 frames, 376 bits = 376 us of bus time" in r.out
    assert "bus load: 37.6 %" in r.out and "highest control rate: 2660 Hz" in r.out


def test_bus_load_with_reply_state_and_overload(cli: Cli) -> None:
    quiet = cli("bus-load", "--motors", "6", "--rate", "200", "--reply-state", "--json").records()[0]
    polled = cli("bus-load", "--motors", "6", "--rate", "200", "--json").records()[0]
    assert quiet["frames_per_cycle"] == 12 and polled["frames_per_cycle"] == 18
    assert quiet["bits_per_cycle"] < polled["bits_per_cycle"]
    r = cli("bus-load", "--motors", "20", "--rate", "500", "--bitrate", "500k")
    assert "over 100 %" in r.out
    assert cli("bus-load", "--motors", "64", "--rate", "100").code == 2


def test_every_subcommand_takes_json() -> None:
    (commands,) = [a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction)]
    without = [
        name for name, p in commands.choices.items() if not any("--json" in a.option_strings for a in p._actions)
    ]
    assert without == []


def test_params_finding_nothing_fails_with_json_too(cli: Cli) -> None:
    r = cli("params", "no-such-parameter-word", "--json")
    assert r.code == 1 and r.out == "" and "no parameter matches" in r.err


def test_sim_json(cli: Cli) -> None:
    channel = "drempower-cli-sim-json"
    r = cli("sim", "--ids", "1,2", "--python-can", channel, "--duration", "0.05", "--json")
    assert r.code == 0
    start, attachment, running, stopped = r.records()
    assert start == {"motors": [1, 2], "bitrate": None, "time_scale": 1.0}
    assert attachment == {"attachment": "python-can", "interface": "virtual", "channel": channel}
    assert running == {"running": True} and stopped["stopped"] is True and stopped["bus_load"] is None


def test_sim_refuses_a_uart_of_another_motor(cli: Cli) -> None:
    r = cli("sim", "--ids", "1", "--uart-pty", "2", "--duration", "0.1")
    assert r.code == 2 and "drempower sim: error: --uart-pty 2 is not one of --ids" in r.err


def test_completion_script(cli: Cli) -> None:
    r = cli("completion", "bash")
    assert r.code == 0
    assert "complete -o default -F _drempower drempower" in r.out
    for word in ("monitor", "bus-load", "set-bitrate", "axis0.output_shaft.vel_limit", "--no-stop-on-exit"):
        assert word in r.out
    assert "--sim-time-scale" not in r.out


@pytest.mark.skipif(shutil.which("bash") is None, reason="needs bash")
def test_completion_in_bash(cli: Cli) -> None:
    script = cli("completion", "bash").out
    probe = script + (
        "COMP_WORDS=(drempower get --sim 1 1 axis0.output_shaft.vel_l); COMP_CWORD=5; _drempower; "
        'echo "${COMPREPLY[*]}"; '
        "COMP_WORDS=(drempower mon); COMP_CWORD=1; _drempower; "
        'echo "${COMPREPLY[*]}"'
    )
    out = subprocess.run(["bash", "-c", probe], capture_output=True, text=True, timeout=30, check=True).stdout
    assert out.splitlines() == ["axis0.output_shaft.vel_limit", "monitor"]


def test_demo(cli: Cli) -> None:
    r = cli("demo")
    assert r.code == 0, r.err
    lines = r.out.splitlines()
    assert lines[0].startswith("3 simulated motors") and "90, -45, 180 deg" in lines[0]
    assert "targets reached: 3/3" in r.out
    last = next(line for line in reversed(lines) if line.startswith("t = "))  # motors named by the naming rule
    assert [w for w in last.split() if w.startswith("motor")] == ["motor_1", "motor_2", "motor_3"]
    sync = next(line for line in lines if line.startswith("max sync error:"))
    assert float(sync.split()[3]) < 1.0


def test_demo_json(cli: Cli) -> None:
    r = cli("demo", "--motors", "2", "--json")
    assert r.code == 0, r.err
    (rec,) = r.records()
    assert rec["motors"] == [1, 2] and rec["targets_deg"] == [90.0, -45.0] and rec["reached"] == 2
    assert rec["move_time_s"] > 0 and rec["max_sync_error_deg"] < 1.0


def test_completion_json(cli: Cli) -> None:
    (rec,) = cli("completion", "bash", "--json").records()
    assert rec["shell"] == "bash" and rec["script"] == cli("completion", "bash").out


def test_demo_live_on_a_terminal(cli: Cli, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr("drempower.cli.demo.is_terminal", lambda stream: True)
    r = cli("demo", "--motors", "2")
    assert r.code == 0
    assert "\x1b[3F" in r.out and "motor_2  [" in r.out and "targets reached: 2/2" in r.out
