"""drempower's slcan transport: the lines it writes, what it reads, timeouts and matching, against a scripted
device on a pseudo-terminal and against the simulated adapter."""

from __future__ import annotations

import os
import select
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager

import pytest

import drempower
from drempower.errors import ValidationError
from drempower.protocol import FastRead, State
from drempower.protocol.ids import Frame
from drempower.protocol.slcan import encode_slcan
from drempower.sim import SimBus, attach_adapter_pty
from drempower.transports import TransportError, open_transport
from drempower.transports.slcan import SlcanTransport

from .test_transport_faults import raw_pty as device  # a raw pty: (the device's end, the port's path)

pytestmark = pytest.mark.skipif(os.name != "posix", reason="pseudo-terminals")


def read_lines(fd: int, count: int, limit: float = 5.0) -> list[bytes]:
    """The next ``count`` CR-terminated lines the host wrote (fails after ``limit`` s)."""
    buf = b""
    deadline = time.monotonic() + limit
    while buf.count(b"\r") < count:
        left = deadline - time.monotonic()
        assert left > 0 and select.select([fd], [], [], left)[0], f"got only {buf!r}"
        buf += os.read(fd, 4096)
    return [line + b"\r" for line in buf.split(b"\r")[:count]]


def quiet(fd: int, seconds: float = 0.1) -> bool:
    """True when the host writes nothing for ``seconds``."""
    return not select.select([fd], [], [], seconds)[0]


def test_golden_lines_on_the_wire() -> None:
    with device() as (dev, path):
        t = open_transport("slcan", path, 500_000, sleep_after_open=0)
        try:
            assert read_lines(dev, 3) == [b"C\r", b"S6\r", b"O\r"]
            assert isinstance(t, SlcanTransport) and t.wire_bitrate == 500_000
            assert "slcan" in t.description and path in t.description
            t.send(FastRead(1).encode())
            assert read_lines(dev, 1) == [b"t03E80000000000000000\r"]
            reply = Frame(0x043, bytes.fromhex("0000b4429600e7ff"))
            os.write(dev, b"\r\r\rz\r" + b"t04380000B4429600E7FF\r")
            assert t.recv(2.0) == reply
            assert t.recv(0.05) is None
            assert t.decoder.answers == 4  # type: ignore[attr-defined]
        finally:
            t.close()
        assert read_lines(dev, 1) == [b"C\r"]


@pytest.mark.parametrize(
    ("kwargs", "opening"),
    [
        ({}, [b"C\r", b"O\r"]),
        ({"listen_only": True}, [b"C\r", b"L\r"]),
        ({"bitrate": 1_000_000}, [b"C\r", b"S8\r", b"O\r"]),
    ],
)
def test_opening_commands(kwargs: dict[str, object], opening: list[bytes]) -> None:
    with device() as (dev, path):
        t = open_transport("slcan", path, sleep_after_open=0, **kwargs)  # type: ignore[arg-type]
        try:
            assert read_lines(dev, len(opening)) == opening
            assert quiet(dev)
        finally:
            t.close()


def test_descriptor_reads_without_a_thread() -> None:
    with device() as (dev, path):
        t = open_transport("slcan", path, sleep_after_open=0)
        try:
            fd = t.fileno()
            assert fd is not None
            assert t.read_nowait() == []
            frames = [Frame(0x021 + i, bytes([i] * 8)) for i in range(3)]
            os.write(dev, b"".join(encode_slcan(f) for f in frames))
            assert select.select([fd], [], [], 2.0)[0]
            got: list[Frame] = []
            deadline = time.monotonic() + 2.0
            while len(got) < 3 and time.monotonic() < deadline:
                got += t.read_nowait()
            assert got == frames
        finally:
            t.close()


@pytest.mark.parametrize(
    ("kwargs", "words"),
    [
        ({"bitrate": 123}, ["bitrate=123", "1000000", "500000"]),
        ({"bitrate": 500_000, "receive_own_messages": True}, ["receive_own_messages", "python-can:slcan"]),
        ({"sleep_after_open": -1}, ["sleep_after_open=-1"]),
    ],
)
def test_bad_options_are_named_and_nothing_is_written(kwargs: dict[str, object], words: list[str]) -> None:
    with device() as (dev, path):
        with pytest.raises(TransportError) as info:
            open_transport("slcan", path, **kwargs)  # type: ignore[arg-type]
        assert isinstance(info.value, ValidationError)  # a user's mistake: the CLI's exit 2
        for w in words:
            assert w in str(info.value)
        assert quiet(dev)


def test_serial_rate_in_the_channel() -> None:
    with device() as (_dev, path):
        t = open_transport("slcan", f"{path}@230400", sleep_after_open=0)
        try:
            assert "230400" in t.description
        finally:
            t.close()
        with pytest.raises(TransportError, match="fast"):
            open_transport("slcan", f"{path}@fast", sleep_after_open=0)


def test_a_silent_device_is_a_timeout() -> None:
    with (
        device() as (dev, path),
        drempower.open_bus("slcan", path, timeout=0.2, sleep_after_open=0, stop_on_close=False) as bus,
    ):
        read_lines(dev, 2)
        t0 = time.monotonic()
        with pytest.raises(drempower.TimeoutError):
            bus.motor(1).get_state()
        assert time.monotonic() - t0 < 5
        assert read_lines(dev, 1) == [encode_slcan(FastRead(1).encode())]


@contextmanager
def answering(dev: int, answer: Callable[[bytes], bytes]) -> Iterator[None]:
    """A device thread while the block runs: after the opening, each line the host writes gets
    ``answer(line)`` written back. It ends before the block does, so that it never reads a descriptor
    that a later test reopened under the same number."""
    stop = threading.Event()

    def run() -> None:
        buf = b""
        while not stop.is_set():
            if not select.select([dev], [], [], 0.05)[0]:
                continue
            buf += os.read(dev, 4096)
            *lines, buf = buf.split(b"\r")
            for line in lines:
                os.write(dev, b"\r" if line[:1] in (b"C", b"O", b"S") else answer(line + b"\r"))

    th = threading.Thread(target=run, daemon=True)
    th.start()
    try:
        yield
    finally:
        stop.set()
        th.join(5.0)


def test_a_reply_is_matched_to_its_request_only() -> None:
    """The device answers motor 1's fast read with motor 2's state first, then motor 1's: the call returns
    motor 1's; motor 2's is no answer to it."""
    mine = State(1, 45.0, 1.5, 0.25, True, False).encode()
    other = State(2, -90.0, 0.0, 0.0, True, False).encode()

    def answer(line: bytes) -> bytes:
        assert line == encode_slcan(FastRead(1).encode())
        return b"z\r" + encode_slcan(other) + encode_slcan(mine)

    with (
        device() as (dev, path),
        answering(dev, answer),
        drempower.open_bus("slcan", path, timeout=1.0, sleep_after_open=0, stop_on_close=False) as bus,
    ):
        state = bus.motor(1).get_state()
        assert state.node == 1 and state.angle == pytest.approx(45.0)
        assert state.speed == pytest.approx(1.5)


def test_only_a_state_of_another_motor_is_a_timeout() -> None:
    other = State(2, -90.0, 0.0, 0.0, True, False).encode()
    with device() as (dev, path), answering(dev, lambda line: b"z\r" + encode_slcan(other)):
        bus = drempower.open_bus("slcan", path, timeout=0.3, sleep_after_open=0, stop_on_close=False)
        with bus, pytest.raises(drempower.TimeoutError):
            bus.motor(1).get_state()


@pytest.mark.parametrize("interface", ["slcan", "python-can:slcan"])
def test_both_slcan_readers_reach_the_simulated_adapter(interface: str) -> None:
    sim = SimBus(ids=[1])
    pty = attach_adapter_pty(sim)
    try:
        with drempower.open_bus(
            interface, pty.path, 1_000_000, timeout=1.0, sleep_after_open=0, stop_on_close=False
        ) as bus:
            bus.motor(1).set_angle(30.0, 10, 10, mode=1, enable=True)
            state = bus.motor(1).get_state()
            assert state.node == 1
            assert pty.slcan.is_open and pty.slcan.bitrate_code == 8
            assert ("python-can" in bus.transport.description) == (interface == "python-can:slcan")
        deadline = time.monotonic() + 5
        while pty.slcan.is_open and time.monotonic() < deadline:
            time.sleep(0.01)
        assert not pty.slcan.is_open  # the close command reached the adapter
    finally:
        pty.close()


def test_bitrate_from_python_cans_configuration(monkeypatch: pytest.MonkeyPatch, tmp_path: object) -> None:
    """As python-can's slcan does, a bit rate not given comes from python-can's configuration."""
    import can

    for k in list(os.environ):
        if k.startswith("CAN_"):
            monkeypatch.delenv(k)
    monkeypatch.setenv("HOME", str(tmp_path))
    monkeypatch.setattr(can, "rc", {})
    monkeypatch.setenv("CAN_BITRATE", "250000")
    with device() as (dev, path):
        t = open_transport("slcan", path, sleep_after_open=0)
        try:
            assert read_lines(dev, 3) == [b"C\r", b"S5\r", b"O\r"]
        finally:
            t.close()
