"""One simulated DrEmpower motor: the firmware's command handling, states, errors and protections.

A :class:`SimMotor` receives decoded host commands (:meth:`SimMotor.receive`),
answers through a callback, and is stepped by its :class:`~drempower.sim.bus.SimBus`
at a fixed period (:meth:`SimMotor.step`). The control loop and mechanics are in
:mod:`drempower.sim.drive`; the parameter memory in :mod:`drempower.sim.params`;
every choice where the vendor is silent in :mod:`drempower.sim.behaviour`.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from enum import IntFlag
from pathlib import Path

from ..errors import DrEmpowerError
from ..protocol.addresses import (
    AXIS0_CONFIG_CAN_NODE_ID,
    AXIS0_CONFIG_EXTRA_SETTING_CIRCULAR_SETPOINT_MAX,
    AXIS0_CONFIG_EXTRA_SETTING_CIRCULAR_SETPOINT_MIN,
    AXIS0_CONFIG_EXTRA_SETTING_ENABLE_CIRCULAR_SETPOINT_LIMIT,
    AXIS0_CONFIG_EXTRA_SETTING_ENABLE_DAMP_IDLE,
    AXIS0_CONFIG_EXTRA_SETTING_ENABLE_MULTI_CIRCLE,
    AXIS0_CONFIG_EXTRA_SETTING_ENABLE_REPLY_STATE,
    AXIS0_CONFIG_EXTRA_SETTING_ENABLE_STALL_LIMIT,
    AXIS0_CONFIG_EXTRA_SETTING_ENCODER_OFFSET_CALIBRATED,
    AXIS0_CONFIG_EXTRA_SETTING_GEAR_RATIO,
    AXIS0_CONFIG_EXTRA_SETTING_STALL_CURRENT_LIMIT,
    AXIS0_CONFIG_EXTRA_SETTING_STALL_TIME_LIMIT,
    AXIS0_CONFIG_EXTRA_SETTING_ZERO_OFFSET_COUNTS,
    AXIS0_CONFIG_STARTUP_CLOSED_LOOP_CONTROL,
    AXIS0_CONTROLLER_CONFIG_CONTROL_MODE,
    AXIS0_CONTROLLER_CONFIG_ENABLE_CURRENT_MODE_VEL_LIMIT,
    AXIS0_CONTROLLER_CONFIG_ENABLE_OVERSPEED_ERROR,
    AXIS0_CONTROLLER_CONFIG_ENABLE_VEL_LIMIT,
    AXIS0_CONTROLLER_CONFIG_INERTIA,
    AXIS0_CONTROLLER_CONFIG_INPUT_FILTER_BANDWIDTH,
    AXIS0_CONTROLLER_CONFIG_INPUT_MODE,
    AXIS0_CONTROLLER_CONFIG_POS_GAIN,
    AXIS0_CONTROLLER_CONFIG_VEL_GAIN,
    AXIS0_CONTROLLER_CONFIG_VEL_INTEGRATOR_GAIN,
    AXIS0_CONTROLLER_CONFIG_VEL_LIMIT,
    AXIS0_CONTROLLER_CONFIG_VEL_LIMIT_TOLERANCE,
    AXIS0_CONTROLLER_ERROR,
    AXIS0_CONTROLLER_INPUT_POS,
    AXIS0_CONTROLLER_INPUT_TORQUE,
    AXIS0_CONTROLLER_INPUT_VEL,
    AXIS0_CONTROLLER_POS_SETPOINT,
    AXIS0_CONTROLLER_TORQUE_SETPOINT,
    AXIS0_CONTROLLER_TRAJECTORY_DONE,
    AXIS0_CONTROLLER_VEL_SETPOINT,
    AXIS0_CURRENT_STATE,
    AXIS0_ENCODER_CONFIG_CPR,
    AXIS0_ENCODER_ERROR,
    AXIS0_ENCODER_POS_ABS,
    AXIS0_ENCODER_POS_CIRCULAR,
    AXIS0_ENCODER_POS_ESTIMATE,
    AXIS0_ENCODER_TURN_ABS,
    AXIS0_ENCODER_VEL_ESTIMATE,
    AXIS0_ERROR,
    AXIS0_FET_THERMISTOR_TEMPERATURE,
    AXIS0_MOTOR_CONFIG_PHASE_RESISTANCE,
    AXIS0_MOTOR_CONFIG_TORQUE_CONSTANT,
    AXIS0_MOTOR_CURRENT_CONTROL_IBUS,
    AXIS0_MOTOR_CURRENT_CONTROL_IQ_MEASURED,
    AXIS0_MOTOR_CURRENT_CONTROL_IQ_SETPOINT,
    AXIS0_MOTOR_EFFECTIVE_CURRENT_LIM,
    AXIS0_MOTOR_ERROR,
    AXIS0_MOTOR_IS_CALIBRATED,
    AXIS0_MOTOR_THERMISTOR_TEMPERATURE,
    AXIS0_OUTPUT_SHAFT_LOAD_INERTIA,
    AXIS0_OUTPUT_SHAFT_TORQUE_ESTIMATE,
    AXIS0_OUTPUT_SHAFT_TORQUE_RAMP_RATE,
    AXIS0_OUTPUT_SHAFT_TRAP_TRAJ_ACCEL_LIMIT,
    AXIS0_OUTPUT_SHAFT_TRAP_TRAJ_DECEL_LIMIT,
    AXIS0_OUTPUT_SHAFT_TRAP_TRAJ_VEL_LIMIT,
    AXIS0_OUTPUT_SHAFT_VEL_RAMP_RATE,
    AXIS0_REQUESTED_STATE,
    AXIS0_TRAP_TRAJ_CONFIG_TRAJ_MODE,
    CAN_CONFIG_BAUD_RATE,
    CAN_CONFIG_HEARTBEAT_MS,
    CAN_CONFIG_TIMEOUT_MS,
    CAN_ERROR,
)
from ..protocol.enums import AxisState, TorqueMode, TrajMode, VelocityMode
from ..protocol.flags import ERROR_WORDS, AxisError, CanError, ControllerError, EncoderError, MotorError
from ..protocol.ids import Frame, StartKind, SysCmd
from ..protocol.limits import MAX_NODE, MIN_MOTOR
from ..protocol.messages import (
    S16_MAX,
    S16_MIN,
    Command,
    FastRead,
    ParamValue,
    PositionP,
    PositionQ,
    PositionT,
    Preset,
    PresetC,
    PresetV,
    ReadParam,
    Start,
    StartImpedance,
    State,
    SystemCommand,
    Torque,
    Velocity,
    WriteParam,
)
from ..protocol.parameters import F32_MAX, Parameter, parameter
from . import behaviour as bh
from . import firmware as firmware_module
from .defaults import MotorModel
from .drive import POSITION, TAU, TRAP_TRAJ, Drive
from .firmware import Firmware, factory_firmware_id
from .params import OUTPUT_VIEWS, ParamStore, view_factor
from .thermal import HEAT_STEPS, Thermal, ThermalLimits

__all__ = ["SimMotor"]

Reply = Callable[[Frame], None]
"""Where a motor puts the frames it answers with."""

_FILTER_MAX = 250.0
"""Largest input-filter bandwidth (1/s): a quarter of the 1 kHz loop rate, as on ODrive."""
_CALIBRATION_STATES = frozenset((3, 4, 6, 7))
_EPS = 1e-9
"""Timer slack (s), so that periods that are whole numbers of steps fire on their step."""
_ANGLE_LIMITS = (
    AXIS0_CONFIG_EXTRA_SETTING_ENABLE_CIRCULAR_SETPOINT_LIMIT,
    AXIS0_CONFIG_EXTRA_SETTING_CIRCULAR_SETPOINT_MIN,
    AXIS0_CONFIG_EXTRA_SETTING_CIRCULAR_SETPOINT_MAX,
)
"""The software angle limits: on/off, minimum and maximum (turns)."""
_WORD_OF_FLAGS: dict[type[IntFlag], int] = {w.flags: w.address for w in ERROR_WORDS}
_ERROR_ADDRESSES = tuple(w.address for w in ERROR_WORDS)


def _s16(x: float) -> float:
    return S16_MIN if x < S16_MIN else S16_MAX if x > S16_MAX else x if x == x else 0.0


class SimMotor:
    """A simulated motor at the output shaft: degrees, r/min, Nm.

    ``ident`` is the id the motor was created with (its identity: the key in
    ``SimBus.motors``, the factory node id, the name of its saved configuration);
    ``node_id`` is its current CAN id. Tests may push the shaft with
    ``external_torque`` (Nm), block it with ``locked``, or add ``load_inertia``
    (kg*m^2 at the output).
    """

    def __init__(
        self,
        ident: int,
        *,
        model: MotorModel | None = None,
        config_path: Path | None = None,
        firmware: Firmware | None = None,
    ) -> None:
        self.ident = ident
        self.model = model or MotorModel()
        self.firmware = firmware or firmware_module.DEFAULT
        """The reading of the document this motor's firmware takes (:mod:`~drempower.sim.firmware`)."""
        self.params = ParamStore(ident, config_path)
        factory_firmware_id(self.params, ident, self.firmware.factory_id)
        self.drive = Drive()
        self.thermal = Thermal(self.model.thermal)
        """Winding and board temperatures (degC); tests may set them (a heat gun)."""
        self._limits = ThermalLimits()
        self._derating = False
        self._tq_sq = 0.0
        """Sum of the squared output torque (Nm^2) over the steps since the last thermal update."""
        self._heat_n = 0
        """The limiter acted at the last step (else the torque limit is the configured one)."""
        self.time = 0.0
        """Simulated time of the last step (s)."""
        self.state = AxisState.IDLE
        self.errors: dict[int, int] = dict.fromkeys(_ERROR_ADDRESSES, 0)
        """Error words by parameter address (30001 axis, 33001 motor, ...)."""
        self.preset: Preset | None = None
        """The pending preset (0x0C), waiting for a start."""
        self.bitrate = 1_000_000
        """CAN bit rate in use (can.config.baud_rate as it was at the last boot)."""
        self.emit: Reply = _discard
        """Where unsolicited frames (heartbeats) go; set by the bus."""
        self._load_inertia = 0.0
        self._requested = 0
        self._offset = 0.0
        self._ratio = 10.0
        self._kt = 1.0
        self._reply_state = False
        self._stall_on = False
        self._stall_tq = math.inf
        self._stall_time = 0.0
        self._stall_t = 0.0
        self._overspeed = math.inf
        self._hb_period = 0.0
        self._hb_next = math.inf
        self._timeout = 0.0
        self._last_rx = 0.0
        self.in_dfu = False
        """True after enter_dfu_mode: the bootloader waits on USB and the motor answers nothing until power_cycle()."""
        self._boot_end = math.inf
        """When a reboot's boot ends (s); inf when not booting."""
        self._calib_end = math.inf
        self._calib_next: list[int] = []
        """Calibration states still to run after the current one."""
        self._calib_start = 0.0
        self._calib_pos = 0.0
        self._wake = math.inf
        self._watchdog_damping = False
        self._sticky_cleared = True
        self._boot()

    @property
    def next_wake(self) -> float:
        """Simulated time (s) of this motor's next timer (heartbeat, CAN timeout, end of calibration)."""
        return self._wake

    # ------------------------------------------------------------------ readings

    @property
    def node_id(self) -> int:
        """The CAN node id the motor answers to (can_node_id, 31001)."""
        return int(self.params.ram[AXIS0_CONFIG_CAN_NODE_ID])

    @node_id.setter
    def node_id(self, value: int) -> None:
        self.params.ram[AXIS0_CONFIG_CAN_NODE_ID] = value

    @property
    def position(self) -> float:
        """Output shaft position (deg) as the motor reports it."""
        return self.drive.pos * 360.0 - self._offset

    @property
    def speed(self) -> float:
        """Output shaft speed (r/min)."""
        return self.drive.vel * 60.0

    @property
    def torque(self) -> float:
        """Output torque the motor applies (Nm)."""
        return self.drive.torque

    @property
    def current(self) -> float:
        """q-axis current (A)."""
        return self.drive.torque / self._kt

    @property
    def axis_error(self) -> int:
        """axis0.error (30001); non-zero sets the E bit of state frames."""
        return self.errors[AXIS0_ERROR]

    @property
    def trajectory_done(self) -> bool:
        """The T bit: see :data:`drempower.sim.behaviour.DONE_TOLERANCE_DEG`."""
        d = self.drive
        if not d.active or d.mode != POSITION:
            return True
        if d.input_mode == TRAP_TRAJ:
            return d.trajectory_done()
        return abs(d.in_pos - d.pos) * 360.0 <= bh.DONE_TOLERANCE_DEG

    @property
    def external_torque(self) -> float:
        """Torque applied to the output shaft from outside (Nm), e.g. a load or a hand."""
        return self.drive.ext

    @external_torque.setter
    def external_torque(self, value: float) -> None:
        self.drive.ext = value

    @property
    def locked(self) -> bool:
        """True: the output shaft is mechanically blocked (it cannot turn)."""
        return self.drive.locked

    @locked.setter
    def locked(self, value: bool) -> None:
        self.drive.locked = value
        if value:
            self.drive.vel = 0.0

    @property
    def load_inertia(self) -> float:
        """Inertia of the load on the output shaft (kg*m^2)."""
        return self._load_inertia

    @load_inertia.setter
    def load_inertia(self, value: float) -> None:
        self._load_inertia = value
        self._refresh()

    def state_frame(self, answered: int = 0) -> Frame:
        """The real-time state frame as the motor would send it now, answering command ``answered``
        (0: none, a heartbeat), whose bits 3-4 it may keep (:attr:`firmware`)."""
        d = self.drive
        pos = d.pos * 360.0 - self._offset
        return State(
            self.node_id,
            pos if -F32_MAX <= pos <= F32_MAX else 0.0,
            _s16(d.vel * 60.0),
            _s16(d.torque),
            self.trajectory_done,
            self.errors[AXIS0_ERROR] != 0,
            self.firmware.spare_bits(answered),
        ).encode()

    def param(self, key: str | int) -> int | float:
        """A parameter's value as the motor would report it (in its table type)."""
        value = self._read(parameter(key).address)
        assert value is not None
        return value

    def set_param(self, key: str | int, value: float) -> None:
        """Write a parameter as a 0x1F frame would (same checks; read-only ones are ignored)."""
        p = parameter(key)
        self._write(p, bh.convert_value(value, p.dtype))

    def inject_error(self, flag: IntFlag, word: str | int | None = None) -> None:
        """Raise error ``flag`` as the firmware would (the axis drops to IDLE unless it is a CAN error).

        ``word`` (name or address) defaults to the word of the flag's type, e.g.
        ``MotorError.DRV_FAULT`` goes to axis0.motor.error.
        """
        addr = _WORD_OF_FLAGS[type(flag)] if word is None else parameter(word).address
        if addr == AXIS0_ENCODER_ERROR and int(flag) & bh.STICKY_ENCODER_ERRORS:
            self._sticky_cleared = False
        self._fault(addr, int(flag))

    # ------------------------------------------------------------------ stepping

    def step(self, dt: float, now: float) -> None:
        """Advance by ``dt`` s to simulated time ``now``."""
        d = self.drive
        plant = d.plant
        if plant is not None:
            plant.sync(now)
        d.step(dt)
        self.time = now
        tq = d.torque
        self._tq_sq += tq * tq
        self._heat_n += 1
        if self._heat_n >= HEAT_STEPS:
            self._heat(dt)
        if self.state == AxisState.ENCODER_OFFSET_CALIBRATION:
            self._encoder_scan(now)
        if d.active:
            if self._stall_on:
                if abs(d.torque) >= self._stall_tq:
                    self._stall_t += dt
                    if self._stall_t >= self._stall_time:
                        self._fault(AXIS0_MOTOR_ERROR, bh.STALL_FLAG, bh.STALL_AXIS_ERROR)
                else:
                    self._stall_t = 0.0
            if abs(d.vel) > self._overspeed:
                self._fault(AXIS0_CONTROLLER_ERROR, ControllerError.OVERSPEED)
        if now >= self._wake:
            self._timers()

    def _heat(self, dt: float) -> None:
        """Heat with the mean square current of the last HEAT_STEPS steps (the step sums the torque's squares),
        derate the current limit, trip above the upper limits."""
        lim, t, n = self._limits, self.thermal, self._heat_n
        t.heat(dt * n, self._tq_sq / (n * self._kt * self._kt), lim.phase_resistance)
        self._tq_sq, self._heat_n = 0.0, 0
        calm = t.winding < lim.calm_below and t.board < lim.calm_below
        if calm and not self._derating:
            return
        self._derating = not calm
        trip = lim.tripped(t)
        if trip:
            self._fault(trip, 0x1)
        self.drive.tlim = lim.torque_limit(t)

    def _timers(self) -> None:
        now = self.time + _EPS
        if now >= self._boot_end:
            self._boot_end = math.inf
            self._boot()
        if now >= self._hb_next and not self.in_dfu:
            self.emit(self.state_frame())
            self._hb_next = max(self._hb_next + self._hb_period, now)
        if self._timeout and self.drive.active and now - self._last_rx >= self._timeout:
            self._watchdog_damping = True
            self._fault(AXIS0_ERROR, bh.WATCHDOG_ERROR)
        if now >= self._calib_end:
            self._calibration_phase_done()
        self._rearm()

    def _rearm(self) -> None:
        wake = min(self._hb_next, self._calib_end, self._boot_end)
        if self._timeout and self.drive.active:
            wake = min(wake, self._last_rx + self._timeout)
        self._wake = wake - _EPS

    # ------------------------------------------------------------------ commands

    def receive(self, msg: Command, reply: Reply) -> None:
        """Handle one host command addressed to this motor (or broadcast); answers go to ``reply``."""
        if self.in_dfu or self._boot_end != math.inf:
            return  # the firmware is not running, or still booting
        self._last_rx = self.time
        _HANDLERS[type(msg)](self, msg, reply)

    def _answer_state(self, reply: Reply, cmd: int) -> None:
        if self._reply_state and self.firmware.replies_to(cmd):
            reply(self.state_frame(cmd))

    def _raw(self, deg: float) -> float:
        """Reported degrees -> internal output turns, clamped to the software limits when they are on."""
        pos = (deg + self._offset) / 360.0
        d = self.drive
        if d.lim_on:
            pos = min(d.lmax, max(d.lmin, pos))
        return pos

    def _on_t(self, msg: PositionT, reply: Reply) -> None:
        if self.drive.active:
            self._track(msg.position, msg.bandwidth)
        self._answer_state(reply, 0x19)

    def _track(self, deg: float, bandwidth: float) -> None:
        bw = abs(bandwidth)
        self.params.ram[AXIS0_CONTROLLER_CONFIG_INPUT_FILTER_BANDWIDTH] = bw
        self.drive.filtered(self._raw(deg), min(bw, _FILTER_MAX))

    def _on_q(self, msg: PositionQ, reply: Reply) -> None:
        if self.drive.active:
            self._move(msg.position, abs(msg.speed), abs(msg.accel))
        self._answer_state(reply, 0x1A)

    def _move(self, deg: float, speed: float, accel: float) -> None:
        """Q move to ``deg`` at ``speed`` r/min and ``accel`` (r/min)/s."""
        if speed == 0.0:
            self._fault(AXIS0_CONTROLLER_ERROR, bh.Q_ZERO_SPEED_ERROR)
            return
        self._set_output(AXIS0_OUTPUT_SHAFT_TRAP_TRAJ_VEL_LIMIT, speed)
        self._set_output(AXIS0_OUTPUT_SHAFT_TRAP_TRAJ_ACCEL_LIMIT, accel)
        self._set_output(AXIS0_OUTPUT_SHAFT_TRAP_TRAJ_DECEL_LIMIT, accel)
        target = self._raw(deg)
        if accel == 0.0:
            self.drive.hold(target)
            return
        vmax = min(speed / 60.0, self.drive.vlim)
        self.drive.trajectory(target, vmax, accel / 60.0, self._s_curve())

    def _s_curve(self) -> bool:
        return bool(self.params.ram[AXIS0_TRAP_TRAJ_CONFIG_TRAJ_MODE] == TrajMode.S_CURVE)

    def _timed_move(self, deg: float, seconds: float, accel: float) -> None:
        """Q target-time move: reach ``deg`` in ``seconds`` with ``accel`` (r/min)/s."""
        if seconds <= 0.0 and self.firmware.q_time_zero == "ignore":
            return  # this firmware does nothing with a time of 0 (sim.firmware)
        limit = float(self._read(AXIS0_OUTPUT_SHAFT_TRAP_TRAJ_ACCEL_LIMIT) or 0.0)
        self._set_output(AXIS0_OUTPUT_SHAFT_TRAP_TRAJ_ACCEL_LIMIT, accel)
        self._set_output(AXIS0_OUTPUT_SHAFT_TRAP_TRAJ_DECEL_LIMIT, accel)
        target = self._raw(deg)
        d = self.drive
        start = d.pos_sp if d.mode == POSITION else d.pos
        s_curve = self._s_curve()
        if seconds <= 0.0:  # no move time: as fast as the speed and acceleration limits allow
            self._fastest_move(target, accel if accel > 0.0 else limit, s_curve)
            return
        a = accel / 60.0 * (0.5 if s_curve else 1.0)
        vmax, a = bh.target_time_profile(abs(target - start), seconds, a)
        if not vmax > 0.0:  # nothing to move, or less than float resolution
            d.hold(target)
            return
        d.trajectory(target, min(vmax, d.vlim), a * (2.0 if s_curve else 1.0), s_curve)

    def _fastest_move(self, target: float, accel: float, s_curve: bool) -> None:
        """A Q target-time move with a time of 0: at the trajectory speed limit (38014, at most the speed
        limit) and ``accel`` (r/min)/s; with no acceleration, the position loop holds the target within
        its speed and current limits."""
        d = self.drive
        vel = self._read(AXIS0_OUTPUT_SHAFT_TRAP_TRAJ_VEL_LIMIT)
        vmax = min(float(vel) / 60.0, d.vlim) if vel else d.vlim
        a = accel / 60.0
        if not (vmax > 0.0 and a > 0.0):
            d.hold(target)
            return
        d.trajectory(target, vmax, a, s_curve)

    def _on_p(self, msg: PositionP, reply: Reply) -> None:
        if self.drive.active:
            self.drive.position(self._raw(msg.position), msg.speed_ff / 60.0, msg.torque_ff)
        self._answer_state(reply, 0x1B)

    def _on_v(self, msg: Velocity, reply: Reply) -> None:
        if self.drive.active:
            self._velocity(msg.speed, msg.param, msg.mode)
        self._answer_state(reply, 0x1C)

    def _velocity(self, speed: float, param: float, mode: VelocityMode) -> None:
        if mode == VelocityMode.PASSTHROUGH:
            self.drive.velocity(speed / 60.0, param, None)
        else:
            self._set_output(AXIS0_OUTPUT_SHAFT_VEL_RAMP_RATE, abs(param))
            self.drive.velocity(speed / 60.0, 0.0, abs(param) / 60.0)

    def _on_c(self, msg: Torque, reply: Reply) -> None:
        if self.drive.active:
            self._torque(msg.torque, msg.param, msg.mode)
        self._answer_state(reply, 0x1D)

    def _torque(self, torque: float, param: float, mode: TorqueMode) -> None:
        if mode == TorqueMode.DIRECT:
            self.drive.torque_command(torque, None)
        else:
            self._set_output(AXIS0_OUTPUT_SHAFT_TORQUE_RAMP_RATE, abs(param))
            self.drive.torque_command(torque, abs(param))

    def _on_preset(self, msg: Preset, reply: Reply) -> None:
        self.preset = msg
        self._answer_state(reply, 0x0C)

    def _on_start(self, msg: Start | StartImpedance, reply: Reply) -> None:
        p, self.preset = self.preset, None
        if p is None or not self.drive.active:
            return
        kind = msg.kind
        target = p.p1 + self.position if isinstance(msg, Start) and msg.relative else p.p1
        if kind is StartKind.T:
            self._track(target, p.p3)
        elif kind is StartKind.Q:
            self._timed_move(target, p.p2, abs(p.p3))
        elif kind is StartKind.P:
            self.drive.position(self._raw(target), p.p2 / 60.0, p.p3)
        elif isinstance(msg, StartImpedance):
            self.drive.impedance(self._raw(target), p.p2 / 60.0, p.p3, msg.kp * TAU, msg.kd * TAU)
        else:
            try:
                typed = p.as_kind(kind)
            except DrEmpowerError:
                return
            if isinstance(typed, PresetV):
                self._velocity(typed.speed, typed.param, typed.mode)
            elif isinstance(typed, PresetC):
                self._torque(typed.torque, typed.param, typed.mode)

    def _on_system(self, msg: SystemCommand, reply: Reply) -> None:
        op = msg.op
        if op < SysCmd.START_T:  # a start answers through its preset
            self._answer_state(reply, 0x08)
        if op is SysCmd.ESTOP:
            self._fault(AXIS0_ERROR, AxisError.ESTOP_REQUESTED)
        elif op is SysCmd.CLEAR_ERRORS:
            self._clear_errors()
        elif op is SysCmd.SET_ZERO_POSITION:
            self._set_zero()
        elif op is SysCmd.SAVE_CONFIG:
            self.params.save()
        elif op is SysCmd.ERASE_CONFIG:
            self.params.erase()
        elif op is SysCmd.INIT_CONFIG:
            self.params.init()
            self._refresh()
        elif op is SysCmd.REBOOT:
            self._reboot()
        elif op is SysCmd.ENTER_DFU_MODE:
            self._enter_idle()
            self.in_dfu = True

    def power_cycle(self) -> None:
        """Switch the supply off and on: leaves firmware-update mode and boots as a reboot does."""
        self.in_dfu = False
        self._reboot()

    @property
    def booting(self) -> bool:
        """True while the firmware boots after a reboot or power cycle: the motor is idle, hears and sends
        nothing, for :data:`~drempower.sim.behaviour.BOOT_SECONDS`."""
        return self._boot_end != math.inf

    def _reboot(self) -> None:
        """The firmware stops (the axis idles, heartbeats stop) and boots :data:`BOOT_SECONDS` later."""
        self._enter_idle()
        self.preset = None
        self._hb_next = math.inf
        self._boot_end = self.time + self.firmware.boot_s
        self._rearm()

    def _on_read(self, msg: ReadParam, reply: Reply) -> None:
        value = self._read(msg.address)
        if value is not None:
            reply(ParamValue(self.node_id, msg.address, msg.dtype, bh.convert_value(value, msg.dtype)).encode())

    def _on_fast_read(self, msg: FastRead, reply: Reply) -> None:
        if self.firmware.fast_read:
            reply(self.state_frame(0x1E))

    def _on_write(self, msg: WriteParam, reply: Reply) -> None:
        try:
            p = parameter(msg.address)
        except DrEmpowerError:
            return
        self._write(p, bh.convert_value(msg.value, p.dtype))
        self._answer_state(reply, 0x1F)

    # ------------------------------------------------------------------ parameters

    def _read(self, addr: int) -> int | float | None:
        getter = _LIVE.get(addr)
        if getter is not None:
            return getter(self)
        view = OUTPUT_VIEWS.get(addr)
        if view is not None:
            rotor = self._read(view[0])
            assert rotor is not None
            return float(rotor) * view_factor(view[1], self._ratio)
        return self.params.ram.get(addr)

    def _set_output(self, addr: int, value: float) -> None:
        """Store an output-shaft configuration value (through its rotor-side twin)."""
        rotor, kind = OUTPUT_VIEWS[addr]
        self.params.ram[rotor] = value / view_factor(kind, self._ratio)
        self._refresh()

    def _write(self, p: Parameter, value: int | float) -> None:
        addr = p.address
        view = OUTPUT_VIEWS.get(addr)
        if view is not None:
            rotor = parameter(view[0])
            self._write(rotor, bh.convert_value(value / view_factor(view[1], self._ratio), rotor.dtype))
            return
        if not p.writable:
            return
        special = _WRITE_HOOKS.get(addr)
        if special is not None:
            special(self, value)
            return
        if not self._accept(addr, value):
            return
        self.params.ram[addr] = value
        self._refresh()
        if addr in (CAN_CONFIG_TIMEOUT_MS, CAN_CONFIG_HEARTBEAT_MS):
            self._hb_next = self.time + self._hb_period if self._hb_period else math.inf
            self._rearm()

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
            turns = self.position * self._ratio / 360.0
            return not on or lo <= turns <= hi
        return True

    def _write_requested_state(self, value: float) -> None:
        self._requested = int(value)
        if value == AxisState.CLOSED_LOOP_CONTROL:
            self._enter_closed_loop()
        elif value == AxisState.IDLE:
            self._enter_idle()
        elif value in _CALIBRATION_STATES:
            self._enter_idle()
            if self.errors[AXIS0_ERROR]:
                return  # as for closed loop: refused while an error is set
            self._calib_next = list(bh.CALIBRATION_PHASES[int(value)])
            self._start_calibration_phase()

    # ------------------------------------------------------------------ calibration

    def _start_calibration_phase(self) -> None:
        state = self._calib_next.pop(0)
        self.state = AxisState(state)
        self._calib_start = self.time
        self._calib_pos = self.drive.pos
        seconds = {
            AxisState.MOTOR_CALIBRATION: bh.MOTOR_CALIBRATION_SECONDS,
            AxisState.ENCODER_OFFSET_CALIBRATION: bh.ENCODER_OFFSET_CALIBRATION_SECONDS,
        }.get(self.state, bh.CALIBRATION_SECONDS)
        self._calib_end = self.time + seconds
        self._rearm()

    def _encoder_scan(self, now: float) -> None:
        """Encoder offset calibration: the rotor turns once forward and back (unless the shaft is blocked)."""
        d = self.drive
        if d.locked:
            d.vel = 0.0
            return
        span = bh.ENCODER_OFFSET_CALIBRATION_SECONDS
        f = min(max((now - self._calib_start) / span, 0.0), 1.0)
        turns = (2 * f if f < 0.5 else 2 - 2 * f) / self._ratio  # output turns of one rotor turn
        d.pos = self._calib_pos + turns
        d.vel = (2 if f < 0.5 else -2) / self._ratio / span if f < 1.0 else 0.0

    def _calibration_phase_done(self) -> None:
        """End the current calibration state: record its result or fault, then the next phase or IDLE."""
        self._calib_end = math.inf
        state = self.state
        ram = self.params.ram
        if state == AxisState.MOTOR_CALIBRATION:
            if self.model.vbus < bh.CALIBRATION_MIN_VBUS:
                self._calib_next = []
                self._fault(AXIS0_MOTOR_ERROR, MotorError.PHASE_RESISTANCE_OUT_OF_RANGE, AxisError.MOTOR_FAILED)
                self._fault(AXIS0_ERROR, AxisError.DC_BUS_UNDER_VOLTAGE)
                return
            ram[AXIS0_MOTOR_IS_CALIBRATED] = 1
        elif state == AxisState.ENCODER_OFFSET_CALIBRATION:
            self.drive.vel = 0.0
            if self.drive.locked:
                self._calib_next = []
                self._fault(AXIS0_ENCODER_ERROR, EncoderError.CPR_POLEPAIRS_MISMATCH)
                return
            ram[AXIS0_CONFIG_EXTRA_SETTING_ENCODER_OFFSET_CALIBRATED] = 1
        if self._calib_next and not self.errors[AXIS0_ERROR]:
            self._start_calibration_phase()
        else:
            self._calib_next = []
            self._enter_idle()

    def _write_input(self, addr: int, value: float) -> None:
        d = self.drive
        if not d.active:
            return
        if addr == AXIS0_CONTROLLER_INPUT_POS:
            d.position(self._raw(value * 360.0 / self._ratio), 0.0, 0.0)
        elif addr == AXIS0_CONTROLLER_INPUT_VEL:
            d.velocity(value / self._ratio, 0.0, None)
        else:
            d.torque_command(value * self._ratio, None)

    def _refresh(self) -> None:
        """Recompute the drive's gains and limits and the protections from the parameters."""
        ram, d, m = self.params.ram, self.drive, self.model
        r = self._ratio = float(ram[AXIS0_CONFIG_EXTRA_SETTING_GEAR_RATIO])
        r2 = r * r
        kt = float(ram[AXIS0_MOTOR_CONFIG_TORQUE_CONSTANT]) * r
        self._kt = kt if kt else 1.0
        d.kp = float(ram[AXIS0_CONTROLLER_CONFIG_POS_GAIN])
        d.kv = float(ram[AXIS0_CONTROLLER_CONFIG_VEL_GAIN]) * r2
        d.ki = float(ram[AXIS0_CONTROLLER_CONFIG_VEL_INTEGRATOR_GAIN]) * r2
        d.vlim = (
            float(ram[AXIS0_CONTROLLER_CONFIG_VEL_LIMIT]) / r
            if ram[AXIS0_CONTROLLER_CONFIG_ENABLE_VEL_LIMIT]
            else math.inf
        )
        self._limits.configure(ram, r)
        d.tlim = self._limits.torque_limit(self.thermal)
        d.jff = float(ram[AXIS0_CONTROLLER_CONFIG_INERTIA]) * r2 + float(ram[AXIS0_OUTPUT_SHAFT_LOAD_INERTIA])
        d.j = TAU * (m.rotor_inertia * r2 + self._load_inertia)
        d.b = TAU * m.viscous
        d.fc = m.coulomb
        d.cm_vlim = bool(ram[AXIS0_CONTROLLER_CONFIG_ENABLE_CURRENT_MODE_VEL_LIMIT])
        damp = ram[AXIS0_CONFIG_EXTRA_SETTING_ENABLE_DAMP_IDLE] or self._watchdog_damping
        d.g_idle = bh.IDLE_DAMPING_NM_PER_RPM * 60.0 if damp else 0.0
        cpr = float(ram[AXIS0_ENCODER_CONFIG_CPR])
        self._offset = float(ram[AXIS0_CONFIG_EXTRA_SETTING_ZERO_OFFSET_COUNTS]) / cpr * 360.0 / r
        d.lim_on = bool(ram[AXIS0_CONFIG_EXTRA_SETTING_ENABLE_CIRCULAR_SETPOINT_LIMIT])
        d.lmin = float(ram[AXIS0_CONFIG_EXTRA_SETTING_CIRCULAR_SETPOINT_MIN]) / r + self._offset / 360.0
        d.lmax = float(ram[AXIS0_CONFIG_EXTRA_SETTING_CIRCULAR_SETPOINT_MAX]) / r + self._offset / 360.0
        self._reply_state = bool(ram[AXIS0_CONFIG_EXTRA_SETTING_ENABLE_REPLY_STATE])
        self._stall_on = bool(ram[AXIS0_CONFIG_EXTRA_SETTING_ENABLE_STALL_LIMIT])
        self._stall_tq = float(ram[AXIS0_CONFIG_EXTRA_SETTING_STALL_CURRENT_LIMIT]) * self._kt
        self._stall_time = float(ram[AXIS0_CONFIG_EXTRA_SETTING_STALL_TIME_LIMIT])
        self._overspeed = (
            d.vlim * float(ram[AXIS0_CONTROLLER_CONFIG_VEL_LIMIT_TOLERANCE])
            if ram[AXIS0_CONTROLLER_CONFIG_ENABLE_OVERSPEED_ERROR]
            else math.inf
        )
        self._hb_period = float(ram[CAN_CONFIG_HEARTBEAT_MS]) / 1000.0 if self.firmware.heartbeat else 0.0
        self._timeout = float(ram[CAN_CONFIG_TIMEOUT_MS]) / 1000.0

    # ------------------------------------------------------------------ states and errors

    def _boot(self) -> None:
        """Power-up or reboot."""
        p = self.params
        p.boot()
        self.errors = dict.fromkeys(_ERROR_ADDRESSES, 0)
        self.preset = None
        self._watchdog_damping = False
        self._sticky_cleared = True
        self._requested = 0
        self._calib_end = math.inf
        self._refresh()
        if not p.ram[AXIS0_CONFIG_EXTRA_SETTING_ENABLE_MULTI_CIRCLE]:
            p.ram[AXIS0_CONFIG_EXTRA_SETTING_ZERO_OFFSET_COUNTS] = (
                self.drive.pos * self._ratio * float(p.ram[AXIS0_ENCODER_CONFIG_CPR])
            )
            self._refresh()
        self.bitrate = int(p.ram[CAN_CONFIG_BAUD_RATE])
        self._last_rx = self.time
        self._hb_next = self.time + self._hb_period if self._hb_period else math.inf
        self._enter_idle()
        if p.ram[AXIS0_CONFIG_STARTUP_CLOSED_LOOP_CONTROL]:
            self._enter_closed_loop()
        self._rearm()

    def _enter_idle(self) -> None:
        self._calib_end = math.inf  # an error or a request ends a calibration
        self._calib_next = []
        self.state = AxisState.IDLE
        self.drive.active = False
        self._stall_t = 0.0
        self._refresh()

    def _enter_closed_loop(self) -> None:
        if self.errors[AXIS0_ERROR] or self.state == AxisState.CLOSED_LOOP_CONTROL:
            return
        d = self.drive
        self.state = AxisState.CLOSED_LOOP_CONTROL
        self._calib_end = math.inf
        self._watchdog_damping = False
        self._last_rx = self.time
        d.active = True
        d.integ = 0.0
        d.hold(d.pos)
        self._refresh()
        self._recover_limits()
        self._rearm()

    def _recover_limits(self) -> None:
        """Outside the software limits in closed loop: move slowly to the nearest one."""
        d = self.drive
        if d.active and d.lim_on and not d.lmin <= d.pos <= d.lmax:
            target = d.lmax if d.pos > d.lmax else d.lmin
            d.hold(d.pos)
            d.trajectory(target, bh.LIMIT_RECOVERY_SPEED_RPM / 60.0, bh.LIMIT_RECOVERY_ACCEL / 60.0, False)

    def _fault(self, word: int, flags: int, axis_flag: int | None = None) -> None:
        """Set error ``flags`` in ``word``; any axis error drops the axis to IDLE."""
        self.errors[word] |= flags
        if word != AXIS0_ERROR:
            extra = bh.ERROR_WORD_AXIS_FLAG.get(word, 0) if axis_flag is None else axis_flag
            self.errors[AXIS0_ERROR] |= extra
        if self.errors[AXIS0_ERROR] and self.state != AxisState.IDLE:
            self._enter_idle()

    def _clear_errors(self) -> None:
        sticky = 0 if self._sticky_cleared else self.errors[AXIS0_ENCODER_ERROR] & bh.STICKY_ENCODER_ERRORS
        self.errors = dict.fromkeys(_ERROR_ADDRESSES, 0)
        self._stall_t = 0.0
        if sticky:
            self._fault(AXIS0_ENCODER_ERROR, sticky)

    def _set_zero(self) -> None:
        ram = self.params.ram
        ram[AXIS0_CONFIG_EXTRA_SETTING_ZERO_OFFSET_COUNTS] = (
            self.drive.pos * self._ratio * float(ram[AXIS0_ENCODER_CONFIG_CPR])
        )
        self._sticky_cleared = True
        self._refresh()
        self._recover_limits()

    def saw_frame(self, node: int) -> None:
        """Another motor put a frame with ``node`` on the bus: flag a duplicate id."""
        if node == self.node_id:
            self.errors[CAN_ERROR] |= CanError.DUPLICATE_CAN_IDS


def _discard(frame: Frame) -> None:
    """Default sink of unsolicited frames (a motor on no bus)."""


def _ibus(m: SimMotor) -> float:
    """Supply current (A): mechanical power plus copper loss over the bus voltage."""
    d = m.drive
    iq = d.torque / m._kt
    power = d.torque * d.vel * TAU + 1.5 * iq * iq * float(m.params.ram[AXIS0_MOTOR_CONFIG_PHASE_RESISTANCE])
    return power / m.model.vbus


def _pos_rotor(m: SimMotor) -> float:
    return m.position * m._ratio / 360.0


def _rotor_turns(raw_of: Callable[[Drive], float]) -> Callable[[SimMotor], float]:
    def read(m: SimMotor) -> float:
        return (raw_of(m.drive) * 360.0 - m._offset) * m._ratio / 360.0

    return read


def _error_word(addr: int) -> Callable[[SimMotor], int]:
    return lambda m: m.errors[addr]


_LIVE: dict[int, Callable[[SimMotor], int | float]] = {
    1: lambda m: m.model.vbus,
    2: _ibus,
    AXIS0_CURRENT_STATE: lambda m: int(m.state),
    AXIS0_REQUESTED_STATE: lambda m: m._requested,
    AXIS0_CONTROLLER_INPUT_POS: _rotor_turns(lambda d: d.in_pos),
    AXIS0_CONTROLLER_INPUT_VEL: lambda m: m.drive.in_vel * m._ratio,
    AXIS0_CONTROLLER_INPUT_TORQUE: lambda m: m.drive.in_tq / m._ratio,
    AXIS0_CONTROLLER_POS_SETPOINT: _rotor_turns(lambda d: d.pos_sp),
    AXIS0_CONTROLLER_VEL_SETPOINT: lambda m: m.drive.vel_sp * m._ratio,
    AXIS0_CONTROLLER_TORQUE_SETPOINT: lambda m: m.drive.tq_sp / m._ratio,
    AXIS0_CONTROLLER_TRAJECTORY_DONE: lambda m: int(m.trajectory_done),
    AXIS0_CONTROLLER_CONFIG_CONTROL_MODE: lambda m: m.drive.mode,
    AXIS0_CONTROLLER_CONFIG_INPUT_MODE: lambda m: m.drive.input_mode,
    AXIS0_MOTOR_EFFECTIVE_CURRENT_LIM: lambda m: m._limits.current_limit(m.thermal),
    AXIS0_MOTOR_THERMISTOR_TEMPERATURE: lambda m: m.thermal.winding,
    AXIS0_FET_THERMISTOR_TEMPERATURE: lambda m: m.thermal.board,
    AXIS0_MOTOR_CURRENT_CONTROL_IBUS: _ibus,
    AXIS0_MOTOR_CURRENT_CONTROL_IQ_SETPOINT: lambda m: m.current,
    AXIS0_MOTOR_CURRENT_CONTROL_IQ_MEASURED: lambda m: m.current,
    AXIS0_ENCODER_POS_ESTIMATE: _pos_rotor,
    AXIS0_ENCODER_POS_CIRCULAR: lambda m: _pos_rotor(m) % 1.0,
    AXIS0_ENCODER_VEL_ESTIMATE: lambda m: m.drive.vel * m._ratio,
    AXIS0_ENCODER_POS_ABS: lambda m: int(_pos_rotor(m) % 1.0 * float(m.params.ram[AXIS0_ENCODER_CONFIG_CPR])),
    AXIS0_ENCODER_TURN_ABS: lambda m: math.floor(_pos_rotor(m)),
    AXIS0_OUTPUT_SHAFT_TORQUE_ESTIMATE: lambda m: m.drive.torque,
    **{a: _error_word(a) for a in _ERROR_ADDRESSES},
}
"""Parameters computed from the motor's state when read."""

_WRITE_HOOKS: dict[int, Callable[[SimMotor, float], None]] = {
    AXIS0_REQUESTED_STATE: SimMotor._write_requested_state,
    AXIS0_CONTROLLER_INPUT_POS: lambda m, v: m._write_input(AXIS0_CONTROLLER_INPUT_POS, v),
    AXIS0_CONTROLLER_INPUT_VEL: lambda m, v: m._write_input(AXIS0_CONTROLLER_INPUT_VEL, v),
    AXIS0_CONTROLLER_INPUT_TORQUE: lambda m, v: m._write_input(AXIS0_CONTROLLER_INPUT_TORQUE, v),
    AXIS0_CONTROLLER_CONFIG_CONTROL_MODE: lambda m, v: None,
    AXIS0_CONTROLLER_CONFIG_INPUT_MODE: lambda m, v: None,
    AXIS0_MOTOR_ERROR: lambda m, v: m.errors.__setitem__(AXIS0_MOTOR_ERROR, int(v)),
}
"""Writable parameters that act instead of being stored (control and input mode follow the commands)."""

_HANDLERS: dict[type, Callable[[SimMotor, object, Reply], None]] = {
    PositionT: SimMotor._on_t,  # type: ignore[dict-item]
    PositionQ: SimMotor._on_q,  # type: ignore[dict-item]
    PositionP: SimMotor._on_p,  # type: ignore[dict-item]
    Velocity: SimMotor._on_v,  # type: ignore[dict-item]
    Torque: SimMotor._on_c,  # type: ignore[dict-item]
    Preset: SimMotor._on_preset,  # type: ignore[dict-item]
    Start: SimMotor._on_start,  # type: ignore[dict-item]
    StartImpedance: SimMotor._on_start,  # type: ignore[dict-item]
    SystemCommand: SimMotor._on_system,  # type: ignore[dict-item]
    ReadParam: SimMotor._on_read,  # type: ignore[dict-item]
    FastRead: SimMotor._on_fast_read,  # type: ignore[dict-item]
    WriteParam: SimMotor._on_write,  # type: ignore[dict-item]
}
