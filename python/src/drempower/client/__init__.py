"""The host client: drive DrEmpower motors from Python, threaded or with asyncio.

>>> import drempower
>>> with drempower.open_bus("sim", motors=[1, 2]) as bus:   # doctest: +SKIP
...     m = bus.motor(1)
...     m.set_angle(90, speed=10, param=20, mode=1)
...     m.wait_position_done(timeout=10)
"""

from typing import TYPE_CHECKING

from .._lazy import lazy_names
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

if TYPE_CHECKING:
    from .api.bus_async import AsyncBus, AsyncMotor, open_bus_async
    from .api.bus_sync import Bus, Motor, open_bus
    from .engine.backup import ConfigBackup, ParamRecord, RestoreReport
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

_HOMES = {  # where each public name lives: imported on first use
    "api.bus_async": ("AsyncBus", "AsyncMotor", "open_bus_async"),
    "api.bus_sync": ("Bus", "Motor", "open_bus"),
    "engine.backup": ("ConfigBackup", "ParamRecord", "RestoreReport"),
    "engine.commands": (
        "AxisMode",
        "PositionMode",
        "TorqueMode",
        "TrajMode",
        "VelocityMode",
        "make_angle",
        "make_angles",
        "make_impedance",
        "make_impedances",
        "make_speed",
        "make_speeds",
        "make_torque",
        "make_torques",
        "q_move_time",
    ),
    "engine.results": ("ErrorReport", "GpioMode", "MotorInfo"),
    "engine.session": ("DEFAULT_MOVE_TIMEOUT", "DEFAULT_POLL_INTERVAL", "DEFAULT_TIMEOUT", "MOVE_TOLERANCE"),
    "engine.state": ("MotorState", "Subscription"),
}
__getattr__ = lazy_names(__name__, _HOMES)
