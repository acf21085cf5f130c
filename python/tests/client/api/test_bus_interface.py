"""The bus's interface for the layers above (robot, motion, apps): no ``.core``, and each method does what
its docstring says, on both flavours, on the simulator's virtual clock."""

from __future__ import annotations

import asyncio
import time

import pytest

import drempower
from drempower.client import AsyncBus, Bus, PositionMode, open_bus_async
from drempower.client.engine.commands import make_angles
from drempower.errors import SoftLimitError, ValidationError
from drempower.protocol.enums import AxisState
from drempower.protocol.ids import Frame
from drempower.sim import SimBus


def test_buses_expose_no_core() -> None:
    for cls in (Bus, AsyncBus):
        assert not hasattr(cls, "core"), cls
    with drempower.open_bus("sim", motors=[1], clock="virtual") as bus:
        assert not hasattr(bus, "core")


def test_now_virtual_and_pass_time_on_the_virtual_clock() -> None:
    with drempower.open_bus("sim", motors=[1], clock="virtual") as bus:
        assert bus.virtual
        t0, wall = bus.now(), time.perf_counter()
        bus.pass_time(2.5)
        assert bus.now() - t0 == pytest.approx(2.5)
        assert time.perf_counter() - wall < 1.0  # simulated seconds, not wall ones
        bus.pass_time(0)
        assert bus.now() - t0 == pytest.approx(2.5)
        for bad in (-1.0, "1", float("nan"), True):
            with pytest.raises(ValidationError, match=r"seconds="):
                bus.pass_time(bad)  # type: ignore[arg-type]


def test_async_pass_time_on_both_clocks() -> None:
    async def main() -> None:
        async with open_bus_async("sim", motors=[1], clock="virtual") as bus:
            t0 = bus.now()
            await bus.pass_time(3.0)
            assert bus.now() - t0 == pytest.approx(3.0)
        async with open_bus_async("sim", motors=[1]) as bus:
            assert not bus.virtual
            t0 = bus.now()
            await bus.pass_time(0.05)
            assert bus.now() - t0 >= 0.05
            t0 = bus.now()
            await bus.pass_time(30.0, until=lambda: bus.now() - t0 > 0.05)  # ends on its condition
            assert 0.05 < bus.now() - t0 < 5.0
            with pytest.raises(ValidationError, match=r"seconds=-2"):
                await bus.pass_time(-2)
            waiting = asyncio.ensure_future(bus.pass_time(30.0))
            await asyncio.sleep(0.05)
            t0 = time.monotonic()
            await bus.close()
            await asyncio.wait_for(waiting, 2.0)  # the close ends the wait
            assert time.monotonic() - t0 < 2.0

    asyncio.run(main())


def test_commanded_and_stop_on_close_set_after_opening() -> None:
    sim = SimBus(ids=[1, 2])
    with drempower.open_bus("sim", bus=sim, clock="virtual", stop_on_close=False) as bus:
        bus.enable([1, 2])
        bus.motor(1).set_speed(30.0)
        assert bus.commanded >= {1}
        assert bus.stop_on_close is False
        for bad in ("halt", 2, None):
            with pytest.raises(ValidationError, match=r"stop_on_close=.*True, False, 'idle' or 'estop'"):
                bus.stop_on_close = bad  # type: ignore[assignment]
        assert bus.stop_on_close is False  # a refused value changes nothing
        bus.stop_on_close = "idle"
        assert bus.stop_on_close == "idle"
        assert sim.motors[1].state == AxisState.CLOSED_LOOP_CONTROL
    assert sim.motors[1].state == AxisState.IDLE  # the close applied the value set afterwards


def test_reply_state_is_a_read_only_view_of_what_the_bus_learned() -> None:
    with drempower.open_bus("sim", motors=[1], clock="virtual") as bus:
        view = bus.reply_state
        assert dict(view) == {}
        bus.motor(1).enable_reply_state(True)
        assert dict(view) == {1: True}  # live: the same view sees it
        with pytest.raises(TypeError):
            view[1] = False  # type: ignore[index]


def test_on_sent_and_taps_see_the_frames() -> None:
    with drempower.open_bus("sim", motors=[1], clock="virtual") as bus:
        sent: list[tuple[Frame, float]] = []
        taps: list[tuple[Frame, bool]] = []
        assert bus.on_sent is None
        bus.on_sent = lambda f, when: sent.append((f, when))
        bus.add_tap(lambda f, tx: taps.append((f, tx)))
        before = time.monotonic()
        bus.motor(1).get_state()
        assert len(sent) == 1 and sent[0][0].arbitration_id == (1 << 5) | 0x1E
        assert before <= sent[0][1] <= time.monotonic()  # time.monotonic() of the hand-over
        assert [tx for _, tx in taps] == [True, False]  # the read and its reply
        bus.on_sent = None
        tap = bus._core.frame_taps[0]
        bus.remove_tap(tap)
        bus.motor(1).get_state()
        assert len(sent) == 1 and len(taps) == 2


def test_send_batch_moves_the_motors_and_the_gate_measures_from_where_they_are() -> None:
    sim = SimBus(ids=[1, 2])
    with drempower.open_bus("sim", bus=sim, clock="virtual") as bus:
        bus.enable([1, 2])
        bus.set_limits(1, max_step=60.0)
        presets, start = make_angles([1, 2], [50.0, -20.0], 0.0, 20.0, PositionMode.T)
        where = bus.send_batch(presets, start, [50.0, -20.0])
        assert where == [0]  # one broadcast start (bus option start="auto" with every motor addressed)
        assert sim.motors[1].position == pytest.approx(0.0, abs=1.0)  # no time has passed yet
        with pytest.raises(SoftLimitError, match="max_step 100 deg"):
            bus.motor(1).set_angle(100.0, 0.0, 20.0)  # 100 deg from where the motor is: refused
        bus.pass_time(1.0)
        assert sim.motors[1].position == pytest.approx(50.0, abs=0.5)
        bus.motor(1).set_angle(100.0, 0.0, 20.0)  # 50 deg from where it now is: passes
        bus.pass_time(1.0)
        assert sim.motors[1].position == pytest.approx(100.0, abs=0.5)
        assert sim.motors[2].position == pytest.approx(-20.0, abs=0.5)


def test_estop_now_and_close_now_run_in_the_calling_thread_on_the_asyncio_bus() -> None:
    sim = SimBus(ids=[1, 2])

    async def main() -> None:
        bus = open_bus_async("sim", bus=sim, clock="virtual", stop_on_close=False)
        await bus.enable([1, 2])
        await bus.pass_time(0.1)
        assert sim.motors[1].state == sim.motors[2].state == AxisState.CLOSED_LOOP_CONTROL
        with pytest.raises(ValidationError, match="id_list is empty"):
            bus.estop_now([])
        bus.estop_now([2])  # no await: the frame is out when it returns
        await bus.pass_time(0.1)
        assert sim.motors[1].state == AxisState.CLOSED_LOOP_CONTROL and sim.motors[2].state == AxisState.IDLE
        bus.close_now()
        assert bus.closed
        bus.close_now()  # idempotent

    asyncio.run(main())


def test_traj_modes_read_once_then_known() -> None:
    with drempower.open_bus("sim", motors=[1, 2], clock="virtual") as bus:
        bus.motor(2).set_traj_mode(2)
        bus.motor(1).set_traj_mode(1)
        sent: list[Frame] = []
        bus.add_tap(lambda f, tx: sent.append(f) if tx else None)
        bus._core.session.known.traj_mode.clear()  # forget what the writes taught it
        assert bus.traj_modes([1, 2]) == {1: 1, 2: 2}
        assert len(sent) == 2  # one read each, in one exchange
        assert bus.traj_modes([2, 1]) == {2: 2, 1: 1}
        assert len(sent) == 2  # known now: nothing sent
        with pytest.raises(ValidationError, match="id"):
            bus.traj_modes([0])
