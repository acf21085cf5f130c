"""``drempower sim``: where to connect, the attachments work, a clean stop."""

from __future__ import annotations

import io
import re
import threading
import time
from pathlib import Path

import can
import pytest

from drempower.cli import build_parser, main, sim
from drempower.protocol import FastRead, decode_reply
from drempower.transports import open_transport


def _start(argv: list[str]) -> tuple[threading.Thread, threading.Event, io.StringIO]:
    args = build_parser().parse_args(["sim", *argv])
    out, stop = io.StringIO(), threading.Event()
    thread = threading.Thread(target=sim.run, args=(args, out, stop))
    thread.start()
    deadline = time.monotonic() + 5.0
    while "Ctrl-C stops" not in out.getvalue() and time.monotonic() < deadline:
        time.sleep(0.01)
    return thread, stop, out


def test_duration_and_summary(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["sim", "--ids", "1,2", "--socketcand-port", "0", "--duration", "0.1"]) == 0
    text = capsys.readouterr().out
    assert "motors 1,2" in text and "socketcand: 127.0.0.1 port" in text
    assert "stopped after" in text


def test_default_attachments_reach_the_motors(tmp_path: Path) -> None:
    thread, stop, out = _start(["--ids", "1,2,3", "--bitrate", "1M", "--config-dir", str(tmp_path)])
    try:
        text = out.getvalue()
        pty = re.search(r"adapter \(0xAA frames and slcan\): (\S+)", text)
        port = re.search(r"socketcand: 127\.0\.0\.1 port (\d+)", text)
        assert pty and port, text
        t = open_transport("adapter", pty.group(1))
        try:
            t.send(FastRead(3).encode())
            f = t.recv(2.0)
            assert f is not None and decode_reply(*f[:2]).node == 3
        finally:
            t.close()
        client = can.Bus(interface="socketcand", host="127.0.0.1", port=int(port.group(1)), channel="can0")
        try:
            f2 = FastRead(2).encode()
            client.send(can.Message(arbitration_id=f2.arbitration_id, data=f2.data, is_extended_id=False))
            msg = client.recv(2.0)
            assert msg is not None and msg.arbitration_id == 0x043
        finally:
            client.shutdown()
    finally:
        stop.set()
        thread.join(5.0)
    assert not thread.is_alive()
    assert "bus load" in out.getvalue()


def test_uart_and_python_can_attachments() -> None:
    thread, stop, out = _start(["--ids", "4", "--uart-pty", "4", "--python-can", "cli-sim-test"])
    try:
        text = out.getvalue()
        uart = re.search(r"UART of motor 4 \(11-byte frames\): (\S+)", text)
        assert uart and "adapter" not in text, text
        t = open_transport("uart", uart.group(1))
        try:
            t.send(FastRead(4).encode())
            f = t.recv(2.0)
            assert f is not None and f.arbitration_id == 0x083
        finally:
            t.close()
        client = can.Bus(interface="virtual", channel="cli-sim-test")
        try:
            client.send(can.Message(arbitration_id=0x09E, data=bytes(8), is_extended_id=False))
            msg = client.recv(2.0)
            assert msg is not None and msg.arbitration_id == 0x083
        finally:
            client.shutdown()
    finally:
        stop.set()
        thread.join(5.0)


def test_uart_id_must_be_simulated(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["sim", "--ids", "1", "--uart-pty", "2", "--duration", "0.1"]) == 2
    assert "--uart-pty 2" in capsys.readouterr().err


def test_faults_from_the_command_line() -> None:
    thread, stop, out = _start(["--ids", "1", "--adapter-pty", "--drop-rate", "1"])
    try:
        pty = re.search(r"adapter \(0xAA frames and slcan\): (\S+)", out.getvalue())
        assert pty
        t = open_transport("adapter", pty.group(1))
        try:
            t.send(FastRead(1).encode())
            assert t.recv(0.2) is None
        finally:
            t.close()
    finally:
        stop.set()
        thread.join(5.0)


def test_rates_are_probabilities(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit):
        build_parser().parse_args(["sim", "--drop-rate", "1.5"])
    assert "probability" in capsys.readouterr().err
