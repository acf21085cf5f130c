"""drempower: the open toolkit for DrEmpower (Daran Robot) servo joint motors."""

from .client import (
    AsyncBus,
    AsyncMotor,
    Bus,
    BusClosedError,
    Motor,
    MotorFaultError,
    MotorState,
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
    "NoMotorError",
    "PositionMode",
    "ProtocolError",
    "TransportError",
    "ValidationError",
    "VerifyError",
    "__version__",
    "open_bus",
    "open_bus_async",
]
