"""The configuration a simulated motor runs with: its hardware model, and the values it derives from its
parameters at every change (gear ratio, torque constant, zero offset, gains and limits of the drive,
the protections' thresholds, the heartbeat and the CAN timeout)."""

from __future__ import annotations

import math
from collections.abc import MutableMapping

from ..protocol.addresses import (
    AXIS0_CONFIG_EXTRA_SETTING_CIRCULAR_SETPOINT_MAX,
    AXIS0_CONFIG_EXTRA_SETTING_CIRCULAR_SETPOINT_MIN,
    AXIS0_CONFIG_EXTRA_SETTING_ENABLE_CIRCULAR_SETPOINT_LIMIT,
    AXIS0_CONFIG_EXTRA_SETTING_ENABLE_DAMP_IDLE,
    AXIS0_CONFIG_EXTRA_SETTING_ENABLE_REPLY_STATE,
    AXIS0_CONFIG_EXTRA_SETTING_ENABLE_STALL_LIMIT,
    AXIS0_CONFIG_EXTRA_SETTING_GEAR_RATIO,
    AXIS0_CONFIG_EXTRA_SETTING_STALL_CURRENT_LIMIT,
    AXIS0_CONFIG_EXTRA_SETTING_STALL_TIME_LIMIT,
    AXIS0_CONFIG_EXTRA_SETTING_ZERO_OFFSET_COUNTS,
    AXIS0_CONTROLLER_CONFIG_ENABLE_CURRENT_MODE_VEL_LIMIT,
    AXIS0_CONTROLLER_CONFIG_ENABLE_OVERSPEED_ERROR,
    AXIS0_CONTROLLER_CONFIG_ENABLE_VEL_LIMIT,
    AXIS0_CONTROLLER_CONFIG_INERTIA,
    AXIS0_CONTROLLER_CONFIG_POS_GAIN,
    AXIS0_CONTROLLER_CONFIG_VEL_GAIN,
    AXIS0_CONTROLLER_CONFIG_VEL_INTEGRATOR_GAIN,
    AXIS0_CONTROLLER_CONFIG_VEL_LIMIT,
    AXIS0_CONTROLLER_CONFIG_VEL_LIMIT_TOLERANCE,
    AXIS0_ENCODER_CONFIG_CPR,
    AXIS0_MOTOR_CONFIG_TORQUE_CONSTANT,
    AXIS0_OUTPUT_SHAFT_LOAD_INERTIA,
    CAN_CONFIG_HEARTBEAT_MS,
    CAN_CONFIG_TIMEOUT_MS,
)
from . import behaviour as bh
from .defaults import MotorModel
from .drive import TAU, Drive
from .thermal import Thermal, ThermalLimits

__all__ = ["Settings"]


class Settings:
    """The values a motor derives from its parameters (``ram``), its ``model`` and its load.

    :meth:`refresh` recomputes them, and the ``drive``'s gains and limits, after every change.
    ``heartbeat`` is False for firmware that stores heartbeat_ms but sends nothing.
    """

    __slots__ = (
        "drive",
        "hb_period",
        "heartbeat",
        "kt",
        "limits",
        "load_inertia",
        "model",
        "offset",
        "overspeed",
        "ram",
        "ratio",
        "reply_state",
        "stall_on",
        "stall_time",
        "stall_tq",
        "thermal",
        "timeout",
        "watchdog_damping",
    )

    def __init__(
        self,
        ram: MutableMapping[int, int | float],
        drive: Drive,
        model: MotorModel,
        thermal: Thermal,
        limits: ThermalLimits,
        *,
        heartbeat: bool,
    ) -> None:
        self.ram, self.drive, self.model, self.thermal, self.limits = ram, drive, model, thermal, limits
        self.heartbeat = heartbeat
        self.load_inertia = 0.0
        """Inertia of the load on the output shaft (kg*m^2)."""
        self.watchdog_damping = False
        """The CAN timeout expired: the idle axis brakes as with enable_damp_idle."""
        self.ratio = 10.0
        """Gear ratio (rotor turns per output turn)."""
        self.kt = 1.0
        """Torque constant at the output (Nm/A)."""
        self.offset = 0.0
        """Zero offset (output degrees)."""
        self.reply_state = False
        self.stall_on = False
        self.stall_tq = math.inf
        """Output torque (Nm) at the stall current limit."""
        self.stall_time = 0.0
        self.overspeed = math.inf
        """Output speed (turn/s) above which the overspeed error trips."""
        self.hb_period = 0.0
        """Heartbeat period (s); 0: none."""
        self.timeout = 0.0
        """CAN timeout (s); 0: none."""

    def refresh(self) -> None:
        """Recompute the drive's gains and limits and the protections from the parameters."""
        ram, d, m = self.ram, self.drive, self.model
        r = self.ratio = float(ram[AXIS0_CONFIG_EXTRA_SETTING_GEAR_RATIO])
        r2 = r * r
        kt = float(ram[AXIS0_MOTOR_CONFIG_TORQUE_CONSTANT]) * r
        self.kt = kt if kt else 1.0
        d.kp = float(ram[AXIS0_CONTROLLER_CONFIG_POS_GAIN])
        d.kv = float(ram[AXIS0_CONTROLLER_CONFIG_VEL_GAIN]) * r2
        d.ki = float(ram[AXIS0_CONTROLLER_CONFIG_VEL_INTEGRATOR_GAIN]) * r2
        d.vlim = (
            float(ram[AXIS0_CONTROLLER_CONFIG_VEL_LIMIT]) / r
            if ram[AXIS0_CONTROLLER_CONFIG_ENABLE_VEL_LIMIT]
            else math.inf
        )
        self.limits.configure(ram, r)
        d.tlim = self.limits.torque_limit(self.thermal)
        d.jff = float(ram[AXIS0_CONTROLLER_CONFIG_INERTIA]) * r2 + float(ram[AXIS0_OUTPUT_SHAFT_LOAD_INERTIA])
        d.j = TAU * (m.rotor_inertia * r2 + self.load_inertia)
        d.b = TAU * m.viscous
        d.fc = m.coulomb
        d.cm_vlim = bool(ram[AXIS0_CONTROLLER_CONFIG_ENABLE_CURRENT_MODE_VEL_LIMIT])
        damp = ram[AXIS0_CONFIG_EXTRA_SETTING_ENABLE_DAMP_IDLE] or self.watchdog_damping
        d.g_idle = bh.IDLE_DAMPING_NM_PER_RPM * 60.0 if damp else 0.0
        cpr = float(ram[AXIS0_ENCODER_CONFIG_CPR])
        self.offset = float(ram[AXIS0_CONFIG_EXTRA_SETTING_ZERO_OFFSET_COUNTS]) / cpr * 360.0 / r
        d.lim_on = bool(ram[AXIS0_CONFIG_EXTRA_SETTING_ENABLE_CIRCULAR_SETPOINT_LIMIT])
        d.lmin = float(ram[AXIS0_CONFIG_EXTRA_SETTING_CIRCULAR_SETPOINT_MIN]) / r + self.offset / 360.0
        d.lmax = float(ram[AXIS0_CONFIG_EXTRA_SETTING_CIRCULAR_SETPOINT_MAX]) / r + self.offset / 360.0
        self.reply_state = bool(ram[AXIS0_CONFIG_EXTRA_SETTING_ENABLE_REPLY_STATE])
        self.stall_on = bool(ram[AXIS0_CONFIG_EXTRA_SETTING_ENABLE_STALL_LIMIT])
        self.stall_tq = float(ram[AXIS0_CONFIG_EXTRA_SETTING_STALL_CURRENT_LIMIT]) * self.kt
        self.stall_time = float(ram[AXIS0_CONFIG_EXTRA_SETTING_STALL_TIME_LIMIT])
        self.overspeed = (
            d.vlim * float(ram[AXIS0_CONTROLLER_CONFIG_VEL_LIMIT_TOLERANCE])
            if ram[AXIS0_CONTROLLER_CONFIG_ENABLE_OVERSPEED_ERROR]
            else math.inf
        )
        self.hb_period = float(ram[CAN_CONFIG_HEARTBEAT_MS]) / 1000.0 if self.heartbeat else 0.0
        self.timeout = float(ram[CAN_CONFIG_TIMEOUT_MS]) / 1000.0

    def turns(self, deg: float) -> float:
        """Reported degrees -> internal output turns, clamped to the software limits when they are on."""
        pos = (deg + self.offset) / 360.0
        d = self.drive
        if d.lim_on:
            pos = min(d.lmax, max(d.lmin, pos))
        return pos

    def zero_here(self) -> None:
        """set_zero_position: the zero offset (31205, in RAM) so the current position reads 0."""
        ram = self.ram
        ram[AXIS0_CONFIG_EXTRA_SETTING_ZERO_OFFSET_COUNTS] = (
            self.drive.pos * self.ratio * float(ram[AXIS0_ENCODER_CONFIG_CPR])
        )
        self.refresh()
