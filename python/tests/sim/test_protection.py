"""Software angle limits, stall protection, over-speed, and two motors sharing an id."""

from __future__ import annotations

import pytest

from drempower.protocol import (
    AxisError,
    AxisState,
    ControllerError,
    FastRead,
    PositionQ,
    PositionT,
    ReadParam,
    Torque,
    Velocity,
)
from drempower.protocol.flags import CanError, MotorError
from drempower.sim import SimBus

from .helpers import exchange, read, write

LIMIT_ON = "axis0.config.extra_setting.enable_circular_setpoint_limit"


def _limited(lo: float, hi: float) -> SimBus:
    bus = SimBus([1])
    write(bus, 1, "axis0.output_shaft.circular_setpoint_min", lo)
    write(bus, 1, "axis0.output_shaft.circular_setpoint_max", hi)
    write(bus, 1, LIMIT_ON, 1)
    assert read(bus, 1, LIMIT_ON) == 1
    return bus


def test_position_targets_are_clamped_to_the_limits() -> None:
    bus = _limited(-90.0, 90.0)
    m = bus.motors[1]
    exchange(bus, PositionQ(1, 180.0, 60.0, 300.0))
    bus.advance(2.0)
    assert m.position == pytest.approx(90.0, abs=0.05)
    exchange(bus, PositionT(1, -400.0, bandwidth=50.0))
    bus.advance(2.0)
    assert m.position == pytest.approx(-90.0, abs=0.05)


@pytest.mark.parametrize("command", [Velocity(1, 60.0), Torque(1, 0.3), Velocity(1, -60.0)])
def test_speed_and_torque_modes_stop_at_the_limits(command: Velocity | Torque) -> None:
    bus = _limited(-90.0, 90.0)
    m = bus.motors[1]
    exchange(bus, command)
    highest = 0.0
    for _ in range(3000):
        bus.advance(0.001)
        highest = max(highest, abs(m.position))
    assert highest < 95.0
    assert abs(m.position) == pytest.approx(90.0, abs=0.1)
    assert m.speed == pytest.approx(0.0, abs=0.1)


def test_a_limit_that_excludes_the_position_is_refused() -> None:
    bus = SimBus([1])
    exchange(bus, PositionQ(1, 100.0, 100.0, 300.0))
    bus.advance(2.0)
    write(bus, 1, "axis0.output_shaft.circular_setpoint_max", 50.0)
    write(bus, 1, LIMIT_ON, 1)
    assert read(bus, 1, LIMIT_ON) == 0  # 100 deg is outside [-360, 50]
    write(bus, 1, "axis0.output_shaft.circular_setpoint_max", 200.0)
    write(bus, 1, LIMIT_ON, 1)
    write(bus, 1, "axis0.output_shaft.circular_setpoint_max", 50.0)
    assert read(bus, 1, "axis0.output_shaft.circular_setpoint_max") == pytest.approx(200.0)


def test_outside_the_limits_the_motor_creeps_back_to_the_nearest() -> None:
    bus = _limited(-10.0, 90.0)
    m = bus.motors[1]
    write(bus, 1, "axis0.requested_state", AxisState.IDLE)
    m.external_torque = -0.3  # turned by hand while unpowered
    bus.advance(0.1)
    m.external_torque = 0.0
    bus.advance(2.0)
    assert m.position < -15.0 and m.speed == 0.0
    write(bus, 1, "axis0.requested_state", AxisState.CLOSED_LOOP_CONTROL)
    bus.advance(0.5)
    assert 0.0 < m.speed <= 5.01  # slowly, toward -10 deg
    assert not m.trajectory_done
    bus.advance(60.0)
    assert m.position == pytest.approx(-10.0, abs=0.05)


def test_stall_protection_trips_after_the_time_limit() -> None:
    bus = SimBus([1])
    m = bus.motors[1]
    m.locked = True
    exchange(bus, Torque(1, 11.0))  # 11 A > 10 A stall current
    bus.advance(1.99)
    assert m.state is AxisState.CLOSED_LOOP_CONTROL
    bus.advance(0.02)
    assert m.state is AxisState.IDLE
    assert read(bus, 1, "axis0.motor.error") == MotorError.STALL_LIMIT_VIOLATION
    assert read(bus, 1, "axis0.error") == AxisError.MOTOR_FAILED


def test_stall_protection_off_or_below_the_current_holds() -> None:
    bus = SimBus([1])
    m = bus.motors[1]
    m.locked = True
    exchange(bus, Torque(1, 9.0))
    bus.advance(3.0)
    assert m.state is AxisState.CLOSED_LOOP_CONTROL
    write(bus, 1, "axis0.config.extra_setting.enable_stall_limit", 0)
    exchange(bus, Torque(1, 12.0))
    bus.advance(3.0)
    assert m.state is AxisState.CLOSED_LOOP_CONTROL and m.current == pytest.approx(12.0)


def test_overspeed_error_when_enabled() -> None:
    bus = SimBus([1])
    m = bus.motors[1]
    write(bus, 1, "axis0.controller.config.enable_overspeed_error", 1)
    write(bus, 1, "axis0.controller.config.enable_current_mode_vel_limit", 0)
    exchange(bus, Torque(1, 2.0))
    bus.advance(1.0)
    assert m.state is AxisState.IDLE
    assert read(bus, 1, "axis0.controller.error") == ControllerError.OVERSPEED


def test_two_motors_sharing_an_id_both_answer_and_flag_it() -> None:
    bus = SimBus([1, 2])
    bus.motors[2].node_id = 1
    answers = exchange(bus, FastRead(1))
    assert [a.node for a in answers] == [1, 1]
    (word_1, word_2) = exchange(bus, ReadParam.of(1, "can.error"))
    assert word_1.value == word_2.value == CanError.DUPLICATE_CAN_IDS  # type: ignore[union-attr]
