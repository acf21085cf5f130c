"""Errors raised by transports."""

from __future__ import annotations

from ..errors import DrEmpowerError

__all__ = ["TransportError"]


class TransportError(DrEmpowerError, OSError):
    """A bus that cannot be opened, or a device that failed while in use.

    The message says what was tried (interface, channel or serial port) and why
    it failed.
    """
