"""The UART pty applies the bus's faults: lost frames, flipped bits, late replies."""

from __future__ import annotations

import time
from collections.abc import Iterator

import pytest

from drempower.protocol import DataType, ParamValue, ReadParam, decode_reply
from drempower.sim import Faults, SimBus, SimRunner, attach_uart_pty
from drempower.transports import Transport, open_transport

VBUS = ReadParam(1, 1, DataType.F32).encode()


@pytest.fixture
def uart() -> Iterator[tuple[SimBus, Transport]]:
    bus = SimBus([1])
    with SimRunner(bus), attach_uart_pty(bus, 1) as pty:
        t = open_transport("uart", pty.path)
        try:
            yield bus, t
        finally:
            t.close()


def _answers(t: Transport, n: int, wait: float) -> list[object]:
    out = []
    for _ in range(n):
        t.send(VBUS)
        f = t.recv(wait)
        if f is not None:
            out.append(decode_reply(f.arbitration_id, f.data))
    return out


def test_uart_pty_drops_frames(uart: tuple[SimBus, Transport]) -> None:
    bus, t = uart
    assert len(_answers(t, 1, 2.0)) == 1
    bus.faults = Faults(drop_rate=1.0)
    assert _answers(t, 3, 0.2) == []
    bus.faults = Faults(drop_rate=0.5)
    got = len(_answers(t, 40, 0.2))
    assert 5 <= got <= 30  # each way loses half: about a quarter come back


def test_uart_pty_corrupts_frames(uart: tuple[SimBus, Transport]) -> None:
    bus, t = uart
    (good,) = _answers(t, 1, 2.0)
    assert isinstance(good, ParamValue)
    bus.faults = Faults(corrupt_rate=1.0)
    replies: list[object] = []
    for _ in range(10):
        t.send(VBUS)
        while (f := t.recv(0.2)) is not None:
            replies.append((f.arbitration_id, f.data))
    good_frame = (0x03E, good.encode().data)
    assert replies and all(r != good_frame for r in replies)


def test_uart_pty_delays_replies(uart: tuple[SimBus, Transport]) -> None:
    bus, t = uart
    bus.faults = Faults(reply_delay=0.4)
    t.send(VBUS)
    t0 = time.monotonic()
    assert t.recv(0.2) is None
    f = t.recv(3.0)
    assert f is not None and time.monotonic() - t0 >= 0.35
