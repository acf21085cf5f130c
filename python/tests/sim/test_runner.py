"""The real-time runner: wakes when something is due, sleeps otherwise, syncs the clock before host frames."""

from __future__ import annotations

import time

import pytest

from drempower.protocol import FastRead
from drempower.sim import SimBus, SimRunner
from drempower.sim.timing import frame_bits


def test_next_due_is_the_end_of_the_frame_on_the_wire_or_a_motor_timer() -> None:
    bus = SimBus([1], bitrate=1_000_000)
    assert bus.next_due() == float("inf")  # idle motors, nothing on the wire
    req = FastRead(1).encode()
    bus.send(req)
    assert bus.next_due() == pytest.approx(frame_bits(req.arbitration_id, req.data) / 1e6)
    bus.advance(0.01)
    assert bus.next_due() == float("inf")
    bus.motors[1].set_param("can.config.heartbeat_ms", 5)
    bus.advance(0.001)
    assert bus.now < bus.next_due() <= bus.now + 0.005 + 1e-9


def test_an_idle_runner_sleeps() -> None:
    """With nothing due it wakes every 20 ms, not every millisecond."""
    bus = SimBus([1, 2, 3])
    calls = 0
    advance = bus.advance

    def counting(seconds: float) -> None:
        nonlocal calls
        calls += 1
        advance(seconds)

    bus.advance = counting  # type: ignore[method-assign]
    with SimRunner(bus):
        time.sleep(0.4)
    assert 0 < calls < 60
    assert bus.now == pytest.approx(0.4, abs=0.1)


def test_a_host_frame_enters_at_wall_time_and_is_answered_at_its_completion_time() -> None:
    bus = SimBus([1], bitrate=1_000_000)
    seen: list[float] = []
    bus.add_listener(lambda f: seen.append(bus.now))
    with SimRunner(bus):
        time.sleep(0.1)  # the runner is asleep: nothing is due
        req = FastRead(1).encode()
        reply = bus.motors[1].state_frame()
        t0 = time.monotonic()
        bus.send(req)
        entered = bus.now
        deadline = time.monotonic() + 2.0
        while not seen and time.monotonic() < deadline:
            time.sleep(0.001)
        waited = time.monotonic() - t0
    assert entered == pytest.approx(0.1, abs=0.05)  # the clock was brought up to wall time first
    wire = (frame_bits(req.arbitration_id, req.data) + frame_bits(reply.arbitration_id, reply.data)) / 1e6
    assert seen and seen[0] == pytest.approx(entered + wire, abs=1e-6)
    assert waited < 0.5
