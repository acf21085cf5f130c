"""The steps every flavour of wait takes on a bus: submit an operation, act on the time now, give up."""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any, TypeVar

from ...errors import BusClosedError
from ..engine.effects import Runnable

if TYPE_CHECKING:
    from ..engine.session import Operation
    from .bus_driver import BusDriver
    from .receiver import Receiver

__all__ = ["WaitSteps"]

T = TypeVar("T")

_WAIT_SLICE = 1.0
"""Longest single wait (s) of a caller for its operation (the session's deadlines are usually sooner)."""


class WaitSteps:
    """The steps of a wait on ``driver`` (``rx`` feeds it what arrives); each flavour adds its loop."""

    __slots__ = ("driver", "rx")

    def __init__(self, driver: BusDriver, rx: Receiver) -> None:
        self.driver = driver
        self.rx = rx

    def submit(self, op: Runnable[T], on_done: Callable[[], None] | None) -> tuple[Operation[T], float | None]:
        """Start ``op`` in the session now and write what it sends first; returns it and how long (s) the
        caller may wait before stepping (None: step now)."""
        d = self.driver
        if d._closed or d._failure is not None:
            d.check_open()
        with d._lock:
            s = d.session
            now = d._now()
            s.advance(now)
            opn = s.submit(op, on_done)
            if s.outbox.frames or d._stopped:
                d._flush(now)
            events = d._events
            if events:
                d._events = []
            wait = None
            if not opn.done and not s.hold.awaiting_confirmation:
                due = s.next_deadline()
                wait = _WAIT_SLICE if due is None else min(_WAIT_SLICE, max(0.0, due - d._now()))
        if events:
            d._dispatch(events)
        return opn, wait

    def step(self, opn: Operation[Any]) -> float | None:
        """Act on the time now; returns how long (s) the caller may sleep before stepping again (None:
        ``opn`` is done). A transport's wait for the confirmation of a write is taken here (then 0.0)."""
        d = self.driver
        confirm = False
        with d._lock:
            s = d.session
            s.advance(d._now())
            d._flush()
            events = d._take_events()
            if opn.done:
                wait = None
            else:
                confirm = s.awaiting_confirmation
                wait = self.until(s.next_deadline())
        if events:
            d._dispatch(events)
        if confirm:
            ok = d.transport.wait_sent(wait or 0.0)
            with d._lock:
                s.transmitted(d._now(), ok)
                d._flush()
                events = d._take_events()
            if events:
                d._dispatch(events)
            return 0.0
        return wait

    def until(self, due: float | None) -> float:
        """How long (s) a caller may wait for the session's next deadline ``due`` (at most :data:`_WAIT_SLICE`)."""
        return _WAIT_SLICE if due is None else min(_WAIT_SLICE, max(0.0, due - self.driver._now()))

    def cancel(self, opn: Operation[Any]) -> None:
        """Stop ``opn``, whose caller gave up (Ctrl-C): it must not take the next request's reply."""
        d = self.driver
        with d._lock:
            d.session.cancel(opn)

    def end_closed(self, opn: Operation[Any]) -> None:
        """A wait that stopped because the bus closed: fail ``opn`` if the close has not yet."""
        if not opn.done:
            d = self.driver
            with d._lock:
                d.session.cancel(opn, BusClosedError(f"the bus ({d.transport.description}) was closed"))
