"""The firmware's protections of a simulated motor: heating and derating, stall and overspeed."""

from __future__ import annotations

from ..protocol.addresses import AXIS0_CONTROLLER_ERROR, AXIS0_MOTOR_ERROR
from ..protocol.flags import ControllerError
from . import behaviour as bh
from .drive import Drive
from .error_words import ErrorWords
from .settings import Settings
from .thermal import HEAT_STEPS, Thermal, ThermalLimits

__all__ = ["Protections"]


class Protections:
    """Heats the motor with its current, derates and trips; trips on a stall or an overspeed.

    Thresholds come from ``settings``; errors are raised in ``errors``.
    """

    __slots__ = ("_derating", "_heat_n", "_stall_t", "_tq_sq", "drive", "errors", "limits", "settings", "thermal")

    def __init__(
        self, drive: Drive, settings: Settings, thermal: Thermal, limits: ThermalLimits, errors: ErrorWords
    ) -> None:
        self.drive, self.settings, self.thermal, self.limits, self.errors = drive, settings, thermal, limits, errors
        self._derating = False
        """The limiter acted at the last thermal update (else the torque limit is the configured one)."""
        self._tq_sq = 0.0
        """Sum of the squared output torque (Nm^2) over the steps since the last thermal update."""
        self._heat_n = 0
        self._stall_t = 0.0
        """How long (s) the current has been at or above the stall limit."""

    def reset_stall(self) -> None:
        """The stall timer restarts (the axis idles, or errors are cleared)."""
        self._stall_t = 0.0

    def heat_step(self, dt: float) -> None:
        """Count the step's torque; every HEAT_STEPS steps heat with their mean square current."""
        tq = self.drive.torque
        self._tq_sq += tq * tq
        self._heat_n += 1
        if self._heat_n >= HEAT_STEPS:
            self._heat(dt)

    def _heat(self, dt: float) -> None:
        """Heat with the mean square current of the last HEAT_STEPS steps, derate the current limit,
        trip above the upper limits."""
        lim, t, n, kt = self.limits, self.thermal, self._heat_n, self.settings.kt
        t.heat(dt * n, self._tq_sq / (n * kt * kt), lim.phase_resistance)
        self._tq_sq, self._heat_n = 0.0, 0
        calm = t.winding < lim.calm_below and t.board < lim.calm_below
        if calm and not self._derating:
            return
        self._derating = not calm
        trip = lim.tripped(t)
        if trip:
            self.errors.raise_flags(trip, 0x1)
        self.drive.tlim = lim.torque_limit(t)

    def check(self, dt: float) -> None:
        """Stall and overspeed protection of an active axis after a step of ``dt`` s."""
        d, s = self.drive, self.settings
        if d.active:
            if s.stall_on:
                if abs(d.torque) >= s.stall_tq:
                    self._stall_t += dt
                    if self._stall_t >= s.stall_time:
                        self.errors.raise_flags(AXIS0_MOTOR_ERROR, bh.STALL_FLAG, bh.STALL_AXIS_ERROR)
                else:
                    self._stall_t = 0.0
            if abs(d.vel) > s.overspeed:
                self.errors.raise_flags(AXIS0_CONTROLLER_ERROR, ControllerError.OVERSPEED)
