"""How a simulated motor handles host commands: one handler for each kind of command, found in one table.

Control frames (T, Q, P, V, C), the preset and its start, parameter reads and writes, the fast read;
system commands (0x08) are answered here and acted on by the motor (``system``).
"""

from __future__ import annotations

from collections.abc import Callable

from ..errors import DrEmpowerError
from ..protocol.addresses import (
    AXIS0_CONTROLLER_CONFIG_INPUT_FILTER_BANDWIDTH,
    AXIS0_CONTROLLER_ERROR,
    AXIS0_OUTPUT_SHAFT_TORQUE_RAMP_RATE,
    AXIS0_OUTPUT_SHAFT_TRAP_TRAJ_ACCEL_LIMIT,
    AXIS0_OUTPUT_SHAFT_TRAP_TRAJ_DECEL_LIMIT,
    AXIS0_OUTPUT_SHAFT_TRAP_TRAJ_VEL_LIMIT,
    AXIS0_OUTPUT_SHAFT_VEL_RAMP_RATE,
    AXIS0_TRAP_TRAJ_CONFIG_TRAJ_MODE,
)
from ..protocol.enums import TorqueMode, TrajMode, VelocityMode
from ..protocol.ids import Frame, StartKind, SysCmd
from ..protocol.messages import (
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
    SystemCommand,
    Torque,
    Velocity,
    WriteParam,
)
from ..protocol.parameters import parameter
from . import behaviour as bh
from .drive import POSITION, TAU
from .error_words import ErrorWords
from .param_writes import ParamWriter
from .readings import Readings

__all__ = ["CommandHandlers", "Reply"]

Reply = Callable[[Frame], None]
"""Where a motor puts the frames it answers with."""

_FILTER_MAX = 250.0
"""Largest input-filter bandwidth (1/s): a quarter of the 1 kHz loop rate, as on ODrive."""


class CommandHandlers:
    """The command handlers of one motor, and its pending preset.

    Reads go through ``readings``, writes through ``writer``, errors into ``errors``; ``system``
    acts on a system command (after its answer).
    """

    __slots__ = ("_system", "drive", "errors", "preset", "readings", "settings", "writer")

    def __init__(
        self, readings: Readings, writer: ParamWriter, errors: ErrorWords, system: Callable[[SysCmd], None]
    ) -> None:
        self.readings, self.writer, self.errors = readings, writer, errors
        self.settings = readings.settings
        self.drive = readings.drive
        self._system = system
        self.preset: Preset | None = None
        """The pending preset (0x0C), waiting for a start."""

    def handle(self, msg: Command, reply: Reply) -> None:
        """Act on one host command; answers go to ``reply``."""
        _HANDLERS[type(msg)](self, msg, reply)

    def _answer_state(self, reply: Reply, cmd: int) -> None:
        if self.settings.reply_state and self.readings.firmware.replies_to(cmd):
            reply(self.readings.state_frame(cmd))

    def _on_t(self, msg: PositionT, reply: Reply) -> None:
        if self.drive.active:
            self._track(msg.position, msg.bandwidth)
        self._answer_state(reply, 0x19)

    def _track(self, deg: float, bandwidth: float) -> None:
        bw = abs(bandwidth)
        self.readings.params.ram[AXIS0_CONTROLLER_CONFIG_INPUT_FILTER_BANDWIDTH] = bw
        self.drive.filtered(self.settings.turns(deg), min(bw, _FILTER_MAX))

    def _on_q(self, msg: PositionQ, reply: Reply) -> None:
        if self.drive.active:
            self._move(msg.position, abs(msg.speed), abs(msg.accel))
        self._answer_state(reply, 0x1A)

    def _move(self, deg: float, speed: float, accel: float) -> None:
        """Q move to ``deg`` at ``speed`` r/min and ``accel`` (r/min)/s."""
        if speed == 0.0:
            self.errors.raise_flags(AXIS0_CONTROLLER_ERROR, bh.Q_ZERO_SPEED_ERROR)
            return
        w = self.writer
        w.set_output(AXIS0_OUTPUT_SHAFT_TRAP_TRAJ_VEL_LIMIT, speed)
        w.set_output(AXIS0_OUTPUT_SHAFT_TRAP_TRAJ_ACCEL_LIMIT, accel)
        w.set_output(AXIS0_OUTPUT_SHAFT_TRAP_TRAJ_DECEL_LIMIT, accel)
        target = self.settings.turns(deg)
        if accel == 0.0:
            self.drive.hold(target)
            return
        vmax = min(speed / 60.0, self.drive.vlim)
        self.drive.trajectory(target, vmax, accel / 60.0, self._s_curve())

    def _s_curve(self) -> bool:
        return bool(self.readings.params.ram[AXIS0_TRAP_TRAJ_CONFIG_TRAJ_MODE] == TrajMode.S_CURVE)

    def _timed_move(self, deg: float, seconds: float, accel: float) -> None:
        """Q target-time move: reach ``deg`` in ``seconds`` with ``accel`` (r/min)/s."""
        if seconds <= 0.0 and self.readings.firmware.q_time_zero == "ignore":
            return  # this firmware does nothing with a time of 0 (sim.firmware)
        limit = float(self.readings.read(AXIS0_OUTPUT_SHAFT_TRAP_TRAJ_ACCEL_LIMIT) or 0.0)
        self.writer.set_output(AXIS0_OUTPUT_SHAFT_TRAP_TRAJ_ACCEL_LIMIT, accel)
        self.writer.set_output(AXIS0_OUTPUT_SHAFT_TRAP_TRAJ_DECEL_LIMIT, accel)
        target = self.settings.turns(deg)
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
        vel = self.readings.read(AXIS0_OUTPUT_SHAFT_TRAP_TRAJ_VEL_LIMIT)
        vmax = min(float(vel) / 60.0, d.vlim) if vel else d.vlim
        a = accel / 60.0
        if not (vmax > 0.0 and a > 0.0):
            d.hold(target)
            return
        d.trajectory(target, vmax, a, s_curve)

    def _on_p(self, msg: PositionP, reply: Reply) -> None:
        if self.drive.active:
            self.drive.position(self.settings.turns(msg.position), msg.speed_ff / 60.0, msg.torque_ff)
        self._answer_state(reply, 0x1B)

    def _on_v(self, msg: Velocity, reply: Reply) -> None:
        if self.drive.active:
            self._velocity(msg.speed, msg.param, msg.mode)
        self._answer_state(reply, 0x1C)

    def _velocity(self, speed: float, param: float, mode: VelocityMode) -> None:
        if mode == VelocityMode.PASSTHROUGH:
            self.drive.velocity(speed / 60.0, param, None)
        else:
            self.writer.set_output(AXIS0_OUTPUT_SHAFT_VEL_RAMP_RATE, abs(param))
            self.drive.velocity(speed / 60.0, 0.0, abs(param) / 60.0)

    def _on_c(self, msg: Torque, reply: Reply) -> None:
        if self.drive.active:
            self._torque(msg.torque, msg.param, msg.mode)
        self._answer_state(reply, 0x1D)

    def _torque(self, torque: float, param: float, mode: TorqueMode) -> None:
        if mode == TorqueMode.DIRECT:
            self.drive.torque_command(torque, None)
        else:
            self.writer.set_output(AXIS0_OUTPUT_SHAFT_TORQUE_RAMP_RATE, abs(param))
            self.drive.torque_command(torque, abs(param))

    def _on_preset(self, msg: Preset, reply: Reply) -> None:
        self.preset = msg
        self._answer_state(reply, 0x0C)

    def _on_start(self, msg: Start | StartImpedance, reply: Reply) -> None:
        p, self.preset = self.preset, None
        if p is None or not self.drive.active:
            return
        kind = msg.kind
        target = p.p1 + self.readings.position if isinstance(msg, Start) and msg.relative else p.p1
        if kind is StartKind.T:
            self._track(target, p.p3)
        elif kind is StartKind.Q:
            self._timed_move(target, p.p2, abs(p.p3))
        elif kind is StartKind.P:
            self.drive.position(self.settings.turns(target), p.p2 / 60.0, p.p3)
        elif isinstance(msg, StartImpedance):
            self.drive.impedance(self.settings.turns(target), p.p2 / 60.0, p.p3, msg.kp * TAU, msg.kd * TAU)
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
        self._system(op)

    def _on_read(self, msg: ReadParam, reply: Reply) -> None:
        value = self.readings.read(msg.address)
        if value is not None:
            node = self.readings.node_id
            reply(ParamValue(node, msg.address, msg.dtype, bh.convert_value(value, msg.dtype)).encode())

    def _on_fast_read(self, msg: FastRead, reply: Reply) -> None:
        if self.readings.firmware.fast_read:
            reply(self.readings.state_frame(0x1E))

    def _on_write(self, msg: WriteParam, reply: Reply) -> None:
        try:
            p = parameter(msg.address)
        except DrEmpowerError:
            return
        self.writer.write(p, bh.convert_value(msg.value, p.dtype))
        self._answer_state(reply, 0x1F)


_HANDLERS: dict[type, Callable[[CommandHandlers, object, Reply], None]] = {
    PositionT: CommandHandlers._on_t,  # type: ignore[dict-item]
    PositionQ: CommandHandlers._on_q,  # type: ignore[dict-item]
    PositionP: CommandHandlers._on_p,  # type: ignore[dict-item]
    Velocity: CommandHandlers._on_v,  # type: ignore[dict-item]
    Torque: CommandHandlers._on_c,  # type: ignore[dict-item]
    Preset: CommandHandlers._on_preset,  # type: ignore[dict-item]
    Start: CommandHandlers._on_start,  # type: ignore[dict-item]
    StartImpedance: CommandHandlers._on_start,  # type: ignore[dict-item]
    SystemCommand: CommandHandlers._on_system,  # type: ignore[dict-item]
    ReadParam: CommandHandlers._on_read,  # type: ignore[dict-item]
    FastRead: CommandHandlers._on_fast_read,  # type: ignore[dict-item]
    WriteParam: CommandHandlers._on_write,  # type: ignore[dict-item]
}
"""The handler of each kind of command."""
