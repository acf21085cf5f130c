"""The order of the bridge's ROS 2 service calls: an estop comes after every call that arrived before it.

Zenoh runs the service callbacks of different links at the same time, so an
``enable`` or ``clear_errors`` that arrived just before an ``estop`` could put
its frames on the bus after the estop's and undo it (closed loop, no estop
flag). Each call takes a ticket when it arrives. Calls other than an estop run
one at a time in ticket order (:meth:`ServiceOrder.turn`); an estop never waits
for them: its arrival is a fence, and every call that arrived before it is
:meth:`~ServiceOrder.stale` from then on and sends nothing more. Only a call
that arrives after the estop (an explicit ``clear_errors``) undoes it.
"""

from __future__ import annotations

import threading
from collections.abc import Iterator
from contextlib import contextmanager

__all__ = ["ServiceOrder"]


class ServiceOrder:
    """Tickets of service calls, the turn of each non-estop call, and the fence of the last estop."""

    def __init__(self) -> None:
        self._cv = threading.Condition()
        self._next = 0
        self._pending: set[int] = set()
        """Tickets of non-estop calls not finished yet."""
        self._fence = -1
        """Ticket of the last estop: every call with a lower ticket is stale."""

    def arrive(self, estop: bool = False) -> int:
        """A ticket for a call that just arrived; an estop's is a fence at once."""
        with self._cv:
            ticket = self._next
            self._next += 1
            if estop:
                self._fence = ticket
            else:
                self._pending.add(ticket)
            return ticket

    def stale(self, ticket: int) -> bool:
        """True when an estop arrived after call ``ticket``: the call must send nothing more."""
        return ticket < self._fence

    @contextmanager
    def turn(self, ticket: int) -> Iterator[None]:
        """Run call ``ticket`` (a non-estop call) once every call that arrived before it has finished."""
        with self._cv:
            while ticket in self._pending and min(self._pending) != ticket:
                self._cv.wait()
        try:
            yield
        finally:
            with self._cv:
                self._pending.discard(ticket)
                self._cv.notify_all()
