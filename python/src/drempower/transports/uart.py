"""A single G-series motor's UART: 11-byte frames over a serial port."""

from __future__ import annotations

from typing import Any

from ..protocol.framing import Uart11Decoder, encode_uart11
from ..protocol.ids import Frame
from .serialport import SerialFrameTransport

__all__ = ["UartTransport"]


def _encode(frame: Frame) -> bytes:
    return encode_uart11(frame[0], frame[1])


class UartTransport(SerialFrameTransport):
    """The UART of one G-series motor (or the adapter in TTL->CAN mode) on ``port``.

    ``baudrate`` is the motor's UART rate (115200 by default). Only the motor
    wired to the port answers. Other keyword arguments go to
    :func:`serial.serial_for_url` (``write_timeout`` bounds a send, 1 s by default).
    """

    in_order = True
    """A serial line carries the frames one after another, in the order sent, to one motor."""

    def __init__(self, port: str, baudrate: int = 115200, **serial_kwargs: Any) -> None:
        super().__init__(port, baudrate, Uart11Decoder(), _encode, "motor UART (11-byte frames)", **serial_kwargs)
