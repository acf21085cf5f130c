"""Transports: python-can, the vendor USB-CAN adapter (0xAA), a motor's UART (11-byte), the simulator."""

from .base import Transport

__all__ = ["Transport"]
