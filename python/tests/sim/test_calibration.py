"""The calibration sequence the firmware inherits from ODrive: phases, durations, the shaft turning during
encoder offset calibration, and the ways it fails (low supply, a blocked shaft, an error on the way)."""

from __future__ import annotations

import pytest

from drempower.protocol import AxisState
from drempower.protocol.flags import AxisError, EncoderError, MotorError
from drempower.sim import SimBus
from drempower.sim import behaviour as bh
from drempower.sim.defaults import MotorModel

from .helpers import read, write

MOTOR_S = bh.MOTOR_CALIBRATION_SECONDS
ENCODER_S = bh.ENCODER_OFFSET_CALIBRATION_SECONDS


def _states(bus: SimBus, seconds: float, step: float = 0.5) -> list[tuple[AxisState, float]]:
    """(state, position deg) of motor 1 every ``step`` s of simulated time."""
    m = bus.motors[1]
    out = []
    for _ in range(round(seconds / step)):
        bus.advance(step)
        out.append((m.state, m.position))
    return out


def test_full_sequence_runs_motor_then_encoder_calibration_and_ends_idle() -> None:
    bus = SimBus([1])
    write(bus, 1, "axis0.requested_state", AxisState.FULL_CALIBRATION_SEQUENCE)
    assert read(bus, 1, "axis0.current_state") == AxisState.MOTOR_CALIBRATION
    trace = _states(bus, MOTOR_S + ENCODER_S + 1.0, 0.25)
    phases = [s for k, (s, _) in enumerate(trace) if k == 0 or trace[k - 1][0] != s]
    assert phases == [AxisState.MOTOR_CALIBRATION, AxisState.ENCODER_OFFSET_CALIBRATION, AxisState.IDLE]
    motor_part = [p for s, p in trace if s is AxisState.MOTOR_CALIBRATION]
    encoder_part = [p for s, p in trace if s is AxisState.ENCODER_OFFSET_CALIBRATION]
    assert len(motor_part) == pytest.approx(MOTOR_S / 0.25, abs=1)
    assert len(encoder_part) == pytest.approx(ENCODER_S / 0.25, abs=1)
    assert all(p == 0.0 for p in motor_part)  # the rotor is held still
    # one rotor turn forward and back: 360 deg / gear ratio at the output, back to the start
    ratio = float(read(bus, 1, "axis0.config.extra_setting.gear_ratio"))
    assert max(encoder_part) == pytest.approx(360.0 / ratio, rel=0.05)
    assert trace[-1] == (AxisState.IDLE, pytest.approx(0.0, abs=1e-6))
    assert read(bus, 1, "axis0.motor.is_calibrated") == 1
    assert read(bus, 1, "axis0.config.extra_setting.encoder_offset_calibrated") == 1
    assert read(bus, 1, "axis0.error") == 0


def test_encoder_calibration_alone() -> None:
    bus = SimBus([1])
    write(bus, 1, "axis0.requested_state", AxisState.ENCODER_OFFSET_CALIBRATION)
    trace = _states(bus, ENCODER_S + 0.5)
    assert trace[0][0] is AxisState.ENCODER_OFFSET_CALIBRATION and trace[0][1] > 0
    assert trace[-1][0] is AxisState.IDLE


def test_low_supply_fails_motor_calibration() -> None:
    bus = SimBus([1], model=MotorModel(vbus=bh.CALIBRATION_MIN_VBUS - 3))
    write(bus, 1, "axis0.requested_state", AxisState.FULL_CALIBRATION_SEQUENCE)
    trace = _states(bus, MOTOR_S + ENCODER_S)
    assert AxisState.ENCODER_OFFSET_CALIBRATION not in [s for s, _ in trace]  # the sequence stops
    assert bus.motors[1].state is AxisState.IDLE
    assert read(bus, 1, "axis0.error") == AxisError.MOTOR_FAILED | AxisError.DC_BUS_UNDER_VOLTAGE
    assert read(bus, 1, "axis0.motor.error") == MotorError.PHASE_RESISTANCE_OUT_OF_RANGE


def test_blocked_shaft_fails_encoder_calibration() -> None:
    bus = SimBus([1])
    bus.motors[1].locked = True
    write(bus, 1, "axis0.requested_state", AxisState.ENCODER_OFFSET_CALIBRATION)
    trace = _states(bus, ENCODER_S + 0.5)
    assert all(p == 0.0 for _, p in trace)
    assert read(bus, 1, "axis0.encoder.error") == EncoderError.CPR_POLEPAIRS_MISMATCH
    assert read(bus, 1, "axis0.error") == AxisError.ENCODER_FAILED


def test_an_error_on_the_way_ends_the_sequence_in_idle() -> None:
    bus = SimBus([1])
    write(bus, 1, "axis0.requested_state", AxisState.FULL_CALIBRATION_SEQUENCE)
    bus.advance(MOTOR_S + 1.0)
    assert bus.motors[1].state is AxisState.ENCODER_OFFSET_CALIBRATION
    bus.motors[1].inject_error(AxisError.OVER_TEMP)
    assert bus.motors[1].state is AxisState.IDLE
    trace = _states(bus, ENCODER_S)
    assert {s for s, _ in trace} == {AxisState.IDLE}


def test_calibration_is_refused_while_an_error_is_set() -> None:
    bus = SimBus([1])
    bus.motors[1].inject_error(AxisError.OVER_TEMP)
    write(bus, 1, "axis0.requested_state", AxisState.MOTOR_CALIBRATION)
    assert bus.motors[1].state is AxisState.IDLE
