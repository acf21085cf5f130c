"""Factory defaults of a simulated motor and the physical model behind it.

The simulated motor is a typical joint: a 10:1 planetary gearbox, 12 Nm peak and
300 r/min top speed at the output, 15-bit multi-turn absolute encoder, 24 V
supply. Parameters without ``output_shaft`` are rotor-side (turns, turn/s, rotor
Nm), as on the firmware; the output-shaft parameters are views of them through
the gear ratio (see :mod:`drempower.sim.params`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from .thermal import ThermalModel

__all__ = ["FACTORY", "READ_ONLY_CONSTANTS", "MotorModel"]

FACTORY: dict[str, int | float] = {
    "config.uart_baudrate": 115200,
    "config.dc_bus_undervoltage_trip_level": 10.0,
    "config.dc_bus_overvoltage_trip_level": 56.0,
    "config.dc_max_positive_current": 20.0,
    "config.dc_max_negative_current": -5.0,
    "config.max_regen_current": 0.0,
    "config.brake_resistance": 2.0,
    "config.enable_uart": 1,
    "can.config.baud_rate": 1_000_000,
    "can.config.protocol": 1,
    "can.config.timeout_ms": 0,
    "can.config.heartbeat_ms": 0,
    "axis0.config.startup_closed_loop_control": 1,
    "axis0.config.turns_per_step": 1.0 / 1024.0,
    "axis0.config.calibration_lockin.current": 10.0,
    "axis0.config.calibration_lockin.ramp_time": 0.4,
    "axis0.config.calibration_lockin.ramp_distance": math.pi,
    "axis0.config.calibration_lockin.accel": 20.0,
    "axis0.config.calibration_lockin.vel": 40.0,
    "axis0.config.extra_setting.enable_120r": 1,
    "axis0.config.extra_setting.circular_setpoint_min": -10.0,
    "axis0.config.extra_setting.circular_setpoint_max": 10.0,
    "axis0.config.extra_setting.enable_multi_circle": 1,
    "axis0.config.extra_setting.gear_ratio": 10.0,
    "axis0.config.extra_setting.stall_current_limit": 10.0,
    "axis0.config.extra_setting.stall_time_limit": 2.0,
    "axis0.config.extra_setting.enable_stall_limit": 1,
    "axis0.config.extra_setting.encoder_offset_calibrated": 1,
    "axis0.controller.config.enable_vel_limit": 1,
    "axis0.controller.config.enable_current_mode_vel_limit": 1,
    "axis0.controller.config.gain_scheduling_width": 10.0,
    "axis0.controller.config.pos_gain": 40.0,
    "axis0.controller.config.vel_gain": 0.06,
    "axis0.controller.config.vel_integrator_gain": 2.4,
    "axis0.controller.config.vel_limit": 50.0,
    "axis0.controller.config.vel_limit_tolerance": 1.2,
    "axis0.controller.config.vel_ramp_rate": 50.0,
    "axis0.controller.config.torque_ramp_rate": 1.0,
    "axis0.controller.config.circular_setpoint_range": 1.0,
    "axis0.controller.config.inertia": 3.0e-4,
    "axis0.controller.config.input_filter_bandwidth": 20.0,
    "axis0.motor.config.pre_calibrated": 1,
    "axis0.motor.config.pole_pairs": 14,
    "axis0.motor.config.calibration_current": 10.0,
    "axis0.motor.config.resistance_calib_max_voltage": 2.0,
    "axis0.motor.config.phase_inductance": 1.0e-4,
    "axis0.motor.config.phase_resistance": 0.2,
    "axis0.motor.config.torque_constant": 0.1,
    "axis0.motor.config.direction": 1,
    "axis0.motor.config.current_lim": 15.0,
    "axis0.motor.config.current_lim_margin": 8.0,
    "axis0.motor.config.torque_lim": 1.2,
    "axis0.motor.config.requested_current_range": 60.0,
    "axis0.motor.config.current_control_bandwidth": 1000.0,
    "axis0.encoder.config.mode": 271,
    "axis0.encoder.config.cpr": 32768,
    "axis0.encoder.config.pre_calibrated": 1,
    "axis0.encoder.config.bandwidth": 1000.0,
    "axis0.encoder.config.abs_spi_cs_gpio_pin": 1,
    "axis0.trap_traj.config.vel_limit": 10.0,
    "axis0.trap_traj.config.accel_limit": 100.0,
    "axis0.trap_traj.config.decel_limit": 100.0,
    "axis0.trap_traj.config.traj_mode": 1,
    "axis0.fet_thermistor.config.enabled": 1,
    "axis0.fet_thermistor.config.temp_limit_lower": 95.0,
    "axis0.fet_thermistor.config.temp_limit_upper": 100.0,
    "axis0.motor_thermistor.config.enabled": 1,
    "axis0.motor_thermistor.config.temp_limit_lower": 95.0,
    "axis0.motor_thermistor.config.temp_limit_upper": 100.0,
    "axis0.output_shaft.steps_per_turn": 10240.0,
    "axis0.output_shaft.homing_torque_lim": 1.0,
    "axis0.output_shaft.homing_vel_limit": 10.0,
    "axis0.output_shaft.homing_move_range": 360.0,
}
"""Factory values of the saved configuration, by name. Every other configuration
parameter defaults to 0; the node id defaults to the id the motor was created with."""

READ_ONLY_CONSTANTS: dict[str, int | float] = {
    "serial_number_h": 0x4452,
    "hw_version": 2,
    "fw_version": 21,
    "axis0.motor.is_calibrated": 1,
    "axis0.encoder.is_ready": 1,
    "axis0.encoder.index_found": 1,
    "axis0.encoder.battery_voltage": 3.6,
    "axis0.encoder.encoder_voltage": 3.3,
}
"""Fixed readings of the hardware (the serial number's low word is the motor's creation id)."""


@dataclass(frozen=True, slots=True)
class MotorModel:
    """Physical properties the firmware does not know, at the output shaft unless noted.

    ``rotor_inertia`` kg*m^2 (reflected through the gear ratio squared),
    ``viscous`` Nm/(rad/s), ``coulomb`` Nm, ``vbus`` supply voltage V.
    The default rotor inertia matches the factory ``controller.config.inertia``.
    """

    rotor_inertia: float = 3.0e-4 / (2.0 * math.pi)
    viscous: float = 0.005
    coulomb: float = 0.1
    vbus: float = 24.0
    thermal: ThermalModel = field(default_factory=ThermalModel)
    """Winding and driver-board heating (:mod:`drempower.sim.thermal`)."""
