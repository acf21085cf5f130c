"""Parameter writes that command motion pass the safety gate, whatever the front end: the API (threaded
and asyncio), compat, the actions table, ``drempower actions set``, the dashboard's Parameters Set and its
Actions view. Each refusal leaves the motor's parameter as it was (nothing reached it)."""

from __future__ import annotations

import asyncio
from collections.abc import Callable, Iterator

import pytest

import drempower
from drempower import actions, compat
from drempower.client.engine.gate import MOTION_PARAMETERS
from drempower.errors import MotionParameterError, MotorIdleError, SoftLimitError, ValidationError
from drempower.protocol.parameters import parameters
from drempower.sim import SimBus

LIMITS = {"position": (-90, 90), "speed": 30, "torque": 1}
VEL, POS, TQ = "axis0.output_shaft.input_vel", "axis0.output_shaft.input_pos", "axis0.output_shaft.input_torque"

WRITES: list[tuple[str, float, type[Exception], str]] = [
    (VEL, 200, SoftLimitError, "motor 1: speed 200 r/min is beyond its soft limit -30..30 r/min"),
    (POS, 170, SoftLimitError, "motor 1: position 170 deg is beyond its soft limit -90..90 deg"),
    (TQ, 5, SoftLimitError, "motor 1: torque 5 Nm is beyond its soft limit -1..1 Nm"),
    ("axis0.controller.input_vel", 3, MotionParameterError, "motor 1: writing axis0.controller.input_vel=3"),
    ("axis0.controller.config.control_mode", 2, MotionParameterError, "motor 1: writing axis0.controller.config"),
    ("axis0.controller.config.input_mode", 1, MotionParameterError, "motor 1: writing axis0.controller.config"),
    ("axis0.requested_state", 4, MotionParameterError, "motor 1: writing axis0.requested_state=4 (axis state)"),
]


@pytest.fixture
def sim() -> Iterator[SimBus]:
    yield SimBus(ids=[1, 2])


def _limited(bus: drempower.Bus | drempower.AsyncBus) -> None:
    bus.set_limits(1, **LIMITS)  # type: ignore[arg-type]


def _untouched(sim: SimBus, before: dict[str, float]) -> None:
    for name, value in before.items():
        assert sim.motors[1].param(name) == value, name


def _values(sim: SimBus) -> dict[str, float]:
    """The parameters the writes aim at (the axis state aside: the tests enable the motor)."""
    return {name: sim.motors[1].param(name) for name, _, _, _ in WRITES if name != "axis0.requested_state"}


FRONT_ENDS: list[tuple[str, Callable[[drempower.Bus, str, float], object]]] = [
    ("api", lambda b, n, v: b.motor(1).write_property(n, v, force=True)),
    ("actions", lambda b, n, v: actions.run(b, "set", {"id": 1, "name": n, "value": v, "force": True})),
]


@pytest.mark.parametrize(("front", "write"), FRONT_ENDS, ids=[f for f, _ in FRONT_ENDS])
@pytest.mark.parametrize(("name", "value", "error", "words"), WRITES, ids=[w[0] for w in WRITES])
def test_a_motion_parameter_beyond_the_limits_is_refused(
    sim: SimBus,
    front: str,
    write: Callable[[drempower.Bus, str, float], object],
    name: str,
    value: float,
    error: type[Exception],
    words: str,
) -> None:
    with drempower.open_bus("sim", bus=sim, clock="virtual", stop_on_close=False) as bus:
        bus.enable([1])
        _limited(bus)
        before = _values(sim)
        with pytest.raises(error) as info:
            write(bus, name, value)
        assert str(info.value).startswith(words)
        bus.pass_time(0.5)
        _untouched(sim, before)
        assert abs(sim.motors[1].speed) < 1 and abs(sim.motors[1].position) < 1


def test_within_the_limits_a_motion_parameter_is_written(sim: SimBus) -> None:
    with drempower.open_bus("sim", bus=sim, clock="virtual", stop_on_close=False) as bus:
        bus.enable([1])
        _limited(bus)
        bus.motor(1).write_property(VEL, 20)
        assert sim.motors[1].param(VEL) == pytest.approx(20)
        bus.motor(1).write_property("axis0.output_shaft.vel_limit", 50)  # no motion: never gated
        bus.set_limits(1)
        bus.motor(1).write_property("axis0.controller.config.input_mode", 1, force=True)  # no limits: allowed


def test_a_motion_parameter_to_an_idle_motor_is_refused(sim: SimBus) -> None:
    with drempower.open_bus("sim", bus=sim, clock="virtual", stop_on_close=False) as bus:
        bus.idle([1])
        with pytest.raises(MotorIdleError, match="motor 1 is idle"):
            bus.motor(1).write_property(VEL, 20)
        assert sim.motors[1].param(VEL) == 0


def test_the_asyncio_api_refuses_the_same(sim: SimBus) -> None:
    async def main() -> None:
        async with drempower.open_bus_async("sim", bus=sim, clock="virtual", stop_on_close=False) as bus:
            await bus.enable([1])
            _limited(bus)
            for name, value, error, words in WRITES:
                with pytest.raises(error) as info:
                    await bus.motor(1).write_property(name, value, force=True)
                assert str(info.value).startswith(words)
            with pytest.raises(SoftLimitError, match="speed 200 r/min"):
                await actions.run_async(bus, "set", {"id": 1, "name": VEL, "value": 200, "force": True})

    before = _values(sim)
    asyncio.run(main())
    _untouched(sim, before)


def test_compat_write_property_is_gated(sim: SimBus) -> None:
    with drempower.open_bus("sim", bus=sim, clock="virtual", stop_on_close=False) as bus:
        bus.enable([1])
        _limited(bus)
        compat.use_bus(bus)
        try:
            before = _values(sim)
            for name, value, error, words in WRITES[:-1]:  # (a calibration state is outside the domain first)
                with pytest.raises(error) as info:
                    compat.write_property(1, name, value)
                assert str(info.value).startswith(words)
            with pytest.raises(SoftLimitError, match="motor 1: speed 200 r/min"):
                compat.write_property(0, VEL, 200)  # every motor: motor 1 among them
            _untouched(sim, before)
        finally:
            compat._bus = None


def test_the_actions_set_row_asks_force_for_a_parameter_not_meant_for_users(sim: SimBus) -> None:
    with drempower.open_bus("sim", bus=sim, clock="virtual", stop_on_close=False) as bus:
        bus.enable([1])
        with pytest.raises(ValidationError, match=r"input_vel is not meant to be changed by users \(add force"):
            actions.run(bus, "set", {"id": 1, "name": VEL, "value": 20})
        assert sim.motors[1].param(VEL) == 0
        actions.run(bus, "set", {"id": 1, "name": "axis0.output_shaft.vel_limit", "value": 50})  # a user's one


def test_every_writable_input_setpoint_or_mode_of_the_table_is_a_motion_parameter() -> None:
    """The table's writable parameters named as inputs, setpoints or modes are all gated (a new one in
    spec/parameters.csv cannot slip past the gate)."""
    for p in parameters():
        last = p.name.rsplit(".", 1)[-1]
        commands = last.startswith("input_") and last not in ("input_filter_bandwidth",)
        commands = commands or last.endswith("_setpoint") or (last.endswith("_mode") and "traj" not in last)
        if p.writable and commands and "homing" not in p.name:
            assert p.name in MOTION_PARAMETERS, p.name
    for name in MOTION_PARAMETERS:
        assert any(p.name == name and p.writable for p in parameters()), name
