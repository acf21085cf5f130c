"""Waits for a move end only when the move has happened, at its target (in-process simulator)."""

from __future__ import annotations

import asyncio

import pytest

import drempower
from drempower import compat
from drempower.client import Bus, MoveError, MoveFaultError, MoveTimeoutError, open_bus_async
from drempower.sim import Faults, SimBus

from ..links import link

TARGETS = [30.0, -30.0, 60.0]
STATE_SOURCES = ["both"]
"""Replies to commands and heartbeats at once (the waits' logic for each is checked on scripted time)."""


def _chatty(bus: Bus, ids: list[int], source: str) -> None:
    """Make the motors send state frames of their own: replies to commands, heartbeats or both."""
    for i in ids:
        if source in ("reply_state", "both"):
            bus.motor(i).enable_reply_state(True)
        if source in ("heartbeat", "both"):
            bus.motor(i).write_property("can.config.heartbeat_ms", 2)


@pytest.mark.parametrize("source", STATE_SOURCES)
def test_positions_done_waits_for_the_move_despite_stale_states(source: str) -> None:
    """Every motor frame takes 20 ms to arrive: states sent before the start are still in flight after it."""
    sim = SimBus(ids=[1, 2, 3], faults=Faults(reply_delay=0.02))
    with link("inprocess", sim, timeout=1.0) as bus:
        _chatty(bus, [1, 2, 3], source)
        t = bus.set_angles([1, 2, 3], TARGETS, speed=60, param=200, mode=1)
        assert t is not None and t > 0.1
        done = bus.positions_done([1, 2, 3], timeout=10)
        assert [done[i].angle for i in (1, 2, 3)] == pytest.approx(TARGETS, abs=0.5)
        assert [sim.motors[i].position for i in (1, 2, 3)] == pytest.approx(TARGETS, abs=0.5)


@pytest.mark.parametrize("source", STATE_SOURCES)
def test_single_motor_waits_t_mode(source: str) -> None:
    """T mode has no planned time: the wait needs T = 0 after the command, or the motor at its target."""
    sim = SimBus(ids=[1], faults=Faults(reply_delay=0.02))
    with link("inprocess", sim, timeout=1.0) as bus:
        _chatty(bus, [1], source)
        m = bus.motor(1)
        m.set_angle(45, 0, 5, 0)  # a slow filter: the T bit stays 1 for a moment after the command
        assert m.wait_position_done(10).angle == pytest.approx(45, abs=0.5)
        assert sim.motors[1].position == pytest.approx(45, abs=0.5)


def test_async_and_compat_waits_wait_for_the_move() -> None:
    sim = SimBus(ids=[1, 2])

    async def run() -> float:
        async with open_bus_async("sim", bus=sim, clock="virtual", timeout=1.0, stop_on_close=False) as bus:
            for i in (1, 2):
                await bus.motor(i).enable_reply_state(True)
            await bus.set_angles([1, 2], [40, -40], 60, 200, 1)
            done = await bus.positions_done([1, 2], timeout=10)
            await bus.motor(1).set_angle(10, 60, 200, 1)
            st = await bus.motor(1).wait_position_done(10)
            assert done[2].angle == pytest.approx(-40, abs=0.5)
            return st.angle

    assert asyncio.run(run()) == pytest.approx(10, abs=0.5)
    with link("inprocess", sim, timeout=1.0) as bus:
        compat.use_bus(bus)
        try:
            bus.motor(1).enable_reply_state(True)
            compat.set_angles([1, 2], [-20, 20], 60, 200, 1)
            assert compat.positions_done([1, 2], timeout=10) is True
            assert [sim.motors[i].position for i in (1, 2)] == pytest.approx([-20, 20], abs=0.5)
        finally:
            compat.close()


def test_a_move_stopped_by_angle_limits_raises_move_error() -> None:
    sim = SimBus(ids=[1])
    with link("inprocess", sim, timeout=1.0) as bus:
        m = bus.motor(1)
        m.enable_reply_state(True)
        m.set_angle_range(-20, 20)
        m.set_angle(90, 60, 200, 1)
        with pytest.raises(MoveError) as info:
            m.wait_position_done(10)
        e = info.value
        assert e.node == 1 and e.target == 90 and e.position == pytest.approx(20, abs=0.5)
        assert "motor 1" in str(e) and "target 90.00 deg" in str(e) and "reached 20.0" in str(e)
        assert not isinstance(e, MoveTimeoutError)


def test_an_estop_during_the_wait_raises_move_fault_error_with_flags() -> None:
    sim = SimBus(ids=[1])
    with link("inprocess", sim, timeout=1.0) as bus:
        m = bus.motor(1)
        m.set_angle(90, 30, 60, 1)
        sim.schedule(sim.now + 0.3, lambda: sim.motors[1].receive(_estop(), lambda f: None))
        with pytest.raises(MoveFaultError) as info:
            m.wait_position_done(10)
        e = info.value
        assert isinstance(e, drempower.MotorFaultError) and e.target == 90
        assert e.flags == {"axis0.error": ["ESTOP_REQUESTED"]} and e.position is not None and e.position < 90


def test_tolerance_is_checked() -> None:
    sim = SimBus(ids=[1])
    with link("inprocess", sim, timeout=1.0) as bus, pytest.raises(drempower.ValidationError):
        bus.motor(1).wait_position_done(1, tolerance=-1)


def _estop() -> drempower.protocol.SystemCommand:
    from drempower.protocol import SysCmd, SystemCommand

    return SystemCommand(1, SysCmd.ESTOP)
