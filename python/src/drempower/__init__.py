"""drempower: the open toolkit for DrEmpower (Daran Robot) servo joint motors."""

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
from .client.errors import TimeoutError as TimeoutError
from .errors import DrEmpowerError, FieldRangeError, ProtocolError, ValidationError
from .transports.errors import TransportError

__version__ = "0.1.0"

__all__ = [
    "AsyncBus",
    "AsyncMotor",
    "Bus",
    "BusClosedError",
    "DrEmpowerError",
    "FieldRangeError",
    "Motor",
    "MotorFaultError",
    "MotorState",
    "MoveError",
    "MoveFaultError",
    "MoveTimeoutError",
    "PositionMode",
    "ProtocolError",
    "TransportError",
    "ValidationError",
    "__version__",
    "open_bus",
    "open_bus_async",
]
