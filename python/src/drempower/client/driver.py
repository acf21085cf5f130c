"""The driver: runs a :class:`~drempower.client.session.BusSession` over a transport.

It owns the I/O the session leaves out: the transport, the clock, a receive
thread that feeds received frames in, and the waits of the threaded and the
asyncio front ends (:meth:`BusDriver.run`, :meth:`BusDriver.run_async`). One
lock serialises every call into the session; frames are written in the order
the session gives them, under that lock. Closing applies ``stop_on_close``.
"""

from __future__ import annotations

import atexit
import logging
import threading
import time
import weakref
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any, TypeVar

from ..protocol.ids import Frame
from ..protocol.messages import Message, Start, StartImpedance
from ..transports.base import Transport
from . import signals
from .effects import Batch, Op
from .errors import BusClosedError
from .requests import Matcher
from .session import DEFAULT_TIMEOUT, BusSession, MoveRecord, Operation, StartPolicy, StopOnClose, TxOrder
from .state import MotorState, StateCache

if TYPE_CHECKING:
    import asyncio

__all__ = ["BusDriver", "FrameTap"]

_log = logging.getLogger("drempower.client")

T = TypeVar("T")
FrameTap = Callable[[Frame, bool], None]
"""``tap(frame, tx)``: a frame this bus sent (``tx`` True) or received (False)."""

_RX_SLICE = 1.0
"""Longest wait (s) of the receive loop for a frame; closing the transport wakes it sooner."""
_WAIT_SLICE = 1.0
"""Longest single wait (s) of a caller for its operation (the session's deadlines are usually sooner)."""
_SIGNAL_LOCK_WAIT = 0.2
"""Longest wait (s) for a lock when a signal handler closes a bus or sends an estop: the
interrupted code may hold it."""
_monotonic = time.monotonic
_open_drivers: weakref.WeakSet[BusDriver] = weakref.WeakSet()


@atexit.register
def _close_open_buses() -> None:
    """Close (and so apply ``stop_on_close`` to) every bus still open when Python exits."""
    for d in list(_open_drivers):
        d.close()


def _close_stopping_buses() -> None:
    """From a signal handler: close every open bus with ``stop_on_close``, never waiting long on a lock."""
    for d in list(_open_drivers):
        if d.stop_on_close:
            d.close(lock_timeout=_SIGNAL_LOCK_WAIT)


signals.register_stopper(_close_stopping_buses)


def tx_order(transport: Transport) -> TxOrder:
    """How a session over ``transport`` knows that frames are on the wire (see :data:`TxOrder`)."""
    if transport.in_order:
        return "in_order"
    if type(transport).wait_sent is not Transport.wait_sent:
        return "confirmed"
    return "timed"


def _wake(fut: asyncio.Future[Any]) -> None:
    if not fut.done():
        fut.set_result(None)


class BusDriver:
    """One bus: a :class:`BusSession` driven over ``transport`` by a receive thread and the callers' waits.

    The options are the session's (``timeout`` s, ``retries``, ``start``,
    ``stop_on_close``; see :class:`BusSession`). With ``stop_on_close`` a bus
    opened in the main thread also makes SIGTERM and SIGHUP close it (see
    :mod:`drempower.client.signals`); every bus still open when Python exits
    is closed.
    """

    def __init__(
        self,
        transport: Transport,
        *,
        timeout: float = DEFAULT_TIMEOUT,
        retries: int = 0,
        stop_on_close: StopOnClose = True,
        start: StartPolicy = "auto",
        on_unsolicited: Callable[[Frame], None] | None = None,
    ) -> None:
        self.session = BusSession(
            timeout=timeout,
            retries=retries,
            start=start,
            stop_on_close=stop_on_close,
            tx=tx_order(transport),
            bitrate=transport.wire_bitrate,
            tx_latency=transport.tx_latency,
            motor_ids=getattr(transport, "motor_ids", ()),
            now=_monotonic(),
        )
        self.transport = transport
        self.on_unsolicited = on_unsolicited
        """Called in the receive thread with every frame that is no reply to a request and no state frame."""
        self.frame_taps: tuple[FrameTap, ...] = ()
        """Called with every frame this bus sends (``tx`` True) or receives (``tx`` False, in the receive
        thread) as it passes the transport: for recorders. See :meth:`add_tap`."""
        self.on_sent: Callable[[Frame, float], None] | None = None
        """Called after each frame is handed to the transport, with the frame and :func:`time.monotonic`
        of the hand-over (s); keep it short."""
        self.states = StateCache(self.session.states)
        self._lock = threading.Lock()
        self._close_lock = threading.Lock()
        self._closed = False
        self.closed_event = threading.Event()
        """Set when the bus closes."""
        self._failure: BaseException | None = None
        self._sleepers: set[Callable[[], None]] = set()
        """How to wake each caller sleeping until its operation's next deadline."""
        self._thread = threading.Thread(
            target=self._rx_loop, name=f"drempower rx ({transport.description})", daemon=True
        )
        self._thread.start()
        _open_drivers.add(self)
        if stop_on_close:
            signals.install_stop_handlers()

    # ------------------------------------------------------------------ the session's facts

    @property
    def timeout(self) -> float:
        return self.session.timeout

    @timeout.setter
    def timeout(self, value: float) -> None:
        self.session.timeout = value

    @property
    def retries(self) -> int:
        return self.session.retries

    @property
    def stop_on_close(self) -> StopOnClose:
        return self.session.stop_on_close

    @stop_on_close.setter
    def stop_on_close(self, value: StopOnClose) -> None:
        self.session.stop_on_close = value

    @property
    def start_policy(self) -> StartPolicy:
        return self.session.start_policy

    @property
    def matcher(self) -> Matcher:
        return self.session.matcher

    @property
    def moves(self) -> dict[int, MoveRecord]:
        return self.session.moves

    @property
    def traj_mode(self) -> dict[int, int]:
        return self.session.traj_mode

    @property
    def reply_state(self) -> dict[int, bool]:
        return self.session.reply_state

    @property
    def other_hosts(self) -> bool:
        return self.session.other_hosts

    @other_hosts.setter
    def other_hosts(self, value: bool) -> None:
        self.session.other_hosts = value

    @property
    def zero_reply_grace(self) -> float:
        return self.session.zero_reply_grace

    @zero_reply_grace.setter
    def zero_reply_grace(self, value: float) -> None:
        self.session.zero_reply_grace = value

    @property
    def commanded(self) -> frozenset[int]:
        """Motors this bus has sent motion commands or a requested state to (0 = broadcast)."""
        return frozenset(self.session.commanded.copy())

    @property
    def closed(self) -> bool:
        return self._closed

    def check_open(self) -> None:
        """Raise :class:`BusClosedError` if the bus is closed or its receive loop stopped."""
        if self._closed:
            raise BusClosedError(f"the bus ({self.transport.description}) is closed")
        if self._failure is not None:
            raise BusClosedError(f"the receive loop stopped: {self._failure}") from self._failure

    def stop_frames(self) -> list[Frame]:
        """The frames ``stop_on_close`` sends: idle or estop to every commanded motor."""
        return self.session.stop_frames()

    # ------------------------------------------------------------------ taps

    def add_tap(self, tap: FrameTap) -> None:
        """Call ``tap(frame, tx)`` with every frame sent or received from now on (keep it short)."""
        self.frame_taps = (*self.frame_taps, tap)

    def remove_tap(self, tap: FrameTap) -> None:
        """Stop calling ``tap`` (no error when it is not registered)."""
        self.frame_taps = tuple(t for t in self.frame_taps if t is not tap)

    def _tap(self, frame: Frame, tx: bool) -> None:
        for tap in self.frame_taps:
            try:
                tap(frame, tx)
            except Exception:
                _log.exception("frame tap %r failed", tap)

    # ------------------------------------------------------------------ writing

    def _flush(self) -> None:
        """Write what the session wants sent (the lock is held). A failed write fails the operations
        waiting on the session and is raised."""
        s = self.session
        s.now = _monotonic()
        frames = s.data_to_send()
        if not frames:
            return
        try:
            self._write(frames)
        except Exception as exc:
            s.abort(exc)
            raise

    def _write(self, frames: Sequence[Frame]) -> None:
        send, sent, taps = self.transport.send, self.on_sent, self.frame_taps
        for f in frames:
            send(f)
            if taps:
                self._tap(f, True)
            if sent is not None:
                sent(f, _monotonic())

    def _send_frames(self, frames: Sequence[Frame], lock_timeout: float = -1) -> None:
        """Write ``frames`` as they are, after anything queued (no tracking: frames the protocol does not
        define, the stop frames of a close). With ``lock_timeout`` >= 0 (s), frames whose lock does not
        come in that time are written anyway (a signal handler may interrupt the code holding it)."""
        held = self._lock.acquire(timeout=lock_timeout)
        try:
            if held:
                self.session.send_frames(frames)
                self._flush()
            else:
                self._write(frames)
        finally:
            if held:
                self._lock.release()

    # ------------------------------------------------------------------ sending

    def send(self, msg: Message) -> None:
        """Encode (validating) and send one message; never waits for a reply (a start may wait until
        the presets it starts are on the wire: see :meth:`BusSession.send`)."""
        self.send_many((msg,))

    def send_many(self, msgs: Sequence[Message]) -> None:
        """Encode every message first (nothing is sent if one is invalid), then send them in order
        (see :meth:`BusSession.send`)."""
        self.check_open()
        done = threading.Event()
        with self._lock:
            opn = self.session.send(msgs, done.set)
            self._flush()
        if opn is not None:
            self._wait(opn, done)
            opn.result()

    @staticmethod
    def sequenced(msgs: Sequence[Message]) -> bool:
        """Whether sending ``msgs`` involves presets or starts (and so may wait for the wire)."""
        return any(m.cmd == 0x0C or isinstance(m, (Start, StartImpedance)) for m in msgs)

    def send_batch(
        self,
        presets: Sequence[Message],
        start: Start | StartImpedance,
        targets: Sequence[float | None] | None = None,
        move_time: float | None = None,
    ) -> list[int]:
        """Send presets and their start as one atomic batch; returns where the start(s) went."""

        def batch() -> Op[list[int]]:
            where: list[int] = yield Batch(presets, start, targets, move_time)
            return where

        return self.run(batch())

    def estop(self, nodes: Sequence[int]) -> None:
        """Emergency stop: one frame per node (0 = every motor), sent before anything queued, no reply
        awaited. Works even after the receive loop failed; only a closed bus refuses."""
        if self._closed:
            raise BusClosedError(f"the bus ({self.transport.description}) is closed")
        held = self._lock.acquire(timeout=_SIGNAL_LOCK_WAIT)
        try:
            if held:
                self.session.estop(nodes)
                self._flush()
            else:  # the lock is held by the code a signal interrupted: write at once
                from ..protocol.ids import SysCmd
                from ..protocol.messages import SystemCommand

                self._write([SystemCommand(n, SysCmd.ESTOP).encode() for n in nodes])
        finally:
            if held:
                self._lock.release()

    # ------------------------------------------------------------------ running operations

    def submit(self, op: Op[T], on_done: Callable[[], None] | None = None) -> Operation[T]:
        """Start ``op`` in the session now and write what it sends first."""
        self.check_open()
        with self._lock:
            s = self.session
            s.advance(_monotonic())
            opn = s.submit(op, on_done)
            self._flush()
        return opn

    def _step(self, opn: Operation[Any]) -> float | None:
        """Act on the time now; returns how long (s) the caller may sleep before stepping again."""
        confirm = False
        with self._lock:
            s = self.session
            s.advance(_monotonic())
            self._flush()
            if opn.done:
                return None
            confirm = s.awaiting_confirmation
            due = s.next_deadline()
            wait = _WAIT_SLICE if due is None else min(_WAIT_SLICE, max(0.0, due - _monotonic()))
        if confirm:
            ok = self.transport.wait_sent(wait)
            with self._lock:
                s.transmitted(_monotonic(), ok)
                self._flush()
            return 0.0
        return wait

    def _wait(self, opn: Operation[Any], done: threading.Event) -> None:
        wake = done.set
        self._sleepers.add(wake)
        try:
            while not opn.done:
                wait = self._step(opn)
                if wait is None:
                    return
                if wait > 0:
                    done.wait(wait)
                    done.clear()
        except BaseException:  # Ctrl-C: the operation must not take the next request's reply
            with self._lock:
                self.session.cancel(opn)
            raise
        finally:
            self._sleepers.discard(wake)

    def run(self, op: Op[T]) -> T:
        """Run operation ``op`` to completion in the calling thread; returns its result or raises its error."""
        done = threading.Event()
        opn = self.submit(op, done.set)
        if not opn.done:
            self._wait(opn, done)
        return opn.result()

    async def run_async(self, op: Op[T]) -> T:
        """Run operation ``op`` to completion on the running event loop; returns its result or raises its error."""
        import asyncio

        loop = asyncio.get_running_loop()
        holder: list[asyncio.Future[None]] = [loop.create_future()]

        def wake() -> None:
            try:
                loop.call_soon_threadsafe(_wake, holder[0])
            except RuntimeError:  # the loop is closed; nobody waits any more
                pass

        opn = self.submit(op, wake)
        self._sleepers.add(wake)
        try:
            while not opn.done:
                with self._lock:
                    confirm = self.session.awaiting_confirmation
                if confirm:  # the transport's confirmation blocks: not on the event loop
                    await asyncio.to_thread(self._step, opn)
                    continue
                wait = self._step(opn)
                if wait is None:
                    break
                if wait > 0:
                    await asyncio.wait((holder[0],), timeout=wait)
                    if holder[0].done():
                        holder[0] = loop.create_future()
        except BaseException:
            with self._lock:
                self.session.cancel(opn)
            raise
        finally:
            self._sleepers.discard(wake)
        return opn.result()

    # ------------------------------------------------------------------ receiving

    def _rx_loop(self) -> None:
        recv = self.transport.recv
        s = self.session
        lock = self._lock
        states = self.states
        try:
            while not self._closed:
                frame = recv(_RX_SLICE)
                if frame is None:
                    continue
                if self.frame_taps:
                    self._tap(frame, False)
                with lock:
                    changes = s.changes
                    try:
                        event = s.receive(frame, _monotonic())
                    except Exception:
                        _log.exception("dispatching %r failed", frame)
                        continue
                    if s.wants_to_send:
                        try:
                            self._flush()
                        except Exception as exc:
                            _log.warning("sending from the receive loop failed: %s", exc)
                    if s.changes != changes:  # new deadlines: sleeping callers must look again
                        for wake in list(self._sleepers):
                            wake()
                if event is None:
                    continue
                if event.__class__ is MotorState:
                    if states.subscribed:
                        states.notify(event)
                else:
                    hook = self.on_unsolicited
                    if hook is not None:
                        try:
                            hook(event)  # type: ignore[arg-type]
                        except Exception:
                            _log.exception("unsolicited-frame hook %r failed", hook)
        except Exception as exc:
            if not self._closed:
                _log.error("receive loop on %s stopped: %s", self.transport.description, exc)
                self._failure = exc
                with lock:
                    s.close(BusClosedError(f"the receive loop stopped: {exc}"), final=False)

    # ------------------------------------------------------------------ closing

    def close(self, *, lock_timeout: float = -1) -> None:
        """Apply ``stop_on_close``, stop the receive loop, close the transport. Idempotent.

        ``lock_timeout`` (s) bounds the waits for locks (a signal handler may
        run while the code it interrupted holds one): when another close holds
        the bus that long, it is left to finish; the stop frames go out even if
        a send still holds the transport.
        """
        if not self._close_lock.acquire(timeout=lock_timeout):
            return
        try:
            if self._closed:
                return
            stops = self.session.stop_frames() if self._failure is None else []
            try:
                self._send_frames(stops, lock_timeout)
            except Exception as exc:
                _log.warning("stopping the motors on close failed: %s", exc)
            self._closed = True
            self.closed_event.set()
            _open_drivers.discard(self)
            held = self._lock.acquire(timeout=lock_timeout)
            try:
                self.session.close(BusClosedError(f"the bus ({self.transport.description}) was closed"))
            finally:
                if held:
                    self._lock.release()
        finally:
            self._close_lock.release()
        try:
            self.transport.close()
        finally:
            if self._thread is not threading.current_thread():
                self._thread.join(1.0)
