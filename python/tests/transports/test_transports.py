"""Transports on their own: serial framings over pyserial's loop://, python-can virtual, opening errors."""

from __future__ import annotations

import threading
import time

import pytest

import drempower
from drempower.protocol import PositionQ, State, encode_aa, encode_uart11
from drempower.protocol.ids import Frame
from drempower.sim import SimBus, attach_adapter_pty, attach_uart_pty
from drempower.transports import TransportError, open_transport
from drempower.transports.serial_adapter import AdapterTransport
from drempower.transports.uart import UartTransport

FRAMES = [
    PositionQ(1, -150.0, 10.0, 5.0).encode(),
    State(2, 12.5, -3.0, 0.25, True, False).encode(),
    Frame(0x7FF, bytes(range(8))),
]


@pytest.mark.parametrize("kind", ["adapter", "serial", "uart"])
def test_serial_framings_round_trip_over_loop(kind: str) -> None:
    t = open_transport(kind, "loop://")
    try:
        for f in FRAMES:
            t.send(f)
        assert [t.recv(1) for _ in FRAMES] == FRAMES
        t0 = time.monotonic()
        assert t.recv(0.05) is None
        assert time.monotonic() - t0 < 10  # no hang
    finally:
        t.close()
    assert t.recv(0.01) is None  # closed: returns at once


@pytest.mark.parametrize(("cls", "encode"), [(AdapterTransport, encode_aa), (UartTransport, None)])
def test_serial_resynchronises_after_garbage(cls: type[AdapterTransport], encode: object) -> None:
    t = cls("loop://")
    try:
        pack = encode_aa if cls is AdapterTransport else (lambda f: encode_uart11(f[0], f[1]))
        good = FRAMES[1]
        ser = t._ser  # write raw bytes into the loop
        ser.write(b"\x00\xff\x12garbage" + pack(good)[:5])  # noise, then a truncated frame
        time.sleep(0.05)
        assert t.recv(0.1) is None  # the quiet line drops the partial frame
        ser.write(b"\xaa\x08\x08" + pack(good))
        assert t.recv(1) == good
        assert t.decoder.pending == 0
    finally:
        t.close()


def test_client_over_loop_times_out_cleanly() -> None:
    """On a loopback nobody answers: the echoed fast read is no state frame (it reads as another host's
    fast read), the request times out."""
    with drempower.open_bus("adapter", "loop://", timeout=0.25, stop_on_close=False) as bus:
        with pytest.raises(drempower.TimeoutError):
            bus.motor(1).get_state()
        assert (bus.stats["foreign"], bus.stats["malformed"]) == (1, 0)


def test_python_can_virtual_round_trip() -> None:
    a = open_transport("virtual", "drempower-test-vrt")
    b = open_transport("python-can:virtual", "drempower-test-vrt")
    try:
        for f in FRAMES:
            a.send(f)
        assert [b.recv(1) for _ in FRAMES] == FRAMES
        assert b.recv(0.01) is None
        assert "virtual" in a.description.lower()
    finally:
        a.close()
        b.close()


@pytest.mark.parametrize(
    ("args", "words"),
    [
        (("adapter", "/dev/drempower-no-such-port"), ["adapter", "/dev/drempower-no-such-port"]),
        (("uart", "/dev/drempower-no-such-port"), ["UART", "/dev/drempower-no-such-port"]),
        (("adapter", None), ["channel"]),
        (("no-such-interface", "x"), ["no-such-interface", "socketcan"]),
    ],
)
def test_opening_a_missing_bus_fails_at_once(args: tuple[str, str | None], words: list[str]) -> None:
    t0 = time.monotonic()
    with pytest.raises(TransportError) as info:
        drempower.open_bus(*args)
    assert time.monotonic() - t0 < 10  # fails at once, no retry loop
    assert isinstance(info.value, OSError) and isinstance(info.value, drempower.DrEmpowerError)
    for w in words:
        assert w in str(info.value)


def test_python_can_configuration_is_used_when_nothing_is_given(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("CAN_INTERFACE", "virtual")
    monkeypatch.setenv("CAN_CHANNEL", "drempower-test-env")
    monkeypatch.setenv("CAN_CONFIG", "{}")
    with drempower.open_bus(stop_on_close=False) as bus:
        assert "drempower-test-env" in bus.transport.description


def test_transport_or_options_not_both() -> None:
    t = open_transport("virtual", "drempower-test-both")
    with pytest.raises(ValueError, match="either"):
        drempower.open_bus("virtual", transport=t)
    t.close()


@pytest.mark.parametrize("kind", ["adapter", "uart"])
def test_close_wakes_a_receive_waiting_on_a_quiet_serial_port(kind: str) -> None:
    """A quiet port is waited on with no time slice (no wake-ups); close must end that wait itself."""
    sim = SimBus(ids=[1])
    pty = attach_adapter_pty(sim) if kind == "adapter" else attach_uart_pty(sim, 1)
    try:
        t = AdapterTransport(pty.path) if kind == "adapter" else UartTransport(pty.path)
        assert t.recv_slice is None  # a file descriptor: the wait is one select with no timeout
        got: list[object] = ["not returned"]
        reader = threading.Thread(target=lambda: got.__setitem__(0, t.recv(None)), daemon=True)
        reader.start()
        time.sleep(0.05)
        assert reader.is_alive()  # nothing arrived: still waiting
        t.close()
        reader.join(10.0)
        assert not reader.is_alive()
        assert got == [None]
        assert t.recv(None) is None  # a wait that starts after close returns at once
    finally:
        pty.close()
