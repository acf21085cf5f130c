"""drempower: the open toolkit for DrEmpower (Daran Robot) servo joint motors."""

from typing import TYPE_CHECKING, Any

from ._lazy import lazy_names
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
    from .client import (
        AsyncBus,
        AsyncMotor,
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
        open_bus_async,
    )
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

_HOMES = {
    "client": (
        "AsyncBus",
        "AsyncMotor",
        "Bus",
        "BusClosedError",
        "BusStoppedError",
        "Motor",
        "MotorFaultError",
        "MotorState",
        "MoveError",
        "MoveFaultError",
        "MoveTimeoutError",
        "PositionMode",
        "open_bus",
        "open_bus_async",
    ),
    "robot": ("AsyncRobot", "Robot", "open_robot", "open_robot_async"),
}
_PACKAGES = frozenset(
    ("actions", "bridge", "cli", "client", "compat", "dash", "motion", "protocol", "records", "robot")
) | {"sim", "transports"}
_names = lazy_names(__name__, _HOMES)


def __getattr__(name: str) -> Any:
    """The client, the robot layer and the package's parts, imported on first use: ``import drempower``
    costs next to nothing, and a command line tool imports only what its command needs."""
    if name in _PACKAGES:
        import importlib

        return importlib.import_module(f"{__name__}.{name}")
    return _names(name)
