"""Injected faults: lost and corrupted frames, late replies, a motor that stops answering."""

from __future__ import annotations

from drempower.protocol import FastRead, PositionQ, decode_reply
from drempower.sim import Faults, SimBus

from .helpers import Tap


def _poll(bus: SimBus, n: int, node: int = 1) -> Tap:
    tap = Tap(bus)
    for _ in range(n):
        bus.send(FastRead(node).encode())
    return tap


def test_drop_rate_loses_frames_repeatably() -> None:
    counts = []
    for _ in range(2):
        bus = SimBus([1], faults=Faults(drop_rate=0.3), seed=7)
        counts.append(len(_poll(bus, 1000).frames))
    assert counts[0] == counts[1]
    assert 400 < counts[0] < 560  # both the read and the reply must survive: 0.7 * 0.7


def test_drop_everything() -> None:
    bus = SimBus([1], faults=Faults(drop_rate=1.0))
    bus.send(PositionQ(1, 90.0, 30.0, 100.0).encode())
    bus.advance(1.0)
    assert bus.motors[1].position == 0.0


def test_corrupted_frames_differ_in_one_bit() -> None:
    bus = SimBus([1], seed=1)
    bus.motors[1].set_param("can.config.heartbeat_ms", 10)
    tap = Tap(bus)
    bus.advance(0.1)
    clean = {f.data for f in tap.take()}
    assert clean == {bytes(8)}  # a motor at rest at 0
    bus.faults.corrupt_rate = 1.0
    bus.advance(1.0)
    seen = [f.data for f in tap.take()]
    assert len(seen) == 100
    assert all(bin(int.from_bytes(d, "little")).count("1") == 1 for d in seen)
    assert len(set(seen)) > 30


def test_reply_delay_and_jitter() -> None:
    bus = SimBus([1], faults=Faults(reply_delay=0.01, reply_jitter=0.005))
    tap = _poll(bus, 1)
    bus.advance(0.0099)
    assert tap.frames == []
    bus.advance(0.0052)
    assert len(tap.frames) == 1
    assert decode_reply(*tap.frames[0][:2]).node == 1


def test_a_silent_motor_obeys_but_does_not_answer() -> None:
    bus = SimBus([1, 2], faults=Faults(silent={2}))
    tap = _poll(bus, 1, node=0)
    assert [f.arbitration_id >> 5 for f in tap.frames] == [1]
    bus.send(PositionQ(2, 90.0, 30.0, 100.0).encode())
    bus.advance(1.5)
    assert abs(bus.motors[2].position - 90.0) < 0.05
    assert bus.uart_request(2, FastRead(2).encode()) == []  # silent on its UART too
    bus.faults.silent.clear()
    assert len(_poll(bus, 1, node=2).frames) == 1
    assert len(bus.uart_request(2, FastRead(2).encode())) == 1
