"""Errors raised by the client."""

from __future__ import annotations

import builtins
from collections.abc import Sequence

from ..errors import DrEmpowerError

__all__ = [
    "TimeoutError",
    "BusClosedError",
    "MotorFaultError",
    "VerifyError",
    "MoveError",
    "MoveFaultError",
    "MoveTimeoutError",
]


def motors(nodes: Sequence[int]) -> str:
    """``"motor 3"``, ``"motors 1, 2"``; node 0 reads "broadcast"."""
    names = ["broadcast" if n == 0 else str(n) for n in nodes]
    return ("motor " if len(names) == 1 else "motors ") + ", ".join(names)


class TimeoutError(DrEmpowerError, builtins.TimeoutError):
    """A motor did not answer a request in time.

    ``nodes`` lists the silent motors, ``request`` names what was asked and
    ``timeout`` is the time waited (s). Also an instance of the builtin
    :class:`TimeoutError`.
    """

    def __init__(self, nodes: Sequence[int], request: str, timeout: float, message: str | None = None) -> None:
        self.nodes = tuple(nodes)
        self.request = request
        self.timeout = timeout
        if message is None:
            message = f"{motors(nodes)}: no answer to {request} within {timeout:g} s"
        super().__init__(message)


class BusClosedError(DrEmpowerError):
    """The bus was closed, or its receive loop stopped because the device failed."""


class MotorFaultError(DrEmpowerError):
    """A motor reported an error (the E bit of its state) while a call waited on it.

    ``node`` is the motor, ``flags`` maps each error word that is set to its
    flag names (empty when the words could not be read).
    """

    def __init__(self, node: int, doing: str, flags: dict[str, list[str]]) -> None:
        self.node = node
        self.flags = flags
        named = "; ".join(f"{word}: {', '.join(names)}" for word, names in flags.items()) or "error words unread"
        super().__init__(f"motor {node} reported an error {doing} ({named})")


class VerifyError(DrEmpowerError):
    """A value read back after writing it differs from what was written (the write was lost or refused)."""


def _flags_text(flags: dict[str, list[str]]) -> str:
    return "; ".join(f"{word}: {', '.join(names)}" for word, names in flags.items()) or "no error flags"


class MoveError(DrEmpowerError):
    """A position move did not end at its target (angle limits, stall, estop, a fault or a timeout).

    ``node`` is the motor, ``target`` the commanded angle (deg), ``position`` the
    angle it reported last (deg, None when it never answered), ``flags`` its
    decoded error words (empty when none is set or they could not be read) and
    ``reason`` says what went wrong. :class:`MoveFaultError` (the motor
    reported an error) and :class:`MoveTimeoutError` (still moving when the wait
    ended) are the two kinds that are also :class:`MotorFaultError` and
    :class:`TimeoutError`.
    """

    def __init__(
        self,
        node: int,
        target: float | None,
        position: float | None,
        flags: dict[str, list[str]],
        reason: str,
    ) -> None:
        self.node = node
        self.target = target
        self.position = position
        self.flags = flags
        self.reason = reason
        goal = "unknown" if target is None else f"{target:.2f} deg"
        where = "unknown" if position is None else f"{position:.2f} deg"
        DrEmpowerError.__init__(self, f"motor {node}: {reason}: target {goal}, reached {where} ({_flags_text(flags)})")


class MoveFaultError(MoveError, MotorFaultError):
    """The motor reported an error (E bit) while a wait for its move was running."""

    def __init__(
        self, node: int, target: float | None, position: float | None, flags: dict[str, list[str]], reason: str
    ) -> None:
        MoveError.__init__(self, node, target, position, flags, reason)


class MoveTimeoutError(MoveError, TimeoutError):
    """The motor had not finished its move when the wait's ``timeout`` (s) ended."""

    def __init__(
        self,
        node: int,
        target: float | None,
        position: float | None,
        flags: dict[str, list[str]],
        reason: str,
        timeout: float,
        nodes: Sequence[int] = (),
    ) -> None:
        self.nodes = tuple(nodes) or (node,)
        self.request = "wait_position_done"
        self.timeout = timeout
        MoveError.__init__(self, node, target, position, flags, reason)
