"""Corners of the gate: truth values are no numbers, an estopped motor is not brought back by an enable
alone, and ``max_step`` is the same bound both ways at exactly its value (a limit from radians)."""

from __future__ import annotations

import pytest

import drempower
from drempower.errors import MotorIdleError, ValidationError
from drempower.protocol.enums import AxisState
from drempower.sim import SimBus


def test_true_and_false_are_refused_as_numbers() -> None:
    with drempower.open_bus("sim", motors=[1], clock="virtual") as bus:
        m = bus.motor(1)
        m.enable()
        for call, field in (
            (lambda: m.set_angle(True, 0, 50), "angle=True"),
            (lambda: m.set_speed(True), "speed=True"),
            (lambda: m.set_torque(False), "torque=False"),
            (lambda: m.impedance_control(True), "pos=True"),
            (lambda: bus.set_angles([1], [True], 10, 10, 1), "angle_list: True"),
            (lambda: bus.set_speeds([1], [True]), "speed_list: True"),
        ):
            with pytest.raises(ValidationError, match=field):
                call()


def test_enable_true_on_an_estopped_motor_says_clear_first() -> None:
    sim = SimBus(ids=[1])
    with drempower.open_bus("sim", bus=sim, clock="virtual", stop_on_close=False) as bus:
        m = bus.motor(1)
        m.enable()
        m.estop()
        with pytest.raises(MotorIdleError, match="after clearing its errors: it was emergency-stopped"):
            m.set_angle(30, 0, 50, enable=True)
        m.clear_error()
        m.set_angle(30, 0, 50, enable=True)
        bus.pass_time(0.5)
        assert sim.motors[1].state == AxisState.CLOSED_LOOP_CONTROL
        assert sim.motors[1].position == pytest.approx(30, abs=1)


def test_max_step_from_radians_holds_the_same_both_ways() -> None:
    from drempower.robot import parse_robot

    spec = parse_robot(
        {"buses": {"b": {"interface": "sim"}}, "joints": {"a": {"bus": "b", "id": 1, "limits": {"max_step": 0.5}}}}
    )
    with drempower.open_robot(spec, sim={"clock": "virtual"}) as robot:
        a = robot.joint("a")
        a.set_position(0.5, enable=True)  # exactly max_step up
        robot.bus("b").pass_time(1.0)
        a.set_position(0.0)  # and exactly max_step down
        robot.bus("b").pass_time(1.0)
        assert a.get_joint_state().position == pytest.approx(0.0, abs=1e-3)
