"""drempower: the open toolkit for DrEmpower (Daran Robot) servo joint motors."""

from typing import TYPE_CHECKING, Any

from .client import (
    AsyncBus,
    AsyncMotor,
    Bus,
    BusClosedError,
    Motor,
    MotorFaultError,
    MotorState,
    MoveError,
    MoveFaultError,
    MoveTimeoutError,
    PositionMode,
    open_bus,
    open_bus_async,
)
from .errors import (
    ConfigError,
    DrEmpowerError,
    FieldRangeError,
    IdTakenError,
    NoMotorError,
    ProtocolError,
    TransportError,
    ValidationError,
    VerifyError,
)
from .errors import TimeoutError as TimeoutError

if TYPE_CHECKING:
    from .robot import AsyncRobot, Robot, open_robot, open_robot_async

__version__ = "0.1.0"

__all__ = [
    "AsyncBus",
    "AsyncMotor",
    "Bus",
    "BusClosedError",
    "ConfigError",
    "DrEmpowerError",
    "FieldRangeError",
    "IdTakenError",
    "Motor",
    "MotorFaultError",
    "MotorState",
    "MoveError",
    "MoveFaultError",
    "MoveTimeoutError",
    "NoMotorError",
    "PositionMode",
    "ProtocolError",
    "TransportError",
    "ValidationError",
    "VerifyError",
    "__version__",
    "open_bus",
    "open_bus_async",
    "open_robot",
    "open_robot_async",
    "Robot",
    "AsyncRobot",
]

_ROBOT = frozenset(("open_robot", "open_robot_async", "Robot", "AsyncRobot"))


def __getattr__(name: str) -> Any:
    """The robot layer is imported on first use (it is not needed to drive one bus)."""
    if name in _ROBOT:
        from . import robot

        return getattr(robot, name)
    raise AttributeError(f"module 'drempower' has no attribute {name!r}")
