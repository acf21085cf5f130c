"""How a simulated motor takes a parameter write: output-shaft views through their rotor-side twins,
the writes that act instead of being stored, and the checks of a configuration write."""

from __future__ import annotations

from collections.abc import Callable

from ..protocol.addresses import (
    AXIS0_CONFIG_CAN_NODE_ID,
    AXIS0_CONFIG_EXTRA_SETTING_CIRCULAR_SETPOINT_MAX,
    AXIS0_CONFIG_EXTRA_SETTING_CIRCULAR_SETPOINT_MIN,
    AXIS0_CONFIG_EXTRA_SETTING_ENABLE_CIRCULAR_SETPOINT_LIMIT,
    AXIS0_CONFIG_EXTRA_SETTING_GEAR_RATIO,
    AXIS0_CONTROLLER_CONFIG_CONTROL_MODE,
    AXIS0_CONTROLLER_CONFIG_INPUT_MODE,
    AXIS0_CONTROLLER_INPUT_POS,
    AXIS0_CONTROLLER_INPUT_TORQUE,
    AXIS0_CONTROLLER_INPUT_VEL,
    AXIS0_ENCODER_CONFIG_CPR,
    AXIS0_MOTOR_ERROR,
    AXIS0_REQUESTED_STATE,
    CAN_CONFIG_BAUD_RATE,
    CAN_CONFIG_HEARTBEAT_MS,
    CAN_CONFIG_TIMEOUT_MS,
)
from ..protocol.limits import MAX_NODE, MIN_MOTOR
from ..protocol.parameters import Parameter, parameter
from . import behaviour as bh
from .error_words import ErrorWords
from .params import OUTPUT_VIEWS, ParamStore, view_factor
from .readings import Readings
from .settings import Settings

__all__ = ["ParamWriter"]

_ANGLE_LIMITS = (
    AXIS0_CONFIG_EXTRA_SETTING_ENABLE_CIRCULAR_SETPOINT_LIMIT,
    AXIS0_CONFIG_EXTRA_SETTING_CIRCULAR_SETPOINT_MIN,
    AXIS0_CONFIG_EXTRA_SETTING_CIRCULAR_SETPOINT_MAX,
)
"""The software angle limits: on/off, minimum and maximum (turns)."""
_TIMING = (CAN_CONFIG_TIMEOUT_MS, CAN_CONFIG_HEARTBEAT_MS)


class ParamWriter:
    """Writes parameters of one motor as a 0x1F frame would (same checks; read-only ones are ignored).

    ``request_state`` takes a write of axis0.requested_state; ``timing_changed`` is called after a new
    heartbeat period or CAN timeout.
    """

    __slots__ = ("_hooks", "_timing_changed", "errors", "params", "readings", "settings")

    def __init__(
        self,
        params: ParamStore,
        settings: Settings,
        readings: Readings,
        errors: ErrorWords,
        *,
        request_state: Callable[[float], None],
        timing_changed: Callable[[], None],
    ) -> None:
        self.params, self.settings, self.readings, self.errors = params, settings, readings, errors
        self._timing_changed = timing_changed
        self._hooks: dict[int, Callable[[float], None]] = {
            AXIS0_REQUESTED_STATE: request_state,
            AXIS0_CONTROLLER_INPUT_POS: lambda v: self._write_input(AXIS0_CONTROLLER_INPUT_POS, v),
            AXIS0_CONTROLLER_INPUT_VEL: lambda v: self._write_input(AXIS0_CONTROLLER_INPUT_VEL, v),
            AXIS0_CONTROLLER_INPUT_TORQUE: lambda v: self._write_input(AXIS0_CONTROLLER_INPUT_TORQUE, v),
            AXIS0_CONTROLLER_CONFIG_CONTROL_MODE: lambda v: None,
            AXIS0_CONTROLLER_CONFIG_INPUT_MODE: lambda v: None,
            AXIS0_MOTOR_ERROR: lambda v: self.errors.words.__setitem__(AXIS0_MOTOR_ERROR, int(v)),
        }
        """Writable parameters that act instead of being stored (control and input mode follow the commands)."""

    def write(self, p: Parameter, value: int | float) -> None:
        """Write ``value`` (already in ``p``'s type) to ``p``."""
        addr = p.address
        view = OUTPUT_VIEWS.get(addr)
        if view is not None:
            rotor = parameter(view[0])
            self.write(rotor, bh.convert_value(value / view_factor(view[1], self.settings.ratio), rotor.dtype))
            return
        if not p.writable:
            return
        special = self._hooks.get(addr)
        if special is not None:
            special(value)
            return
        if not self._accept(addr, value):
            return
        self.params.ram[addr] = value
        self.settings.refresh()
        if addr in _TIMING:
            self._timing_changed()

    def set_output(self, addr: int, value: float) -> None:
        """Store an output-shaft configuration value (through its rotor-side twin)."""
        rotor, kind = OUTPUT_VIEWS[addr]
        self.params.ram[rotor] = value / view_factor(kind, self.settings.ratio)
        self.settings.refresh()

    def _accept(self, addr: int, value: float) -> bool:
        """Validation of a configuration write (see :mod:`drempower.sim.behaviour`)."""
        if addr == AXIS0_CONFIG_CAN_NODE_ID:
            return MIN_MOTOR <= value <= MAX_NODE
        if addr == CAN_CONFIG_BAUD_RATE:
            return value in bh.CAN_BITRATES
        if addr in (AXIS0_CONFIG_EXTRA_SETTING_GEAR_RATIO, AXIS0_ENCODER_CONFIG_CPR):
            return value > 0
        ram = self.params.ram
        if addr in _ANGLE_LIMITS:
            on, lo, hi = (value if a == addr else ram[a] for a in _ANGLE_LIMITS)
            turns = self.readings.position * self.settings.ratio / 360.0
            return not on or lo <= turns <= hi
        return True

    def _write_input(self, addr: int, value: float) -> None:
        """A write of an input parameter acts as the matching passthrough command."""
        s = self.settings
        d = s.drive
        if not d.active:
            return
        if addr == AXIS0_CONTROLLER_INPUT_POS:
            d.position(s.turns(value * 360.0 / s.ratio), 0.0, 0.0)
        elif addr == AXIS0_CONTROLLER_INPUT_VEL:
            d.velocity(value / s.ratio, 0.0, None)
        else:
            d.torque_command(value * s.ratio, None)
