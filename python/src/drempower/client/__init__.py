"""The host client: drive DrEmpower motors from Python, threaded or with asyncio.

>>> import drempower
>>> with drempower.open_bus("sim", motors=[1, 2]) as bus:   # doctest: +SKIP
...     m = bus.motor(1)
...     m.set_angle(90, speed=10, param=20, mode=1)
...     m.wait_position_done(timeout=10)
"""

from typing import TYPE_CHECKING, Any

from ..errors import (
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
from .api.bus_sync import Bus, Motor, open_bus
from .engine.commands import (
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
from .engine.results import ErrorReport, GpioMode, MotorInfo
from .engine.session import DEFAULT_MOVE_TIMEOUT, DEFAULT_POLL_INTERVAL, DEFAULT_TIMEOUT, MOVE_TOLERANCE
from .engine.state import MotorState, Subscription

if TYPE_CHECKING:
    from .api.bus_async import AsyncBus, AsyncMotor, open_bus_async
    from .engine.backup import ConfigBackup, ParamRecord, RestoreReport

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
    "AsyncBus": "api.bus_async",
    "AsyncMotor": "api.bus_async",
    "open_bus_async": "api.bus_async",
    "ConfigBackup": "engine.backup",
    "ParamRecord": "engine.backup",
    "RestoreReport": "engine.backup",
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
