"""Transports: python-can, the vendor USB-CAN adapter (0xAA), a motor's UART (11-byte), the simulator."""

from .base import Transport
from .errors import TransportError
from .factory import open_transport

__all__ = ["Transport", "TransportError", "open_transport"]
