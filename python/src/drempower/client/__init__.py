"""The host client: drive DrEmpower motors from Python, threaded or with asyncio.

>>> import drempower
>>> with drempower.open_bus("sim", motors=[1, 2]) as bus:   # doctest: +SKIP
...     m = bus.motor(1)
...     m.set_angle(90, speed=10, param=20, mode=1)
...     m.wait_position_done(timeout=10)
"""

from typing import TYPE_CHECKING, Any

from .bus import DEFAULT_MOVE_TIMEOUT, DEFAULT_POLL_INTERVAL, Bus, open_bus
from .commands import (
    AxisMode,
    PositionMode,
    TorqueMode,
    TrajMode,
    VelocityMode,
    make_angle,
    make_angles,
    make_impedance,
    make_impedances,
    make_speed,
    make_speeds,
    make_torque,
    make_torques,
    q_move_time,
)
from .errors import (
    BusClosedError,
    BusStoppedError,
    IdTakenError,
    MotorFaultError,
    MoveError,
    MoveFaultError,
    MoveTimeoutError,
    NoMotorError,
    TimeoutError,
    VerifyError,
)
from .motor import Motor
from .results import ErrorReport, GpioMode, MotorInfo
from .session import DEFAULT_TIMEOUT, MOVE_TOLERANCE
from .state import MotorState, Subscription

if TYPE_CHECKING:
    from .aio import AsyncBus, AsyncMotor, open_bus_async
    from .backup import ConfigBackup, ParamRecord, RestoreReport

__all__ = [
    "AsyncBus",
    "AsyncMotor",
    "AxisMode",
    "Bus",
    "BusClosedError",
    "BusStoppedError",
    "ConfigBackup",
    "DEFAULT_MOVE_TIMEOUT",
    "DEFAULT_POLL_INTERVAL",
    "DEFAULT_TIMEOUT",
    "ErrorReport",
    "GpioMode",
    "IdTakenError",
    "Motor",
    "MotorFaultError",
    "MotorInfo",
    "MOVE_TOLERANCE",
    "MoveError",
    "MoveFaultError",
    "MoveTimeoutError",
    "NoMotorError",
    "MotorState",
    "ParamRecord",
    "PositionMode",
    "RestoreReport",
    "Subscription",
    "TimeoutError",
    "TorqueMode",
    "TrajMode",
    "VelocityMode",
    "VerifyError",
    "make_angle",
    "make_angles",
    "make_impedance",
    "make_speed",
    "make_speeds",
    "make_torque",
    "make_torques",
    "make_impedances",
    "open_bus",
    "open_bus_async",
    "q_move_time",
]

_LAZY = {
    "AsyncBus": "aio",
    "AsyncMotor": "aio",
    "open_bus_async": "aio",
    "ConfigBackup": "backup",
    "ParamRecord": "backup",
    "RestoreReport": "backup",
}


def __getattr__(name: str) -> Any:
    """The asyncio front end and the configuration backup are imported on first use (asyncio is slow to import)."""
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    import importlib

    value = getattr(importlib.import_module(f"{__name__}.{module}"), name)
    globals()[name] = value
    return value
