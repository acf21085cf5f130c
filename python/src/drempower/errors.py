"""Exception hierarchy shared by every layer of drempower."""

from __future__ import annotations

__all__ = [
    "DrEmpowerError",
    "ProtocolError",
    "ValidationError",
    "FieldRangeError",
]


class DrEmpowerError(Exception):
    """Base class of every error raised by drempower."""


class ProtocolError(DrEmpowerError, ValueError):
    """A frame or byte stream that does not follow the DrEmpower protocol."""


class ValidationError(DrEmpowerError, ValueError):
    """A value that cannot be put on the wire (bad type, NaN, unknown name...)."""


class FieldRangeError(ValidationError):
    """A numeric field outside the range its wire encoding can hold.

    ``field`` names the field, ``value`` is what was given and ``low``/``high``
    bound the allowed range (inclusive).
    """

    def __init__(self, field: str, value: object, low: float, high: float, detail: str = "") -> None:
        self.field = field
        self.value = value
        self.low = low
        self.high = high
        extra = f" ({detail})" if detail else ""
        super().__init__(f"{field}={value!r} is out of range: allowed {low:g}..{high:g}{extra}")
