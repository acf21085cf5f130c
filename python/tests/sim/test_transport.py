"""SimTransport: the simulator behind the Transport interface, and the SimRunner clock."""

from __future__ import annotations

import threading
import time

import pytest

from drempower.protocol import FastRead, PositionQ, State, decode_reply
from drempower.sim import SimBus, SimRunner
from drempower.transports import Transport, open_transport
from drempower.transports.sim import SimTransport


def test_send_and_receive() -> None:
    with SimTransport([1, 2]) as t:
        assert isinstance(t, Transport)
        assert "motors 1,2" in t.description
        t.send(FastRead(0).encode())
        got = [t.recv(1.0), t.recv(1.0)]
        assert [decode_reply(*f[:2]).node for f in got if f is not None] == [1, 2]
        assert t.recv(0.01) is None


def test_close_wakes_a_blocked_recv() -> None:
    t = SimTransport()
    result: list[object] = []
    reader = threading.Thread(target=lambda: result.append(t.recv()))
    reader.start()
    time.sleep(0.05)
    t.close()
    reader.join(2.0)
    assert result == [None]
    assert t.recv() is None
    t.close()  # idempotent


def test_manual_clock_on_a_given_bus() -> None:
    bus = SimBus([3])
    with SimTransport(bus=bus, time_scale=0) as t:
        assert t.bus is bus and "manual clock" in t.description
        t.send(PositionQ(3, 90.0, 30.0, 100.0).encode())
        bus.advance(1.0)
        t.send(FastRead(3).encode())
        f = t.recv(1.0)
        assert f is not None
        s = decode_reply(*f[:2])
        assert isinstance(s, State) and s.trajectory_done and abs(s.position - 90.0) < 0.05


def test_factory_passes_simulator_options() -> None:
    t = open_transport("sim", motors=[4], time_scale=5.0, bitrate=1_000_000, seed=3)
    try:
        assert isinstance(t, SimTransport)
        assert t.bus.bitrate == 1_000_000 and list(t.bus.motors) == [4]
        t.send(FastRead(4).encode())
        f = t.recv(2.0)
        assert f is not None and f.arbitration_id == 0x083
    finally:
        t.close()


def test_runner_advances_and_stops() -> None:
    bus = SimBus([1])
    with SimRunner(bus, time_scale=10.0) as runner:
        assert runner.running
        deadline = time.monotonic() + 2.0
        while bus.now < 0.2 and time.monotonic() < deadline:
            time.sleep(0.01)
    assert bus.now >= 0.2
    stopped = bus.now
    time.sleep(0.02)
    assert bus.now == stopped and not runner.running
    with pytest.raises(ValueError):
        SimRunner(bus, time_scale=0)
