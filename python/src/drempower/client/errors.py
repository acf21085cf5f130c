"""Errors raised by the client."""

from __future__ import annotations

import builtins
from collections.abc import Sequence

from ..errors import DrEmpowerError

__all__ = ["TimeoutError", "BusClosedError", "MotorFaultError", "VerifyError"]


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
