"""Every attachment exercised from a real client: python-can (virtual, slcan, socketcand) and raw serial."""

from __future__ import annotations

import subprocess
import sys
import textwrap
import time
from collections.abc import Callable, Iterator

import can
import pytest
import serial

from drempower.protocol import (
    AADecoder,
    FastRead,
    PositionQ,
    ReadParam,
    State,
    Uart11Decoder,
    decode_reply,
    encode_aa,
    encode_uart11,
)
from drempower.protocol.ids import Frame
from drempower.sim import (
    Faults,
    SimBus,
    SimRunner,
    attach_adapter_pty,
    attach_python_can,
    attach_socketcand,
    attach_uart_pty,
)
from drempower.transports import open_transport


@pytest.fixture
def bus() -> Iterator[SimBus]:
    b = SimBus([1, 2])
    with SimRunner(b):
        yield b


def _msg(frame: Frame) -> can.Message:
    return can.Message(arbitration_id=frame.arbitration_id, data=frame.data, is_extended_id=False)


def _reply(msg: can.Message | None) -> object:
    assert msg is not None
    return decode_reply(msg.arbitration_id, bytes(msg.data))


def _read_exactly(port: serial.Serial, n: int, limit: float = 2.0) -> bytes:
    data = b""
    deadline = time.monotonic() + limit
    while len(data) < n and time.monotonic() < deadline:
        data += port.read(n - len(data))
    return data


def _eventually(condition: Callable[[], bool], limit: float = 2.0) -> bool:
    deadline = time.monotonic() + limit
    while not condition() and time.monotonic() < deadline:
        time.sleep(0.005)
    return condition()


def test_python_can_virtual(bus: SimBus) -> None:
    with attach_python_can(bus, channel="sim-test-virtual") as att:
        assert att.can_bus.channel_info
        client = can.Bus(interface="virtual", channel="sim-test-virtual")
        try:
            client.send(_msg(FastRead(2).encode()))
            s = _reply(client.recv(2.0))
            assert isinstance(s, State) and s.node == 2
        finally:
            client.shutdown()


def test_python_can_slcan_over_the_adapter_pty(bus: SimBus) -> None:
    with attach_adapter_pty(bus) as pty:
        client = can.Bus(interface="slcan", channel=pty.path, bitrate=1_000_000, sleep_after_open=0)
        try:
            client.send(_msg(ReadParam.of(1, "axis0.config.can_node_id").encode()))
            answer = _reply(client.recv(2.0))
            assert answer.value == 1  # type: ignore[attr-defined]
            assert pty.slcan.is_open and pty.slcan.bitrate_code == 8
            client.send(_msg(PositionQ(1, 45.0, 60.0, 300.0).encode()))
            assert _eventually(lambda: abs(bus.motors[1].position - 45.0) <= 0.05, 3.0)
        finally:
            client.shutdown()
        assert _eventually(lambda: not pty.slcan.is_open)


def test_slcan_commands_and_errors(bus: SimBus) -> None:
    with attach_adapter_pty(bus) as pty, serial.Serial(pty.path, timeout=0.2) as port:
        port.write(b"V\rN\rt03E80000000000000000\rS8\rO\rS6\rF\rX\r")
        expected = b"V2003\rN0001\r" + b"\a" + b"\r\r" + b"\a" + b"F00\r" + b"\a"
        assert _read_exactly(port, len(expected)) == expected
        port.write(b"t03E80000000000000000\r")
        assert _read_exactly(port, 2) == b"z\r"
        assert _read_exactly(port, 22) == b"t02380000000000000000\r"
        port.write(b"C\r")
        assert _read_exactly(port, 1) == b"\r"


def test_raw_aa_frames_with_garbage_both_ways(bus: SimBus) -> None:
    bus.faults = Faults(serial_garbage=0.5)
    with attach_adapter_pty(bus) as pty, serial.Serial(pty.path, timeout=0.2) as port:
        port.write(b"\x00\xaa\x17junk\xaa\x00" + encode_aa(FastRead(1).encode()) + b"\xff")
        port.write(encode_aa(FastRead(2).encode())[:7])
        port.write(encode_aa(FastRead(2).encode())[7:])  # a frame split across writes
        decoder = AADecoder()
        frames: list[Frame] = []
        deadline = time.monotonic() + 2.0
        while len(frames) < 2 and time.monotonic() < deadline:
            frames += decoder.feed(port.read(64))
        assert [decode_reply(*f[:2]).node for f in frames] == [1, 2]
        assert pty.dropped >= 7


def test_project_adapter_transport_on_the_pty(bus: SimBus) -> None:
    with attach_adapter_pty(bus) as pty:
        t = open_transport("adapter", pty.path)
        try:
            t.send(FastRead(1).encode())
            f = t.recv(2.0)
            assert f is not None and f.arbitration_id == 0x023
        finally:
            t.close()


def test_uart_pty_reaches_only_its_motor_with_garbage_and_heartbeats(bus: SimBus) -> None:
    bus.faults = Faults(serial_garbage=0.3)
    with attach_uart_pty(bus, 2) as uart, serial.Serial(uart.path, timeout=0.02) as port:
        port.write(b"\x08\x99garbage" + encode_uart11(*FastRead(0).encode()[:2]))
        port.write(encode_uart11(*FastRead(1).encode()[:2]))  # another motor: not reachable
        decoder = Uart11Decoder()
        frames: list[Frame] = []
        deadline = time.monotonic() + 2.0
        while not frames and time.monotonic() < deadline:
            frames += decoder.feed(port.read(64))
        time.sleep(0.1)
        frames += decoder.feed(port.read(4096))
        assert [f.arbitration_id for f in frames] == [0x043]
        assert uart.decoder.dropped >= 9
        bus.motors[2].set_param("can.config.heartbeat_ms", 50)
        beats: list[Frame] = []
        deadline = time.monotonic() + 2.0
        while len(beats) < 2 and time.monotonic() < deadline:
            beats += decoder.feed(port.read(4096))
        assert len(beats) >= 2 and {f.arbitration_id for f in beats} == {0x043}


def test_project_uart_transport_on_the_pty(bus: SimBus) -> None:
    with attach_uart_pty(bus, 1) as uart:
        t = open_transport("uart", uart.path)
        try:
            t.send(FastRead(1).encode())
            f = t.recv(2.0)
            assert f is not None and f.arbitration_id == 0x023
        finally:
            t.close()


def test_socketcand_from_another_process(bus: SimBus) -> None:
    with attach_socketcand(bus) as server:
        client = textwrap.dedent(
            f"""
            import can
            b = can.Bus(interface="socketcand", host="127.0.0.1", port={server.port}, channel="can0")
            b.send(can.Message(arbitration_id=0x01E, data=bytes(8), is_extended_id=False))
            got = sorted(m.arbitration_id for m in (b.recv(5.0), b.recv(5.0)) if m is not None)
            b.shutdown()
            print(" ".join(hex(i) for i in got))
            """
        )
        out = subprocess.run([sys.executable, "-c", client], capture_output=True, text=True, timeout=30)
        assert out.returncode == 0, out.stderr
        assert out.stdout.split() == ["0x23", "0x43"]


def test_socketcand_refuses_other_buses_and_non_loopback(bus: SimBus) -> None:
    with pytest.raises(ValueError):
        attach_socketcand(bus, host="0.0.0.0")
    with attach_socketcand(bus, channel="can0") as server, pytest.raises(can.CanError):
        can.Bus(interface="socketcand", host="127.0.0.1", port=server.port, channel="vcan9")


def test_nobody_reading_the_adapter_pty_does_not_hold_the_bus_up() -> None:
    sim = SimBus([1, 2, 3, 4])
    for m in sim.motors.values():
        m.set_param("can.config.heartbeat_ms", 1)
    with SimRunner(sim, time_scale=5.0), attach_adapter_pty(sim) as pty:
        assert _eventually(lambda: sim.now > 1.0, 5.0)  # > 4000 frames, more than the queue holds
        with serial.Serial(pty.path, timeout=0.05) as port:
            backlog = port.read(1 << 20)
            assert len(backlog) <= (1 << 16) + (1 << 15)
            assert len(AADecoder().feed(backlog)) > 0
            before = sim.now
            assert _eventually(lambda: sim.now > before + 0.2)


def test_every_attachment_sees_the_other_hosts_frames_but_not_its_own() -> None:
    """As on a CAN bus: a sniffer on python-can sees what a host sends through the adapter pty."""
    from drempower.transports.sim import SimTransport

    sim = SimBus([1])
    with attach_python_can(sim, "drempower-sim-hosts"), attach_adapter_pty(sim) as pty:
        sniffer = can.Bus(interface="virtual", channel="drempower-sim-hosts")
        local = SimTransport(bus=sim, time_scale=0)
        adapter = open_transport("adapter", pty.path)
        try:
            adapter.send(FastRead(1).encode())
            seen = [sniffer.recv(2.0) for _ in range(2)]
            assert [m.arbitration_id for m in seen if m is not None] == [0x03E, 0x023]
            got = adapter.recv(2.0)
            assert got is not None and got.arbitration_id == 0x023  # the reply, not its own request
            assert adapter.recv(0.2) is None
            heard = [local.recv(1.0), local.recv(1.0), local.recv(0.05)]
            assert [f.arbitration_id if f else None for f in heard] == [0x03E, 0x023, None]
            local.send(FastRead(1).encode())
            assert [local.recv(1.0), local.recv(0.05)] == [Frame(0x023, got.data), None]
            heard = [adapter.recv(2.0), adapter.recv(2.0)]
            assert [f.arbitration_id if f else None for f in heard] == [0x03E, 0x023]  # the other host's
        finally:
            adapter.close()
            local.close()
            sniffer.shutdown()
