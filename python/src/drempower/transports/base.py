"""The one small interface every transport implements."""

from __future__ import annotations

from abc import ABC, abstractmethod
from types import TracebackType

from ..protocol.ids import Frame

__all__ = ["Transport"]


class Transport(ABC):
    """Moves whole CAN frames between the host and a bus.

    ``send`` queues one frame for transmission and returns without waiting for
    any reply; ``recv`` returns the next received frame, or ``None`` when
    ``timeout`` seconds pass without one (``timeout=None`` waits until a frame
    arrives or the transport is closed, then returns ``None``). A transport may
    be used by one sending thread and one receiving thread at the same time.
    ``close`` is idempotent and makes a blocked ``recv`` return.
    """

    description: str = "transport"
    """What this transport is connected to, e.g. ``"python-can socketcan can0"``."""
    default_timeout: float | None = None
    """Reply timeout (s) a bus should use on this transport when none is given (None: the bus's own)."""
    in_order: bool = False
    """True when frames reach the bus one at a time in the order sent (a UART to one motor)."""
    wire_bitrate: int | None = None
    """The bus's bit rate (bit/s) when this transport knows it; used to time what is queued."""
    tx_latency: float = 0.005
    """Longest time (s) a sent frame may wait in drivers, adapters or servers before it competes for the bus."""

    def wait_sent(self, timeout: float) -> bool | None:
        """Wait until every frame sent so far is on the wire: True once confirmed, False when
        ``timeout`` s passed first, None when this transport cannot tell (the default)."""
        return None

    @abstractmethod
    def send(self, frame: Frame) -> None:
        """Transmit one frame."""

    @abstractmethod
    def recv(self, timeout: float | None = None) -> Frame | None:
        """Next received frame, or None after ``timeout`` seconds (or once closed)."""

    @abstractmethod
    def close(self) -> None:
        """Release the underlying device or socket."""

    def __enter__(self) -> Transport:
        return self

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.close()

    def __repr__(self) -> str:
        return f"<{type(self).__name__} {self.description}>"
