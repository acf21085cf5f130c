"""The wire of a simulated bus with a bit rate: each host's transmit queue, arbitration by identifier,
one frame on the wire at a time for its real length (see :mod:`drempower.sim.bus`)."""

from __future__ import annotations

import collections
import heapq
from collections.abc import Callable, Iterator
from typing import Generic, TypeVar

from ..protocol.ids import Frame
from .timing import BusStats, frame_bits

__all__ = ["Wire"]

S = TypeVar("S")
"""Who put a frame on the bus: a motor, or None for a host."""
A = TypeVar("A")
"""The attachment a host frame came through."""


class _HostQueue(Generic[S, A]):
    """One host's transmit queue: frames wait in ``backlog`` until one of ``slots`` mailboxes is free."""

    __slots__ = ("backlog", "in_flight", "slots")

    def __init__(self, slots: int) -> None:
        self.slots = slots
        self.in_flight = 0
        self.backlog: collections.deque[tuple[int, int, Frame, S | None, A | None]] = collections.deque()


class Wire(Generic[S, A]):
    """Frames contend for a bus of ``bitrate`` bit/s: the lowest identifier among those ready goes next.

    Each host has ``host_slots`` transmit mailboxes; motors send in order. ``seq`` numbers the frames
    (ties go to the first), ``stats`` counts what was carried; ``host_sent`` is called each time a host
    frame has left its host.
    """

    __slots__ = ("_host_sent", "_hosts", "_ready", "_seq", "bitrate", "host_slots", "stats", "tx")

    def __init__(
        self, bitrate: int, host_slots: int, seq: Iterator[int], stats: BusStats, host_sent: Callable[[], None]
    ) -> None:
        self.bitrate, self.host_slots, self._seq, self.stats = bitrate, host_slots, seq, stats
        self._host_sent = host_sent
        self._hosts: dict[A | None, _HostQueue[S, A]] = {}
        self._ready: list[tuple[int, int, Frame, S | None, A | None]] = []
        self.tx: tuple[float, Frame, S | None, A | None] | None = None
        """The frame on the wire: (end of its transmission, frame, source, origin); None when idle."""

    def offer(self, frame: Frame, source: S | None, origin: A | None, now: float) -> None:
        """A frame is offered at ``now`` by a host (``source`` None, through ``origin``) or a motor."""
        entry = (frame.arbitration_id, next(self._seq), frame, source, origin)
        if source is None:
            q = self._hosts.get(origin)
            if q is None:
                q = self._hosts[origin] = _HostQueue(self.host_slots)
            q.backlog.append(entry)
            self._refill(q)
        else:
            heapq.heappush(self._ready, entry)
        if self.tx is None and self._ready:
            self._start(now)

    def host_pending(self, origin: A | None) -> int:
        """Frames the host sending through ``origin`` has queued that are not yet fully on the wire."""
        q = self._hosts.get(origin)
        return 0 if q is None else q.in_flight + len(q.backlog)

    def finish(self, now: float) -> tuple[Frame, S | None, A | None]:
        """The frame on the wire ends its transmission at ``now``; the next one starts. Returns the frame,
        its source and origin."""
        assert self.tx is not None
        _, frame, source, origin = self.tx
        self.tx = None
        if source is None:
            q = self._hosts[origin]
            q.in_flight -= 1
            self._refill(q)
            self._host_sent()
        if self._ready:
            self._start(now)
        return frame, source, origin

    def _refill(self, q: _HostQueue[S, A]) -> None:
        """Move a host's waiting frames into its free mailboxes, where they contend for the bus."""
        while q.backlog and q.in_flight < q.slots:
            heapq.heappush(self._ready, q.backlog.popleft())
            q.in_flight += 1

    def _start(self, now: float) -> None:
        _, _, frame, source, origin = heapq.heappop(self._ready)
        bits = frame_bits(frame.arbitration_id, frame.data, frame.is_extended)
        duration = bits / self.bitrate
        s = self.stats
        s.frames += 1
        s.bits += bits
        s.busy += duration
        self.tx = (now + duration, frame, source, origin)
