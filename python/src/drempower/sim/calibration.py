"""The calibration states of a simulated motor: motor calibration, encoder offset calibration, index search."""

from __future__ import annotations

import math

from ..protocol.addresses import (
    AXIS0_CONFIG_EXTRA_SETTING_ENCODER_OFFSET_CALIBRATED,
    AXIS0_ENCODER_ERROR,
    AXIS0_ERROR,
    AXIS0_MOTOR_ERROR,
    AXIS0_MOTOR_IS_CALIBRATED,
)
from ..protocol.enums import AxisState
from ..protocol.flags import AxisError, EncoderError, MotorError
from . import behaviour as bh
from .axis import Axis
from .error_words import ErrorWords
from .settings import Settings

__all__ = ["CALIBRATION_STATES", "Calibration"]

CALIBRATION_STATES = frozenset((3, 4, 6, 7))
"""The requestable states that run a calibration."""


class Calibration:
    """Runs a requested calibration phase by phase (see :data:`~drempower.sim.behaviour.CALIBRATION_PHASES`),
    setting the ``axis`` state, recording results in the parameters of ``settings`` and faults in ``errors``."""

    __slots__ = ("_next", "_pos", "_start", "axis", "end", "errors", "settings")

    def __init__(self, axis: Axis, settings: Settings, errors: ErrorWords) -> None:
        self.axis, self.settings, self.errors = axis, settings, errors
        self.end = math.inf
        """When the current phase ends (s); inf when none runs."""
        self._next: list[int] = []
        """Calibration states still to run after the current one."""
        self._start = 0.0
        self._pos = 0.0

    def cancel(self) -> None:
        """An error or a request ends a calibration."""
        self.end = math.inf
        self._next = []

    def begin(self, requested: int, now: float) -> None:
        """Run calibration state ``requested`` (one of :data:`CALIBRATION_STATES`) from time ``now``."""
        self._next = list(bh.CALIBRATION_PHASES[requested])
        self._phase(now)

    def _phase(self, now: float) -> None:
        axis = self.axis
        axis.state = AxisState(self._next.pop(0))
        self._start = now
        self._pos = self.settings.drive.pos
        seconds = {
            AxisState.MOTOR_CALIBRATION: bh.MOTOR_CALIBRATION_SECONDS,
            AxisState.ENCODER_OFFSET_CALIBRATION: bh.ENCODER_OFFSET_CALIBRATION_SECONDS,
        }.get(axis.state, bh.CALIBRATION_SECONDS)
        self.end = now + seconds

    def scan(self, now: float) -> None:
        """Encoder offset calibration: the rotor turns once forward and back (unless the shaft is blocked)."""
        d = self.settings.drive
        if d.locked:
            d.vel = 0.0
            return
        ratio = self.settings.ratio
        span = bh.ENCODER_OFFSET_CALIBRATION_SECONDS
        f = min(max((now - self._start) / span, 0.0), 1.0)
        turns = (2 * f if f < 0.5 else 2 - 2 * f) / ratio  # output turns of one rotor turn
        d.pos = self._pos + turns
        d.vel = (2 if f < 0.5 else -2) / ratio / span if f < 1.0 else 0.0

    def phase_done(self, now: float) -> bool:
        """End the current phase: record its result or fault, start the next phase.
        True when the sequence is over and the axis goes to IDLE."""
        self.end = math.inf
        state = self.axis.state
        s = self.settings
        ram = s.ram
        if state == AxisState.MOTOR_CALIBRATION:
            if s.model.vbus < bh.CALIBRATION_MIN_VBUS:
                self._next = []
                self.errors.raise_flags(
                    AXIS0_MOTOR_ERROR, MotorError.PHASE_RESISTANCE_OUT_OF_RANGE, AxisError.MOTOR_FAILED
                )
                self.errors.raise_flags(AXIS0_ERROR, AxisError.DC_BUS_UNDER_VOLTAGE)
                return False
            ram[AXIS0_MOTOR_IS_CALIBRATED] = 1
        elif state == AxisState.ENCODER_OFFSET_CALIBRATION:
            s.drive.vel = 0.0
            if s.drive.locked:
                self._next = []
                self.errors.raise_flags(AXIS0_ENCODER_ERROR, EncoderError.CPR_POLEPAIRS_MISMATCH)
                return False
            ram[AXIS0_CONFIG_EXTRA_SETTING_ENCODER_OFFSET_CALIBRATED] = 1
        if self._next and not self.errors.axis:
            self._phase(now)
            return False
        self._next = []
        return True
