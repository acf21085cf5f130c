"""``max_step`` and relative moves are measured from what the motor will actually do: its measured
position (the firmware adds a relative step to it; an absolute target is reached from it), fresh where
the state cache may be stale. On the virtual clock, threaded and asyncio."""

from __future__ import annotations

import asyncio
from collections.abc import Iterator

import pytest

import drempower
from drempower.errors import SoftLimitError
from drempower.sim import SimBus


@pytest.fixture
def sim() -> Iterator[SimBus]:
    yield SimBus(ids=[1])


def _open(sim: SimBus) -> drempower.Bus:
    return drempower.open_bus("sim", bus=sim, clock="virtual", stop_on_close=False)


def test_a_step_during_a_slow_move_is_measured_from_where_the_motor_is(sim: SimBus) -> None:
    with _open(sim) as bus:
        m = bus.motor(1)
        m.set_angle(80, 60, 100, 1, enable=True)
        m.wait_position_done(5)
        bus.set_limits(1, position=(-90, 90))
        m.set_angle(0, 5, 100, 1)  # a slow move back: 30 deg/s
        bus.pass_time(0.5)
        at = sim.motors[1].position
        assert 60 < at < 79, at
        beyond = r"motor 1: position 1[45]\d\.\d+ deg is beyond its soft limit -90\.\.90"
        with pytest.raises(SoftLimitError, match=beyond):
            m.step_angle(85, 10, 100, 1)  # the firmware adds 85 to where the motor is, not to 0
        bus.pass_time(0.2)
        assert sim.motors[1].position < at  # still on its way to 0


def test_after_an_estop_and_a_push_the_step_is_measured_from_a_fresh_read(sim: SimBus) -> None:
    with _open(sim) as bus:
        m = bus.motor(1)
        m.set_angle(0, 0, 50, enable=True)
        bus.pass_time(0.2)
        assert m.get_state().angle == pytest.approx(0, abs=0.5)  # the cache says 0
        bus.set_limits(1, max_step=20)
        m.estop()
        sim.motors[1].drive.pos += 3150 / 360  # turned by hand while released: 3150 deg
        m.clear_error()
        m.enable()
        beyond = r"motor 1: max_step -313\d(\.\d+)? deg is beyond its soft limit -20\.\.20"
        with pytest.raises(SoftLimitError, match=beyond):
            m.set_angle(15, 0, 50)
        bus.pass_time(0.5)
        assert sim.motors[1].position == pytest.approx(3150, abs=1)


def test_after_a_timed_speed_the_step_is_measured_from_where_it_ended(sim: SimBus) -> None:
    with _open(sim) as bus:
        m = bus.motor(1)
        m.enable()
        bus.set_limits(1, max_step=20)
        m.get_state()  # the cache says 0
        m.set_speed(60, duration=1)
        bus.pass_time(1.5)
        assert 330 < sim.motors[1].position < 390
        with pytest.raises(SoftLimitError, match=r"motor 1: max_step -3[3-8]\d"):
            m.set_angle(10, 0, 50)
        m.set_angle(sim.motors[1].position + 10, 0, 50)  # a step of 10 deg from where it is passes


def test_the_asyncio_bus_measures_the_same(sim: SimBus) -> None:
    async def main() -> None:
        async with drempower.open_bus_async("sim", bus=sim, clock="virtual", stop_on_close=False) as bus:
            m = bus.motor(1)
            await m.enable()
            bus.set_limits(1, max_step=20)
            await m.get_state()
            await m.set_speed(60, duration=1)
            await bus.pass_time(1.5)
            with pytest.raises(SoftLimitError, match=r"motor 1: max_step -3[3-8]\d"):
                await m.set_angle(10, 0, 50)

    asyncio.run(main())


def test_at_exactly_max_step_both_directions_pass(sim: SimBus) -> None:
    with _open(sim) as bus:
        m = bus.motor(1)
        m.enable()
        bus.set_limits(1, max_step=28.6479)
        at = m.get_state().angle
        m.set_angle(at + 28.6479, 0, 50)
        m.set_angle(at - 28.6479, 0, 50)  # the same step the other way (the motor has not moved yet)


def test_max_step_holds_for_the_first_command_of_a_new_bus(sim: SimBus) -> None:
    """A bus that does not yet know the motor's axis state reads it, and still measures the step."""
    with _open(sim) as bus:
        bus.enable([1])
    with _open(sim) as bus:
        bus.set_limits(1, max_step=20)
        assert bus.motor(1).get_state().angle == pytest.approx(0, abs=0.5)
        with pytest.raises(SoftLimitError, match="motor 1: max_step 100 deg"):
            bus.motor(1).set_angle(100, 0, 50)
        bus.pass_time(0.5)
        assert abs(sim.motors[1].position) < 1
