"""One simulated DrEmpower motor: the firmware's life cycle, its states, timers and protections.

A :class:`SimMotor` receives decoded host commands (:meth:`SimMotor.receive`),
answers through a callback, and is stepped by its :class:`~drempower.sim.bus.SimBus`
at a fixed period (:meth:`SimMotor.step`). Its parts, each holding only what it needs:
the control loop and mechanics (:mod:`~drempower.sim.drive`), the parameter memory
(:mod:`~drempower.sim.params`), the configuration in effect (:mod:`~drempower.sim.settings`),
what it reports (:mod:`~drempower.sim.readings`), how it takes writes
(:mod:`~drempower.sim.param_writes`), its command handlers (:mod:`~drempower.sim.handlers`),
its error words (:mod:`~drempower.sim.error_words`), its protections
(:mod:`~drempower.sim.protection`) and calibration (:mod:`~drempower.sim.calibration`);
every choice where the vendor is silent is in :mod:`drempower.sim.behaviour`, every
reading of the document a firmware may take in :mod:`drempower.sim.firmware`.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from enum import IntFlag
from pathlib import Path

from ..protocol.addresses import (
    AXIS0_CONFIG_CAN_NODE_ID,
    AXIS0_CONFIG_EXTRA_SETTING_ENABLE_MULTI_CIRCLE,
    AXIS0_CONFIG_STARTUP_CLOSED_LOOP_CONTROL,
    AXIS0_ENCODER_ERROR,
    AXIS0_ERROR,
    CAN_CONFIG_BAUD_RATE,
)
from ..protocol.enums import AxisState
from ..protocol.flags import AxisError
from ..protocol.ids import Frame, SysCmd
from ..protocol.messages import Command, Preset
from ..protocol.parameters import parameter
from . import behaviour as bh
from . import firmware as firmware_module
from .axis import Axis
from .calibration import CALIBRATION_STATES, Calibration
from .defaults import MotorModel
from .drive import Drive
from .error_words import ErrorWords
from .firmware import Firmware, factory_firmware_id
from .handlers import CommandHandlers, Reply
from .param_writes import ParamWriter
from .params import ParamStore
from .protection import Protections
from .readings import Readings
from .settings import Settings
from .thermal import Thermal, ThermalLimits

__all__ = ["AxisState", "Reply", "SimMotor"]

_EPS = 1e-9
"""Timer slack (s), so that periods that are whole numbers of steps fire on their step."""


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
        self.firmware = firmware or firmware_module.DEFAULT
        """The reading of the document this motor's firmware takes (:mod:`~drempower.sim.firmware`)."""
        self.params = ParamStore(ident, config_path)
        factory_firmware_id(self.params, ident, self.firmware.factory_id)
        self.drive = Drive()
        model = model or MotorModel()
        self.thermal = Thermal(model.thermal)
        """Winding and board temperatures (degC); tests may set them (a heat gun)."""
        limits = ThermalLimits()
        self.time = 0.0
        """Simulated time of the last step (s)."""
        self.axis = Axis()
        self.error_words = ErrorWords(self._axis_error)
        self.settings = Settings(
            self.params.ram, self.drive, model, self.thermal, limits, heartbeat=self.firmware.heartbeat
        )
        self.readings = Readings(self.drive, self.axis, self.params, self.settings, self.error_words, self.firmware)
        self.writer = ParamWriter(
            self.params,
            self.settings,
            self.readings,
            self.error_words,
            request_state=self._request_state,
            timing_changed=self._timing_changed,
        )
        self.handlers = CommandHandlers(self.readings, self.writer, self.error_words, self._system)
        self.protections = Protections(self.drive, self.settings, self.thermal, limits, self.error_words)
        self.calibration = Calibration(self.axis, self.settings, self.error_words)
        self.bitrate = 1_000_000
        """CAN bit rate in use (can.config.baud_rate as it was at the last boot)."""
        self.emit: Reply = _discard
        """Where unsolicited frames (heartbeats) go; set by the bus."""
        self.in_dfu = False
        """True after enter_dfu_mode: the bootloader waits on USB and the motor answers nothing until power_cycle()."""
        self._hb_next = math.inf
        self._last_rx = 0.0
        self._boot_end = math.inf
        """When a reboot's boot ends (s); inf when not booting."""
        self._wake = math.inf
        self._boot()

    @property
    def next_wake(self) -> float:
        """Simulated time (s) of this motor's next timer (heartbeat, CAN timeout, end of calibration)."""
        return self._wake

    # ------------------------------------------------------------------ readings and knobs

    @property
    def model(self) -> MotorModel:
        """The motor's hardware (supply voltage, inertia, friction); tests may replace it."""
        return self.settings.model

    @model.setter
    def model(self, value: MotorModel) -> None:
        self.settings.model = value

    @property
    def state(self) -> AxisState:
        """The axis state (axis0.current_state)."""
        return self.axis.state

    @property
    def errors(self) -> dict[int, int]:
        """Error words by parameter address (30001 axis, 33001 motor, ...)."""
        return self.error_words.words

    @property
    def preset(self) -> Preset | None:
        """The pending preset (0x0C), waiting for a start."""
        return self.handlers.preset

    @property
    def node_id(self) -> int:
        """The CAN node id the motor answers to (can_node_id, 31001)."""
        return self.readings.node_id

    @node_id.setter
    def node_id(self, value: int) -> None:
        self.params.ram[AXIS0_CONFIG_CAN_NODE_ID] = value

    @property
    def position(self) -> float:
        """Output shaft position (deg) as the motor reports it."""
        return self.readings.position

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
        return self.readings.current

    @property
    def axis_error(self) -> int:
        """axis0.error (30001); non-zero sets the E bit of state frames."""
        return self.error_words.axis

    @property
    def trajectory_done(self) -> bool:
        """The T bit: see :data:`drempower.sim.behaviour.DONE_TOLERANCE_DEG`."""
        return self.readings.trajectory_done

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
        return self.settings.load_inertia

    @load_inertia.setter
    def load_inertia(self, value: float) -> None:
        self.settings.load_inertia = value
        self.settings.refresh()

    def state_frame(self, answered: int = 0) -> Frame:
        """The real-time state frame as the motor would send it now, answering command ``answered``
        (0: none, a heartbeat), whose bits 3-4 it may keep (:attr:`firmware`)."""
        return self.readings.state_frame(answered)

    def param(self, key: str | int) -> int | float:
        """A parameter's value as the motor would report it (in its table type)."""
        value = self.readings.read(parameter(key).address)
        assert value is not None
        return value

    def set_param(self, key: str | int, value: float) -> None:
        """Write a parameter as a 0x1F frame would (same checks; read-only ones are ignored)."""
        p = parameter(key)
        self.writer.write(p, bh.convert_value(value, p.dtype))

    def inject_error(self, flag: IntFlag, word: str | int | None = None) -> None:
        """Raise error ``flag`` as the firmware would (the axis drops to IDLE unless it is a CAN error).

        ``word`` (name or address) defaults to the word of the flag's type, e.g.
        ``MotorError.DRV_FAULT`` goes to axis0.motor.error.
        """
        self.error_words.inject(flag, word)

    def saw_frame(self, node: int) -> None:
        """Another motor put a frame with ``node`` on the bus: flag a duplicate id."""
        if node == self.node_id:
            self.error_words.duplicate_id()

    # ------------------------------------------------------------------ stepping and timers

    def step(self, dt: float, now: float) -> None:
        """Advance by ``dt`` s to simulated time ``now``."""
        d = self.drive
        plant = d.plant
        if plant is not None:
            plant.sync(now)
        d.step(dt)
        self.time = now
        self.protections.heat_step(dt)
        if self.axis.state == AxisState.ENCODER_OFFSET_CALIBRATION:
            self.calibration.scan(now)
        self.protections.check(dt)
        if now >= self._wake:
            self._timers()

    def _timers(self) -> None:
        now = self.time + _EPS
        if now >= self._boot_end:
            self._boot_end = math.inf
            self._boot()
        if now >= self._hb_next and not self.in_dfu:
            self.emit(self.state_frame())
            self._hb_next = max(self._hb_next + self.settings.hb_period, now)
        timeout = self.settings.timeout
        if timeout and self.drive.active and now - self._last_rx >= timeout:
            self.settings.watchdog_damping = True
            self.error_words.raise_flags(AXIS0_ERROR, bh.WATCHDOG_ERROR)
        if now >= self.calibration.end and self.calibration.phase_done(self.time):
            self._enter_idle()
        self._rearm()

    def _rearm(self) -> None:
        wake = min(self._hb_next, self.calibration.end, self._boot_end)
        timeout = self.settings.timeout
        if timeout and self.drive.active:
            wake = min(wake, self._last_rx + timeout)
        self._wake = wake - _EPS

    def _timing_changed(self) -> None:
        """A new heartbeat period or CAN timeout: the next heartbeat is one period from now."""
        hb = self.settings.hb_period
        self._hb_next = self.time + hb if hb else math.inf
        self._rearm()

    # ------------------------------------------------------------------ commands

    def receive(self, msg: Command, reply: Reply) -> None:
        """Handle one host command addressed to this motor (or broadcast); answers go to ``reply``."""
        if self.in_dfu or self._boot_end != math.inf:
            return  # the firmware is not running, or still booting
        self._last_rx = self.time
        self.handlers.handle(msg, reply)

    def _system(self, op: SysCmd) -> None:
        action = _SYSTEM.get(op)
        if action is not None:
            action(self)

    def _init_config(self) -> None:
        self.params.init()
        self.settings.refresh()

    def _enter_dfu(self) -> None:
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
        self.handlers.preset = None
        self._hb_next = math.inf
        self._boot_end = self.time + self.firmware.boot_s
        self._rearm()

    def _request_state(self, value: float) -> None:
        """A write of axis0.requested_state."""
        self.axis.requested = int(value)
        if value == AxisState.CLOSED_LOOP_CONTROL:
            self._enter_closed_loop()
        elif value == AxisState.IDLE:
            self._enter_idle()
        elif value in CALIBRATION_STATES:
            self._enter_idle()
            if self.error_words.axis:
                return  # as for closed loop: refused while an error is set
            self.calibration.begin(int(value), self.time)
            self._rearm()

    # ------------------------------------------------------------------ states and errors

    def _boot(self) -> None:
        """Power-up or reboot."""
        p, s = self.params, self.settings
        p.boot()
        self.error_words.reset()
        self.handlers.preset = None
        s.watchdog_damping = False
        self.axis.requested = 0
        self.calibration.end = math.inf
        s.refresh()
        if not p.ram[AXIS0_CONFIG_EXTRA_SETTING_ENABLE_MULTI_CIRCLE]:
            s.zero_here()
        self.bitrate = int(p.ram[CAN_CONFIG_BAUD_RATE])
        self._last_rx = self.time
        self._hb_next = self.time + s.hb_period if s.hb_period else math.inf
        self._enter_idle()
        if p.ram[AXIS0_CONFIG_STARTUP_CLOSED_LOOP_CONTROL]:
            self._enter_closed_loop()
        self._rearm()

    def _axis_error(self) -> None:
        """axis0.error is set: the axis drops to IDLE."""
        if self.axis.state != AxisState.IDLE:
            self._enter_idle()

    def _enter_idle(self) -> None:
        self.calibration.cancel()
        self.axis.state = AxisState.IDLE
        self.drive.active = False
        self.protections.reset_stall()
        self.settings.refresh()

    def _enter_closed_loop(self) -> None:
        if self.error_words.axis or self.axis.state == AxisState.CLOSED_LOOP_CONTROL:
            return
        d = self.drive
        self.axis.state = AxisState.CLOSED_LOOP_CONTROL
        self.calibration.end = math.inf
        self.settings.watchdog_damping = False
        self._last_rx = self.time
        d.active = True
        d.integ = 0.0
        d.hold(d.pos)
        self.settings.refresh()
        self._recover_limits()
        self._rearm()

    def _recover_limits(self) -> None:
        """Outside the software limits in closed loop: move slowly to the nearest one."""
        d = self.drive
        if d.active and d.lim_on and not d.lmin <= d.pos <= d.lmax:
            target = d.lmax if d.pos > d.lmax else d.lmin
            d.hold(d.pos)
            d.trajectory(target, bh.LIMIT_RECOVERY_SPEED_RPM / 60.0, bh.LIMIT_RECOVERY_ACCEL / 60.0, False)

    def _clear_errors(self) -> None:
        sticky = self.error_words.clear()
        self.protections.reset_stall()
        if sticky:
            self.error_words.raise_flags(AXIS0_ENCODER_ERROR, sticky)

    def _set_zero(self) -> None:
        """set_zero_position: the current position reads 0 from now on; the sticky encoder errors may go."""
        self.error_words.sticky_cleared = True
        self.settings.zero_here()
        self._recover_limits()


def _discard(frame: Frame) -> None:
    """Default sink of unsolicited frames (a motor on no bus)."""


_SYSTEM: dict[SysCmd, Callable[[SimMotor], None]] = {
    SysCmd.ESTOP: lambda m: m.error_words.raise_flags(AXIS0_ERROR, AxisError.ESTOP_REQUESTED),
    SysCmd.CLEAR_ERRORS: SimMotor._clear_errors,
    SysCmd.SET_ZERO_POSITION: SimMotor._set_zero,
    SysCmd.SAVE_CONFIG: lambda m: m.params.save(),
    SysCmd.ERASE_CONFIG: lambda m: m.params.erase(),
    SysCmd.INIT_CONFIG: SimMotor._init_config,
    SysCmd.REBOOT: SimMotor._reboot,
    SysCmd.ENTER_DFU_MODE: SimMotor._enter_dfu,
}
"""What each system command does (after its answer); the starts act through the preset."""
