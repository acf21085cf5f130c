"""Every choice the simulator makes where the vendor documents nothing.

PROTOCOL.md tags these points [UNCERTAIN] or [INFERRED]; the simulator picks the
least surprising behaviour and keeps all of those picks here, as constants and
small pure functions, so that a finding on real hardware changes one place.
docs/simulator.md lists them for users.

Readings a host can see and that real firmware may take either way (the bits 3-4 of
state frames, the boot time, what reply-state answers, the fast read, a Q time of 0,
heartbeats, the factory id) are knobs of :mod:`drempower.sim.firmware`; its defaults
are the choices stated here.

Choices that are simply "do nothing" live in this docstring:

* No reply to parameter writes (0x1F) or to system commands (0x08).
* Frames that do not decode (unknown command, bad mode code, DLC other than 8,
  remote or extended frames) are ignored without a reply.
* Reads of unknown addresses get no reply; writes to unknown or read-only
  addresses are ignored.
* A read reply and a state frame always carry the motor's own node id, so a
  read sent to node 0 is answered by every motor, each with its own id (the
  replies collide on real hardware: that is the user's problem).
* A start (0x08, sys 0x10-0x15) addressed to the motor's own id works like a
  broadcast start for that motor; a motor with no pending preset ignores it. A
  start consumes the preset, also when the axis is not in closed loop (then
  nothing moves).
* Relative starts (sys_data1 = 1) add the preset target to the measured position.
* Replies to control and preset frames (enable_reply_state) are sent in every
  axis state, including IDLE and estop, where the motion itself is ignored.
* The bandwidth of a T frame, the speed and acceleration of a Q frame or preset,
  and the ramp rate of a V or C ramp frame are written into the matching
  parameter (32118, 38014-38016, 38017, 38018) in RAM, as on ODrive.
* After power-up, reboot and every entry into closed loop the axis holds its
  current position (position control, passthrough).
* Requesting closed loop while an error word is non-zero is ignored (the axis
  stays in IDLE); requesting it while in closed loop changes nothing.
  Requesting a calibration state runs it and ends in IDLE (see
  :data:`CALIBRATION_PHASES`); other states are ignored. Motor calibration (4)
  holds still for :data:`MOTOR_CALIBRATION_SECONDS` and fails below
  :data:`CALIBRATION_MIN_VBUS`; encoder offset calibration (7) turns the rotor
  one turn forward and back in :data:`ENCODER_OFFSET_CALIBRATION_SECONDS` and
  fails when the shaft is blocked; the full sequence (3) runs both, reporting
  each as the current state. Any error ends the sequence in IDLE.
* ``reboot`` stops the firmware: the axis idles and the motor hears and sends
  nothing (no heartbeats, no answers, on CAN and UART) for :data:`BOOT_SECONDS`;
  then RAM is loaded from the saved configuration (or the factory defaults),
  errors are cleared and the axis enters closed loop.
  The position survives when multi-turn counting (31207) is on, else it
  restarts at 0. ``erase_config`` deletes the saved configuration only;
  ``init_config`` loads the factory defaults into RAM only. The factory node id
  of a simulated motor is the id it was created with. ``save_config`` works in
  every axis state without disturbing the motion.
* ``enter_dfu_mode`` sets the axis idle and the motor answers nothing, on CAN
  and UART, as its bootloader waits on USB (there is no firmware to update);
  ``SimMotor.power_cycle()`` brings it back.
* ``set_zero_position`` shifts the zero (31205, in RAM; kept by save_config) so
  the current output position reads 0 and the motion carries on undisturbed.
* A new CAN bit rate (21001) takes effect at the next reboot; a motor whose bit
  rate differs from a timed SimBus's bit rate then neither hears nor sends.
* can_node_id (31001) accepts 1..63 and takes effect at once; other values are
  ignored.
* Software angle limits (31202, 38010/38011): a write that enables them, or that
  moves a bound while they are on, is ignored when the current position would
  lie outside the new range.
* Two motors sharing an id both answer; each sets CAN_ERROR_DUPLICATE_CAN_IDS
  when it sees the other's frame.
* control_mode and input_mode (32105/32106) follow the commands; writes to them
  are ignored. Writing an input parameter (input_pos/vel/torque, rotor side or
  output side) acts like the matching passthrough command.
* Speed and torque in state frames saturate to the s16 range (+-327.67).
"""

from __future__ import annotations

import math

from ..protocol.addresses import (
    AXIS0_CONTROLLER_ERROR,
    AXIS0_ENCODER_ERROR,
    AXIS0_FET_THERMISTOR_ERROR,
    AXIS0_MOTOR_ERROR,
    AXIS0_MOTOR_THERMISTOR_ERROR,
)
from ..protocol.flags import AxisError, ControllerError, MotorError
from ..protocol.parameters import F32_MAX, DataType

__all__ = [
    "DONE_TOLERANCE_DEG",
    "IDLE_DAMPING_NM_PER_RPM",
    "WATCHDOG_ERROR",
    "STALL_AXIS_ERROR",
    "STALL_FLAG",
    "Q_ZERO_SPEED_ERROR",
    "ERROR_WORD_AXIS_FLAG",
    "STICKY_ENCODER_ERRORS",
    "LIMIT_RECOVERY_SPEED_RPM",
    "LIMIT_RECOVERY_ACCEL",
    "CALIBRATION_SECONDS",
    "CALIBRATION_MIN_VBUS",
    "CALIBRATION_PHASES",
    "ENCODER_OFFSET_CALIBRATION_SECONDS",
    "MOTOR_CALIBRATION_SECONDS",
    "BOOT_SECONDS",
    "CAN_BITRATES",
    "convert_value",
    "target_time_profile",
]

DONE_TOLERANCE_DEG = 0.1
"""T bit in T and P modes (and Q with accel 0): 1 when the shaft is within this many degrees of
the target. In Q mode the T bit is 1 when the profile ends; in V, C and impedance modes it is 1."""

IDLE_DAMPING_NM_PER_RPM = 0.05
"""Idle damping (31215, or after a watchdog timeout): braking torque per r/min of output speed."""

WATCHDOG_ERROR = AxisError.WATCHDOG_TIMER_EXPIRED
"""Axis error set when the CAN timeout (21003) expires; the axis goes to IDLE with idle damping."""

STALL_AXIS_ERROR = AxisError.MOTOR_FAILED
"""Stall protection sets MOTOR_ERROR_STALL_LIMIT_VIOLATION and this axis flag, once
|Iq| >= stall_current_limit (31209) has lasted stall_time_limit (31210) seconds."""

Q_ZERO_SPEED_ERROR = ControllerError.INVALID_INPUT_MODE
"""A Q move with speed 0 raises this controller error (and CONTROLLER_FAILED) and leaves closed
loop, as the library manual says; a Q move with accel 0 goes to the target as fast as possible."""

ERROR_WORD_AXIS_FLAG: dict[int, AxisError] = {
    AXIS0_MOTOR_ERROR: AxisError.MOTOR_FAILED,
    AXIS0_ENCODER_ERROR: AxisError.ENCODER_FAILED,
    AXIS0_CONTROLLER_ERROR: AxisError.CONTROLLER_FAILED,
    AXIS0_FET_THERMISTOR_ERROR: AxisError.OVER_TEMP,
    AXIS0_MOTOR_THERMISTOR_ERROR: AxisError.OVER_TEMP,
}
"""An error in a sub-word also sets this flag in axis0.error (so the E bit shows it).
can.error does not stop the axis."""

STICKY_ENCODER_ERRORS = 0x0200 | 0x0400 | 0x0800 | 0x2000 | 0x4000
"""Encoder errors (EDR over range, EDR power failure, battery low, incorrect offset, turns counter)
that survive clear_errors until set_zero_position has been done."""

LIMIT_RECOVERY_SPEED_RPM = 5.0
"""Speed of the slow move back inside the software angle limits (r/min)."""
LIMIT_RECOVERY_ACCEL = 50.0
"""Acceleration of that move ((r/min)/s)."""

CALIBRATION_SECONDS = 2.0
"""Duration of an encoder index search (state 6) before the axis returns to IDLE."""
BOOT_SECONDS = 0.3
"""Time (s) from a reboot (or power-up) to a running firmware: the motor hears and sends nothing meanwhile.

An assumption, not a measurement: an STM32F4 firmware of the ODrive family starts its clocks, loads
its configuration from flash, checks the DC bus and takes its first encoder readings in a few
hundred milliseconds; no vendor document gives the time (docs/simulator.md)."""
MOTOR_CALIBRATION_SECONDS = 4.0
"""Duration of motor calibration (state 4): phase resistance and inductance, the rotor held still."""
ENCODER_OFFSET_CALIBRATION_SECONDS = 8.0
"""Duration of encoder offset calibration (state 7): one slow rotor turn forward and back."""
CALIBRATION_MIN_VBUS = 12.0
"""Supply voltage (V) below which motor calibration cannot drive its current: it fails with
PHASE_RESISTANCE_OUT_OF_RANGE and DC_BUS_UNDER_VOLTAGE."""
CALIBRATION_PHASES: dict[int, tuple[int, ...]] = {3: (4, 7), 4: (4,), 6: (6,), 7: (7,)}
"""The states each requestable calibration state runs through, in order (3 = the full sequence)."""

CAN_BITRATES = frozenset((125_000, 250_000, 500_000, 1_000_000))
"""Values accepted by can.config.baud_rate (21001); other writes are ignored."""

STALL_FLAG = MotorError.STALL_LIMIT_VIOLATION
"""The motor error stall protection raises."""

_INT_RANGE = {
    DataType.U16: (0, 0xFFFF),
    DataType.S16: (-0x8000, 0x7FFF),
    DataType.U32: (0, 0xFFFFFFFF),
    DataType.S32: (-0x80000000, 0x7FFFFFFF),
}


def convert_value(value: float, dtype: DataType) -> int | float:
    """A parameter value in another data type, as the motor answers a read of a different type
    (and takes a write of one): floats truncate toward zero, and every value saturates to the
    type's range (NaN reads as 0)."""
    if dtype is DataType.F32:
        v = float(value)
        return max(-F32_MAX, min(F32_MAX, v)) if v == v else 0.0
    lo, hi = _INT_RANGE[dtype]
    if not math.isfinite(value):
        return hi if value > 0 else lo if value < 0 else 0
    return min(hi, max(lo, int(value)))


def target_time_profile(distance: float, time: float, accel: float) -> tuple[float, float]:
    """Cruise speed and acceleration that cover ``distance`` in exactly ``time`` (Q target-time preset).

    All in one unit system (e.g. turns, turn/s, turn/s^2), ``distance`` >= 0, ``accel`` the
    constant acceleration of a trapezoid (half the peak of an S-curve). Solves the host
    library's own T formula for the cruise speed (PROTOCOL.md 3.4.3). When ``time`` is too
    short for ``accel`` the motor raises its acceleration to the least that still finishes
    in ``time`` (a triangle profile), so synchronised motors stay synchronised.
    """
    if distance <= 0.0:
        return 0.0, accel
    disc = (accel * time) ** 2 / 4.0 - accel * distance
    if accel > 0.0 and disc >= 0.0:
        return accel * time / 2.0 - math.sqrt(disc), accel
    needed = 4.0 * distance / (time * time)
    return needed * time / 2.0, needed
