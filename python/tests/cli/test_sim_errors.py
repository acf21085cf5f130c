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
