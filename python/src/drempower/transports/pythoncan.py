"""Transport over python-can: any interface and channel python-can supports."""

from __future__ import annotations

import threading
import time
from typing import Any

import can
from can.interfaces import VALID_INTERFACES

from ..protocol.ids import Frame
from .base import Transport
from .errors import TransportError

__all__ = ["PythonCanTransport"]

_SLICE = 0.1
"""Longest single wait inside ``recv`` (s), so that ``close`` is noticed promptly."""


class PythonCanTransport(Transport):
    """A python-can bus carrying DrEmpower frames.

    ``interface``, ``channel`` and ``bitrate`` follow python-can; any that are
    None are left out, so python-can's own configuration (its config file and
    ``CAN_INTERFACE``/``CAN_CHANNEL``/``CAN_BITRATE`` environment variables)
    fills them in. Other keyword arguments go to :class:`can.Bus` unchanged.
    Error frames are skipped.
    """

    def __init__(
        self,
        interface: str | None = None,
        channel: str | int | None = None,
        bitrate: int | None = None,
        **kwargs: Any,
    ) -> None:
        if bitrate is not None:
            kwargs["bitrate"] = bitrate
        given = {"interface": interface, "channel": channel, "bitrate": bitrate}
        tried = ", ".join(f"{k}={v!r}" for k, v in given.items() if v is not None) or "python-can's configuration"
        try:
            self._bus = can.Bus(channel=channel, interface=interface, **kwargs)
        except can.CanInterfaceNotImplementedError as exc:
            raise TransportError(
                f"cannot open python-can bus ({tried}): {exc}. Interfaces python-can knows: "
                f"{', '.join(sorted(VALID_INTERFACES))}; drempower adds 'adapter', 'serial', 'uart' and 'sim'"
            ) from exc
        except (can.CanError, ImportError, OSError, ValueError, TypeError) as exc:
            raise TransportError(f"cannot open python-can bus ({tried}): {exc}") from exc
        self._closing = threading.Event()
        self._recv_lock = threading.Lock()
        self.description = f"python-can {self._bus.channel_info}"

    @property
    def bus(self) -> can.BusABC:
        """The underlying python-can bus."""
        return self._bus

    def send(self, frame: Frame) -> None:
        msg = can.Message(
            arbitration_id=frame[0],
            data=frame[1],
            is_extended_id=frame[2],
            is_remote_frame=frame[3],
        )
        try:
            self._bus.send(msg)
        except (can.CanError, OSError, ValueError) as exc:
            raise TransportError(f"{self.description}: send failed: {exc}") from exc

    def recv(self, timeout: float | None = None) -> Frame | None:
        deadline = None if timeout is None else time.monotonic() + timeout
        recv = self._bus.recv
        while not self._closing.is_set():
            wait = _SLICE if deadline is None else min(_SLICE, max(0.0, deadline - time.monotonic()))
            try:
                with self._recv_lock:
                    if self._closing.is_set():
                        return None
                    msg = recv(wait)
            except (can.CanError, OSError, ValueError, AttributeError, TypeError) as exc:
                if self._closing.is_set():
                    return None
                raise TransportError(f"{self.description}: receive failed: {exc}") from exc
            if msg is not None:
                if msg.is_error_frame:
                    continue
                return Frame(msg.arbitration_id, bytes(msg.data), msg.is_extended_id, msg.is_remote_frame)
            if deadline is not None and time.monotonic() >= deadline:
                return None
        return None

    def close(self) -> None:
        if self._closing.is_set():
            return
        self._closing.set()
        with self._recv_lock:  # let a receive in progress end first: some interfaces fail loudly otherwise
            self._bus.shutdown()
