"""The adapter as a python-can interface: python-can's own logger and player through the simulated adapter's pty."""

from __future__ import annotations

import json
import os
import select
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import can
import pytest

from drempower.protocol import DataType, PositionQ, WriteParam, decode_reply
from drempower.protocol.messages import State
from drempower.sim import SimBus, SimRunner, attach_adapter_pty
from drempower.sim.adapter_pty import AdapterPty


@pytest.fixture
def adapter() -> Iterator[tuple[SimBus, AdapterPty]]:
    bus = SimBus([1, 2])
    with SimRunner(bus), attach_adapter_pty(bus) as pty:
        yield bus, pty


def _eventually(check: object, limit: float = 5.0) -> bool:
    deadline = time.monotonic() + limit
    while time.monotonic() < deadline:
        if check():  # type: ignore[operator]
            return True
        time.sleep(0.02)
    return False


def test_entry_point_is_registered() -> None:
    assert "drempower_adapter" in can.interfaces.VALID_INTERFACES


def test_python_can_bus_through_the_adapter(adapter: tuple[SimBus, AdapterPty]) -> None:
    sim, pty = adapter
    with can.Bus(interface="drempower_adapter", channel=pty.path) as bus:
        f = PositionQ(1, 30.0, 60.0, 300.0).encode()
        bus.send(can.Message(arbitration_id=f.arbitration_id, data=f.data, is_extended_id=False))
        assert _eventually(lambda: abs(sim.motors[1].position - 30.0) <= 0.05)
        bus.send(can.Message(arbitration_id=0x03E, data=bytes(8), is_extended_id=False))  # fast read
        msg = bus.recv(2.0)
        assert msg is not None and msg.arbitration_id & 0x1F in (1, 3) and msg.timestamp > 1e9
        assert isinstance(decode_reply(msg.arbitration_id, bytes(msg.data)), State)


def test_bitrate_and_missing_port_are_refused(tmp_path: Path) -> None:
    with pytest.raises(can.CanInitializationError, match="vendor's configuration tool"):
        can.Bus(interface="drempower_adapter", channel="loop://", bitrate=500_000)
    with pytest.raises(can.CanInitializationError, match="no-such-port"):
        can.Bus(interface="drempower_adapter", channel=str(tmp_path / "no-such-port"))


def test_python_can_logger_and_player(adapter: tuple[SimBus, AdapterPty], tmp_path: Path) -> None:
    sim, pty = adapter
    for node in (1, 2):  # heartbeats every 20 ms
        sim.send(WriteParam(node, 21004, DataType.U32, 20).encode())
    log = tmp_path / "heartbeats.asc"
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    logger = subprocess.Popen(
        [sys.executable, "-m", "can.logger", "-i", "drempower_adapter", "-c", pty.path, "-f", str(log)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        env=env,
    )
    try:
        # the logger says it is connected before it logs: the 1.5 s of heartbeats count from there (a loaded
        # machine may take seconds to start an interpreter)
        assert logger.stdout is not None
        ready, _, _ = select.select([logger.stdout], [], [], 60.0)
        assert ready and b"Connected to" in logger.stdout.readline()
        time.sleep(1.5)
    finally:
        logger.send_signal(signal.SIGINT)
        _, err = logger.communicate(timeout=20)
    assert logger.returncode in (0, 130, -signal.SIGINT), err
    states = [decode_reply(m.arbitration_id, bytes(m.data)) for m in can.LogReader(log)]
    assert {s.node for s in states} == {1, 2} and all(isinstance(s, State) for s in states)
    assert len(states) >= 10

    # the player sends a recorded command through the adapter: the motor moves
    for node in (1, 2):
        sim.send(WriteParam(node, 21004, DataType.U32, 0).encode())
    cmd = tmp_path / "move.log"
    f = PositionQ(2, -45.0, 60.0, 300.0).encode()
    cmd.write_text(f"(1700000000.000000) can0 {f.arbitration_id:03X}#{f.data.hex().upper()} T\n")
    r = subprocess.run(
        [sys.executable, "-m", "can.player", "-i", "drempower_adapter", "-c", pty.path, str(cmd)],
        capture_output=True,
        text=True,
        timeout=60,
        env=env,
    )
    assert r.returncode == 0, r.stderr
    assert _eventually(lambda: abs(sim.motors[2].position + 45.0) <= 0.05)


@pytest.mark.parametrize("suffix", [".log", ".asc"])
def test_python_can_logger_file_reads_back_and_decodes(tmp_path: Path, suffix: str) -> None:
    """can.logger through the adapter of an external `drempower sim`: can.LogReader and `drempower decode` read it."""
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    sim = subprocess.Popen(
        [sys.executable, "-m", "drempower", "sim", "--ids", "1,2", "--adapter-pty", "--json", "--duration", "60"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
    )
    try:
        assert sim.stdout is not None
        path = ""
        while not path:
            line = json.loads(sim.stdout.readline())
            path = line.get("path", "") if line.get("attachment") == "adapter" else ""
        with can.Bus(interface="drempower_adapter", channel=path) as bus:  # heartbeats every 20 ms
            for node in (1, 2):
                f = WriteParam(node, 21004, DataType.U32, 20).encode()
                bus.send(can.Message(arbitration_id=f.arbitration_id, data=f.data, is_extended_id=False))
        log = tmp_path / f"x{suffix}"
        logger = subprocess.Popen(
            [sys.executable, "-m", "can.logger", "-i", "drempower_adapter", "-c", path, "-f", str(log)],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            env=env,
        )
        try:
            assert logger.stdout is not None
            assert "Connected to" in logger.stdout.readline()  # the bus is open: heartbeats are logged from now
            time.sleep(1.0)
        finally:
            logger.send_signal(signal.SIGINT)
            _, err = logger.communicate(timeout=20)
        assert logger.returncode in (0, 130, -signal.SIGINT), err
    finally:
        sim.send_signal(signal.SIGINT)
        sim.communicate(timeout=20)
    msgs = list(can.LogReader(log))
    assert len(msgs) >= 10
    assert {decode_reply(m.arbitration_id, bytes(m.data)).node for m in msgs} == {1, 2}
    if suffix == ".log":
        assert {m.channel for m in msgs} == {path}  # the channel's name, one word
        assert path in log.read_text().splitlines()[0].split()
    r = subprocess.run(
        [sys.executable, "-m", "drempower", "decode", "--json", str(log)],
        capture_output=True,
        text=True,
        timeout=60,
        env=env,
    )
    assert r.returncode == 0, r.stderr
    decoded = [json.loads(line) for line in r.stdout.splitlines()]
    assert len(decoded) == len(msgs) and all(d["command"] == "state" for d in decoded), decoded[:3]
