"""Shared machinery of the serial-port transports (vendor adapter, motor UART)."""

from __future__ import annotations

import threading
import time
from collections import deque
from collections.abc import Callable
from typing import Any, Protocol

import serial

from ..protocol.ids import Frame
from .base import Transport
from .errors import TransportError

__all__ = ["SerialFrameTransport", "StreamDecoder"]

READ_TIMEOUT = 0.02
"""Timeout of one blocking read of the port (s); a partial frame older than this is dropped."""
WRITE_TIMEOUT = 1.0
"""A write that cannot complete in this time (s) fails instead of hanging."""


class StreamDecoder(Protocol):
    """What the framings' incremental decoders provide."""

    @property
    def pending(self) -> int: ...

    def feed(self, chunk: bytes) -> list[Frame]: ...

    def flush(self) -> int: ...


class SerialFrameTransport(Transport):
    """Frames over a serial port (pyserial; URLs such as ``loop://`` work).

    Reads block on the port with a short timeout and take everything that has
    arrived, so a frame costs one or two system calls and no CPU is spent
    waiting. A read that times out with part of a frame buffered drops that
    partial frame (the line went quiet mid-frame: it was garbage or truncated).
    """

    def __init__(
        self,
        port: str,
        baudrate: int,
        decoder: StreamDecoder,
        encode: Callable[[Frame], bytes],
        what: str,
        **serial_kwargs: Any,
    ) -> None:
        try:
            self._ser = serial.serial_for_url(
                port, baudrate=baudrate, timeout=READ_TIMEOUT, write_timeout=WRITE_TIMEOUT, **serial_kwargs
            )
        except (serial.SerialException, OSError, ValueError, TypeError) as exc:
            raise TransportError(f"cannot open {what} on serial port {port!r}: {exc}") from exc
        self._decoder = decoder
        self._encode = encode
        self._frames: deque[Frame] = deque()
        self._wlock = threading.Lock()
        self._closing = threading.Event()
        self.description = f"{what} on {port} at {baudrate} Bd"

    @property
    def decoder(self) -> StreamDecoder:
        """The stream decoder (its ``dropped`` count tells how much garbage was skipped)."""
        return self._decoder

    def send(self, frame: Frame) -> None:
        data = self._encode(frame)
        with self._wlock:
            try:
                self._ser.write(data)
            except (serial.SerialException, OSError, ValueError) as exc:
                raise TransportError(f"{self.description}: write failed: {exc}") from exc

    def recv(self, timeout: float | None = None) -> Frame | None:
        frames = self._frames
        if frames:
            return frames.popleft()
        deadline = None if timeout is None else time.monotonic() + timeout
        ser = self._ser
        decoder = self._decoder
        while not self._closing.is_set():
            try:
                chunk = ser.read(ser.in_waiting or 1)
            except (serial.SerialException, OSError, ValueError, TypeError, AttributeError) as exc:
                if self._closing.is_set():
                    return None
                raise TransportError(f"{self.description}: read failed: {exc}") from exc
            if chunk:
                got = decoder.feed(chunk)
                if got:
                    frames.extend(got)
                    return frames.popleft()
            elif decoder.pending:
                decoder.flush()
            if deadline is not None and time.monotonic() >= deadline:
                return None
        return None

    def close(self) -> None:
        if self._closing.is_set():
            return
        self._closing.set()
        cancel = getattr(self._ser, "cancel_read", None)
        if cancel is not None:
            try:
                cancel()
            except (serial.SerialException, OSError):
                pass
        self._ser.close()
