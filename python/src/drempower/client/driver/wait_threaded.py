"""The threaded wait of a bus on a wall clock: a caller's thread runs an operation to its end.

On a transport with a descriptor the caller takes the reader role before its requests go out, so that
once they are written it goes straight to ``select`` on the transport and reads its reply itself: no
thread handoff. A caller that does not get the role (another one reads), and every caller on a
transport without a descriptor, sleeps until its operation ends (the thread that finished it wakes it),
the session's next deadline, or a wake-up (a new deadline, the role free again).
"""

from __future__ import annotations

import select
import threading
import time
from collections.abc import Callable
from typing import TYPE_CHECKING, Any, TypeVar

from ..engine.effects import Runnable
from .wait_steps import WaitSteps

if TYPE_CHECKING:
    from ..engine.session import Operation
    from .bus_driver import BusDriver
    from .receiver import Receiver

__all__ = ["ThreadWaits", "Wake"]

T = TypeVar("T")

_WALL_POLL = 0.01
"""Longest sleep (s) of :meth:`ThreadWaits.pass_time` before it checks its condition again."""
_monotonic = time.monotonic


class Wake:
    """A one-shot wake-up of one sleeping thread, any thread may :meth:`set` it; cheaper than a
    :class:`threading.Event` (one lock, held while not set)."""

    __slots__ = ("_lock",)

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._lock.acquire()

    def set(self) -> None:
        """Wake the sleeper (or the next :meth:`wait`); idempotent."""
        try:
            self._lock.release()
        except RuntimeError:  # already set
            pass

    def wait(self, timeout: float) -> None:
        """Sleep until set or ``timeout`` s passed; leaves it cleared."""
        self._lock.acquire(timeout=timeout)

    def clear(self) -> None:
        """Forget a wake-up nobody waited for."""
        self._lock.acquire(False)


class ThreadWaits(WaitSteps):
    """How the calling thread waits for its operation on ``driver`` (see the module docstring)."""

    __slots__ = ("_instant", "_pool")

    def __init__(self, driver: BusDriver, rx: Receiver) -> None:
        super().__init__(driver, rx)
        self._instant = driver._collect is not None
        """Replies come inside the send (the in-process simulator): most operations end in their submit,
        before any reader role or wake-up is needed."""
        self._pool = threading.local()
        """Each thread's spare :class:`Wake` objects (reused across its calls; nested calls get their own)."""

    def run(self, op: Runnable[T]) -> T:
        """Submit ``op`` and wait in this thread until it is done; returns its result or raises its error."""
        if self._instant:
            opn = self.submit(op, None)[0]
            if not opn.done:
                self._run(None, opn)
            return opn.result()
        return self._run(op, None).result()

    def wait(self, opn: Operation[Any]) -> None:
        """Wait in this thread until ``opn`` (submitted without ``on_done``) is done."""
        self._run(None, opn)

    def _run(self, op: Runnable[T] | None, opn: Operation[T] | None) -> Operation[T]:
        """The wait: submit ``op`` (or take ``opn``), then until it is done read the transport while this
        thread holds the reader role, else sleep on a :class:`Wake` until the next deadline or a wake-up."""
        d, rx = self.driver, self.rx
        reads = rx.fd is not None
        reading = False
        if reads:
            if rx.loop_reader is not None:
                rx.take_back()
            rx.enter()
            reading = rx.lock.acquire(False)
        ev: Wake | None = None
        wake: Callable[[], None] | None = None
        if not reading:
            ev = self._wake()
            wake = ev.set
            d._sleepers.add(wake)
        wait: float | None = None
        try:
            if opn is None:
                assert op is not None
                opn, wait = self.submit(op, wake)
            else:
                opn.on_done = wake
            while not opn.done:
                if reads and not reading:
                    reading = rx.lock.acquire(False)
                if reading:
                    self._read_until(opn, wait)
                    if d._closed:
                        break
                    continue
                if wait is None:
                    wait = self.step(opn)
                    if wait is None:
                        break
                if wait > 0:
                    assert ev is not None
                    ev.wait(wait)
                wait = None
        except BaseException:  # Ctrl-C: the operation must not take the next request's reply
            if opn is not None:
                self.cancel(opn)
            raise
        finally:
            if reading:
                rx.release(wake)
            if reads:
                rx.leave()
            if ev is not None:
                d._sleepers.discard(ev.set)
                ev.clear()
                self._pool.spare.append(ev)
        if not opn.done:
            self.end_closed(opn)
        return opn

    def _wake(self) -> Wake:
        """A cleared :class:`Wake` of the calling thread."""
        spare: list[Wake] | None = getattr(self._pool, "spare", None)
        if spare is None:
            spare = self._pool.spare = []
        if not spare:
            return Wake()
        ev = spare.pop()
        ev.clear()  # a late wake-up of its last use
        return ev

    def _read_until(self, opn: Operation[Any], wait: float | None) -> None:
        """Read and feed frames (the reader role is held) until ``opn`` is done or the bus closes; the
        first wait is ``wait`` s (None: as the session says)."""
        d, rx = self.driver, self.rx
        fds, rest = rx.read_fds, rx.rest_time
        while not opn.done and not d._closed:
            if wait is None:
                wait = self.step(opn)
                if wait is None:
                    return
            if wait > 0:
                try:
                    select.select(fds, [], [], wait)
                except (OSError, ValueError):  # closed under us
                    if d._is_closed():
                        return
                    raise
            wait = None
            rx.read_feed()
            if rest is not None and not opn.done:
                pause = rest()
                if pause > 0:  # part of a frame is here: let the rest arrive rather than wake per byte
                    time.sleep(pause)

    def pass_time(self, seconds: float, until: Callable[[], bool] | None = None) -> None:
        """Sleep ``seconds`` (the receive thread takes the frames meanwhile); end early once ``until()``
        is true or the bus closes (seen within :data:`_WALL_POLL`).

        A plain sleep, not a wait on an event the close sets: a signal handler that closes the bus runs
        in this thread, possibly while it holds that event's lock, and would wait for itself forever."""
        d = self.driver
        end = _monotonic() + seconds
        while not (until is not None and until()) and (left := end - _monotonic()) > 0:
            time.sleep(min(left, _WALL_POLL))
            if d._is_closed():
                return
