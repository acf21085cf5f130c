"""Heat in a simulated motor: the winding and the driver board, their thermistors and the current limiter.

Two first-order thermal nodes, each heated by its losses and cooled to the
ambient air through a thermal resistance::

    C dT/dt = P - (T - T_ambient) / R_th        tau = R_th * C

* winding: ``P = 1.5 * Iq^2 * R_phase`` (the copper loss of the q-axis current,
  amplitude-invariant Park transform as on ODrive; ``R_phase`` is
  ``axis0.motor.config.phase_resistance``, 33106);
* driver board: ``P = P_idle + 1.5 * Iq^2 * R_fet`` (the MOSFETs' conduction
  loss and the board's own consumption).

The motor updates the nodes every :data:`HEAT_STEPS` steps with the mean square
current of those steps. Each node is integrated exactly over an update (``T += (T_ss - T) * (1 - exp(-dt/tau))``),
so the temperature after ``t`` seconds at a constant current is the textbook
exponential whatever the step. The thermistors read the nodes directly (no
sensor lag); the nodes do not exchange heat with each other.

The current limiter is ODrive's ``ThermistorCurrentLimiter`` [ODRIVE-LIKE]
(PROTOCOL.md 3.5): with a thermistor enabled, its limit is
``current_lim * (upper - T) / (upper - lower)`` clipped to ``[0, current_lim]``;
the effective limit (``axis0.motor.effective_current_lim``, 33003) is the lowest of
the two. At ``upper + OVER_TEMP_TRIP_MARGIN_C`` the thermistor's error word gets
OVER_TEMP and the axis AXIS_ERROR_OVER_TEMP (it drops to IDLE).

**Constants, all estimates** (no vendor document gives a thermal resistance or a
time constant; the vendor's ratings give the anchors): the simulated joint has
12 A peak (current_lim x torque_constant caps it at 12 Nm at the output); its
continuous rating is taken as a third of the peak, 4 A (usual for geared BLDC
joints). At that current the winding is to settle at the 80 degC the user manual
[U] advises as the ceiling for long periods, from a 25 degC room: the copper loss
is ``1.5 * 4^2 * 0.2 = 4.8 W``, so ``R_th = 55 K / 4.8 W = 11.5 K/W``. A motor of
this size (a few hundred grams of copper and iron in an aluminium housing) warms
with a time constant of minutes: 300 s. The board is small and close to the
housing: 60 s, 8 K/W, 0.5 W idle, 20 mOhm conduction resistance, so it stays
below the winding. Holding the example pendulum level (4.9 Nm, 4.9 A) then
heats the winding towards 108 degC: it enters the 95 degC derating after about
9.4 minutes (``t = -300 s * ln(1 - 70/82.6)``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, replace

from ..errors import ConfigError, ValidationError
from ..protocol.addresses import (
    AXIS0_FET_THERMISTOR_CONFIG_ENABLED,
    AXIS0_FET_THERMISTOR_CONFIG_TEMP_LIMIT_LOWER,
    AXIS0_FET_THERMISTOR_CONFIG_TEMP_LIMIT_UPPER,
    AXIS0_FET_THERMISTOR_ERROR,
    AXIS0_MOTOR_CONFIG_CURRENT_LIM,
    AXIS0_MOTOR_CONFIG_PHASE_RESISTANCE,
    AXIS0_MOTOR_CONFIG_TORQUE_CONSTANT,
    AXIS0_MOTOR_CONFIG_TORQUE_LIM,
    AXIS0_MOTOR_THERMISTOR_CONFIG_ENABLED,
    AXIS0_MOTOR_THERMISTOR_CONFIG_TEMP_LIMIT_LOWER,
    AXIS0_MOTOR_THERMISTOR_CONFIG_TEMP_LIMIT_UPPER,
    AXIS0_MOTOR_THERMISTOR_ERROR,
)
from ..robotfile import thermal_table

__all__ = [
    "HEAT_STEPS",
    "ThermalModel",
    "Thermal",
    "ThermalLimits",
    "derated_limit",
    "OVER_TEMP_TRIP_MARGIN_C",
    "thermal_model",
]

HEAT_STEPS = 10
"""The simulated motor updates its temperatures, the limiter and the trip every this many 1 ms steps (10 ms),
with the mean square current of those steps: the loss is the same, the error of the exponential negligible
(the time constants are 60 s and more), and the simulator stays fast."""

OVER_TEMP_TRIP_MARGIN_C = 0.0
"""How far above ``temp_limit_upper`` (degC) a thermistor trips. PROTOCOL.md 3.5 (and ODrive's
documentation) say "above upper": 0. ODrive 0.5's code trips at upper + 5: set 5.0 to model that."""


@dataclass(frozen=True, slots=True)
class ThermalModel:
    """Thermal constants of one motor (estimates; see the module docstring).

    Temperatures in degC, thermal resistances in K/W, time constants in s,
    electrical resistance in ohm, power in W.
    """

    ambient_c: float = 25.0
    winding_r_th: float = 11.5
    winding_tau: float = 300.0
    board_r_th: float = 8.0
    board_tau: float = 60.0
    board_idle_w: float = 0.5
    fet_resistance: float = 0.02


def thermal_model(base: ThermalModel, values: ThermalModel | Mapping[str, float] | None, where: str) -> ThermalModel:
    """``base`` with the constants of ``values`` (a :class:`ThermalModel`, or some of its fields by name, each in
    :data:`~drempower.robotfile.THERMAL_KEYS`'s range); a :class:`ValidationError` naming ``where``, the key and
    the range otherwise."""
    if values is None:
        return base
    if isinstance(values, ThermalModel):
        return values
    try:
        checked = thermal_table(values, where)
    except ConfigError as exc:
        raise ValidationError(str(exc)) from None
    return replace(base, **checked)


def derated_limit(base: float, temperature: float, lower: float, upper: float) -> float:
    """ODrive's thermistor current limit (A): ``base`` above nothing, linear to 0 from ``lower`` to ``upper``."""
    span = upper - lower
    if span <= 0.0:
        return base if temperature < upper else 0.0
    lim = base * (upper - temperature) / span
    if not lim >= 0.0:  # also NaN
        return 0.0
    return min(lim, base)


class Thermal:
    """The temperatures of one motor's winding and driver board (degC), stepped with its current."""

    __slots__ = ("_a_board", "_a_winding", "_dt", "_for", "board", "model", "winding")

    def __init__(self, model: ThermalModel) -> None:
        self.model = model
        self.winding = model.ambient_c
        """Winding temperature (degC): axis0.motor_thermistor.temperature."""
        self.board = model.ambient_c
        """Driver board temperature (degC): axis0.fet_thermistor.temperature."""
        self._dt = -1.0
        self._for: ThermalModel | None = None
        self._a_winding = self._a_board = 0.0

    def losses(self, current: float, phase_resistance: float) -> tuple[float, float]:
        """Heat (W) into the winding and the board at q-axis current ``current`` A."""
        i2 = 1.5 * current * current
        m = self.model
        return i2 * phase_resistance, m.board_idle_w + i2 * m.fet_resistance

    def steady(self, current: float, phase_resistance: float) -> tuple[float, float]:
        """Where the winding and the board settle (degC) at a constant ``current`` A."""
        pw, pb = self.losses(current, phase_resistance)
        m = self.model
        return m.ambient_c + pw * m.winding_r_th, m.ambient_c + pb * m.board_r_th

    def step(self, dt: float, current: float, phase_resistance: float) -> None:
        """Advance by ``dt`` s at ``current`` A (exact for a current constant over the step)."""
        self.heat(dt, current * current, phase_resistance)

    def heat(self, dt: float, i_sq: float, phase_resistance: float) -> None:
        """Advance by ``dt`` s with the mean square current ``i_sq`` A^2 over it (exact when it was constant)."""
        m = self.model
        if dt != self._dt or m is not self._for:
            self._dt, self._for = dt, m
            self._a_winding = -math.expm1(-dt / m.winding_tau)
            self._a_board = -math.expm1(-dt / m.board_tau)
        i2 = 1.5 * i_sq
        amb = m.ambient_c
        self.winding += (amb + i2 * phase_resistance * m.winding_r_th - self.winding) * self._a_winding
        self.board += (amb + (m.board_idle_w + i2 * m.fet_resistance) * m.board_r_th - self.board) * self._a_board


class ThermalLimits:
    """The configuration the limiter uses, taken from the parameters (rotor side, as the firmware keeps it)."""

    __slots__ = (
        "board_on",
        "board_range",
        "calm_below",
        "current_lim",
        "kt",
        "phase_resistance",
        "ratio",
        "torque_lim",
        "winding_on",
        "winding_range",
    )

    def __init__(self) -> None:
        self.current_lim = math.inf
        self.torque_lim = math.inf
        self.kt = 1.0
        self.ratio = 1.0
        self.phase_resistance = 0.0
        self.winding_on = self.board_on = False
        self.winding_range = self.board_range = (95.0, 100.0)
        self.calm_below = math.inf
        """Below this temperature (degC) on both nodes nothing derates or trips: the step skips the limiter."""

    def configure(self, ram: Mapping[int, int | float], ratio: float) -> None:
        """Read current_lim, torque_lim, torque_constant, phase_resistance and both thermistors' settings."""
        self.current_lim = float(ram[AXIS0_MOTOR_CONFIG_CURRENT_LIM])
        self.torque_lim = float(ram[AXIS0_MOTOR_CONFIG_TORQUE_LIM])
        self.kt = float(ram[AXIS0_MOTOR_CONFIG_TORQUE_CONSTANT])
        self.phase_resistance = float(ram[AXIS0_MOTOR_CONFIG_PHASE_RESISTANCE])
        self.ratio = ratio
        self.winding_on = bool(ram[AXIS0_MOTOR_THERMISTOR_CONFIG_ENABLED])
        self.winding_range = (
            float(ram[AXIS0_MOTOR_THERMISTOR_CONFIG_TEMP_LIMIT_LOWER]),
            float(ram[AXIS0_MOTOR_THERMISTOR_CONFIG_TEMP_LIMIT_UPPER]),
        )
        self.board_on = bool(ram[AXIS0_FET_THERMISTOR_CONFIG_ENABLED])
        self.board_range = (
            float(ram[AXIS0_FET_THERMISTOR_CONFIG_TEMP_LIMIT_LOWER]),
            float(ram[AXIS0_FET_THERMISTOR_CONFIG_TEMP_LIMIT_UPPER]),
        )
        edges = [min(lo, hi + OVER_TEMP_TRIP_MARGIN_C) for on, (lo, hi) in
                 ((self.winding_on, self.winding_range), (self.board_on, self.board_range)) if on]  # fmt: skip
        self.calm_below = min(edges, default=math.inf)

    def current_limit(self, t: Thermal) -> float:
        """The effective current limit (A, axis0.motor.effective_current_lim): current_lim, derated."""
        lim = self.current_lim
        if self.winding_on:
            lim = min(lim, derated_limit(self.current_lim, t.winding, *self.winding_range))
        if self.board_on:
            lim = min(lim, derated_limit(self.current_lim, t.board, *self.board_range))
        return lim

    def torque_limit(self, t: Thermal) -> float:
        """The drive's torque limit at the output (Nm): torque_lim and the effective current limit."""
        return min(self.torque_lim, self.current_limit(t) * self.kt) * self.ratio

    def tripped(self, t: Thermal) -> int:
        """The error word (address) of a thermistor above its upper limit (+ the margin), else 0."""
        if self.winding_on and t.winding >= self.winding_range[1] + OVER_TEMP_TRIP_MARGIN_C:
            return AXIS0_MOTOR_THERMISTOR_ERROR
        if self.board_on and t.board >= self.board_range[1] + OVER_TEMP_TRIP_MARGIN_C:
            return AXIS0_FET_THERMISTOR_ERROR
        return 0
