"""What a simulated motor reports: its state frame and its parameters as a read answers them.

Live parameters (positions, currents, temperatures, states, error words) are computed from
the motor's state when read (:data:`LIVE`); output-shaft views from their rotor-side twins;
the rest come from RAM.
"""

from __future__ import annotations

import math
from collections.abc import Callable

from ..protocol.addresses import (
    AXIS0_CONFIG_CAN_NODE_ID,
    AXIS0_CONTROLLER_CONFIG_CONTROL_MODE,
    AXIS0_CONTROLLER_CONFIG_INPUT_MODE,
    AXIS0_CONTROLLER_INPUT_POS,
    AXIS0_CONTROLLER_INPUT_TORQUE,
    AXIS0_CONTROLLER_INPUT_VEL,
    AXIS0_CONTROLLER_POS_SETPOINT,
    AXIS0_CONTROLLER_TORQUE_SETPOINT,
    AXIS0_CONTROLLER_TRAJECTORY_DONE,
    AXIS0_CONTROLLER_VEL_SETPOINT,
    AXIS0_CURRENT_STATE,
    AXIS0_ENCODER_CONFIG_CPR,
    AXIS0_ENCODER_POS_ABS,
    AXIS0_ENCODER_POS_CIRCULAR,
    AXIS0_ENCODER_POS_ESTIMATE,
    AXIS0_ENCODER_TURN_ABS,
    AXIS0_ENCODER_VEL_ESTIMATE,
    AXIS0_ERROR,
    AXIS0_FET_THERMISTOR_TEMPERATURE,
    AXIS0_MOTOR_CONFIG_PHASE_RESISTANCE,
    AXIS0_MOTOR_CURRENT_CONTROL_IBUS,
    AXIS0_MOTOR_CURRENT_CONTROL_IQ_MEASURED,
    AXIS0_MOTOR_CURRENT_CONTROL_IQ_SETPOINT,
    AXIS0_MOTOR_EFFECTIVE_CURRENT_LIM,
    AXIS0_MOTOR_THERMISTOR_TEMPERATURE,
    AXIS0_OUTPUT_SHAFT_TORQUE_ESTIMATE,
    AXIS0_REQUESTED_STATE,
)
from ..protocol.ids import Frame
from ..protocol.messages import S16_MAX, S16_MIN, State
from ..protocol.parameters import F32_MAX
from . import behaviour as bh
from .axis import Axis
from .drive import POSITION, TAU, TRAP_TRAJ, Drive
from .error_words import ERROR_ADDRESSES, ErrorWords
from .firmware import Firmware
from .params import OUTPUT_VIEWS, ParamStore, view_factor
from .settings import Settings

__all__ = ["LIVE", "Readings"]


def _s16(x: float) -> float:
    return S16_MIN if x < S16_MIN else S16_MAX if x > S16_MAX else x if x == x else 0.0


class Readings:
    """A motor's readings: the state frame, live values and parameter reads (nothing here changes the motor)."""

    __slots__ = ("axis", "drive", "errors", "firmware", "params", "settings")

    def __init__(
        self,
        drive: Drive,
        axis: Axis,
        params: ParamStore,
        settings: Settings,
        errors: ErrorWords,
        firmware: Firmware,
    ) -> None:
        self.drive, self.axis, self.params, self.settings = drive, axis, params, settings
        self.errors, self.firmware = errors, firmware

    @property
    def node_id(self) -> int:
        """The CAN node id the motor answers to (can_node_id, 31001)."""
        return int(self.params.ram[AXIS0_CONFIG_CAN_NODE_ID])

    @property
    def position(self) -> float:
        """Output shaft position (deg) as the motor reports it."""
        return self.drive.pos * 360.0 - self.settings.offset

    @property
    def current(self) -> float:
        """q-axis current (A)."""
        return self.drive.torque / self.settings.kt

    @property
    def trajectory_done(self) -> bool:
        """The T bit: see :data:`drempower.sim.behaviour.DONE_TOLERANCE_DEG`."""
        d = self.drive
        if not d.active or d.mode != POSITION:
            return True
        if d.input_mode == TRAP_TRAJ:
            return d.trajectory_done()
        return abs(d.in_pos - d.pos) * 360.0 <= bh.DONE_TOLERANCE_DEG

    def state_frame(self, answered: int = 0) -> Frame:
        """The real-time state frame as the motor would send it now, answering command ``answered``
        (0: none, a heartbeat), whose bits 3-4 it may keep (:attr:`firmware`)."""
        d = self.drive
        pos = d.pos * 360.0 - self.settings.offset
        return State(
            self.node_id,
            pos if -F32_MAX <= pos <= F32_MAX else 0.0,
            _s16(d.vel * 60.0),
            _s16(d.torque),
            self.trajectory_done,
            self.errors.words[AXIS0_ERROR] != 0,
            self.firmware.spare_bits(answered),
        ).encode()

    def read(self, addr: int) -> int | float | None:
        """Parameter ``addr`` as the motor reports it (in its table type); None: no such parameter."""
        getter = LIVE.get(addr)
        if getter is not None:
            return getter(self)
        view = OUTPUT_VIEWS.get(addr)
        if view is not None:
            rotor = self.read(view[0])
            assert rotor is not None
            return float(rotor) * view_factor(view[1], self.settings.ratio)
        return self.params.ram.get(addr)


def _ibus(r: Readings) -> float:
    """Supply current (A): mechanical power plus copper loss over the bus voltage."""
    d = r.drive
    iq = d.torque / r.settings.kt
    power = d.torque * d.vel * TAU + 1.5 * iq * iq * float(r.params.ram[AXIS0_MOTOR_CONFIG_PHASE_RESISTANCE])
    return power / r.settings.model.vbus


def _pos_rotor(r: Readings) -> float:
    return r.position * r.settings.ratio / 360.0


def _rotor_turns(raw_of: Callable[[Drive], float]) -> Callable[[Readings], float]:
    def read(r: Readings) -> float:
        return (raw_of(r.drive) * 360.0 - r.settings.offset) * r.settings.ratio / 360.0

    return read


def _error_word(addr: int) -> Callable[[Readings], int]:
    return lambda r: r.errors.words[addr]


LIVE: dict[int, Callable[[Readings], int | float]] = {
    1: lambda r: r.settings.model.vbus,
    2: _ibus,
    AXIS0_CURRENT_STATE: lambda r: int(r.axis.state),
    AXIS0_REQUESTED_STATE: lambda r: r.axis.requested,
    AXIS0_CONTROLLER_INPUT_POS: _rotor_turns(lambda d: d.in_pos),
    AXIS0_CONTROLLER_INPUT_VEL: lambda r: r.drive.in_vel * r.settings.ratio,
    AXIS0_CONTROLLER_INPUT_TORQUE: lambda r: r.drive.in_tq / r.settings.ratio,
    AXIS0_CONTROLLER_POS_SETPOINT: _rotor_turns(lambda d: d.pos_sp),
    AXIS0_CONTROLLER_VEL_SETPOINT: lambda r: r.drive.vel_sp * r.settings.ratio,
    AXIS0_CONTROLLER_TORQUE_SETPOINT: lambda r: r.drive.tq_sp / r.settings.ratio,
    AXIS0_CONTROLLER_TRAJECTORY_DONE: lambda r: int(r.trajectory_done),
    AXIS0_CONTROLLER_CONFIG_CONTROL_MODE: lambda r: r.drive.mode,
    AXIS0_CONTROLLER_CONFIG_INPUT_MODE: lambda r: r.drive.input_mode,
    AXIS0_MOTOR_EFFECTIVE_CURRENT_LIM: lambda r: r.settings.limits.current_limit(r.settings.thermal),
    AXIS0_MOTOR_THERMISTOR_TEMPERATURE: lambda r: r.settings.thermal.winding,
    AXIS0_FET_THERMISTOR_TEMPERATURE: lambda r: r.settings.thermal.board,
    AXIS0_MOTOR_CURRENT_CONTROL_IBUS: _ibus,
    AXIS0_MOTOR_CURRENT_CONTROL_IQ_SETPOINT: lambda r: r.current,
    AXIS0_MOTOR_CURRENT_CONTROL_IQ_MEASURED: lambda r: r.current,
    AXIS0_ENCODER_POS_ESTIMATE: _pos_rotor,
    AXIS0_ENCODER_POS_CIRCULAR: lambda r: _pos_rotor(r) % 1.0,
    AXIS0_ENCODER_VEL_ESTIMATE: lambda r: r.drive.vel * r.settings.ratio,
    AXIS0_ENCODER_POS_ABS: lambda r: int(_pos_rotor(r) % 1.0 * float(r.params.ram[AXIS0_ENCODER_CONFIG_CPR])),
    AXIS0_ENCODER_TURN_ABS: lambda r: math.floor(_pos_rotor(r)),
    AXIS0_OUTPUT_SHAFT_TORQUE_ESTIMATE: lambda r: r.drive.torque,
    **{a: _error_word(a) for a in ERROR_ADDRESSES},
}
"""Parameters computed from the motor's state when read."""
