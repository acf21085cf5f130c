"""Bad arguments raise ValidationError before a single frame is sent, in the sync and the asyncio API."""

from __future__ import annotations

import asyncio
import inspect
from collections.abc import Callable
from typing import Any

import pytest

import drempower
from drempower.client import AsyncBus, AsyncMotor, Bus, Motor
from drempower.client.engine.timeouts import MAX_TIMEOUT, check_timeout
from drempower.errors import ValidationError

from ..scripted import FakeMotors, ScriptedTransport

NAN = float("nan")

Call = Callable[[Any, Any], Any]
"""A call on (bus, motor 1); sync or async."""

REFUSED: list[tuple[str, Call, str]] = [
    ("set_torque param nan", lambda b, m: m.set_torque(1, NAN, 6), "param (ramp rate)=nan"),
    ("set_torque param None", lambda b, m: m.set_torque(1, None, 6), "param (ramp rate)=None"),
    ("set_torque param str", lambda b, m: m.set_torque(1, "abc", 6), "param (ramp rate)='abc'"),
    ("set_torque direct nan", lambda b, m: m.set_torque(1, NAN, 1), "param=nan"),  # ignored, still checked
    ("set_torque direct None", lambda b, m: m.set_torque(1, None), "param=None"),
    ("set_speed ff at 0 nan", lambda b, m: m.set_speed(0, NAN, 1), "param=nan"),
    ("set_torques direct nan", lambda b, m: b.set_torques([1, 2], [1, 1], NAN, 1), "param=nan"),
    ("set_angle T negative bw", lambda b, m: m.set_angle(10, 0, -20, 0), "param (bandwidth)=-20"),
    ("set_angles T negative bw", lambda b, m: b.set_angles([1, 2], [1, 2], 0, -20, 0), "param (bandwidth)=-20"),
    ("estop []", lambda b, m: b.estop([]), "id_list is empty"),
    ("estop [64]", lambda b, m: b.estop([64]), "id_list=64"),
    ("set_angle_range 1e39", lambda b, m: m.set_angle_range(-1e39, 1e39), "circular_setpoint_min=-1e+39"),
    ("set_angle_range nan", lambda b, m: m.set_angle_range(NAN, 10), "angle_min=nan"),
    ("write_property [1]", lambda b, m: m.write_property("axis0.controller.config.pos_gain", [1]), "pos_gain=[1]"),
    ("write_property None", lambda b, m: m.write_property(32108, None), "pos_gain=None"),
    ("set_GPIO_mode nan", lambda b, m: m.set_GPIO_mode("step_dir", NAN), "param=nan"),
    ("set_GPIO_mode str", lambda b, m: m.set_GPIO_mode("step_dir", "x"), "param='x'"),
    ("wait_position_done str", lambda b, m: m.wait_position_done(timeout="x"), "timeout='x'"),
    ("wait_position_done poll", lambda b, m: m.wait_position_done(1, poll_interval=NAN), "poll_interval=nan"),
    ("positions_done inf", lambda b, m: b.positions_done([1, 2], timeout=float("inf")), "timeout=inf"),
    ("get_state inf", lambda b, m: m.get_state(timeout=float("inf")), "timeout=inf"),
    ("get_state 1e12", lambda b, m: m.get_state(timeout=1e12), "timeout=1000000000000.0"),
    ("get_state str", lambda b, m: m.get_state(timeout="x"), "timeout='x'"),
    ("get_state bool", lambda b, m: m.get_state(timeout=True), "timeout=True"),
    ("read_property inf", lambda b, m: m.read_property(32108, timeout=float("inf")), "timeout=inf"),
    (
        "write verify 1e12",
        lambda b, m: m.write_property(32108, 1, verify=True, timeout=1e12),
        "timeout=1000000000000.0",
    ),
    ("set_id inf", lambda b, m: m.set_id(5, timeout=float("inf")), "timeout=inf"),
    ("wait_state str", lambda b, m: m.wait_state("x"), "timeout='x'"),
    ("wait_state None", lambda b, m: b.wait_state(1, None), "timeout=None"),
    ("scan inf", lambda b, m: b.scan([1, 2], timeout=float("inf")), "timeout=inf"),
    ("request str", lambda b, m: b.request([], timeout="x"), "timeout='x'"),
    ("backup inf", lambda b, m: m.backup(timeout=float("inf")), "timeout=inf"),
    ("set_angles ids None", lambda b, m: b.set_angles(None, [1]), "id_list=None: expected a list"),
    ("positions_done ids float", lambda b, m: b.positions_done(1.5), "id_list=1.5: expected a list"),
    ("scan ids None", lambda b, m: b.scan(None), "ids=None: expected a list"),
    ("cycle str", lambda b, m: b.cycle("x"), "commands='x'"),
    ("cycle ints", lambda b, m: b.cycle([1]), "commands: 1 is no protocol message"),
    ("motor list", lambda b, m: b.motor([1]), "id=[1]"),
    ("wait_state id list", lambda b, m: b.wait_state([1], 0.01), "id=[1]"),
    ("broadcast get_state", lambda b, m: b.motor(0).get_state(), "ambiguous on a bus with motors 1, 2"),
    ("broadcast get_id", lambda b, m: b.motor(0).get_id(), "id 0"),
    ("broadcast dump_error", lambda b, m: b.motor(0).dump_error(), "id 0"),
]


@pytest.mark.parametrize(("name", "call", "message"), REFUSED, ids=[r[0] for r in REFUSED])
def test_refused_before_any_frame(name: str, call: Call, message: str) -> None:
    t = ScriptedTransport(FakeMotors([1, 2]))
    with Bus(t, timeout=0.25, stop_on_close=False) as bus:
        m, _ = bus.motor(1), bus.motor(2)
        with pytest.raises(ValidationError) as info:
            call(bus, m)
        assert message in str(info.value)
    assert t.sent == []


@pytest.mark.parametrize(("name", "call", "message"), REFUSED, ids=[r[0] for r in REFUSED])
async def test_refused_before_any_frame_async(name: str, call: Call, message: str) -> None:
    t = ScriptedTransport(FakeMotors([1, 2]))
    async with AsyncBus(t, timeout=0.25, stop_on_close=False) as bus:
        m, _ = bus.motor(1), bus.motor(2)
        with pytest.raises(ValidationError) as info:
            result = call(bus, m)
            if inspect.isawaitable(result):
                await result
        assert message in str(info.value)
    assert t.sent == []


def test_a_broadcast_read_works_with_one_motor_and_is_refused_once_several_are_known() -> None:
    t = ScriptedTransport(FakeMotors([7, 8]))
    with Bus(t, timeout=0.25, stop_on_close=False) as bus:
        assert bus.known_motors() == set()
        assert bus.motor(0).get_state().node in (7, 8)  # nothing known yet: allowed, as the vendor does
        assert bus.known_motors() == {7, 8}  # both answered: the bus has heard them
        t.sent.clear()
        with pytest.raises(ValidationError, match="motors 7, 8: read each motor by its id"):
            bus.motor(0).get_state()
        assert t.sent == []
        bus.motor(0).set_zero_position()  # commands to every motor are fine
        assert len(t.sent) == 1
    t = ScriptedTransport(FakeMotors([7]))
    with Bus(t, timeout=0.25, stop_on_close=False) as bus:
        for _ in range(2):
            assert bus.motor(0).get_id() == 7  # one motor: broadcast reads keep working
        bus.motor(9)  # a handle makes the motor known
        with pytest.raises(ValidationError, match="motors 7, 9"):
            bus.motor(0).get_id()


def test_the_simulator_declares_its_motors() -> None:
    with drempower.open_bus("sim", motors=[1, 2, 3]) as bus:
        assert bus.known_motors() == {1, 2, 3}
        with pytest.raises(ValidationError, match="ambiguous"):
            bus.motor(0).get_state()
    with drempower.open_bus("sim", motors=[4]) as bus:
        assert bus.motor(0).get_state(timeout=1.0).node == 4


@pytest.mark.parametrize("value", [float("inf"), 1e12, "x", 0, -1, NAN, None])
def test_the_bus_timeout_is_checked(value: object) -> None:
    t = ScriptedTransport()
    with pytest.raises(ValidationError, match="timeout="):
        Bus(t, timeout=value, stop_on_close=False).close() if value is not None else check_timeout(None, none_ok=False)
    with Bus(t, timeout=0.25, stop_on_close=False) as bus:
        with pytest.raises(ValidationError, match="timeout="):
            bus.timeout = value  # type: ignore[assignment]
        assert bus.timeout == 0.25
    assert check_timeout(MAX_TIMEOUT) == MAX_TIMEOUT and check_timeout(None) is None


def test_every_method_with_a_time_argument_checks_it() -> None:
    """No public method escapes the check (a new method gets it from the class decorator)."""
    from drempower.robot import AsyncJoint, AsyncRobot, Joint, Robot

    for cls in (Bus, AsyncBus, Motor, AsyncMotor, Robot, AsyncRobot, Joint, AsyncJoint):
        for name, fn in inspect.getmembers(cls, inspect.isfunction):
            params = inspect.signature(fn).parameters
            if name.startswith("_") or not ({"timeout", "poll_interval"} & set(params)):
                continue
            assert hasattr(fn, "__wrapped__"), f"{cls.__name__}.{name}"


def test_the_check_keeps_signatures_and_docstrings() -> None:
    assert inspect.signature(Motor.get_state) == inspect.signature(Motor.get_state.__wrapped__)  # type: ignore[attr-defined]
    assert Motor.wait_position_done.__doc__
    assert asyncio.iscoroutinefunction(AsyncMotor.get_state)
