"""What both motor handles share: the id, command builders and the cached state (no I/O)."""

from __future__ import annotations

from ...protocol.ids import SysCmd
from ...protocol.messages import (
    PositionP,
    PositionQ,
    PositionT,
    PresetD,
    StartImpedance,
    SystemCommand,
    Torque,
    Velocity,
)
from ..driver.bus_driver import BusDriver
from ..engine.commands import (
    PositionMode,
    TorqueMode,
    VelocityMode,
    make_angle,
    make_impedance,
    make_speed,
    make_torque,
)
from ..engine.gate import MotionGate
from ..engine.session import BusSession
from ..engine.state import MotorState, StateCallback, Subscription

__all__ = ["MotorBase"]


class MotorBase:
    """What both motor handles share: the id, command builders and the cached state (no I/O)."""

    __slots__ = ("_core", "_gate", "_id", "_session")

    def __init__(self, core: BusDriver, id: int, gate: MotionGate | None = None) -> None:
        self._core = core
        self._session: BusSession = core.session
        self._id = id
        self._gate = MotionGate() if gate is None else gate

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
        """Call ``callback(state)`` (in the thread that took the frame) for each state frame of this motor."""
        return self._core.states.subscribe(callback, self._id)

    def _system(self, op: SysCmd) -> None:
        msg = SystemCommand(self._id, op)
        self._core.send(msg)
        self._gate.note_sent((msg,))

    def __repr__(self) -> str:
        return f"<{type(self).__name__} {self._id}>"
