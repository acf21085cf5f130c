"""The asyncio wait of a bus on a wall clock: a coroutine runs an operation to its end without
blocking its event loop and without a thread per call.

On a transport with a descriptor the event loop takes the reader role (:class:`LoopReader`) and
keeps a duplicate of the descriptor registered with ``loop.add_reader`` while its coroutines use the
bus and :data:`~.receiver.LINGER` s after: replies are read and fed in the loop's callback, which
wakes the waiting coroutine directly. While another thread or loop holds the role, and on a transport
without a descriptor, the coroutine is woken by the thread that finished its operation
(``loop.call_soon_threadsafe``); it takes the role for its loop as soon as the role is free.
"""

from __future__ import annotations

import asyncio
import math
import os
import threading
import time
from collections.abc import Callable
from typing import TYPE_CHECKING, Any, TypeVar

from ...errors import BusClosedError
from ..engine.effects import Runnable
from .receiver import LINGER
from .wait_steps import WaitSteps

if TYPE_CHECKING:
    from ..engine.session import Operation
    from .receiver import Receiver

__all__ = ["AsyncWaits", "LoopReader"]

T = TypeVar("T")
_monotonic = time.monotonic


def _wake(fut: asyncio.Future[Any]) -> None:
    if not fut.done():
        fut.set_result(None)


def _waker(loop: asyncio.AbstractEventLoop, holder: list[asyncio.Future[None]]) -> Callable[[], None]:
    """A wake-up of the coroutine awaiting ``holder[0]`` on ``loop`` (made in the loop's thread) that any
    thread may call."""
    loop_thread = threading.get_ident()

    def wake() -> None:
        if threading.get_ident() == loop_thread:
            _wake(holder[0])
            return
        try:
            loop.call_soon_threadsafe(_wake, holder[0])
        except RuntimeError:  # the loop is closed; nobody waits any more
            pass

    return wake


class LoopReader:
    """The reader role held by an event loop: a duplicate of the transport's descriptor stays
    registered with ``loop.add_reader`` while coroutines of that loop use the bus and for
    :data:`~.receiver.LINGER` s after (one registration per linger, not per call), and frames are read
    and fed in the loop's callback.

    The role is given back when the loop is idle, when the bus closes, and to a thread that needs to
    read while the loop cannot (not running, closed, or blocked by that very thread). The
    registration is on a duplicate so that closing the transport never leaves a descriptor number
    registered that another file may reuse: the duplicate is unregistered and closed in the loop's
    own thread (or at once when the loop is closed).
    """

    __slots__ = ("_busy", "_once", "due", "due_at", "fd", "last", "loop", "rx", "thread", "timer", "users", "waits")

    def __init__(self, rx: Receiver, loop: asyncio.AbstractEventLoop) -> None:
        self.rx = rx
        self.loop = loop
        self.thread = threading.get_ident()
        assert rx.fd is not None
        self.fd = os.dup(rx.fd)
        """The registered duplicate of the transport's descriptor (-1 once closed)."""
        self.users = 0
        """Coroutines of this loop running an operation on the bus."""
        self.last = _monotonic()
        self.timer: asyncio.TimerHandle | None = None
        self._once = threading.Lock()
        """Taken by the one :meth:`let_go` that acts (never blocks: a signal handler may call it)."""
        self._busy = threading.Lock()
        """Held while the loop's callback reads, and while another thread takes the role back."""
        self.waits: dict[Callable[[], None], float] = {}
        """When (monotonic s) to wake each waiting coroutine at the latest (its operation's next deadline)."""
        self.due: asyncio.TimerHandle | None = None
        self.due_at = math.inf

    def register(self) -> None:
        try:
            self.loop.add_reader(self.fd, self.readable)
        except BaseException:
            self._close_fd()
            raise
        self.timer = self.loop.call_later(LINGER, self.check)

    def wake_at(self, wake: Callable[[], None], at: float) -> None:
        """Call ``wake`` by monotonic time ``at`` (s). One timer serves every coroutine of the loop: it is
        armed anew only when ``at`` comes before it (calls in a row, each with its timeout, share one)."""
        self.waits[wake] = at
        if at < self.due_at:
            if self.due is not None:
                self.due.cancel()
            self.due_at = at
            self.due = self.loop.call_later(max(0.0, at - _monotonic()), self._due)

    def _due(self) -> None:
        """The shared timer: wake the coroutines whose time came, re-arm for the next."""
        self.due, self.due_at = None, math.inf
        now = _monotonic()
        later = math.inf
        for wake, at in list(self.waits.items()):
            if at <= now:
                del self.waits[wake]
                wake()
            elif at < later:
                later = at
        if later < math.inf:
            self.due_at = later
            self.due = self.loop.call_later(later - now, self._due)

    def readable(self) -> None:
        """The loop's callback: read and feed what arrived (wakes the coroutines whose operation ends)."""
        rx = self.rx
        if rx.loop_reader is not self:  # given back meanwhile (by another thread): only unregister here
            self.unregister()
            return
        if not self._busy.acquire(False):
            return  # being taken back this instant; the descriptor stays readable for whoever reads next
        try:
            if rx.driver._closed or rx.stopped():
                self.let_go(held=True)
                return
            rx.read_feed()
            if rx.stopped():  # the transport failed; its descriptor may stay readable
                self.let_go(held=True)
        finally:
            self._busy.release()

    def check(self) -> None:
        """The linger timer: let go once no coroutine used the bus for :data:`~.receiver.LINGER` s."""
        self.timer = None
        if self.rx.loop_reader is not self:
            return
        left = self.last + LINGER - _monotonic()
        if self.users or left > 0:
            self.timer = self.loop.call_later(max(left, LINGER / 4), self.check)
            return
        self.let_go()

    def stalled(self) -> bool:
        """Whether the loop cannot read for the calling thread: closed, not running, or run by this thread
        (which is busy with something else)."""
        loop = self.loop
        return loop.is_closed() or not loop.is_running() or threading.get_ident() == self.thread

    def let_go(self, lock_timeout: float = -1, held: bool = False, force: bool = False) -> bool:
        """Give the reader role back, from any thread; idempotent. False when the loop's callback is reading
        at this instant (try again; ``force``, for a close, gives up the role without waiting for it).
        The duplicate is unregistered now in the loop's thread, else when the loop next runs."""
        busy = held or self._busy.acquire(False)
        if not busy and not force:
            return False
        try:
            if not self._once.acquire(False):
                return True
            rx = self.rx
            if rx.loop_reader is self:
                rx.loop_reader = None
            if busy:
                rx.release()
            rx.leave(lock_timeout)
        finally:
            if busy and not held:
                self._busy.release()
        loop = self.loop
        if loop.is_closed():
            self._close_fd()
        elif threading.get_ident() == self.thread:
            self.unregister()
        else:
            try:
                loop.call_soon_threadsafe(self.unregister)
            except RuntimeError:  # closed meanwhile
                self._close_fd()
        return True

    def unregister(self) -> None:
        """In the loop's thread: stop the timers, remove and close the duplicate."""
        for handle in (self.timer, self.due):
            if handle is not None:
                handle.cancel()
        self.timer = self.due = None
        if self.fd >= 0:
            try:
                self.loop.remove_reader(self.fd)
            except (OSError, ValueError, RuntimeError):  # the loop closed meanwhile
                pass
            self._close_fd()

    def _close_fd(self) -> None:
        fd, self.fd = self.fd, -1
        if fd >= 0:
            try:
                os.close(fd)
            except OSError:
                pass


class AsyncWaits(WaitSteps):
    """How a coroutine waits for its operation on ``driver`` (see the module docstring)."""

    __slots__ = ()

    async def run(self, op: Runnable[T]) -> T:
        """Submit ``op`` and await its end on the running loop; returns its result or raises its error."""
        d, rx = self.driver, self.rx
        loop = asyncio.get_running_loop()
        holder: list[asyncio.Future[None]] = [loop.create_future()]
        wake = _waker(loop, holder)
        rd: LoopReader | None = None
        counted = False  # counted in as a reading caller while it waits for the role to be free
        if rx.fd is not None:
            rd = rx.loop_reader
            if rd is None or rd.loop is not loop or rd.fd < 0:
                d.check_open()
                rx.enter()
                counted = True
                rd = self._reader(loop)
                counted = rd is None
            if rd is not None:
                rd.users += 1
        d._sleepers.add(wake)  # new deadlines, or the role free again: look again
        opn: Operation[T] | None = None
        try:
            opn, wait = self.submit(op, wake)
            while not opn.done:
                if counted and (rd := self._reader(loop)) is not None:
                    counted = False
                    rd.users += 1
                if wait is None:
                    wait = await self.step_async(opn)
                    if wait is None:
                        break
                if wait > 0:
                    fut = holder[0]
                    if not fut.done():
                        if rd is not None:
                            rd.wake_at(wake, _monotonic() + wait)
                            await fut
                        else:
                            timer = loop.call_later(wait, _wake, fut)
                            try:
                                await fut
                            finally:
                                timer.cancel()
                    holder[0] = loop.create_future()
                wait = None
                if d._closed:
                    break
        except BaseException:
            if opn is not None:
                self.cancel(opn)
            raise
        finally:
            d._sleepers.discard(wake)
            if rd is not None:
                rd.waits.pop(wake, None)
                rd.users -= 1
                rd.last = _monotonic()
            if counted:
                rx.leave()
        self.end_closed(opn)
        return opn.result()

    def _reader(self, loop: asyncio.AbstractEventLoop) -> LoopReader | None:
        """The reader role for a caller on ``loop`` counted in as reading: the loop's :class:`LoopReader`
        (made now when the role is free; the count becomes the reader's), or None while another thread or
        loop holds the role."""
        rx = self.rx
        rd = rx.loop_reader
        if rd is not None and rd.loop is loop and rd.fd >= 0:  # another coroutine of the loop took it
            rx.leave()  # the reader has a count of its own
            return rd
        if rd is not None:
            rx.take_back()
        if not rx.lock.acquire(False):
            return None
        d = self.driver
        if d._closed:
            rx.lock.release()
            raise BusClosedError(f"the bus ({d.transport.description}) is closed")
        rd = LoopReader(rx, loop)
        rx.loop_reader = rd
        try:
            rd.register()
        except BaseException:
            rx.loop_reader = None
            rx.lock.release()
            raise
        return rd

    async def step_async(self, opn: Operation[Any]) -> float | None:
        """:meth:`step` from a coroutine: a transport's blocking wait for a confirmation runs in a
        worker thread, never on the event loop (then 0.0: step again at once)."""
        d = self.driver
        with d._lock:
            confirm = d.session.awaiting_confirmation
        if confirm:
            await asyncio.to_thread(self.step, opn)
            return 0.0
        return self.step(opn)
