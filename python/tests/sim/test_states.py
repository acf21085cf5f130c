"""Axis states, errors, estop and recovery, and the E and T bits."""

from __future__ import annotations

import pytest

from drempower.protocol import (
    AxisError,
    AxisState,
    EncoderError,
    PositionQ,
    SysCmd,
    SystemCommand,
    Velocity,
    WriteParam,
)
from drempower.protocol.flags import CanError, MotorError
from drempower.sim import SimBus

from .helpers import exchange, fast_read, read, write


def _closed_loop(bus: SimBus, node: int) -> None:
    exchange(bus, WriteParam.of(node, "axis0.requested_state", 8))


def test_power_up_in_closed_loop_holding_position() -> None:
    bus = SimBus([1])
    m = bus.motors[1]
    assert m.state is AxisState.CLOSED_LOOP_CONTROL
    m.external_torque = 1.0
    bus.advance(1.0)
    assert m.position == pytest.approx(0.0, abs=0.01)
    s = fast_read(bus, 1)
    assert (s.trajectory_done, s.error) == (True, False)


def test_estop_idles_ignores_motion_and_recovers_with_clear_then_closed_loop() -> None:
    bus = SimBus([1])
    m = bus.motors[1]
    exchange(bus, SystemCommand(1, SysCmd.ESTOP))
    assert m.state is AxisState.IDLE
    assert read(bus, 1, "axis0.error") == AxisError.ESTOP_REQUESTED
    assert fast_read(bus, 1).error
    exchange(bus, PositionQ(1, 90.0, 30.0, 100.0), Velocity(1, 10.0))
    bus.advance(1.0)
    assert m.position == pytest.approx(0.0) and m.speed == 0.0
    _closed_loop(bus, 1)  # refused while the error is set
    assert m.state is AxisState.IDLE
    exchange(bus, SystemCommand(1, SysCmd.CLEAR_ERRORS))
    assert m.state is AxisState.IDLE and not fast_read(bus, 1).error
    _closed_loop(bus, 1)
    assert read(bus, 1, "axis0.current_state") == AxisState.CLOSED_LOOP_CONTROL
    exchange(bus, PositionQ(1, 90.0, 30.0, 100.0))
    bus.advance(1.5)
    assert m.position == pytest.approx(90.0, abs=0.05)


def test_broadcast_estop_stops_every_motor() -> None:
    bus = SimBus([1, 2])
    exchange(bus, SystemCommand(0, SysCmd.ESTOP))
    assert [m.state for m in bus.motors.values()] == [AxisState.IDLE] * 2


def test_error_raised_mid_move_drops_to_idle_and_the_shaft_coasts() -> None:
    bus = SimBus([1])
    m = bus.motors[1]
    exchange(bus, PositionQ(1, 360.0, 60.0, 200.0))
    bus.schedule(1.0, lambda: m.inject_error(MotorError.DRV_FAULT))
    bus.advance(0.999)
    assert m.state is AxisState.CLOSED_LOOP_CONTROL
    bus.advance(0.002)
    assert m.state is AxisState.IDLE
    assert m.torque == 0.0 and m.speed > 50.0  # unpowered, still turning
    assert read(bus, 1, "axis0.motor.error") == MotorError.DRV_FAULT
    assert read(bus, 1, "axis0.error") == AxisError.MOTOR_FAILED
    s = fast_read(bus, 1)
    assert s.error and s.trajectory_done
    bus.advance(5.0)
    assert m.speed == 0.0  # friction stops it


def test_can_errors_do_not_stop_the_axis() -> None:
    bus = SimBus([1])
    bus.motors[1].inject_error(CanError.DUPLICATE_CAN_IDS)
    assert bus.motors[1].state is AxisState.CLOSED_LOOP_CONTROL
    assert not fast_read(bus, 1).error


def test_t_bit_follows_the_move() -> None:
    bus = SimBus([1])
    exchange(bus, PositionQ(1, 45.0, 30.0, 100.0))
    assert not fast_read(bus, 1).trajectory_done
    assert read(bus, 1, "axis0.controller.trajectory_done") == 0
    bus.advance(1.0)
    assert fast_read(bus, 1).trajectory_done
    exchange(bus, Velocity(1, 10.0))
    assert fast_read(bus, 1).trajectory_done


def test_battery_and_offset_errors_need_set_zero_before_clear() -> None:
    bus = SimBus([1])
    m = bus.motors[1]
    m.inject_error(EncoderError.EDR_BATTERY_LOW)
    exchange(bus, SystemCommand(1, SysCmd.CLEAR_ERRORS))
    assert read(bus, 1, "axis0.encoder.error") == EncoderError.EDR_BATTERY_LOW
    assert fast_read(bus, 1).error
    exchange(bus, SystemCommand(1, SysCmd.SET_ZERO_POSITION), SystemCommand(1, SysCmd.CLEAR_ERRORS))
    assert read(bus, 1, "axis0.encoder.error") == 0 and not fast_read(bus, 1).error


def test_requested_idle_and_calibration_states() -> None:
    bus = SimBus([1])
    m = bus.motors[1]
    write(bus, 1, "axis0.requested_state", AxisState.IDLE)
    assert m.state is AxisState.IDLE and not m.drive.active
    write(bus, 1, "axis0.requested_state", AxisState.MOTOR_CALIBRATION)
    assert read(bus, 1, "axis0.current_state") == AxisState.MOTOR_CALIBRATION
    bus.advance(4.1)
    assert m.state is AxisState.IDLE
    write(bus, 1, "axis0.requested_state", AxisState.SENSORLESS_CONTROL)  # not a state a user can request
    assert m.state is AxisState.IDLE


def test_idle_spins_freely_and_idle_damping_brakes() -> None:
    speeds = []
    for damp in (0, 1):
        bus = SimBus([1])
        m = bus.motors[1]
        write(bus, 1, "axis0.config.extra_setting.enable_damp_idle", damp)
        write(bus, 1, "axis0.requested_state", AxisState.IDLE)
        m.external_torque = 1.0
        bus.advance(0.5)
        speeds.append(m.speed)
    assert speeds[0] > 500.0  # no speed limit while unpowered
    expected = (1.0 - 0.1) / 0.05  # (external - coulomb torque) / damping per r/min
    assert speeds[1] == pytest.approx(expected, rel=0.05)


def test_control_frames_are_ignored_in_idle() -> None:
    bus = SimBus([1])
    write(bus, 1, "axis0.requested_state", AxisState.IDLE)
    exchange(bus, Velocity(1, 50.0))
    bus.advance(0.5)
    assert bus.motors[1].speed == 0.0


def test_requesting_closed_loop_again_does_not_interrupt_a_move() -> None:
    bus = SimBus([1])
    exchange(bus, PositionQ(1, 90.0, 30.0, 100.0))
    bus.advance(0.3)
    _closed_loop(bus, 1)
    bus.advance(1.0)
    assert bus.motors[1].position == pytest.approx(90.0, abs=0.05)


def test_enter_dfu_mode_silences_the_motor_until_a_power_cycle() -> None:
    from drempower.protocol import FastRead, SysCmd, SystemCommand
    from drempower.sim.behaviour import BOOT_SECONDS

    from .helpers import exchange, fast_read

    bus = SimBus([1])
    m = bus.motors[1]
    assert m.state is AxisState.CLOSED_LOOP_CONTROL
    exchange(bus, SystemCommand(1, SysCmd.ENTER_DFU_MODE))
    assert m.in_dfu and m.state is AxisState.IDLE and not m.drive.active
    assert exchange(bus, FastRead(1), SystemCommand(1, SysCmd.REBOOT)) == []  # nothing answers, nothing acts
    assert m.in_dfu
    m.power_cycle()
    assert not m.in_dfu and m.booting
    bus.advance(BOOT_SECONDS + 0.001)
    assert fast_read(bus, 1).node == 1
