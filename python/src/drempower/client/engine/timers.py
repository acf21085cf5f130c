"""The session's scheduler: timers, each firing once the time given reaches its due time.

Sans-I/O: the time only comes in (:meth:`Timers.fire_due`); nothing here reads a
clock. Times are seconds on the driver's clock.
"""

from __future__ import annotations

from collections.abc import Callable
from heapq import heapify, heappop, heappush

__all__ = ["Timers"]

_COMPACT_AT = 64
"""Entries in the heap from which dropped timers are cleared out when they outnumber the live ones."""


class Timers:
    """Timers by id, fired in due order by :meth:`fire_due`.

    ``changes`` grows with every timer added and every :meth:`touch`: a driver
    whose caller sleeps wakes it when the count changed (a sooner deadline may
    have come).
    """

    __slots__ = ("changes", "heap", "now", "pending")

    def __init__(self, now: float = 0.0) -> None:
        self.now = now
        """The latest time the driver gave (s): what the parts that schedule read as the time now."""
        self.changes = 0
        self.pending: dict[int, tuple[float, Callable[[], None]]] = {}
        """Timer id -> (due s, what to call) of every timer not fired or dropped (``pending.pop(id, None)``
        is :meth:`drop`, for the hot path)."""
        self.heap: list[tuple[float, int]] = []
        """(due s, id) of every timer, dropped ones included until popped: a heap, the soonest first."""

    def __len__(self) -> int:
        return len(self.pending)

    def add(self, due: float, fire: Callable[[], None]) -> int:
        """Call ``fire()`` once the time reaches ``due`` (s); returns the timer's id (for :meth:`drop`)."""
        self.changes = tid = self.changes + 1
        timers, heap = self.pending, self.heap
        timers[tid] = (due, fire)
        if len(heap) >= _COMPACT_AT and len(heap) > 4 * len(timers):
            # dropped timers (answered requests) outnumber the live ones: keep only these, so that a run
            # of fast calls, each dropping its timer, pushes onto a heap of a few entries, not thousands
            heap[:] = [(d, t) for t, (d, _) in timers.items()]
            heapify(heap)
        else:
            heappush(heap, (due, tid))
        return tid

    def drop(self, tid: int) -> None:
        """Forget timer ``tid`` (fired or dropped already: nothing happens)."""
        self.pending.pop(tid, None)

    def touch(self) -> None:
        """Count a change: a deadline kept elsewhere (held-back reply, held start) was set."""
        self.changes += 1

    def next_due(self) -> float | None:
        """When the earliest timer is due (s), or None."""
        heap, timers = self.heap, self.pending
        while heap and heap[0][1] not in timers:  # dropped timers leave their entry behind
            heappop(heap)
        return heap[0][0] if heap else None

    def fire_due(self, now: float) -> None:
        """Fire every timer due by ``now`` (s), earliest first; timers they add wait for the next call."""
        heap, timers = self.heap, self.pending
        if not heap or heap[0][0] > now:
            return
        newest = self.changes
        later: list[tuple[float, int]] = []
        try:
            while heap and heap[0][0] <= now:
                item = heappop(heap)
                if item[1] > newest:
                    later.append(item)
                    continue
                entry = timers.pop(item[1], None)
                if entry is not None:
                    entry[1]()
        finally:  # a timer that raised leaves the ones set meanwhile due all the same
            for item in later:
                heappush(heap, item)

    def clear(self) -> None:
        """Drop every timer."""
        self.pending.clear()
        self.heap.clear()
