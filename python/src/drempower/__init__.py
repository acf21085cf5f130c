"""drempower: the open toolkit for DrEmpower (Daran Robot) servo joint motors."""

from .errors import DrEmpowerError, FieldRangeError, ProtocolError, ValidationError

__version__ = "0.1.0"

__all__ = ["DrEmpowerError", "FieldRangeError", "ProtocolError", "ValidationError", "__version__"]
