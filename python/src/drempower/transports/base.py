"""The one small interface every transport implements, and the receive deadline loop they share."""

from __future__ import annotations

import queue
import time
from abc import ABC, abstractmethod
from types import TracebackType
from typing import TYPE_CHECKING, Any, Protocol

from ..protocol.ids import Frame
from .capabilities import Capabilities

if TYPE_CHECKING:
    from collections.abc import Callable

__all__ = ["Capabilities", "Transport", "QueuedTransport", "RECV_SLICE", "VirtualClock"]

RECV_SLICE = 0.1
"""Default longest single wait inside :meth:`Transport.recv` (s), so that ``close`` is noticed promptly."""
_LONG = 3600.0
"""One wait of a transport whose ``close`` wakes its wait itself (s)."""


class VirtualClock(Protocol):
    """The simulated time of a transport with ``capabilities.virtual_clock``: read it, and let it pass."""

    def now(self) -> float:
        """The simulated time (s)."""
        ...

    def advance(self, seconds: float, until: Callable[[], bool] | None = None) -> bool:
        """Let up to ``seconds`` of simulated time pass, ending early once a frame is queued or ``until()`` is
        true; True when it ended early."""
        ...


class Transport(ABC):
    """Moves whole CAN frames between the host and a bus.

    ``send`` queues one frame for transmission and returns without waiting for
    any reply; ``recv`` returns the next received frame, or ``None`` when
    ``timeout`` seconds pass without one (``timeout=None`` waits until a frame
    arrives or the transport is closed, then returns ``None``). A transport may
    be used by one sending thread and one receiving thread at the same time.
    ``close`` is idempotent and makes a blocked ``recv`` return.

    A transport implements one wait, :meth:`wait_frame` (a frame, or None after
    at most the given time), and :meth:`is_closed`; ``recv`` runs the deadline
    loop over it in slices of :attr:`recv_slice`. (A transport may override
    ``recv`` itself instead.)
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
    unbounded_latency: bool = False
    """True when a sent frame may wait longer than any ``tx_latency`` before it competes for the bus (a TCP
    hop and a server's queue): a start then waits for the replies to reads sent after its presets."""
    virtual_clock: bool = False
    """True when the transport runs on its own simulated time (the in-process simulator with
    ``clock="virtual"``): it then offers ``now()`` (s) and ``advance(seconds)``, and the client lets that
    time pass instead of waiting."""

    def wait_sent(self, timeout: float) -> bool | None:
        """Wait until every frame sent so far is on the wire: True once confirmed, False when
        ``timeout`` s passed first, None when this transport cannot tell (the default)."""
        return None

    @property
    def capabilities(self) -> Capabilities:
        """What this transport can do, in one object (the client reads it once when it opens a bus).

        The default is made of the attributes above (``in_order``, ``wire_bitrate``, ``tx_latency``,
        ``unbounded_latency``, ``virtual_clock``); a transport with more to declare (``confirms_sent``,
        ``answers_in_send``, ``partial_frames``, ``motor_ids``) overrides this property.
        """
        return Capabilities(
            in_order=self.in_order,
            wire_bitrate=self.wire_bitrate,
            tx_latency=self.tx_latency,
            unbounded_latency=self.unbounded_latency,
            virtual_clock=self.virtual_clock,
        )

    def send_collect(self, frame: Frame) -> list[Frame]:
        """Send ``frame`` and return the frames it caused (only where ``capabilities.answers_in_send``)."""
        raise NotImplementedError(f"{type(self).__name__} does not answer inside a send")

    def rest_time(self) -> float:
        """How long (s) the rest of a partly received frame takes (where ``capabilities.partial_frames``)."""
        return 0.0

    def clock(self) -> VirtualClock | None:
        """The transport's simulated time (where ``capabilities.virtual_clock``), else None."""
        return None

    def fileno(self) -> int | None:
        """A file descriptor that turns readable when :meth:`read_nowait` has frames to give, or None
        when this transport has none (the driver then receives through :meth:`recv` in a thread)."""
        return None

    def read_nowait(self) -> list[Frame]:
        """The frames received so far, without waiting (only for transports with a :meth:`fileno`)."""
        raise NotImplementedError(f"{type(self).__name__} has no non-blocking read")

    recv_slice: float | None = RECV_SLICE
    """Longest single :meth:`wait_frame` of :meth:`recv` (s); None when ``close`` itself wakes a wait."""

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        if cls.recv is Transport.recv and cls.wait_frame is Transport.wait_frame:
            raise TypeError(f"{cls.__name__} must implement wait_frame() (or recv())")

    @abstractmethod
    def send(self, frame: Frame) -> None:
        """Transmit one frame."""

    def wait_frame(self, timeout: float) -> Frame | None:
        """The next received frame, or None after at most ``timeout`` s (>= 0) or once closed.

        Returning None early is allowed (the loop in :meth:`recv` waits again).
        """
        raise NotImplementedError

    def is_closed(self) -> bool:
        """True once :meth:`close` was called (the loop in :meth:`recv` then returns None)."""
        return False

    def recv(self, timeout: float | None = None) -> Frame | None:
        """Next received frame, or None after ``timeout`` seconds (or once closed)."""
        if timeout is not None and timeout <= 0:
            return None if self.is_closed() else self.wait_frame(0.0)
        wait = self.wait_frame
        clock = time.monotonic
        step = _LONG if self.recv_slice is None else self.recv_slice
        deadline = None if timeout is None else clock() + timeout
        closed = self.is_closed
        while not closed():
            if deadline is None:
                frame = wait(step)
            else:
                left = deadline - clock()
                frame = wait(step if left > step else max(0.0, left))
            if frame is not None:
                return frame
            if deadline is not None and clock() >= deadline:
                return None
        return None

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


class QueuedTransport(Transport):
    """A transport whose received frames are put in a queue by another thread (a simulated bus, a
    network session): :meth:`wait_frame` takes from it, and :meth:`_wake` (called by ``close``) queues
    None so that a waiting receive returns at once."""

    recv_slice = None
    """``close`` wakes a waiting receive itself."""

    def __init__(self) -> None:
        self._queue: queue.SimpleQueue[Frame | None] = queue.SimpleQueue()
        self._closed = False

    def is_closed(self) -> bool:
        return self._closed

    def wait_frame(self, timeout: float) -> Frame | None:
        try:
            frame = self._queue.get(timeout=timeout) if timeout > 0 else self._queue.get_nowait()
        except queue.Empty:
            return None
        if frame is None:
            self._queue.put(None)  # closed: the next waiter is woken too
        return frame

    def _wake(self) -> None:
        """Make every waiting and later receive return None (after ``_closed`` is set)."""
        self._queue.put(None)
