"""The driver: runs a :class:`~drempower.client.engine.session.BusSession` over a transport.

It owns the I/O the session leaves out: the transport, the clock, writing what the session sends and
feeding it what arrives, and the callers' waits, in one flavour per kind of caller and clock:
:mod:`.wait_threaded` (a thread waits), :mod:`.wait_asyncio` (a coroutine awaits) and
:mod:`.wait_virtual` (the transport's simulated time passes while a caller waits), chosen when the
driver is made (the asyncio one on the first call from an event loop). On a wall clock a receive
thread (:mod:`.receiver`) takes the frames no caller reads. One lock serialises every call into the
session; frames are written in the order the session gives them, under that lock. The in-process
simulator with instant delivery answers inside the send (``send_collect``): its replies are taken at
once, with no wait at all. Closing applies ``stop_on_close``.

State callbacks and the unsolicited-frame hook run in whichever thread took the frame, never under the
session's lock.
"""

from __future__ import annotations

import logging
import sys
import threading
import time
from collections.abc import Callable, Coroutine, Sequence
from typing import TYPE_CHECKING, Any, TypeVar

from ...errors import BusClosedError
from ...protocol.ids import Frame, SysCmd
from ...protocol.messages import Message, Start, StartImpedance, SystemCommand
from ...transports.base import Transport
from ...transports.capabilities import Capabilities
from ..engine.effects import Batch, Op, Runnable
from ..engine.session import DEFAULT_TIMEOUT, BusSession, Operation, StartPolicy, StopOnClose, TxOrder
from ..engine.state import MotorState, StateCache
from . import open_buses, signals
from .handoff import Handoff
from .receiver import LINGER as _LINGER  # noqa: F401  (how long the receive thread stays parked, s)
from .receiver import Receiver
from .wait_threaded import ThreadWaits
from .wait_virtual import VirtualWaits

if TYPE_CHECKING:
    from .wait_asyncio import LoopReader

__all__ = ["BusDriver", "FrameTap"]

_log = logging.getLogger("drempower.client")

T = TypeVar("T")
FrameTap = Callable[[Frame, bool], None]
"""``tap(frame, tx)``: a frame this bus sent (``tx`` True) or received (False)."""
AsyncRun = Callable[[Runnable[Any]], Coroutine[Any, Any, Any]]

_monotonic = time.monotonic
_HANDOFF_WAIT = 2.0
"""Longest wait (s) of a close handed to a thread (see :mod:`.handoff`) for the bus lock."""


def tx_order(caps: Capabilities) -> TxOrder:
    """How a session over a transport of capabilities ``caps`` knows that frames are on the wire
    (see :data:`TxOrder`)."""
    if caps.in_order:
        return "in_order"
    if caps.confirms_sent:
        return "confirmed"
    if caps.unbounded_latency:
        return "answered"
    return "timed"


class BusDriver:
    """One bus: a :class:`BusSession` driven over ``transport`` by a receive thread and the callers' waits
    (or, on a transport with a virtual clock, by the callers letting its time pass).

    The options are the session's (``timeout`` s, ``retries``, ``start``,
    ``stop_on_close``; see :class:`BusSession`). With ``stop_on_close`` a bus
    opened in the main thread also makes SIGTERM and SIGHUP close it (see
    :mod:`drempower.client.driver.signals`); every bus still open when Python exits
    is closed.
    """

    caller_reads: bool = True
    """Whether callers read a transport with a descriptor themselves (see :mod:`.receiver`); False
    leaves every read to the receive thread, which hands replies over (``bench/bench_table.py`` measures
    both). Read when a driver is made."""

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
        caps = transport.capabilities
        self.capabilities = caps
        """What the transport declared it can do, read once."""
        clock = transport.clock() if caps.virtual_clock else None
        if caps.virtual_clock and clock is None:
            raise TypeError(f"{type(transport).__name__} declares a virtual clock but its clock() gives none")
        self._clock = clock
        self._now: Callable[[], float] = _monotonic if clock is None else clock.now
        """The bus's clock (s): :func:`time.monotonic`, or the simulated time of a virtual-clock transport."""
        self.session = BusSession(
            timeout=timeout,
            retries=retries,
            start=start,
            stop_on_close=stop_on_close,
            tx=tx_order(caps),
            bitrate=caps.wire_bitrate,
            tx_latency=caps.tx_latency,
            motor_ids=caps.motor_ids,
            now=self._now(),
        )
        self.transport = transport
        self.on_unsolicited = on_unsolicited
        """Called with every frame that is no reply to a request and no state frame (in the thread that took it)."""
        self.frame_taps: tuple[FrameTap, ...] = ()
        """Called with every frame this bus sends (``tx`` True) or receives (``tx`` False, in the
        thread that took it) as it passes the transport: for recorders. See :meth:`add_tap`."""
        self.on_sent: Callable[[Frame, float], None] | None = None
        """Called after each frame is handed to the transport, with the frame and :func:`time.monotonic`
        of the hand-over (s); keep it short."""
        self.states = StateCache(self.session.known.states)
        self._lock = threading.RLock()
        """The session's lock; an RLock so that a signal handler can tell that it interrupted its own
        thread's bus work (:meth:`_interrupted_here`). Frame taps and ``on_sent`` run while it is held:
        they must not send."""
        self._close_lock = threading.Lock()
        self._closed = False
        self._handoff = Handoff(lambda: self.transport.description)
        """The threads doing what signal handlers handed over (estops, the close): a close waits for them."""
        self._failure: BaseException | None = None
        self._sleepers: set[Callable[[], None]] = set()
        """How to wake each caller sleeping until its operation's next deadline."""
        self._events: list[MotorState | Frame] = []
        """Events of frames taken in a sending caller's thread (instant delivery), dispatched after the lock."""
        self._collect: Callable[[Frame], list[Frame]] | None = transport.send_collect if caps.answers_in_send else None
        self._stopped: tuple[int, ...] = ()
        """Motors an estop was written to without the session lock (see :meth:`estop`)."""
        self._fd = transport.fileno() if self.caller_reads and clock is None else None
        """The descriptor callers read themselves (None: the receive thread reads, or a virtual clock)."""
        self._rx = Receiver(self, self._fd)
        self._reader = self._rx.lock
        """The reader role of a transport with a descriptor (see :mod:`.receiver`)."""
        self._waits: ThreadWaits | VirtualWaits
        self._run_async: AsyncRun | None = None
        """The asyncio flavour's run, made with the driver when asyncio is loaded, else on the first call
        from an event loop (see :meth:`run_async`)."""
        if clock is None:
            self._waits = ThreadWaits(self, self._rx)
            if "asyncio" in sys.modules:  # likely an asyncio program: its flavour now, not in its first call
                self._asyncio_waits()
            self._rx.start()
        else:  # frames arrive only while a caller lets time pass: it takes them
            self._waits = VirtualWaits(self, self._rx, clock)
            self._run_async = self._waits.run_async
        self.run = self._waits.run  # type: ignore[method-assign]  # run's body, bound: one call fewer per operation
        open_buses.register(self)
        if stop_on_close:
            signals.install_stop_handlers()

    # ------------------------------------------------------------------ the session's facts

    @property
    def commanded(self) -> frozenset[int]:
        """Motors this bus has sent motion commands or a requested state to (0 = broadcast)."""
        return frozenset(self.session.known.commanded.copy())

    @property
    def closed(self) -> bool:
        return self._closed

    @property
    def virtual(self) -> bool:
        """True when the bus runs on its transport's simulated time (see :meth:`now`)."""
        return self._clock is not None

    def now(self) -> float:
        """The bus's clock (s): :func:`time.monotonic`, or the simulated time of a transport with a virtual
        clock (``open_bus("sim", clock="virtual")``). Session times and state timestamps are on it."""
        return self._now()

    def _is_closed(self) -> bool:
        return self._closed

    @property
    def _loop_reader(self) -> LoopReader | None:
        """The event loop holding the reader role, if one does (see :mod:`.wait_asyncio`)."""
        return self._rx.loop_reader

    def check_open(self) -> None:
        """Raise :class:`BusClosedError` if the bus is closed or its receive loop stopped."""
        if self._closed:
            raise BusClosedError(f"the bus ({self.transport.description}) is closed")
        if self._failure is not None:
            raise BusClosedError(f"the receive loop stopped: {self._failure}") from self._failure

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

    def _flush(self, now: float | None = None) -> None:
        """Write what the session wants sent (the lock is held) at ``now`` (s; None: read the clock). A
        failed write fails the operations waiting on the session and is raised. Replies a transport gives
        back at once (instant delivery) are taken here; their events wait in ``_events`` for
        :meth:`_dispatch` after the lock."""
        s = self.session
        if self._stopped:  # estops written without the lock: what the session holds must not follow them
            stopped, self._stopped = self._stopped, ()
            s.stopped(stopped)
        timers = s.timers  # the session's time (s.now), set without the property on every request
        timers.now = self._now() if now is None else now
        frames = s.data_to_send()
        while frames:
            try:
                back = self._write(frames, self._collect)
            except Exception as exc:
                s.abort(exc)
                raise
            if not back:
                return
            if self.frame_taps:
                for f in back:
                    self._tap(f, False)
            now = self._now()
            self._rx.take(back, now)
            if not s.outbox.frames:  # the replies queued nothing more (the commonest)
                return
            timers.now = now  # what they queued is sent at the time they came
            frames = s.data_to_send()

    def _write(self, frames: Sequence[Frame], collect: Callable[[Frame], list[Frame]] | None = None) -> list[Frame]:
        """Hand ``frames`` to the transport; with ``collect``, returns the frames it gave back at once."""
        send, sent, taps = self.transport.send, self.on_sent, self.frame_taps
        back: list[Frame] = []
        for f in frames:
            if collect is not None:
                got = collect(f)
                if got:
                    back.extend(got)
            else:
                send(f)
            if taps:
                self._tap(f, True)
            if sent is not None:
                sent(f, _monotonic())
        return back

    def _take_events(self) -> list[MotorState | Frame] | None:
        """The events waiting for dispatch (the lock is held), or None."""
        if not self._events:
            return None
        events, self._events = self._events, []
        return events

    def _dispatch(self, events: Sequence[MotorState | Frame]) -> None:
        """Hand state frames to the subscribers and other unanswered frames to the hook (no lock held)."""
        states = self.states
        for event in events:
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

    def _interrupted_here(self) -> bool:
        """True when the calling thread holds the bus lock: it runs a signal handler that interrupted its own
        bus work, perhaps in the middle of a transport's write. Writing now could wait for that write's
        lock forever or cut its frame in two: the stopping is handed to a thread (:mod:`.handoff`)."""
        return bool(self._lock._is_owned())  # type: ignore[attr-defined]

    def _close_handed(self) -> None:
        """The close a signal handler handed over (see :mod:`.handoff`): once the interrupted code lets the
        bus go, after what the handlers handed over until then (a chained handler's estop)."""
        if self._lock.acquire(timeout=_HANDOFF_WAIT):
            self._lock.release()
        self.close(lock_timeout=_HANDOFF_WAIT)

    def _send_frames(self, frames: Sequence[Frame], lock_timeout: float = -1) -> None:
        """Write ``frames`` as they are, after anything queued (no tracking: frames the protocol does not
        define, the stop frames of a close). With ``lock_timeout`` >= 0 (s), frames whose lock does not
        come in that time are written anyway (a signal handler may interrupt the code holding it)."""
        held = self._lock.acquire(timeout=lock_timeout)
        events = None
        try:
            if held:
                self.session.send_frames(frames)
                self._flush()
                events = self._take_events()
            else:
                self._write(frames)
        finally:
            if held:
                self._lock.release()
        if events:
            self._dispatch(events)

    # ------------------------------------------------------------------ sending

    def send(self, msg: Message) -> None:
        """Encode (validating) and send one message; never waits for a reply (a start may wait until
        the presets it starts are on the wire: see :meth:`BusSession.send`)."""
        self.send_many((msg,))

    def send_many(self, msgs: Sequence[Message]) -> None:
        """Encode every message first (nothing is sent if one is invalid), then send them in order
        (see :meth:`BusSession.send`)."""
        self.check_open()
        with self._lock:
            opn = self.session.send(msgs)
            self._flush()
            events = self._take_events()
        if events:
            self._dispatch(events)
        if opn is not None and not opn.done:
            self._waits.wait(opn)
        if opn is not None:
            opn.result()

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
        if self._interrupted_here():  # the estop goes out as soon as the interrupted code lets the bus go
            self._handoff.later(self._estop, nodes, _HANDOFF_WAIT)
            return
        self._estop(nodes, open_buses.SIGNAL_LOCK_WAIT)

    def _estop(self, nodes: Sequence[int], lock_wait: float) -> None:
        """:meth:`estop`, waiting ``lock_wait`` s at most for another thread's write in progress."""
        held = self._lock.acquire(timeout=lock_wait)
        try:
            if held:
                self.session.estop(nodes)
                self._flush()
            else:  # the lock is held by the code a signal interrupted: write at once
                self._stopped = (*self._stopped, *nodes)  # the session drops held starts when next entered
                self._write([SystemCommand(n, SysCmd.ESTOP).encode() for n in nodes])
        finally:
            if held:
                self._lock.release()

    # ------------------------------------------------------------------ running operations

    def run(self, op: Runnable[T]) -> T:
        """Run operation ``op`` to completion in the calling thread; returns its result or raises its error."""
        return self._waits.run(op)

    async def run_async(self, op: Runnable[T]) -> T:
        """Run operation ``op`` to completion on the running event loop; returns its result or raises its
        error. No thread per call (see :mod:`.wait_asyncio`); on a virtual clock the call runs as
        :meth:`run` does (simulated time passes inside it)."""
        run = self._run_async or self._asyncio_waits()
        result: T = await run(op)
        return result

    def _asyncio_waits(self) -> AsyncRun:
        """Make the asyncio flavour (its module imports asyncio: only programs that use it load it)."""
        from .wait_asyncio import AsyncWaits

        run = self._run_async = AsyncWaits(self, self._rx).run
        return run

    def pass_time(self, seconds: float, until: Callable[[], bool] | None = None) -> None:
        """Let ``seconds`` of the bus's time pass, taking the frames that arrive meanwhile; end early once
        ``until()`` is true (checked after each frame taken). On a virtual clock no wall time passes; on a
        wall clock it sleeps (the receive thread takes the frames)."""
        self.check_open()
        self._waits.pass_time(seconds, until)

    def submit(self, op: Runnable[T], on_done: Callable[[], None] | None = None) -> Operation[T]:
        """Start ``op`` in the session now and write what it sends first."""
        return self._waits.submit(op, on_done)[0]

    # ------------------------------------------------------------------ closing

    def close(self, *, lock_timeout: float = -1) -> None:
        """Apply ``stop_on_close``, stop the receive loop, close the transport. Idempotent.

        ``lock_timeout`` (s) bounds the waits for locks (a signal handler may
        run while the code it interrupted holds one): when another close holds
        the bus that long, it is left to finish; the stop frames go out even if
        a send still holds the transport. Called by a signal handler that
        interrupted this thread's own bus work, it returns at once and a thread
        of its own closes the bus once that work lets the lock go.
        """
        if self._interrupted_here():
            if not self._closed and not self._handoff.closing():
                self._handoff.closer = self._handoff.later(self._close_handed)
            return
        if self._handoff.threads:  # what signal handlers handed over goes first: their estops, their close
            self._handoff.wait(lock_timeout if lock_timeout >= 0 else 2 * _HANDOFF_WAIT)
            if self._closed:
                return
            if lock_timeout < 0:  # that close failed, or waits still: close here, never for good
                lock_timeout = _HANDOFF_WAIT
        if not self._close_lock.acquire(timeout=lock_timeout):
            return
        try:
            if self._closed:
                return
            stops = self.session.stop_frames()  # tried after a receive failure too: writing may still work
            try:
                self._send_frames(stops, lock_timeout)
            except Exception as exc:
                _log.warning("stopping the motors on close failed: %s", exc)
            self._closed = True
            self._rx.closing(lock_timeout)
            open_buses.forget(self)
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
            self._rx.join()
