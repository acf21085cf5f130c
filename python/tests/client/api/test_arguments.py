"""Arguments the wire would turn into something else are refused, named as the caller gave them."""

from __future__ import annotations

from collections.abc import Callable

import pytest

from drempower.client import Bus
from drempower.client.engine.commands import (
    make_angle,
    make_angles,
    make_impedance,
    make_speed,
    make_speeds,
    make_torque,
    make_torques,
)
from drempower.errors import FieldRangeError

from ..scripted import ScriptedTransport


@pytest.mark.parametrize(
    ("call", "field"),
    [
        (lambda: make_angle(1, 90, 0.004, 20, 1), "speed"),  # would be sent as 0 r/min: the motor faults
        (lambda: make_angle(1, 90, 10, 0.004, 1), "param (accel)"),
        (lambda: make_angle(1, 0, 0, 0.004, 0), "param (bandwidth)"),  # 0 bandwidth: never moves
        (lambda: make_angles([1, 2], [10, 20], 10, 10, 1, move_time=0.004), "move time (s)"),
        (lambda: make_speed(1, 10, 0, 2), "param (ramp rate)"),  # a ramp of 0 holds the speed
        (lambda: make_speed(1, 10, -5, 2), "param (ramp rate)"),
        (lambda: make_torque(1, 0.5, 0.001, 6), "param (ramp rate)"),
        (lambda: make_speeds([1, 2], [5, 5], 0, 2), "param (ramp rate)"),
        (lambda: make_torques([1, 2], [1, 1], -1, 6), "param (ramp rate)"),
    ],
)
def test_values_that_round_to_zero_are_refused(call: Callable[[], object], field: str) -> None:
    with pytest.raises(FieldRangeError) as info:
        call()
    assert info.value.field == field and info.value.low == 0.01


def test_the_smallest_step_is_accepted() -> None:
    assert make_angle(1, 90, 0.006, 0.01, 1).encode().data[4:] == bytes([1, 0, 1, 0])


@pytest.mark.parametrize(
    ("call", "field"),
    [
        (lambda: make_impedance(1, 0, 400, 0, 1, 1), "vel"),
        (lambda: make_impedance(1, 0, 0, -400, 1, 1), "tff"),
        (lambda: make_angle(1, 1e40, 10, 10, 1), "angle"),
        (lambda: make_angle(1, 0, 400, 0, 2), "speed"),  # P mode: speed feed-forward
        (lambda: make_angle(1, 0, 0, 400, 2), "param"),  # P mode: torque feed-forward
        (lambda: make_speed(1, 10, 400, 1), "param"),
        (lambda: make_angles([1, 2], [10, 1e40], 10, 10, 1, move_time=1), "angle_list (motor 2)"),
        (lambda: make_torques([3, 4], [1, 1e40]), "torque_list (motor 4)"),
    ],
)
def test_errors_name_the_argument(call: Callable[[], object], field: str) -> None:
    with pytest.raises(FieldRangeError) as info:
        call()
    assert info.value.field == field and str(info.value).startswith(f"{field}=")


def test_nothing_is_sent_after_a_refused_argument() -> None:
    t = ScriptedTransport()
    with Bus(t, timeout=0.25, stop_on_close=False) as bus:
        m = bus.motor(1)
        for call in (
            lambda: m.set_angle(90, 0.001, 10, 1),
            lambda: m.set_speed(10, 0, 2),
            lambda: m.set_torque(1, 0, 6),
            lambda: m.impedance_control(0, 400, 0, 1, 1),
            lambda: bus.set_torques([1, 2], [1, 1], 0, 6),
        ):
            with pytest.raises(FieldRangeError):
                call()
    assert t.sent == []


def test_mode_parameters_take_only_their_values() -> None:
    from drempower.protocol import WriteParam

    for name, bad in (
        ("axis0.trap_traj.config.traj_mode", 7),
        ("axis0.controller.config.control_mode", 5),
        ("axis0.controller.config.input_mode", 8),
        ("axis0.requested_state", 12),
    ):
        with pytest.raises(FieldRangeError, match=name):
            WriteParam.of(1, name, bad)
    assert WriteParam.of(1, "axis0.trap_traj.config.traj_mode", 2).value == 2


def test_a_traj_mode_the_motor_reports_out_of_its_set_is_named() -> None:
    from drempower import DrEmpowerError
    from drempower.sim import SimBus

    from ..links import link

    sim = SimBus(ids=[1, 2])
    sim.motors[2].set_param("axis0.trap_traj.config.traj_mode", 7)
    with link("inprocess", sim, timeout=1.0) as bus:
        assert int(bus.motor(1).get_traj_mode()) == 1
        with pytest.raises(DrEmpowerError, match=r"motor 2 reports .*traj_mode=7"):
            bus.motor(2).get_traj_mode()
        with pytest.raises(DrEmpowerError, match=r"motor 2 reports .*traj_mode=7"):
            bus.set_angles([1, 2], [10, 10], 10, 10, 1)
