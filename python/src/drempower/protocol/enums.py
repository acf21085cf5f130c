"""Enumerations of the firmware (ODrive-style), as in PROTOCOL.md section 5.1."""

from __future__ import annotations

from enum import IntEnum

__all__ = [
    "AxisState",
    "ControlMode",
    "InputMode",
    "VelocityMode",
    "TorqueMode",
    "TrajMode",
    "MotorType",
    "EncoderMode",
]


class AxisState(IntEnum):
    """``axis0.current_state`` / ``axis0.requested_state`` (30002/30003)."""

    UNDEFINED = 0
    IDLE = 1
    STARTUP_SEQUENCE = 2
    FULL_CALIBRATION_SEQUENCE = 3
    MOTOR_CALIBRATION = 4
    SENSORLESS_CONTROL = 5
    ENCODER_INDEX_SEARCH = 6
    ENCODER_OFFSET_CALIBRATION = 7
    CLOSED_LOOP_CONTROL = 8
    LOCKIN_SPIN = 9
    ENCODER_DIR_FIND = 10
    HOMING = 11


class ControlMode(IntEnum):
    """``axis0.controller.config.control_mode`` (32105)."""

    VOLTAGE_CONTROL = 0
    TORQUE_CONTROL = 1
    VELOCITY_CONTROL = 2
    POSITION_CONTROL = 3
    IMPEDANCE_CONTROL = 4


class InputMode(IntEnum):
    """``axis0.controller.config.input_mode`` (32106)."""

    INACTIVE = 0
    PASSTHROUGH = 1
    VEL_RAMP = 2
    POS_FILTER = 3
    MIX_CHANNELS = 4
    TRAP_TRAJ = 5
    TORQUE_RAMP = 6
    MIRROR = 7


class VelocityMode(IntEnum):
    """Mode field of the V command 0x1C (raw u16) and of V presets (x100)."""

    PASSTHROUGH = 1
    """Speed setpoint jumps to the target; the parameter is a torque feed-forward (Nm)."""
    RAMP = 2
    """Speed ramps to the target; the parameter is the ramp rate ((r/min)/s)."""


class TorqueMode(IntEnum):
    """Mode field of the C command 0x1D (raw u16) and of C presets (x100)."""

    DIRECT = 1
    """Torque setpoint equals the target at once; the parameter is unused."""
    RAMP = 6
    """Torque ramps to the target; the parameter is the ramp rate (Nm/s)."""


class TrajMode(IntEnum):
    """``axis0.trap_traj.config.traj_mode`` (35104): Q-mode velocity profile."""

    TRAPEZOID = 1
    S_CURVE = 2


class MotorType(IntEnum):
    HIGH_CURRENT = 0
    GIMBAL = 2
    ACIM = 3


class EncoderMode(IntEnum):
    INCREMENTAL = 0
    HALL = 1
    SINCOS = 2
    SPI_ABS_CUI = 256
    SPI_ABS_AMS = 257
    SPI_ABS_AEAT = 258
    SPI_ABS_RLS = 259
    SPI_ABS_EDR = 271
