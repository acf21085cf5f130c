"""drempower: the open toolkit for DrEmpower (Daran Robot) servo joint motors."""

from typing import TYPE_CHECKING, Any

from .client import (
    Bus,
    BusClosedError,
    BusStoppedError,
    Motor,
    MotorFaultError,
    MotorState,
    MoveError,
    MoveFaultError,
    MoveTimeoutError,
    PositionMode,
    open_bus,
)
from .errors import (
    ConfigError,
    DrEmpowerError,
    FieldRangeError,
    IdTakenError,
    MotionParameterError,
    MotorIdleError,
    NoMotorError,
    ProtocolError,
    SoftLimitError,
    TransportError,
    ValidationError,
    VerifyError,
)
from .errors import TimeoutError as TimeoutError

if TYPE_CHECKING:
    from .client import AsyncBus, AsyncMotor, open_bus_async
    from .robot import AsyncRobot, Robot, open_robot, open_robot_async

__version__ = "0.1.0"

__all__ = [
    "AsyncBus",
    "AsyncMotor",
    "Bus",
    "BusClosedError",
    "BusStoppedError",
    "ConfigError",
    "DrEmpowerError",
    "FieldRangeError",
    "IdTakenError",
    "Motor",
    "MotorFaultError",
    "MotorIdleError",
    "MotorState",
    "MoveError",
    "MoveFaultError",
    "MoveTimeoutError",
    "NoMotorError",
    "PositionMode",
    "ProtocolError",
    "MotionParameterError",
    "SoftLimitError",
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
_ASYNC = frozenset(("AsyncBus", "AsyncMotor", "open_bus_async"))


def __getattr__(name: str) -> Any:
    """The robot layer and the asyncio front end are imported on first use (neither is needed
    to drive one bus from threads, and asyncio is slow to import)."""
    if name in _ROBOT:
        from . import robot

        return getattr(robot, name)
    if name in _ASYNC:
        from . import client

        return getattr(client, name)
    raise AttributeError(f"module 'drempower' has no attribute {name!r}")
