"""Commands that find their motors (no IDS: a quick scan) and their adapter (no connection: the USB ids)."""

from __future__ import annotations

import argparse
from dataclasses import dataclass

import pytest
from serial.tools import list_ports

from drempower.cli import _connect, build_parser
from drempower.sim import SimBus

from .conftest import Cli


def test_state_errors_and_monitor_without_ids_act_on_the_motors_found(cli: Cli, sim: SimBus) -> None:
    r = cli("state", "--json", "--sim", "1,2,3")
    assert r.code == 0 and [rec["id"] for rec in r.records()] == [1, 2, 3]
    assert "drempower: found motors 1, 2, 3" in r.err
    r = cli("errors", "--sim", "1,2,3")
    assert r.code == 0 and r.out.splitlines() == ["motor 1: no errors", "motor 2: no errors", "motor 3: no errors"]
    r = cli("monitor", "--duration", "0.2", "--json", "--sim", "1,2,3")
    assert r.code == 0 and {rec["id"] for rec in r.records()} == {1, 2, 3}, r.err
    r = cli("monitor", "--fields", "position", "--duration", "0.2", "--json", "--sim", "1,2,3")
    assert r.code == 0 and {rec["id"] for rec in r.records()} == {1, 2, 3}, r.err


def test_no_motor_found_is_a_failure_on_the_bus(cli: Cli, monkeypatch: pytest.MonkeyPatch) -> None:
    from drempower.client.api.bus_sync import Bus

    monkeypatch.setattr(Bus, "scan", lambda self, *a, **k: [])
    r = cli("state", "--sim", "1")
    assert r.code == 1 and "no motor answered a scan" in r.err, r.err


@dataclass
class _Port:
    device: str
    vid: int | None
    pid: int | None


def _ports(monkeypatch: pytest.MonkeyPatch, *ports: _Port) -> None:
    monkeypatch.setattr(list_ports, "comports", lambda *a, **k: list(ports))


def test_one_adapter_by_its_usb_ids_is_used_and_announced(cli: Cli, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(_connect, "_python_can_config", lambda: None)
    _ports(monkeypatch, _Port("/dev/ttyS0", None, None), _Port("/dev/ttyACM7", 0x0483, 0x5740))
    kw, how = _connect.connection_kwargs(cli_args("state", "1"))
    assert kw == {"interface": "adapter", "channel": "/dev/ttyACM7"} and "--serial /dev/ttyACM7" in how
    r = cli("state", "1")  # the port does not exist here: the announcement, then the failure to open it
    assert "drempower: using the USB-CAN adapter found on /dev/ttyACM7" in r.err and r.code == 1
    _ports(monkeypatch, _Port("/dev/ttyUSB3", 0x1A86, 0x7523))
    kw, _ = _connect.connection_kwargs(cli_args("state", "1"))
    assert kw["channel"] == "/dev/ttyUSB3"


def test_no_adapter_or_several_keep_the_message_and_name_what_was_found(
    cli: Cli, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(_connect, "_python_can_config", lambda: None)
    _ports(monkeypatch, _Port("/dev/ttyS0", None, None))
    r = cli("state", "1")
    assert r.code == 1 and "no connection given, no USB-CAN adapter found" in r.err
    _ports(monkeypatch, _Port("/dev/ttyACM0", 0x0483, 0x5740), _Port("/dev/ttyUSB0", 0x1A86, 0x7523))
    r = cli("state", "1")
    assert r.code == 1 and "USB-CAN adapters found on /dev/ttyACM0, /dev/ttyUSB0: choose one with --serial" in r.err
    monkeypatch.setattr(_connect, "_python_can_config", lambda: {"interface": "virtual", "channel": "x"})
    kw, how = _connect.connection_kwargs(cli_args("state", "1"))  # several: python-can's configuration, as before
    assert kw["interface"] == "virtual" and how.startswith("python-can configuration")


def cli_args(*argv: str) -> argparse.Namespace:
    return build_parser().parse_args(list(argv))
