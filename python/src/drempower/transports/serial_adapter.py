"""The vendor USB-CAN adapter in standard mode: CAN frames in 0xAA framing over a serial port."""

from __future__ import annotations

from typing import Any

from ..protocol.framing import AADecoder, encode_aa
from .serialport import SerialFrameTransport

__all__ = ["AdapterTransport"]


class AdapterTransport(SerialFrameTransport):
    """The vendor USB-CAN adapter on ``port`` (e.g. ``/dev/ttyACM0``, ``COM5``, ``loop://``).

    The adapter is a USB CDC device, so ``baudrate`` (the serial rate) does not
    limit the speed; its CAN bitrate is set with the vendor's configuration
    tool. Other keyword arguments go to :func:`serial.serial_for_url`
    (``write_timeout`` bounds a send, 1 s by default).
    """

    def __init__(self, port: str, baudrate: int = 115200, **serial_kwargs: Any) -> None:
        super().__init__(port, baudrate, AADecoder(), encode_aa, "vendor USB-CAN adapter (0xAA)", **serial_kwargs)
