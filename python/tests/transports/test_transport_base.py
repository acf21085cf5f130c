"""The receive deadline loop of the transport base, on a scripted clock, and the transport table."""

from __future__ import annotations

import types
import uuid
from typing import Any

import pytest

from drempower.protocol.ids import Frame
from drempower.transports import base, factory
from drempower.transports.base import Transport
from drempower.transports.errors import TransportError

FRAME = Frame(0x21, bytes(8), False, False)


class Clock:
    def __init__(self) -> None:
        self.now = 100.0

    def monotonic(self) -> float:
        return self.now


class WaitOnly(Transport):
    """Implements only the wait: each wait takes the time asked on the scripted clock."""

    def __init__(self, clock: Clock, frames: list[Frame | None], close_after: int | None = None) -> None:
        self.clock = clock
        self.frames = frames
        self.waits: list[float] = []
        self.close_after = close_after
        self._closed = False

    def is_closed(self) -> bool:
        return self._closed

    def wait_frame(self, timeout: float) -> Frame | None:
        self.waits.append(round(timeout, 9))
        if self.close_after is not None and len(self.waits) >= self.close_after:
            self._closed = True
        frame = self.frames.pop(0) if self.frames else None
        if frame is None:
            self.clock.now += timeout
        return frame

    def send(self, frame: Frame) -> None:
        pass

    def close(self) -> None:
        self._closed = True


@pytest.fixture
def clock(monkeypatch: pytest.MonkeyPatch) -> Clock:
    c = Clock()
    monkeypatch.setattr(base, "time", types.SimpleNamespace(monotonic=c.monotonic))
    return c


def test_recv_waits_in_slices_until_the_deadline(clock: Clock) -> None:
    t = WaitOnly(clock, [])
    assert t.recv(0.25) is None
    assert t.waits == [0.1, 0.1, 0.05] and clock.now == pytest.approx(100.25)


def test_recv_returns_the_first_frame_at_once(clock: Clock) -> None:
    t = WaitOnly(clock, [None, FRAME])
    assert t.recv(1.0) == FRAME and t.waits == [0.1, 0.1]


def test_recv_without_timeout_runs_until_closed(clock: Clock) -> None:
    t = WaitOnly(clock, [], close_after=4)
    assert t.recv(None) is None and t.waits == [0.1] * 4
    assert t.recv(None) is None and len(t.waits) == 4  # closed: no wait at all


def test_zero_timeout_polls_once(clock: Clock) -> None:
    t = WaitOnly(clock, [FRAME])
    assert t.recv(0) == FRAME and t.waits == [0.0]
    assert t.recv(0) is None and t.waits == [0.0, 0.0]


def test_a_transport_whose_close_wakes_the_wait_needs_no_slices(clock: Clock) -> None:
    t = WaitOnly(clock, [])
    t.recv_slice = None
    assert t.recv(2.5) is None and t.waits == [2.5]


def test_a_transport_must_implement_the_wait_or_recv() -> None:
    with pytest.raises(TypeError, match="must implement wait_frame"):

        class Nothing(Transport):
            def send(self, frame: Frame) -> None: ...

            def close(self) -> None: ...

    class OwnRecv(Transport):
        def send(self, frame: Frame) -> None: ...

        def recv(self, timeout: float | None = None) -> Frame | None:
            return FRAME

        def close(self) -> None: ...

    assert OwnRecv().recv(1.0) == FRAME


def test_the_transport_table_routes_names(monkeypatch: pytest.MonkeyPatch) -> None:
    assert set(factory.INTERFACES) >= {"adapter", "serial", "uart", "sim"}
    assert {"adapter", "serial"} == factory.SERIAL_ADAPTER and {"uart"} == factory.MOTOR_UART
    assert {"sim"} == factory.SIMULATOR
    opened: list[tuple[Any, ...]] = []

    def opener(interface: str, channel: Any, bitrate: Any, kwargs: dict[str, Any]) -> Transport:
        opened.append((interface, channel, bitrate, kwargs))
        return WaitOnly(Clock(), [])

    monkeypatch.setitem(factory.INTERFACES, "mine", opener)
    t = factory.open_transport("mine", "ch", 500_000, extra=1)
    assert isinstance(t, WaitOnly) and opened == [("mine", "ch", 500_000, {"extra": 1})]
    with pytest.raises(TransportError, match="unknown interface 'nosuch'"):
        factory.open_transport("nosuch", "x")
    with pytest.raises(TransportError, match="needs channel=<serial port>"):
        factory.open_transport("adapter")
    with factory.open_transport("python-can:virtual", f"drempower-table-{uuid.uuid4().hex}") as pc:
        assert pc.description.startswith("python-can")
