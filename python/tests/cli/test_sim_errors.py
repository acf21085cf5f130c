"""``drempower sim`` mistakes end in one line naming what to do, not a traceback."""

from __future__ import annotations

import socket
from pathlib import Path

from .conftest import Cli


def _one_line(err: str) -> str:
    assert err.count("\n") == 1 and "Traceback" not in err, err
    return err


def test_socketcand_port_in_use(cli: Cli) -> None:
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        r = cli("sim", "--socketcand-port", str(port), "--duration", "0.1")
    assert r.code == 1
    err = _one_line(r.err)
    assert err.startswith(f"drempower: error: sim --socketcand-port {port}: ")
    assert "give another with --socketcand-port, or 0 for a free one" in err


def test_config_dir_that_cannot_be_written(cli: Cli, tmp_path: Path) -> None:
    a_file = tmp_path / "file"
    a_file.write_text("")
    r = cli("sim", "--config-dir", str(a_file / "motors"), "--duration", "0.1")
    assert r.code == 1 and r.out == ""
    err = _one_line(r.err)
    assert err.startswith(f"drempower: error: sim --config-dir {a_file / 'motors'}: cannot write there (")
    assert "give a directory you can write" in err


def test_config_dir_is_made_when_missing(cli: Cli, tmp_path: Path) -> None:
    folder = tmp_path / "new" / "motors"
    assert cli("sim", "--config-dir", str(folder), "--duration", "0.05", "--python-can", "drempower-b13").code == 0
    assert folder.is_dir()


def test_python_can_socketcan_without_the_interface(cli: Cli) -> None:
    r = cli("sim", "--python-can", "nosuchcan9", "--python-can-interface", "socketcan", "--duration", "0.1")
    assert r.code == 1
    err = _one_line(r.err)
    assert err.startswith("drempower: error: sim --python-can nosuchcan9 --python-can-interface socketcan: ")
    assert "sudo ip link add dev nosuchcan9 type vcan" in err


def test_python_can_unknown_interface(cli: Cli) -> None:
    r = cli("sim", "--python-can", "x", "--python-can-interface", "nosuch", "--duration", "0.1")
    assert r.code == 1
    assert 'Unknown interface type "nosuch"' in _one_line(r.err)


def test_python_can_socketcand_without_host_and_port(cli: Cli) -> None:
    r = cli("sim", "--python-can", "1", "--python-can-interface", "socketcand", "--duration", "0.1")
    assert r.code == 1
    err = _one_line(r.err)
    assert err == (
        "drempower: error: sim --python-can 1 --python-can-interface socketcand: the interface needs host and port: "
        "give --python-can-option host=... --python-can-option port=...\n"
    )


def test_python_can_option_without_python_can(cli: Cli) -> None:
    r = cli("sim", "--python-can-option", "port=1", "--duration", "0.1")
    assert (
        r.code == 2 and r.err.splitlines()[-1] == "drempower sim: error: --python-can-option needs --python-can CHANNEL"
    )


def test_python_can_options_reach_the_interface(cli: Cli) -> None:
    """The simulator joins another simulator's socketcand server as a python-can client."""
    from drempower.sim import SimBus, attach_socketcand

    with attach_socketcand(SimBus([5]), 0) as server:
        r = cli(
            "sim",
            "--python-can",
            server.channel,
            "--python-can-interface",
            "socketcand",
            "--python-can-option",
            f"host={server.host}",
            "--python-can-option",
            f"port={server.port}",
            "--duration",
            "0.2",
            "--json",
        )
    assert r.code == 0, r.err
    assert {
        "attachment": "python-can",
        "interface": "socketcand",
        "channel": server.channel,
        "options": {"host": server.host, "port": server.port},
    } in r.records()


def test_noise_out_of_range_names_the_field_value_and_range(cli: Cli, tmp_path: Path) -> None:
    r = cli("sim", "--noise", "position=0.01,speed=12", "--duration", "0.1")
    assert r.code == 2
    assert "argument --noise: noise speed=12.0: expected a standard deviation 0..10 r/min" in r.err
    assert "Traceback" not in r.err
    robot = tmp_path / "noisy.toml"
    robot.write_text('[buses.arm]\ninterface = "sim"\nnoise = {torque = -1}\n[joints.a]\nbus = "arm"\nid = 1\n')
    r = cli("sim", "--robot", str(robot), "--duration", "0.1")
    assert r.code == 2 and r.out == ""
    err = _one_line(r.err)
    assert err == f"drempower: error: {robot}: [buses.arm]: noise torque=-1: expected a standard deviation 0..1 Nm\n"
