"""What arrives on a bus: frames fed to the session, the receive thread of a bus on a wall clock, and
the reader role of a transport with a descriptor.

A transport without a descriptor is read by the receive thread alone: it feeds every frame to the
session, which wakes the caller whose operation ended. A transport with one (:meth:`Transport.fileno`:
the adapter and UART serial ports) is read by whoever holds the reader role (:attr:`Receiver.lock`):
a threaded caller waiting in ``select`` (:mod:`.wait_threaded`), an event loop through
``loop.add_reader`` (:mod:`.wait_asyncio`), or, while no caller reads and for :data:`LINGER` s after,
the receive thread. Callers count themselves in (:meth:`Receiver.enter`) before they try for the role,
so the thread parks rather than race them for each reply. On a virtual clock there is no thread: the
caller letting time pass feeds what arrived (:mod:`.wait_virtual`).
"""

from __future__ import annotations

import logging
import os
import select
import threading
import time
import weakref
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING

from ...errors import BusClosedError
from ...protocol.ids import Frame
from ...transports.fds import close_fds, drain, nonblocking_pipe

if TYPE_CHECKING:
    from .bus_driver import BusDriver
    from .wait_asyncio import LoopReader

__all__ = ["LINGER", "Receiver"]

_log = logging.getLogger("drempower.client")

RX_SLICE = 1.0
"""Longest wait (s) of the receive thread for a frame on a transport without a descriptor; closing the
transport wakes it sooner. On a transport with one it waits in ``select`` with no timeout."""
LINGER = 0.02
"""How long (s) the receive thread stays parked after a caller read the transport itself: calls in a
row keep it asleep; a frame nobody asked for waits at most this long for it."""
_monotonic = time.monotonic


class Receiver:
    """What arrives on ``driver``'s transport: frames fed to the session (:meth:`feed`), the reader role
    of its descriptor ``fd`` (None: the receive thread reads alone) and the receive thread (:meth:`start`)."""

    def __init__(self, driver: BusDriver, fd: int | None) -> None:
        self.driver = driver
        self.fd = fd
        self.lock = threading.Lock()
        """The reader role: held by whoever reads a transport with a descriptor."""
        self.loop_reader: LoopReader | None = None
        """The event loop holding the role, if one does (see :mod:`.wait_asyncio`)."""
        self._gate_lock = threading.Lock()
        self._gate = threading.Condition(self._gate_lock)
        """Guards the count of reading callers; the parked receive thread waits on it."""
        self._callers = 0
        self._last_caller = 0.0
        self._selecting = False
        self.thread: threading.Thread | None = None
        self.pipes: list[int] = []
        if fd is not None:
            self._poke_r, self._poke_w = nonblocking_pipe()  # wakes the receive thread so that it parks
            self._close_r, self._close_w = nonblocking_pipe()  # readable once closed: wakes every select
            self.pipes = [self._poke_r, self._poke_w, self._close_r, self._close_w]
            self.read_fds = [fd, self._close_r]
            """What a reading caller waits on in ``select``: the transport, and the close."""
            self.rest_time: Callable[[], float] | None = (
                driver.transport.rest_time if driver.capabilities.partial_frames else None
            )
            # closed with the driver: a late select on them (a caller still returning) stays valid
            weakref.finalize(driver, close_fds, *self.pipes)

    def start(self) -> None:
        """Start the receive thread (a daemon)."""
        self.thread = threading.Thread(
            target=self._loop if self.fd is None else self._loop_fd,
            name=f"drempower rx ({self.driver.transport.description})",
            daemon=True,
        )
        self.thread.start()

    # ------------------------------------------------------------------ the reader role

    def enter(self) -> None:
        """Count a caller that may read the transport; a receive thread waiting in ``select`` parks."""
        with self._gate_lock:
            self._callers += 1
            if self._selecting:
                try:
                    os.write(self._poke_w, b"p")
                except OSError:  # the pipe is full (the thread wakes anyway) or closed
                    pass

    def leave(self, lock_timeout: float = -1) -> None:
        """Count a reading caller out (``lock_timeout`` s: a signal handler may interrupt the lock's holder)."""
        held = self._gate_lock.acquire(timeout=lock_timeout)
        try:
            self._callers -= 1
            self._last_caller = _monotonic()
        finally:
            if held:
                self._gate_lock.release()

    def release(self, own: Callable[[], None] | None = None) -> None:
        """Give the role up; wake the sleeping callers (but ``own``), one of which may take it over."""
        self.lock.release()
        sleepers = self.driver._sleepers
        if sleepers:
            for wake in list(sleepers):
                if wake is not own:
                    wake()

    def take_back(self) -> None:
        """Take the role back from an event loop that cannot read now (see :meth:`LoopReader.stalled`)."""
        rd = self.loop_reader
        if rd is not None and rd.stalled():
            rd.let_go()

    def closing(self, lock_timeout: float) -> None:
        """On close: wake every ``select`` on the bus for good, unpark the thread, take the role from
        an event loop (its duplicate descriptor is unregistered in its own thread)."""
        if self.pipes:
            try:
                os.write(self._close_w, b"c")
            except OSError:
                pass
            if self._gate_lock.acquire(timeout=lock_timeout):  # a signal may interrupt its holder
                try:
                    self._gate.notify_all()
                finally:
                    self._gate_lock.release()
        rd = self.loop_reader
        if rd is not None:
            rd.let_go(lock_timeout, force=True)

    def join(self) -> None:
        """Wait (at most 1 s) for the receive thread to end, unless called from it."""
        if self.thread is not None and self.thread is not threading.current_thread():
            self.thread.join(1.0)

    # ------------------------------------------------------------------ feeding the session

    def read_feed(self) -> None:
        """One non-blocking read of the transport, fed to the session (by the reader role's holder, or on a
        virtual clock by the caller letting time pass)."""
        try:
            frames = self.driver.transport.read_nowait()
        except Exception as exc:
            if not self.driver._closed and not self.stopped():  # told once
                self.failed(exc)
            return
        if frames:
            self.feed(frames)

    def take(self, frames: Sequence[Frame], now: float) -> None:
        """Feed received ``frames`` to the session at ``now`` (the driver's lock is held); their events wait
        in the driver's ``_events`` for dispatch after the lock."""
        d = self.driver
        receive, events = d.session.inbox.receive, d._events  # BusSession.receive, one call fewer
        for f in frames:
            try:
                event = receive(f, now)
            except Exception:
                _log.exception("dispatching %r failed", f)
                continue
            if event is not None:
                events.append(event)

    def feed(self, frames: Sequence[Frame]) -> None:
        """Feed received ``frames`` to the session; dispatch their events after the lock."""
        d = self.driver
        if d.frame_taps:
            for f in frames:
                d._tap(f, False)
        s = d.session
        timers = s.timers
        with d._lock:
            changes = timers.changes
            self.take(frames, d._now())
            if s.outbox.frames:
                try:
                    d._flush()
                except Exception as exc:
                    _log.warning("sending after a received frame failed: %s", exc)
            if timers.changes != changes:  # new deadlines: sleeping callers must look again
                for wake in list(d._sleepers):
                    wake()
            events = d._events
            if events:
                d._events = []
        if events:
            d._dispatch(events)

    def stopped(self) -> bool:
        """True once receiving failed (:meth:`failed`): the transport is read no more."""
        return self.driver._failure is not None

    def failed(self, exc: BaseException) -> None:
        """Receiving failed: the bus stops taking requests (sending stays possible, for the stops)."""
        d = self.driver
        _log.error("receive loop on %s stopped: %s", d.transport.description, exc)
        d._failure = exc
        with d._lock:
            d.session.close(BusClosedError(f"the receive loop stopped: {exc}"), final=False)

    # ------------------------------------------------------------------ the thread

    def _loop(self) -> None:
        """The receive thread of a transport without a descriptor: every frame is fed as a caller's are."""
        d = self.driver
        recv, feed = d.transport.recv, self.feed
        try:
            while not d._is_closed():
                frame = recv(RX_SLICE)
                if frame is not None:
                    feed((frame,))
        except Exception as exc:
            if not d._is_closed():
                self.failed(exc)

    def _loop_fd(self) -> None:
        """The receive thread of a transport with a descriptor: reads while no caller does."""
        d, fd = self.driver, self.fd
        assert fd is not None
        fds = [fd, self._poke_r, self._close_r]
        gate, reader = self._gate, self.lock
        try:
            while not d._is_closed() and not self.stopped():
                orphan: LoopReader | None = None
                with gate:
                    while not d._is_closed():
                        rd = self.loop_reader
                        if rd is not None and rd.stalled():  # a loop closed or stopped while holding the role
                            orphan = rd
                            break
                        left = LINGER if self._callers else self._last_caller + LINGER - _monotonic()
                        if left <= 0:
                            break
                        gate.wait(left)
                    if d._is_closed():
                        return
                    if orphan is None:
                        self._selecting = True
                if orphan is not None:
                    if not orphan.let_go():
                        time.sleep(LINGER / 4)  # its callback reads this instant: look again shortly
                    continue
                try:
                    ready = select.select(fds, [], [])[0]  # no timeout: the pipes wake it
                finally:
                    with gate:
                        self._selecting = False
                if d._is_closed() or self.stopped():
                    return
                if self._poke_r in ready:
                    drain(self._poke_r)
                if fd not in ready or not reader.acquire(False):
                    continue  # a caller reads: park
                try:
                    self.read_feed()
                finally:
                    self.release()  # wakes a caller that found the role taken
                if self.stopped():
                    return  # the transport failed (a server gone leaves its socket readable): read no more
        except Exception as exc:
            if not d._is_closed():
                self.failed(exc)
