"""A motion command to every motor (id 0) is checked as one command to each motor the bus knows (their
limits, their axis states), or refused when the bus knows none: threaded, asyncio and compat."""

from __future__ import annotations

import asyncio

import pytest

import drempower
from drempower import compat
from drempower.errors import MotorIdleError, SoftLimitError, ValidationError
from drempower.sim import SimBus

from ..scripted import ScriptedTransport


def _open(sim: SimBus) -> drempower.Bus:
    return drempower.open_bus("sim", bus=sim, clock="virtual", stop_on_close=False)


def test_a_broadcast_motion_is_checked_against_every_motor() -> None:
    sim = SimBus(ids=[1, 2])
    with _open(sim) as bus:
        bus.enable([1, 2])
        bus.set_limits(1, position=(-90, 90), speed=30)
        every = bus.motor(0)
        with pytest.raises(SoftLimitError, match=r"motor 1: speed 200 r/min is beyond its soft limit -30\.\.30"):
            every.set_speed(200)
        with pytest.raises(SoftLimitError, match=r"motor 1: position 170 deg is beyond its soft limit -90\.\.90"):
            every.set_angle(170, 0, 50)
        with pytest.raises(ValidationError, match="id=0 is out of range"):
            every.step_angle(100, 10, 100, 1)  # a synchronised move names its motors
        bus.pass_time(0.5)
        assert [abs(sim.motors[n].speed) < 1 for n in (1, 2)] == [True, True]
        assert [abs(sim.motors[n].position) < 1 for n in (1, 2)] == [True, True]
        every.set_speed(20)  # within every motor's limits: sent
        bus.pass_time(0.5)
        assert sim.motors[1].speed == pytest.approx(20, abs=1) and sim.motors[2].speed == pytest.approx(20, abs=1)
        every.stop()
        bus.idle([2])
        with pytest.raises(MotorIdleError, match="motor 2 is idle"):
            every.set_speed(10)


def test_a_broadcast_motion_on_a_bus_that_knows_no_motor_is_refused() -> None:
    t = ScriptedTransport()  # answers nothing, declares no motor
    refused = r"a motion command to every motor \(id 0\) is refused"
    with drempower.Bus(t, stop_on_close=False) as bus, pytest.raises(ValidationError, match=refused):
        bus.motor(0).set_speed(10)
    assert t.sent == []


def test_the_asyncio_bus_and_compat_check_the_same() -> None:
    sim = SimBus(ids=[1, 2])

    async def main() -> None:
        async with drempower.open_bus_async("sim", bus=sim, clock="virtual", stop_on_close=False) as bus:
            await bus.enable([1, 2])
            bus.set_limits(1, speed=30)
            with pytest.raises(SoftLimitError, match="motor 1: speed 200 r/min"):
                await bus.motor(0).set_speed(200)

    asyncio.run(main())
    with _open(sim) as bus:
        bus.enable([1, 2])
        bus.set_limits(1, position=(-90, 90), speed=30)
        compat.use_bus(bus)
        try:
            with pytest.raises(SoftLimitError, match="motor 1: speed 200 r/min"):
                compat.set_speed(0, 200)  # the vendor's default id is 0
            with pytest.raises(SoftLimitError, match="motor 1: position 170 deg"):
                compat.set_angle(speed=10, angle=170, param=10, mode=1)
        finally:
            compat._bus = None
        bus.pass_time(0.5)
        assert abs(sim.motors[1].speed) < 1 and abs(sim.motors[1].position) < 1


def test_compat_presets_pass_the_gate() -> None:
    sim = SimBus(ids=[1, 2])
    with _open(sim) as bus:
        bus.enable([1])
        bus.idle([2])
        bus.set_limits(1, position=(-90, 90), speed=30)
        compat.use_bus(bus)
        try:
            with pytest.raises(SoftLimitError, match="motor 1: position 170 deg"):
                compat.preset_angle(1, 170, 10, 50, 0)
            with pytest.raises(SoftLimitError, match="motor 1: speed 200 r/min"):
                compat.preset_speed(1, 200, 0, 1)
            with pytest.raises(MotorIdleError, match="motor 2 is idle"):
                compat.preset_speed(2, 20, 0, 1)
            compat.preset_angle(1, 45, 10, 50, 0)  # within the limits: sent
        finally:
            compat._bus = None
