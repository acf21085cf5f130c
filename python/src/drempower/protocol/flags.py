"""Error words decoded into named flags (PROTOCOL.md section 5).

Every error word of the motor has an :class:`enum.IntFlag` here and an entry in
:data:`ERROR_WORDS` (keyed by parameter name) with a short meaning and what to
do about each flag.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import IntFlag

from ..errors import FieldRangeError
from .addresses import (
    AXIS0_CONTROLLER_ERROR,
    AXIS0_ENCODER_ERROR,
    AXIS0_ERROR,
    AXIS0_FET_THERMISTOR_ERROR,
    AXIS0_MOTOR_ERROR,
    AXIS0_MOTOR_THERMISTOR_ERROR,
    CAN_ERROR,
)

__all__ = [
    "AxisError",
    "MotorError",
    "EncoderError",
    "ControllerError",
    "CanError",
    "FetThermistorError",
    "MotorThermistorError",
    "ErrorWord",
    "ERROR_WORDS",
    "decode_error_word",
    "FlagInfo",
    "flag_info",
]


class AxisError(IntFlag):
    """``axis0.error`` (30001)."""

    INVALID_STATE = 0x00000001
    DC_BUS_UNDER_VOLTAGE = 0x00000002
    DC_BUS_OVER_VOLTAGE = 0x00000004
    CURRENT_MEASUREMENT_TIMEOUT = 0x00000008
    BRAKE_RESISTOR_DISARMED = 0x00000010
    MOTOR_DISARMED = 0x00000020
    MOTOR_FAILED = 0x00000040
    SENSORLESS_ESTIMATOR_FAILED = 0x00000080
    ENCODER_FAILED = 0x00000100
    CONTROLLER_FAILED = 0x00000200
    POS_CTRL_DURING_SENSORLESS = 0x00000400
    WATCHDOG_TIMER_EXPIRED = 0x00000800
    MIN_ENDSTOP_PRESSED = 0x00001000
    MAX_ENDSTOP_PRESSED = 0x00002000
    ESTOP_REQUESTED = 0x00004000
    UNKNOWN_ERROR_CODE1 = 0x00008000
    UNKNOWN_ERROR_CODE2 = 0x00010000
    HOMING_WITHOUT_ENDSTOP = 0x00020000
    OVER_TEMP = 0x00040000


class MotorError(IntFlag):
    """``axis0.motor.error`` (33001)."""

    PHASE_RESISTANCE_OUT_OF_RANGE = 0x00000001
    PHASE_INDUCTANCE_OUT_OF_RANGE = 0x00000002
    ADC_FAILED = 0x00000004
    DRV_FAULT = 0x00000008
    CONTROL_DEADLINE_MISSED = 0x00000010
    NOT_IMPLEMENTED_MOTOR_TYPE = 0x00000020
    BRAKE_CURRENT_OUT_OF_RANGE = 0x00000040
    MODULATION_MAGNITUDE = 0x00000080
    BRAKE_DEADTIME_VIOLATION = 0x00000100
    UNEXPECTED_TIMER_CALLBACK = 0x00000200
    CURRENT_SENSE_SATURATION = 0x00000400
    UNKNOWN_ERROR_CODE = 0x00000800
    CURRENT_LIMIT_VIOLATION = 0x00001000
    BRAKE_DUTY_CYCLE_NAN = 0x00002000
    DC_BUS_OVER_REGEN_CURRENT = 0x00004000
    DC_BUS_OVER_CURRENT = 0x00008000
    STALL_LIMIT_VIOLATION = 0x00010000


class EncoderError(IntFlag):
    """``axis0.encoder.error`` (34001)."""

    UNSTABLE_GAIN = 0x00000001
    CPR_POLEPAIRS_MISMATCH = 0x00000002
    NO_RESPONSE = 0x00000004
    UNSUPPORTED_ENCODER_MODE = 0x00000008
    ILLEGAL_HALL_STATE = 0x00000010
    INDEX_NOT_FOUND_YET = 0x00000020
    ABS_SPI_TIMEOUT = 0x00000040
    ABS_SPI_COM_FAIL = 0x00000080
    ABS_SPI_NOT_READY = 0x00000100
    EDR_OVER_RANGE = 0x00000200
    EDR_POWER_FAILURE = 0x00000400
    EDR_BATTERY_LOW = 0x00000800
    OFFSET_CALIBRATE_FAILURE = 0x00001000
    INCORRECT_OFFSET = 0x00002000
    TURNS_COUNTER_WARNING = 0x00004000


class ControllerError(IntFlag):
    """``axis0.controller.error`` (32001)."""

    OVERSPEED = 0x01
    INVALID_INPUT_MODE = 0x02
    UNSTABLE_GAIN = 0x04
    INVALID_MIRROR_AXIS = 0x08
    INVALID_LOAD_ENCODER = 0x10
    INVALID_ESTIMATE = 0x20


class CanError(IntFlag):
    """``can.error`` (20001)."""

    DUPLICATE_CAN_IDS = 0x01


class FetThermistorError(IntFlag):
    """``axis0.fet_thermistor.error`` (36001)."""

    OVER_TEMP = 0x01


class MotorThermistorError(IntFlag):
    """``axis0.motor_thermistor.error`` (37001)."""

    OVER_TEMP = 0x01


@dataclass(frozen=True, slots=True)
class FlagInfo:
    """Meaning of one error flag and what a user should do about it."""

    meaning: str
    action: str


@dataclass(frozen=True, slots=True)
class ErrorWord:
    """An error word of the motor: its parameter, short label and flag type."""

    name: str
    address: int
    label: str
    flags: type[IntFlag]


ERROR_WORDS: tuple[ErrorWord, ...] = (
    ErrorWord("axis0.error", AXIS0_ERROR, "axis", AxisError),
    ErrorWord("axis0.motor.error", AXIS0_MOTOR_ERROR, "motor", MotorError),
    ErrorWord("axis0.encoder.error", AXIS0_ENCODER_ERROR, "encoder", EncoderError),
    ErrorWord("axis0.controller.error", AXIS0_CONTROLLER_ERROR, "controller", ControllerError),
    ErrorWord("can.error", CAN_ERROR, "can", CanError),
    ErrorWord("axis0.fet_thermistor.error", AXIS0_FET_THERMISTOR_ERROR, "fet_thermistor", FetThermistorError),
    ErrorWord("axis0.motor_thermistor.error", AXIS0_MOTOR_THERMISTOR_ERROR, "motor_thermistor", MotorThermistorError),
)
"""The seven error words, in the order the vendor's ``dump_error`` reads them
(axis, motor, encoder, controller, can, fet thermistor, motor thermistor)."""

_BY_KEY: dict[object, ErrorWord] = {}
for _w in ERROR_WORDS:
    _BY_KEY[_w.name] = _w
    _BY_KEY[_w.address] = _w
    _BY_KEY[_w.label] = _w


def decode_error_word(word: str | int, value: int) -> list[str]:
    """Names of the flags set in ``value`` for the error word ``word``.

    ``word`` is a parameter name, address or label (``"axis"``, ``"motor"``...).
    Bits with no known name appear as ``"UNKNOWN_0x..."``.
    """
    try:
        ew = _BY_KEY[word]
    except KeyError:
        raise KeyError(f"{word!r} is not an error word") from None
    if not isinstance(value, int) or not 0 <= value <= 0xFFFFFFFF:
        raise FieldRangeError("value", value, 0, 0xFFFFFFFF, "error words are u32")
    names: list[str] = []
    rest = value
    for flag in ew.flags:
        if value & flag.value:
            names.append(str(flag.name))
            rest &= ~flag.value
    bit = 1
    while rest:
        if rest & bit:
            names.append(f"UNKNOWN_0x{bit:08X}")
            rest &= ~bit
        bit <<= 1
    return names


_INFO: dict[tuple[str, str], FlagInfo] = {
    ("axis", "ESTOP_REQUESTED"): FlagInfo(
        "An emergency stop was requested (sys 0x06); the axis is idle and ignores motion commands.",
        "Clear errors, then request closed loop (set_mode 2).",
    ),
    ("axis", "DC_BUS_UNDER_VOLTAGE"): FlagInfo(
        "Supply voltage fell below the under-voltage trip level.",
        "Check the supply and its current capacity; do not power the motor through the 3.3 V pin.",
    ),
    ("axis", "DC_BUS_OVER_VOLTAGE"): FlagInfo(
        "Supply voltage rose above the over-voltage trip level (often regeneration when braking).",
        "Use a supply that can absorb regenerated energy or lower deceleration.",
    ),
    ("axis", "WATCHDOG_TIMER_EXPIRED"): FlagInfo(
        "No CAN command arrived within can.config.timeout_ms.",
        "Send commands more often or raise/disable the timeout, then clear errors.",
    ),
    ("axis", "OVER_TEMP"): FlagInfo(
        "Driver or motor temperature above the upper limit.",
        "Let the motor cool, reduce load or duty cycle, then clear errors.",
    ),
    ("axis", "HOMING_WITHOUT_ENDSTOP"): FlagInfo(
        "Power-up homing travelled homing_move_range without finding a mechanical stop.",
        "Check the homing direction, range and torque limit.",
    ),
    ("axis", "MOTOR_FAILED"): FlagInfo("The motor reported an error.", "Read the motor error word."),
    ("axis", "ENCODER_FAILED"): FlagInfo("The encoder reported an error.", "Read the encoder error word."),
    ("axis", "CONTROLLER_FAILED"): FlagInfo("The controller reported an error.", "Read the controller error word."),
    ("axis", "INVALID_STATE"): FlagInfo(
        "A state was requested that cannot be entered now.",
        "Calibrate the motor or clear the other errors first.",
    ),
    ("motor", "STALL_LIMIT_VIOLATION"): FlagInfo(
        "Current stayed above stall_current_limit for stall_time_limit.",
        "Remove the blockage or raise the stall limits, then clear errors.",
    ),
    ("motor", "CURRENT_LIMIT_VIOLATION"): FlagInfo(
        "Measured current exceeded the current limit plus margin.",
        "Lower gains or the load; check current_lim.",
    ),
    ("motor", "DRV_FAULT"): FlagInfo(
        "The gate driver reported a fault.", "Power-cycle; if it persists, contact support."
    ),
    ("encoder", "EDR_BATTERY_LOW"): FlagInfo(
        "The multi-turn encoder's backup battery is low.",
        "Set zero first, then clear errors; leave the motor powered 3-4 h to recharge.",
    ),
    ("encoder", "INCORRECT_OFFSET"): FlagInfo(
        "The encoder offset does not match.", "Set zero first, then clear errors."
    ),
    ("encoder", "EDR_POWER_FAILURE"): FlagInfo(
        "The multi-turn encoder lost power.", "Set zero first, then clear errors."
    ),
    ("encoder", "EDR_OVER_RANGE"): FlagInfo("The multi-turn counter overflowed.", "Set zero first, then clear errors."),
    ("encoder", "TURNS_COUNTER_WARNING"): FlagInfo(
        "The multi-turn counter is unreliable.", "Set zero first, then clear errors."
    ),
    ("controller", "OVERSPEED"): FlagInfo(
        "Speed exceeded vel_limit times vel_limit_tolerance.",
        "Lower the commanded speed or raise vel_limit, then clear errors.",
    ),
    ("controller", "INVALID_INPUT_MODE"): FlagInfo(
        "A command carried an input mode the controller does not know.", "Send mode 1 or 2 (V) / 1 or 6 (C)."
    ),
    ("can", "DUPLICATE_CAN_IDS"): FlagInfo(
        "Another node on the bus uses the same id.", "Give every motor its own id (set_id with one motor connected)."
    ),
    ("fet_thermistor", "OVER_TEMP"): FlagInfo(
        "Driver board temperature above its upper limit.", "Let it cool and reduce the load."
    ),
    ("motor_thermistor", "OVER_TEMP"): FlagInfo(
        "Motor winding temperature above its upper limit.", "Let it cool and reduce the load."
    ),
}


def flag_info(label: str, flag_name: str) -> FlagInfo:
    """Meaning and suggested action for one flag (a generic text when none is recorded)."""
    info = _INFO.get((label, flag_name))
    if info is not None:
        return info
    return FlagInfo(
        f"{label} error {flag_name.replace('_', ' ').lower()}.",
        "Clear errors and request closed loop; if it returns, check wiring, supply and configuration.",
    )
