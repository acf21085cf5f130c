"""Motor handles: the vendor library's functions as methods of one motor."""

from __future__ import annotations

import os
from typing import TYPE_CHECKING

from ..protocol.ids import SysCmd
from ..protocol.messages import (
    PositionP,
    PositionQ,
    PositionT,
    PresetD,
    StartImpedance,
    SystemCommand,
    Torque,
    Velocity,
)
from . import batch, ops
from .commands import (
    PositionMode,
    TorqueMode,
    TrajMode,
    VelocityMode,
    make_angle,
    make_impedance,
    make_speed,
    make_torque,
)
from .core import DEFAULT_MOVE_TIMEOUT, DEFAULT_POLL_INTERVAL, MOVE_TOLERANCE, BusCore
from .results import ErrorReport, GpioMode
from .state import MotorState, StateCallback, Subscription
from .timeouts import checks_times

if TYPE_CHECKING:
    from . import backup as _backup
    from .bus import Bus

__all__ = ["Motor", "MotorBase"]


class MotorBase:
    """What both motor handles share: the id, command builders and the cached state (no I/O)."""

    __slots__ = ("_core", "_id")

    def __init__(self, core: BusCore, id: int) -> None:
        self._core = core
        self._id = id

    @property
    def id(self) -> int:
        """The motor's node id (0 = broadcast)."""
        return self._id

    def make_angle(
        self, angle: float, speed: float = 0.0, param: float = 0.0, mode: int = PositionMode.T
    ) -> PositionT | PositionQ | PositionP:
        """The message :meth:`set_angle` sends (for :meth:`Bus.cycle` or your own sending)."""
        return make_angle(self._id, angle, speed, param, mode)

    def make_speed(self, speed: float, param: float = 0.0, mode: int = VelocityMode.PASSTHROUGH) -> Velocity:
        """The message :meth:`set_speed` sends."""
        return make_speed(self._id, speed, param, mode)

    def make_torque(self, torque: float, param: float = 0.0, mode: int = TorqueMode.DIRECT) -> Torque:
        """The message :meth:`set_torque` sends."""
        return make_torque(self._id, torque, param, mode)

    def make_impedance(
        self, pos: float, vel: float = 0.0, tff: float = 0.0, kp: float = 0.0, kd: float = 0.0
    ) -> tuple[PresetD, StartImpedance]:
        """The preset and start :meth:`impedance_control` sends."""
        return make_impedance(self._id, pos, vel, tff, kp, kd)

    @property
    def state(self) -> MotorState | None:
        """The latest state received from this motor in any way (no I/O), or None."""
        return self._core.states.get(self._id)

    def subscribe(self, callback: StateCallback) -> Subscription:
        """Call ``callback(state)`` (in the receive thread) for each state frame of this motor."""
        return self._core.states.subscribe(callback, self._id)

    def _system(self, op: SysCmd) -> None:
        self._core.send(SystemCommand(self._id, op))

    def __repr__(self) -> str:
        return f"<{type(self).__name__} {self._id}>"


@checks_times
class Motor(MotorBase):
    """One motor on a :class:`~drempower.client.bus.Bus` (get it with ``bus.motor(id)``).

    Method names and parameter meanings are the vendor library's, without the
    leading ``id_num``. Units: degrees, r/min, Nm, (r/min)/s, Nm/s, seconds.
    Commands return as soon as their frame is sent; queries wait for the reply
    (``timeout=`` s, default the bus's) and raise
    :class:`~drempower.client.errors.TimeoutError`. Invalid arguments raise
    :class:`~drempower.errors.ValidationError` before anything is sent.
    """

    __slots__ = ("_bus",)

    def __init__(self, bus: Bus, id: int) -> None:
        super().__init__(bus.core, id)
        self._bus = bus

    @property
    def bus(self) -> Bus:
        return self._bus

    # ------------------------------------------------------------------ motion

    def set_angle(self, angle: float, speed: float = 0.0, param: float = 0.0, mode: int = PositionMode.T) -> None:
        """Move to ``angle`` deg. mode 0 (T): ``param`` = filter bandwidth 0..300 1/s;
        mode 1 (Q): cruise ``speed`` r/min, accel ``param`` (r/min)/s; mode 2 (P):
        ``speed`` = speed FF r/min, ``param`` = torque FF Nm."""
        self._core.send(make_angle(self._id, angle, speed, param, mode))

    def step_angle(
        self,
        angle: float,
        speed: float = 0.0,
        param: float = 0.0,
        mode: int = PositionMode.T,
        *,
        timeout: float | None = None,
    ) -> float | None:
        """Move by ``angle`` deg from where the motor is (preset + relative start).

        The start goes to this motor only (bus option ``start``); returns the Q move time (s).
        """
        return self._bus.run(batch.move_angles(self._core, [self._id], [angle], speed, param, mode, True, timeout))

    def set_speed(self, speed: float, param: float = 0.0, mode: int = VelocityMode.PASSTHROUGH) -> None:
        """Run at ``speed`` r/min. mode 1: ``param`` = torque FF Nm; mode 2: ramp ``param`` (r/min)/s."""
        self._core.send(make_speed(self._id, speed, param, mode))

    def set_torque(self, torque: float, param: float = 0.0, mode: int = TorqueMode.DIRECT) -> None:
        """Apply ``torque`` Nm. mode 1: at once; mode 6: ramp at ``param`` Nm/s."""
        self._core.send(make_torque(self._id, torque, param, mode))

    def impedance_control(
        self, pos: float, vel: float = 0.0, tff: float = 0.0, kp: float = 0.0, kd: float = 0.0
    ) -> None:
        """Impedance control: ``tff + kp*(pos - P) + kd*(vel - V)``; pos deg, vel r/min, tff Nm,
        kp Nm/rad, kd Nm/(rad/s). The start goes to this motor only (bus option ``start``)."""
        preset, start = make_impedance(self._id, pos, vel, tff, kp, kd)
        self._core.send_batch([preset], start)

    def estop(self) -> None:
        """Emergency stop: the motor goes idle and ignores motion until clear_error + set_mode(2)."""
        self._core.estop([self._id])

    def position_done(
        self,
        timeout: float = DEFAULT_MOVE_TIMEOUT,
        *,
        poll_interval: float = DEFAULT_POLL_INTERVAL,
        tolerance: float = MOVE_TOLERANCE,
    ) -> MotorState:
        """Wait until the move is done (vendor name of :meth:`wait_position_done`)."""
        return self.wait_position_done(timeout, poll_interval=poll_interval, tolerance=tolerance)

    def wait_position_done(
        self,
        timeout: float = DEFAULT_MOVE_TIMEOUT,
        *,
        poll_interval: float = DEFAULT_POLL_INTERVAL,
        tolerance: float = MOVE_TOLERANCE,
    ) -> MotorState:
        """Wait until the motor has finished its move; returns the final state.

        The final position must be within ``tolerance`` deg of the target: raises
        MoveError on a miss (angle limits, stall, estop), MoveFaultError (a
        MotorFaultError, with the decoded error flags) as soon as the motor
        reports an error and MoveTimeoutError (a TimeoutError) after ``timeout`` s.
        """
        return self._bus.run(ops.wait_done(self._core, [self._id], timeout, poll_interval, tolerance=tolerance))[
            self._id
        ]

    def wait_state(self, timeout: float) -> MotorState:
        """Wait for the next state frame of this motor (heartbeat, reply...) without sending anything."""
        return self._bus.wait_state(self._id, timeout)

    # ------------------------------------------------------------------ settings

    def set_id(self, new_id: int, *, timeout: float | None = None) -> Motor:
        """Change the id to ``new_id`` (1..63), check the motor answers there, save; returns its new handle."""
        self._bus.run(ops.set_id(self._core, self._id, new_id, timeout))
        return self._bus.motor(new_id)

    def set_can_baud_rate(self, baud_rate: int, *, timeout: float | None = None) -> None:
        """Set the CAN bitrate (125000/250000/500000/1000000) and save; applies after a reboot."""
        self._bus.run(ops.set_can_baud_rate(self._id, baud_rate, timeout))

    def set_uart_baud_rate(self, baud_rate: int, *, timeout: float | None = None) -> None:
        """Set the UART rate (M series: 9600/19200/57600/115200) and save."""
        self._bus.run(ops.set_uart_baud_rate(self._id, baud_rate, timeout))

    def set_mode(self, mode: int = 2) -> None:
        """1 (AxisMode.IDLE): release the motor; 2 (AxisMode.CLOSED_LOOP): enable control."""
        self._core.send(ops.set_mode(self._id, mode))

    def set_zero_position(self) -> None:
        """Make the current output position 0 deg."""
        self._system(SysCmd.SET_ZERO_POSITION)

    def set_GPIO_mode(self, mode: str = "tx_rx", param: float = 115200, *, timeout: float | None = None) -> None:
        """Spare pins as UART (``"tx_rx"``, param = baud) or step/dir (param = pulses); saves and reboots."""
        self._bus.run(ops.set_gpio_mode(self._id, mode, param, timeout))

    def get_GPIO_mode(self, *, timeout: float | None = None) -> GpioMode:
        """What the spare pins do (M series)."""
        return self._bus.run(ops.get_gpio_mode(self._id, timeout))

    def set_angle_range(
        self, angle_min: float = -360.0, angle_max: float = 360.0, *, timeout: float | None = None
    ) -> None:
        """Enable software limits [angle_min, angle_max] deg and save; the motor must be inside them."""
        self._bus.run(ops.set_angle_range(self._id, angle_min, angle_max, timeout))

    def set_traj_mode(self, mode: int = TrajMode.TRAPEZOID, *, timeout: float | None = None) -> None:
        """Q-mode profile: 1 trapezoid, 2 S-curve (verified, remembered for set_angles; not saved)."""
        self._bus.run(ops.set_traj_mode(self._id, mode, timeout))

    def get_traj_mode(self, *, timeout: float | None = None) -> TrajMode:
        """The motor's Q-mode profile, read from it."""
        return self._bus.run(ops.get_traj_mode(self._core, self._id, timeout))

    def write_property(
        self,
        property: str | int,
        value: float,
        *,
        verify: bool = False,
        timeout: float | None = None,
        force: bool = False,
    ) -> None:
        """Write parameter ``property`` (name or address) in RAM; ``verify`` reads it back.

        A value outside the parameter's domain (``spec/parameters.csv``) raises
        :class:`~drempower.protocol.parameters.DomainError` naming parameter, value and
        domain, and nothing is sent; ``force=True`` writes one outside a soft domain
        (never outside a hard one, such as can_node_id 1..63, or the type's range).
        """
        self._bus.run(ops.write_property(self._id, property, value, verify, timeout, force))

    def read_property(self, property: str | int, *, timeout: float | None = None) -> int | float:
        """Read parameter ``property`` (name or address)."""
        return self._bus.run(ops.read_property(self._core, self._id, property, timeout))

    def enable_reply_state(self, on: bool = True, *, timeout: float | None = None) -> None:
        """Make the motor answer every control frame with its state (31214), verified."""
        self._bus.run(ops.write_property(self._id, 31214, int(on), True, timeout))

    # ------------------------------------------------------------------ queries

    def get_id(self, *, timeout: float | None = None) -> int:
        """The id the motor reports (useful with handle 0 and a single motor)."""
        return self._bus.run(ops.get_id(self._id, timeout))

    def get_state(self, *, timeout: float | None = None) -> MotorState:
        """Fresh state (angle, speed, torque, done, error) by fast read."""
        return self._bus.run(ops.get_state(self._id, timeout))

    def get_volcur(self, *, timeout: float | None = None) -> tuple[float, float]:
        """Supply voltage (V) and q-axis current (A)."""
        return self._bus.run(ops.get_volcur(self._id, timeout))

    def dump_error(self, *, timeout: float | None = None) -> ErrorReport:
        """The seven error words, decoded into flag names."""
        return self._bus.run(ops.dump_error(self._id, timeout))

    # ------------------------------------------------------------------ system

    def clear_error(self) -> None:
        """Clear the error flags; the motor stays idle until set_mode(2)."""
        self._system(SysCmd.CLEAR_ERRORS)

    def save_config(self) -> None:
        """Store the RAM configuration in flash."""
        self._system(SysCmd.SAVE_CONFIG)

    def reboot(self) -> None:
        """Software reset (unsaved writes are lost)."""
        self._system(SysCmd.REBOOT)

    def init_config(self) -> None:
        """Restore the default configuration (a calibration is needed afterwards)."""
        self._system(SysCmd.INIT_CONFIG)

    def erase_config(self) -> None:
        """Erase the stored configuration (calibration is lost)."""
        self._system(SysCmd.ERASE_CONFIG)

    # ------------------------------------------------------------------ configuration backup

    def backup(
        self, path: str | os.PathLike[str] | None = None, *, timeout: float | None = None
    ) -> _backup.ConfigBackup:
        """Read every parameter; also write them as JSON to ``path`` when given."""
        from . import backup as _backup

        result = self._bus.run(_backup.backup(self._id, timeout))
        if path is not None:
            result.save(path)
        return result

    def restore(
        self,
        source: _backup.ConfigBackup | str | os.PathLike[str],
        *,
        include_link: bool = False,
        save: bool = False,
        dry_run: bool = False,
        force: bool = False,
        timeout: float | None = None,
    ) -> _backup.RestoreReport:
        """Write a backup (object or JSON file) back; see :func:`drempower.client.backup.restore`."""
        from . import backup as _backup

        op = _backup.restore(
            self._core, self._id, source, timeout, include_link=include_link, save=save, dry_run=dry_run, force=force
        )
        return self._bus.run(op)
