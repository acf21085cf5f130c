"""The USB ids of the vendor's USB-CAN adapters, by generation (for finding them and for udev rules)."""

from __future__ import annotations

CH340 = ("1a86", "7523")
"""USB vendor and product id of the CH340 generation (ttyUSB)."""
CDC = ("0483", "5740")
"""USB vendor and product id of the CDC generation (ttyACM): the STM32 virtual COM port ids."""
