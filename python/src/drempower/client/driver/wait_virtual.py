"""The wait of a bus on a virtual clock: the bus's time passes only while a caller waits.

A transport with a virtual clock (the in-process simulator with ``clock="virtual"``,
``Transport.capabilities.virtual_clock``) is the bus's clock. There is no receive thread: wherever a caller
would wait it lets that much simulated time pass instead, up to the session's next deadline at a
time, taking the frames that arrive meanwhile. asyncio calls run the same way, inside the call.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from typing import TYPE_CHECKING, Any, TypeVar

from ..engine.effects import Runnable, sleep
from .wait_steps import WaitSteps

if TYPE_CHECKING:
    from ...transports.base import VirtualClock
    from ..engine.session import Operation
    from .bus_driver import BusDriver
    from .receiver import Receiver

__all__ = ["VirtualWaits"]

T = TypeVar("T")

_SLICE = 0.05
"""Most simulated time (s) one step lets pass before the caller looks at the session's deadlines again
(other threads may have added sooner ones)."""
_TICK = 1e-6
"""Least simulated time (s) one step lets pass, so that a deadline due now cannot stall it."""
_IDLE = 0.01
"""Wall time (s) a caller waits for other threads when the session has nothing due."""
_TURN = 0.005
"""Longest wall wait (s) for the turn to let time pass before a caller looks at its operation again."""


class VirtualWaits(WaitSteps):
    """How a caller waits for its operation on ``driver`` whose transport is the ``clock`` (``rx`` feeds
    what arrives; it starts no thread)."""

    __slots__ = ("_turn", "clock")

    def __init__(self, driver: BusDriver, rx: Receiver, clock: VirtualClock) -> None:
        super().__init__(driver, rx)
        self.clock = clock
        self._turn = threading.RLock()
        """Held by the caller letting time pass (one at a time)."""

    def run(self, op: Runnable[T]) -> T:
        """Submit ``op`` and let time pass until it is done; returns its result or raises its error.
        Replies to what it sends first came inside the send."""
        opn = self.submit(op, None)[0]
        if not opn.done:
            self.wait(opn)
        return opn.result()

    async def run_async(self, op: Runnable[T]) -> T:
        """:meth:`run` from a coroutine: simulated time passes inside the call."""
        return self.run(op)

    def pass_time(self, seconds: float, until: Callable[[], bool] | None = None) -> None:
        """Let ``seconds`` of simulated time pass, taking the frames that arrive meanwhile; end early once
        ``until()`` is true (checked after each frame taken). No wall time passes."""
        opn = self.submit(sleep(seconds), None)[0]
        if not opn.done:
            self.wait(opn, until)
        if not opn.done:
            self.cancel(opn)

    def wait(self, opn: Operation[Any], until: Callable[[], bool] | None = None) -> None:
        """Let simulated time pass until ``opn`` is done (or ``until()``): up to the session's next
        deadline at a time, ending early when a frame arrives, which is fed at once. One caller lets
        time pass at a time (the turn); the others look at their operation meanwhile, which that
        caller's frames may finish."""
        d, clock, turn = self.driver, self.clock, self._turn
        session, read_feed = d.session, self.rx.read_feed

        def taken() -> bool:
            """Feed what the transport queued while time passed; whether the wait is over."""
            read_feed()
            return opn.done or (until is not None and until())

        try:
            while not opn.done and not d._closed:
                if not turn.acquire(timeout=_TURN):
                    continue
                try:
                    if taken():
                        break
                    wait = self.step(opn)
                    if wait is None or taken():
                        break
                    with d._lock:
                        idle = session.next_deadline() is None
                    if not idle:
                        clock.advance(min(max(wait, _TICK), _SLICE))
                        read_feed()
                finally:
                    turn.release()
                if idle:  # nothing is due: what it waits for is another thread's to do; then time goes on
                    time.sleep(_IDLE)
                    with turn:
                        clock.advance(_SLICE)
                        read_feed()
        except BaseException:  # Ctrl-C: the operation must not take the next request's reply
            self.cancel(opn)
            raise
        if d._closed:
            self.end_closed(opn)
