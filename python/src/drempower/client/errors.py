"""Errors raised by the client (defined in :mod:`drempower.errors`; this path keeps working)."""

from __future__ import annotations

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
    motors,
)

__all__ = [
    "TimeoutError",
    "BusClosedError",
    "BusStoppedError",
    "MotorFaultError",
    "VerifyError",
    "MoveError",
    "MoveFaultError",
    "MoveTimeoutError",
    "IdTakenError",
    "NoMotorError",
    "motors",
]
