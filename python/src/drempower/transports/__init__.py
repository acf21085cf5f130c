"""Transports: python-can, the vendor USB-CAN adapter (0xAA), a motor's UART (11-byte), the simulator."""

from .base import Transport
from .capabilities import Capabilities
from .errors import TransportError
from .factory import open_transport

__all__ = ["Capabilities", "Transport", "TransportError", "open_transport"]
