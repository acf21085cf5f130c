"""The connection options and argument types every subcommand shares."""

from __future__ import annotations

import argparse

import pytest

from drempower.cli import _connect
from drempower.cli._connect import TIME_SCALE_ENV, bitrate, can_option, connection_kwargs, parse_ids, parse_targets

from .conftest import SLOW_LINK, Cli


def test_parse_ids_keeps_the_order() -> None:
    assert parse_ids("3,1,5-7") == [3, 1, 5, 6, 7]
    assert parse_targets("all") == [0] and parse_targets("2") == [2]
    for bad in ("1,1", "0", "64", "a", "", "3-1x"):
        with pytest.raises(argparse.ArgumentTypeError):
            parse_ids(bad)


def test_bitrates() -> None:
    assert [bitrate(t) for t in ("1M", "500k", "125000", "250K")] == [1_000_000, 500_000, 125_000, 250_000]
    for bad in ("0", "fast", "1.5", "inf", "-1M"):
        with pytest.raises(argparse.ArgumentTypeError):
            bitrate(bad)


def test_python_can_options_pass_through() -> None:
    assert can_option("host=127.0.0.1") == ("host", "127.0.0.1")
    assert can_option("port=29536") == ("port", 29536)
    assert can_option("fd=true") == ("fd", True)
    for bad in ("port", "=1", "a b=1"):
        with pytest.raises(argparse.ArgumentTypeError):
            can_option(bad)
    args = argparse.Namespace(
        sim=None,
        serial=None,
        uart=None,
        interface="socketcand",
        channel="can0",
        bitrate=None,
        timeout=None,
        can_option=[("host", "127.0.0.1"), ("port", 29536)],
        sim_time_scale=None,
    )
    kw, how = connection_kwargs(args)
    assert kw == {"interface": "socketcand", "channel": "can0", "host": "127.0.0.1", "port": 29536}
    assert how == "socketcand can0"  # drempower's own client
    args.interface = "python-can:socketcand"
    assert connection_kwargs(args)[1] == "python-can socketcand can0"
    args.interface, args.channel, args.can_option = "pcan", "PCAN_USBBUS1", []
    assert connection_kwargs(args)[1] == "python-can pcan PCAN_USBBUS1"


def test_ids_named_twice_across_words(cli: Cli) -> None:
    r = cli("state", "1,2", "2", "--sim", "1,2")
    assert r.code == 2 and "motor 2 named twice" in r.err


def test_one_connection_only(cli: Cli) -> None:
    r = cli("state", "1", "--sim", "1", "--serial", "/dev/null")
    assert r.code == 2 and r.err.startswith("usage: drempower state ")
    assert r.err.endswith("drempower state: error: give one connection: --serial, --sim conflict\n")
    r = cli("state", "1", "--uart", "/dev/null", "-i", "virtual")
    assert r.code == 2 and "give one connection: --uart, -i/--interface conflict" in r.err


def test_python_can_options_need_a_python_can_interface(cli: Cli, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(_connect, "_python_can_config", lambda: None)
    r = cli("state", "1", "-c", "can0")
    assert r.code == 2
    assert "drempower state: error: -c/--channel needs -i/--interface (no python-can configuration names" in r.err
    r = cli("state", "1", "-o", "port=1")
    assert r.code == 2 and "-o/--can-option needs -i/--interface" in r.err
    r = cli("state", "1", "--sim", "1", "-c", "can0")
    assert r.code == 2 and "-c/--channel: only with -i/--interface, not with --sim" in r.err


def test_channel_and_options_add_to_the_python_can_configuration(
    cli: Cli, virtual_channel: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    config = {"interface": "virtual", "channel": "drempower-cli-nowhere"}
    monkeypatch.setattr(_connect, "_python_can_config", lambda: config)
    r = cli("state", "2", "-c", virtual_channel, "-o", "receive_own_messages=false", "--json", *SLOW_LINK)
    assert r.code == 0 and r.records()[0]["id"] == 2
    assert r.err == f"drempower: using python-can configuration: virtual {virtual_channel}\n"


def test_without_connection_or_configuration(cli: Cli, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(_connect, "_python_can_config", lambda: None)
    r = cli("state", "1")
    assert r.code == 1 and "no connection given, no USB-CAN adapter found and no python-can configuration" in r.err


def test_python_can_configuration_is_used_and_announced(
    cli: Cli, virtual_channel: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(_connect, "_python_can_config", lambda: {"interface": "virtual", "channel": virtual_channel})
    r = cli("state", "2", "--json", *SLOW_LINK)
    assert r.code == 0 and r.records()[0]["id"] == 2
    assert r.err == f"drempower: using python-can configuration: virtual {virtual_channel}\n"
    r = cli("state", "2", "-i", "virtual", "-c", virtual_channel, "-b", "1M", *SLOW_LINK)
    assert r.code == 0 and r.err == ""


def test_a_missing_serial_port_is_one_line(cli: Cli) -> None:
    r = cli("state", "1", "--serial", "/nonexistent/ttyACM9")
    assert r.code == 1 and r.err.count("\n") == 1 and "/nonexistent/ttyACM9" in r.err


def test_simulator_time_scale(cli: Cli, monkeypatch: pytest.MonkeyPatch) -> None:
    assert cli("state", "1", "--sim", "1", "--sim-time-scale", "5").code == 0
    monkeypatch.setenv(TIME_SCALE_ENV, "fast")
    r = cli("state", "1", "--sim", "1")
    assert r.code == 1 and TIME_SCALE_ENV in r.err


def test_socketcand_through_python_can_options(cli: Cli) -> None:
    """A python-can interface that needs extra options (socketcand: host, port) reaches served motors."""
    from drempower.sim import SimBus, SimRunner, attach_socketcand

    bus = SimBus(ids=[4])
    with SimRunner(bus, time_scale=20.0), attach_socketcand(bus) as server:
        opts = ["-i", "socketcand", "-c", "can0", "-o", "host=127.0.0.1", "-o", f"port={server.port}", *SLOW_LINK]
        r = cli("move", "4", "30", "--mode", "q", "--speed", "100", "--accel", "300", "--wait", *opts)
        assert r.code == 0, r.err
        r = cli("state", "4", "--json", *opts)
        assert r.code == 0, r.err
        assert r.records()[0]["position_deg"] == pytest.approx(30.0, abs=0.05)
    assert bus.motors[4].position == pytest.approx(30.0, abs=0.05)


def test_bitrate_is_refused_with_the_adapter(cli: Cli) -> None:
    r = cli("state", "1", "--serial", "/nonexistent/ttyACM9", "-b", "1M")
    assert r.code == 2 and "-b/--bitrate: not with --serial" in r.err and "vendor's configuration tool" in r.err
