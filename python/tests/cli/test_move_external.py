"""``move --wait`` against an external ``drempower sim`` process: over the adapter pty, the
UART pty and socketcand, with stale state frames about and with the 1 Mbit/s timing model
and bxCAN-like transmit mailboxes (priority:3)."""

from __future__ import annotations

import re
import subprocess
import sys
from collections.abc import Iterator
from dataclasses import dataclass

import pytest

import drempower

from .conftest import Cli

_LINK = ("--timeout", "2")
_FAST = ("--speed", "120", "--accel", "300")


@dataclass
class ExternalSim:
    adapter: str
    uart: str
    host: str
    port: int

    def link(self, kind: str) -> tuple[str, ...]:
        """CLI connection options of attachment ``kind``."""
        if kind == "adapter":
            return ("--serial", self.adapter, *_LINK)
        if kind == "uart":
            return ("--uart", self.uart, *_LINK)
        return ("-i", "socketcand", "-c", "can0", "-o", f"host={self.host}", "-o", f"port={self.port}", *_LINK)

    def bus(self, kind: str) -> drempower.Bus:
        if kind == "adapter":
            return drempower.open_bus("adapter", self.adapter, timeout=2, stop_on_close=False)
        if kind == "uart":
            return drempower.open_bus("uart", self.uart, timeout=2, stop_on_close=False)
        return drempower.open_bus("socketcand", "can0", host=self.host, port=self.port, timeout=2, stop_on_close=False)


@pytest.fixture
def external() -> Iterator[ExternalSim]:
    """``drempower sim --ids 1,2,3 --bitrate 1M --host-queue priority:3`` with every serial and TCP attachment.

    One per test: the adapter pty keeps the frames of the bus (heartbeats) while no client has it open,
    as a USB adapter's buffer does, and the next test would read them first."""
    argv = ["--ids", "1,2,3", "--bitrate", "1M", "--host-queue", "priority:3", "--adapter-pty", "--uart-pty", "1"]
    proc = subprocess.Popen(
        [sys.executable, "-m", "drempower", "sim", *argv, "--socketcand-port", "0"],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    assert proc.stdout is not None
    text = ""
    try:
        while "Ctrl-C stops" not in text:
            line = proc.stdout.readline()
            if not line:
                pytest.fail(f"the simulator did not start: {text}")
            text += line
        adapter = re.search(r"adapter \(0xAA frames and slcan\): (\S+)", text)
        uart = re.search(r"UART of motor 1 \(11-byte frames\): (\S+)", text)
        tcp = re.search(r"socketcand: (\S+) port (\d+)", text)
        assert adapter and uart and tcp, text
        yield ExternalSim(adapter.group(1), uart.group(1), tcp.group(1), int(tcp.group(2)))
    finally:
        proc.terminate()
        try:
            proc.wait(10)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(5)


def _positions(external: ExternalSim, kind: str, ids: list[int]) -> list[float]:
    with external.bus(kind) as bus:
        return [bus.motor(i).get_state().angle for i in ids]


def _chatty(cli: Cli, external: ExternalSim, kind: str, ids: str, source: str) -> None:
    """Turn the motors' own state frames on: replies to commands, heartbeats or both."""
    link = external.link(kind)
    reply, beat = ("1" if source in ("reply_state", "both") else "0"), ("5" if source in ("heartbeat", "both") else "0")
    r = cli("set", ids, "axis0.config.extra_setting.enable_reply_state", reply, *link)
    assert r.code == 0, r.err
    r = cli("set", ids, "can.config.heartbeat_ms", beat, *link)
    assert r.code == 0, r.err


@pytest.mark.parametrize("kind", ["adapter", "socketcand"])
@pytest.mark.parametrize("source", ["reply_state", "heartbeat", "both"])
def test_three_motor_move_wait_reaches_every_target(cli: Cli, external: ExternalSim, kind: str, source: str) -> None:
    _chatty(cli, external, kind, "1,2,3", source)
    goal = [90.0, -45.0, 180.0] if source != "heartbeat" else [-30.0, 60.0, 10.0]
    text = ",".join(f"{a:g}" for a in goal)
    r = cli("move", "1,2,3", text, *_FAST, "--wait", "--json", *external.link(kind))
    assert r.code == 0, r.err
    assert [rec["position_deg"] for rec in r.records()] == pytest.approx(goal, abs=0.5)
    assert _positions(external, kind, [1, 2, 3]) == pytest.approx(goal, abs=0.5)
    r = cli("move", "1,2,3", "0", *_FAST, "--wait", *external.link(kind))
    assert r.code == 0, r.err


@pytest.mark.parametrize("source", ["reply_state", "heartbeat", "both"])
def test_uart_move_wait_reaches_the_target(cli: Cli, external: ExternalSim, source: str) -> None:
    _chatty(cli, external, "uart", "1", source)
    r = cli("move", "1", "75", *_FAST, "--wait", "--json", *external.link("uart"))
    assert r.code == 0, r.err
    assert r.records()[0]["position_deg"] == pytest.approx(75, abs=0.5)
    assert cli("move", "1", "0", *_FAST, "--wait", *external.link("uart")).code == 0


@pytest.mark.parametrize("kind", ["adapter", "uart", "socketcand"])
def test_move_wait_beyond_the_angle_limits_exits_1(cli: Cli, external: ExternalSim, kind: str) -> None:
    with external.bus(kind) as bus:
        bus.motor(1).set_angle_range(-20, 20)
    r = cli("move", "1", "90", *_FAST, "--wait", *external.link(kind))
    assert r.code == 1 and "done" not in r.out
    assert "motor 1" in r.err and "target 90.00 deg" in r.err and "reached 20.0" in r.err, r.err
