"""The asyncio API over the same core."""

from __future__ import annotations

import asyncio
import threading

import pytest

import drempower
from drempower.client import AsyncBus, BusClosedError, open_bus_async

from ..scripted import FakeMotors, ScriptedTransport


async def test_async_queries_and_moves(motors: FakeMotors) -> None:
    t = ScriptedTransport(motors)
    motors.positions[2] = 5.0
    threads = threading.active_count()
    async with open_bus_async(transport=t, timeout=0.5, stop_on_close=False) as bus:
        assert isinstance(bus, AsyncBus)
        m = bus.motor(2)
        states = await asyncio.gather(*(bus.motor(n).get_state() for n in (1, 2, 3)))
        assert [s.angle for s in states] == [0.0, 5.0, 0.0]
        assert threading.active_count() == threads + 1  # the receive thread, nothing per call
        assert await m.read_property("axis0.config.can_node_id") == 2
        assert await bus.set_angles([1, 2], [90, -90], 10, 20, 1) is not None
        await m.set_angle(10, 0, 50)
        await m.step_angle(10, 0, 50)
        assert set(await bus.cycle([bus.motor(n).make_speed(1) for n in (1, 3)], reply_state=False)) == {1, 3}
        assert [i.id for i in await bus.scan(range(1, 8))] == [1, 2, 3]
        assert not await m.dump_error()
        with pytest.raises(drempower.MoveTimeoutError, match="motor 2: no sign that it took the move"):
            await m.wait_position_done(0.05)  # motor 2 never left 5 deg for its target, 15
        motors.positions[2] = 15.0
        assert (await m.wait_position_done(1)).node == 2
        await m.set_traj_mode(2)
        assert bus._core.session.known.traj_mode[2] == 2
        report = await m.restore(await m.backup(), dry_run=True, force=True)  # the fake motor reads 0 for most
        assert report.ok


async def test_async_timeout_and_wait_state(motors: FakeMotors) -> None:
    motors.silent.add(3)
    t = ScriptedTransport(motors)
    async with AsyncBus(t, timeout=0.25, stop_on_close=False) as bus:
        with pytest.raises(drempower.TimeoutError, match="motor 3"):
            await bus.motor(3).get_state()
        with pytest.raises(drempower.TimeoutError):
            await bus.motor(1).wait_state(0.02)
        waiter = asyncio.ensure_future(bus.wait_state(1, 2))
        await asyncio.sleep(0.01)
        await bus.motor(1).get_state()
        assert (await waiter).node == 1


async def test_async_close_fails_waiting_calls() -> None:
    t = ScriptedTransport()
    bus = open_bus_async(transport=t, timeout=10, stop_on_close=False)
    task = asyncio.ensure_future(bus.motor(1).get_state())
    await asyncio.sleep(0.02)
    await bus.close()
    with pytest.raises(BusClosedError):
        await task


async def test_async_cancel_leaves_no_pending_request(motors: FakeMotors) -> None:
    motors.silent.add(1)
    t = ScriptedTransport(motors)
    async with AsyncBus(t, timeout=10, stop_on_close=False) as bus:
        task = asyncio.ensure_future(bus.motor(1).get_state())
        await asyncio.sleep(0.02)
        task.cancel()
        with pytest.raises(asyncio.CancelledError):
            await task
        assert len(bus._core.session.matcher) == 0


async def test_async_against_the_simulator() -> None:
    from drempower.sim import SimBus

    sim = SimBus(ids=[1, 2, 3])
    async with open_bus_async("sim", bus=sim, time_scale=20, timeout=1.0, stop_on_close=False) as bus:
        t = await bus.set_angles([1, 2, 3], [30, 60, 90], 60, 300, 1)
        assert t is not None
        done = await bus.positions_done([1, 2, 3], timeout=10)
        assert [done[i].angle for i in (1, 2, 3)] == pytest.approx([30, 60, 90], abs=0.05)
        volts = await asyncio.gather(*(bus.motor(i).get_volcur() for i in (1, 2, 3)))
        assert all(v == pytest.approx(sim.motors[1].param("vbus_voltage")) for v, _ in volts)
        await bus.motor(2).impedance_control(60, 0, 0, 1, 0.05)
        await bus.estop()
        reports = [await bus.motor(i).dump_error() for i in (1, 2, 3)]
        assert all(r.flags == {"axis0.error": ["ESTOP_REQUESTED"]} for r in reports)
