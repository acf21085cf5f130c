"""The driver: runs a :class:`~drempower.client.session.BusSession` over a transport.

It owns the I/O the session leaves out: the transport, the clock, a receive
thread that feeds received frames in, and the waits of the threaded and the
asyncio front ends (:meth:`BusDriver.run`, :meth:`BusDriver.run_async`). One
lock serialises every call into the session; frames are written in the order
the session gives them, under that lock. Closing applies ``stop_on_close``.

How replies reach a waiting caller depends on the transport:

* a transport with a file descriptor (:meth:`Transport.fileno`: the adapter and
  UART serial ports) is read by the caller itself while it waits: the threaded
  caller in ``select``, the asyncio one through ``loop.add_reader``. One reader
  at a time (a lock; other callers wait for their operation or their turn), and
  the receive thread stays parked while callers read and for
  :data:`_LINGER` s after, so a reply costs no thread handoff;
* the in-process simulator with instant delivery answers inside the send
  (``send_collect``): the replies are taken at once, with no wait at all;
* any other transport is read by the receive thread, which hands each finished
  operation to its caller (a reusable event per thread, or the event loop);
* a transport with a virtual clock (the in-process simulator with
  ``clock="virtual"``, :attr:`Transport.virtual_clock`) is the bus's clock: there is
  no receive thread, and wherever a caller would wait it lets that much simulated
  time pass instead (:meth:`BusDriver.pass_time`), taking the frames that arrive
  meanwhile; asyncio calls run the same way, inside the call.

State callbacks and the unsolicited-frame hook run in whichever thread took the
frame, never under the session's lock.
"""

from __future__ import annotations

import atexit
import logging
import math
import os
import select
import threading
import time
import weakref
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any, Protocol, TypeVar, cast

from ..protocol.ids import Frame
from ..protocol.messages import Message, Start, StartImpedance
from ..transports.base import Transport
from ..transports.fds import close_fds, drain, nonblocking_pipe
from . import signals
from .effects import Batch, Op, Runnable, sleep
from .errors import BusClosedError
from .session import DEFAULT_TIMEOUT, BusSession, Operation, StartPolicy, StopOnClose, TxOrder
from .state import MotorState, StateCache

if TYPE_CHECKING:
    import asyncio

__all__ = ["BusDriver", "FrameTap"]

_log = logging.getLogger("drempower.client")

T = TypeVar("T")
FrameTap = Callable[[Frame, bool], None]
"""``tap(frame, tx)``: a frame this bus sent (``tx`` True) or received (False)."""

_RX_SLICE = 1.0
"""Longest wait (s) of the receive loop for a frame on a transport without a descriptor; closing the
transport wakes it sooner. On a transport with one it waits in ``select`` with no timeout."""
_WAIT_SLICE = 1.0
"""Longest single wait (s) of a caller for its operation (the session's deadlines are usually sooner)."""
_LINGER = 0.02
"""How long (s) the receive thread stays parked after a caller read the transport itself: calls in a
row keep it asleep; a frame nobody asked for waits at most this long for it."""
_SIGNAL_LOCK_WAIT = 0.2
"""Longest wait (s) for a lock when a signal handler closes a bus or sends an estop: the
interrupted code may hold it."""
_VIRTUAL_SLICE = 0.05
"""Most simulated time (s) one step of a caller waiting on a virtual clock lets pass before it looks at the
session's deadlines again (other threads may have added sooner ones)."""
_VIRTUAL_TICK = 1e-6
"""Least simulated time (s) such a step lets pass, so that a deadline due now cannot stall it."""
_VIRTUAL_IDLE = 0.01
"""Wall time (s) a caller on a virtual clock waits for other threads when the session has nothing due."""
_VIRTUAL_TURN = 0.005
"""Longest wall wait (s) for the turn to let virtual time pass before a caller looks at its operation again."""
_WALL_POLL = 0.01
"""Longest sleep (s) of :meth:`BusDriver.pass_time` on a wall clock before it checks its condition again."""
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
        if d.session.stop_on_close:
            d.close(lock_timeout=_SIGNAL_LOCK_WAIT)


signals.register_stopper(_close_stopping_buses)


class VirtualClock(Protocol):
    """What a transport with ``virtual_clock`` offers: its simulated time, and letting it pass."""

    def now(self) -> float:
        """The simulated time (s)."""
        ...

    def advance(self, seconds: float, until: Callable[[], bool] | None = None) -> bool:
        """Let up to ``seconds`` pass; end early once a frame is queued (or ``until()``)."""
        ...


def tx_order(transport: Transport) -> TxOrder:
    """How a session over ``transport`` knows that frames are on the wire (see :data:`TxOrder`)."""
    if transport.in_order:
        return "in_order"
    if type(transport).wait_sent is not Transport.wait_sent:
        return "confirmed"
    if transport.unbounded_latency:
        return "answered"
    return "timed"


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


class _LoopReader:
    """The reader role held by an event loop: a duplicate of the transport's descriptor stays
    registered with ``loop.add_reader`` while coroutines of that loop use the bus and for
    :data:`_LINGER` s after (one registration per linger, not per call), and frames are read and fed
    in the loop's callback.

    The role is given back when the loop is idle, when the bus closes, and to a thread that needs to
    read while the loop cannot (not running, closed, or blocked by that very thread). The
    registration is on a duplicate so that closing the transport never leaves a descriptor number
    registered that another file may reuse: the duplicate is unregistered and closed in the loop's
    own thread (or at once when the loop is closed).
    """

    __slots__ = (
        "_busy",
        "_once",
        "driver",
        "due",
        "due_at",
        "fd",
        "last",
        "loop",
        "thread",
        "timer",
        "users",
        "waits",
    )

    def __init__(self, driver: BusDriver, loop: asyncio.AbstractEventLoop) -> None:
        self.driver = driver
        self.loop = loop
        self.thread = threading.get_ident()
        fd = driver._fd
        assert fd is not None
        self.fd = os.dup(fd)
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
            os.close(self.fd)
            self.fd = -1
            raise
        self.timer = self.loop.call_later(_LINGER, self.check)

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
        d = self.driver
        if d._loop_reader is not self:  # given back meanwhile (by another thread): only unregister here
            self.unregister()
            return
        if not self._busy.acquire(False):
            return  # being taken back this instant; the descriptor stays readable for whoever reads next
        try:
            if d._is_closed():
                self.let_go(held=True)
                return
            d._read_feed()
        finally:
            self._busy.release()

    def check(self) -> None:
        """The linger timer: let go once no coroutine used the bus for :data:`_LINGER` s."""
        self.timer = None
        if self.driver._loop_reader is not self:
            return
        left = self.last + _LINGER - _monotonic()
        if self.users or left > 0:
            self.timer = self.loop.call_later(max(left, _LINGER / 4), self.check)
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
            d = self.driver
            if d._loop_reader is self:
                d._loop_reader = None
            if busy:
                d._release_reader()
            d._leave_reading(lock_timeout)
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


class BusDriver:
    """One bus: a :class:`BusSession` driven over ``transport`` by a receive thread and the callers' waits
    (or, on a transport with a virtual clock, by the callers letting its time pass).

    The options are the session's (``timeout`` s, ``retries``, ``start``,
    ``stop_on_close``; see :class:`BusSession`). With ``stop_on_close`` a bus
    opened in the main thread also makes SIGTERM and SIGHUP close it (see
    :mod:`drempower.client.signals`); every bus still open when Python exits
    is closed.
    """

    caller_reads: bool = True
    """Whether callers read a transport with a descriptor themselves (see the module docstring); False
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
        clock: VirtualClock | None = cast(VirtualClock, transport) if transport.virtual_clock else None
        self._clock = clock
        self._now: Callable[[], float] = _monotonic if clock is None else clock.now
        """The bus's clock (s): :func:`time.monotonic`, or the simulated time of a virtual-clock transport."""
        self._vlock = threading.RLock()
        """Held by the caller letting virtual time pass (one at a time)."""
        self.session = BusSession(
            timeout=timeout,
            retries=retries,
            start=start,
            stop_on_close=stop_on_close,
            tx=tx_order(transport),
            bitrate=transport.wire_bitrate,
            tx_latency=transport.tx_latency,
            motor_ids=getattr(transport, "motor_ids", ()),
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
        self.states = StateCache(self.session.states)
        self._lock = threading.Lock()
        self._close_lock = threading.Lock()
        self._closed = False
        self.closed_event = threading.Event()
        """Set when the bus closes."""
        self._failure: BaseException | None = None
        self._sleepers: set[Callable[[], None]] = set()
        """How to wake each caller sleeping until its operation's next deadline."""
        self._events: list[MotorState | Frame] = []
        """Events of frames taken in a sending caller's thread (instant delivery), dispatched after the lock."""
        self._tls = threading.local()
        collect = getattr(transport, "send_collect", None)
        self._collect: Callable[[Frame], list[Frame]] | None = (
            collect if collect is not None and getattr(transport, "instant", False) else None
        )
        fd = transport.fileno() if self.caller_reads and clock is None else None
        self._fd = fd
        self._reader = threading.Lock()
        """Held by whoever reads a transport with a descriptor (a caller, or the receive thread)."""
        self._stopped: tuple[int, ...] = ()
        """Motors an estop was written to without the session lock (see :meth:`estop`)."""
        self._gate_lock = threading.Lock()
        self._gate = threading.Condition(self._gate_lock)
        """Guards the count of reading callers; the parked receive thread waits on it."""
        self._callers = 0
        self._last_caller = 0.0
        self._loop_reader: _LoopReader | None = None
        """The event loop holding the reader role, if one does (see :meth:`run_async`)."""
        self._rx_selecting = False
        self._pipes: list[int] = []
        if fd is not None:
            self._poke_r, self._poke_w = nonblocking_pipe()  # wakes the receive thread so that it parks
            self._close_r, self._close_w = nonblocking_pipe()  # readable once closed: wakes every select
            self._pipes = [self._poke_r, self._poke_w, self._close_r, self._close_w]
            self._read_fds = [fd, self._close_r]
            self._rest_time: Callable[[], float] | None = getattr(transport, "rest_time", None)
            # closed with the driver: a late select on them (a caller still returning) stays valid
            weakref.finalize(self, close_fds, *self._pipes)
        self._thread: threading.Thread | None = None
        if clock is None:  # on a virtual clock frames arrive only while a caller lets time pass: it takes them
            self._thread = threading.Thread(
                target=self._rx_loop if fd is None else self._rx_loop_fd,
                name=f"drempower rx ({transport.description})",
                daemon=True,
            )
            self._thread.start()
        _open_drivers.add(self)
        if stop_on_close:
            signals.install_stop_handlers()

    # ------------------------------------------------------------------ the session's facts

    @property
    def commanded(self) -> frozenset[int]:
        """Motors this bus has sent motion commands or a requested state to (0 = broadcast)."""
        return frozenset(self.session.commanded.copy())

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

    def _flush(self) -> None:
        """Write what the session wants sent (the lock is held). A failed write fails the operations
        waiting on the session and is raised. Replies a transport gives back at once (instant
        delivery) are taken here; their events wait in ``_events`` for :meth:`_dispatch` after the lock."""
        s = self.session
        if self._stopped:  # estops written without the lock: what the session holds must not follow them
            stopped, self._stopped = self._stopped, ()
            s.stopped(stopped)
        s.now = self._now()
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
            self._take(back, self._now())
            s.now = self._now()
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
            self._wait_op(opn)
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
        held = self._lock.acquire(timeout=_SIGNAL_LOCK_WAIT)
        try:
            if held:
                self.session.estop(nodes)
                self._flush()
            else:  # the lock is held by the code a signal interrupted: write at once
                from ..protocol.ids import SysCmd
                from ..protocol.messages import SystemCommand

                self._stopped = (*self._stopped, *nodes)  # the session drops held starts when next entered
                self._write([SystemCommand(n, SysCmd.ESTOP).encode() for n in nodes])
        finally:
            if held:
                self._lock.release()

    # ------------------------------------------------------------------ running operations

    def submit(self, op: Runnable[T], on_done: Callable[[], None] | None = None) -> Operation[T]:
        """Start ``op`` in the session now and write what it sends first."""
        return self._submit_timed(op, on_done)[0]

    def _step(self, opn: Operation[Any]) -> float | None:
        """Act on the time now; returns how long (s) the caller may sleep before stepping again."""
        confirm = False
        with self._lock:
            s = self.session
            s.advance(self._now())
            self._flush()
            events = self._take_events()
            if opn.done:
                wait = None
            else:
                confirm = s.awaiting_confirmation
                wait = self._until(s.next_deadline())
        if events:
            self._dispatch(events)
        if confirm:
            ok = self.transport.wait_sent(wait or 0.0)
            with self._lock:
                s.transmitted(self._now(), ok)
                self._flush()
                events = self._take_events()
            if events:
                self._dispatch(events)
            return 0.0
        return wait

    def _event(self) -> threading.Event:
        """A cleared event of the calling thread (reused across its calls; nested calls get their own)."""
        pool: list[threading.Event] | None = getattr(self._tls, "pool", None)
        if pool is None:
            pool = self._tls.pool = []
        ev = pool.pop() if pool else threading.Event()
        ev.clear()
        return ev

    def _wait_op(self, opn: Operation[Any]) -> None:
        """Wait in the calling thread until ``opn`` is done (it was submitted without ``on_done``)."""
        ev = self._event()
        try:
            opn.on_done = ev.set
            self._wait(opn, ev)
        finally:
            ev.clear()
            self._tls.pool.append(ev)

    def _enter_reading(self) -> None:
        """Count a caller that may read the transport; a receive thread waiting in ``select`` parks."""
        with self._gate_lock:
            self._callers += 1
            if self._rx_selecting:
                try:
                    os.write(self._poke_w, b"p")
                except OSError:  # the pipe is full (the thread wakes anyway) or closed
                    pass

    def _leave_reading(self, lock_timeout: float = -1) -> None:
        """Count a reading caller out (``lock_timeout`` s: a signal handler may interrupt the lock's holder)."""
        held = self._gate_lock.acquire(timeout=lock_timeout)
        try:
            self._callers -= 1
            self._last_caller = _monotonic()
        finally:
            if held:
                self._gate_lock.release()

    def _release_reader(self, own: Callable[[], None] | None = None) -> None:
        self._reader.release()
        sleepers = self._sleepers
        if sleepers:
            for wake in list(sleepers):  # another caller may take over the reading
                if wake is not own:
                    wake()

    def _until(self, due: float | None) -> float:
        """How long (s) a caller may wait for the session's next deadline ``due`` (at most :data:`_WAIT_SLICE`)."""
        return _WAIT_SLICE if due is None else min(_WAIT_SLICE, max(0.0, due - self._now()))

    def _submit_timed(self, op: Runnable[T], on_done: Callable[[], None] | None) -> tuple[Operation[T], float | None]:
        """:meth:`submit`, also returning how long (s) the caller may wait before stepping (None: step now)."""
        self.check_open()
        with self._lock:
            s = self.session
            s.advance(self._now())
            opn = s.submit(op, on_done)
            self._flush()
            events = self._take_events()
            wait = None
            if not opn.done and not s.awaiting_confirmation:
                wait = self._until(s.next_deadline())
        if events:
            self._dispatch(events)
        return opn, wait

    def _run_reading(self, op: Runnable[T]) -> T:
        """:meth:`run` on a transport with a descriptor: the reader role is taken before the requests go
        out, so that once they are written this thread goes straight to ``select``. A caller that does
        not get the role sleeps on its event until its operation is done or the role is free."""
        reader = self._reader
        if self._loop_reader is not None:
            self._take_back()
        self._enter_reading()
        reading = reader.acquire(False)
        ev: threading.Event | None = None
        wake: Callable[[], None] | None = None
        if not reading:
            ev = self._event()
            wake = ev.set
            self._sleepers.add(wake)
        opn: Operation[T] | None = None
        try:
            opn, wait = self._submit_timed(op, wake)
            while not opn.done:
                if not reading:
                    reading = reader.acquire(False)
                if reading:
                    self._read_until(opn, wait)
                    if self._is_closed():
                        break
                    continue
                assert ev is not None
                wait = self._step(opn)
                if wait is None:
                    break
                if wait > 0:
                    ev.wait(wait)
                    ev.clear()
                wait = None
        except BaseException:
            if opn is not None:
                with self._lock:
                    self.session.cancel(opn)
            raise
        finally:
            if reading:
                self._release_reader(wake)
            self._leave_reading()
            if ev is not None:
                self._sleepers.discard(ev.set)
                ev.clear()
                self._tls.pool.append(ev)
        self._end_closed(opn)
        return opn.result()

    def _end_closed(self, opn: Operation[Any]) -> None:
        """A wait that stopped because the bus closed: fail ``opn`` if the close has not yet."""
        if not opn.done:
            with self._lock:
                self.session.cancel(opn, BusClosedError(f"the bus ({self.transport.description}) was closed"))

    def _wait(self, opn: Operation[Any], done: threading.Event) -> None:
        """Wait in the calling thread until ``opn`` is done: on a transport with a descriptor, reading it
        whenever no other caller does; else (and meanwhile) sleeping on ``done`` until the session's next
        deadline or a wake-up."""
        if self._clock is not None:
            self._wait_virtual(opn)
            return
        wake = done.set
        reads = self._fd is not None
        self._sleepers.add(wake)
        if reads:
            if self._loop_reader is not None:
                self._take_back()
            self._enter_reading()
        try:
            while not opn.done:
                if reads and self._reader.acquire(False):
                    try:
                        self._read_until(opn, None)
                    finally:
                        self._release_reader(wake)
                    if self._is_closed():
                        break
                    continue
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
            if reads:
                self._leave_reading()
        self._end_closed(opn)

    def _run_virtual(self, op: Runnable[T]) -> T:
        """:meth:`run` on a virtual clock: replies came inside the send; what else the operation waits
        for, simulated time brings (:meth:`_wait_virtual`)."""
        opn = self.submit(op)
        if not opn.done:
            self._wait_virtual(opn)
        return opn.result()

    def pass_time(self, seconds: float, until: Callable[[], bool] | None = None) -> None:
        """Let ``seconds`` of the bus's time pass, taking the frames that arrive meanwhile; end early once
        ``until()`` is true (checked after each frame taken). On a virtual clock no wall time passes; on a
        wall clock it sleeps (the receive thread takes the frames)."""
        self.check_open()
        if self._clock is None:
            end = _monotonic() + seconds
            while not (until is not None and until()) and (left := end - _monotonic()) > 0:
                self.closed_event.wait(min(left, _WALL_POLL))
                if self._closed:
                    return
            return
        opn = self.submit(sleep(seconds))
        if not opn.done:
            self._wait_virtual(opn, until)
        if not opn.done:
            with self._lock:
                self.session.cancel(opn)

    def _wait_virtual(self, opn: Operation[Any], until: Callable[[], bool] | None = None) -> None:
        """Let simulated time pass until ``opn`` is done (or ``until()``): up to the session's next deadline
        at a time, ending early when a frame arrives, which is fed at once. One caller lets time pass at a
        time (the lock); the others look at their operation meanwhile, which that caller's frames may finish."""
        clock = self._clock
        assert clock is not None
        session, vlock = self.session, self._vlock
        try:
            while not opn.done and not self._closed:
                if not vlock.acquire(timeout=_VIRTUAL_TURN):
                    continue
                try:
                    if self._take_queued(opn) or (until is not None and until()):
                        break
                    wait = self._step(opn)
                    if wait is None or self._take_queued(opn) or (until is not None and until()):
                        break
                    with self._lock:
                        idle = session.next_deadline() is None
                    if not idle:
                        clock.advance(min(max(wait, _VIRTUAL_TICK), _VIRTUAL_SLICE))
                        self._take_queued(opn)
                finally:
                    vlock.release()
                if idle:  # nothing is due: what it waits for is another thread's to do; then time goes on
                    time.sleep(_VIRTUAL_IDLE)
                    with vlock:
                        clock.advance(_VIRTUAL_SLICE)
                        self._take_queued(opn)
        except BaseException:  # Ctrl-C: the operation must not take the next request's reply
            with self._lock:
                session.cancel(opn)
            raise
        if self._closed:
            self._end_closed(opn)

    def _take_queued(self, opn: Operation[Any]) -> bool:
        """Feed the frames a virtual-clock transport queued while time passed (there is no receive
        thread); returns whether ``opn`` is done."""
        try:
            frames = self.transport.read_nowait()
        except Exception as exc:
            if not self._closed:
                self._rx_failed(exc)
            return opn.done
        if frames:
            self._feed(frames)
        return opn.done

    def _read_until(self, opn: Operation[Any], wait: float | None) -> None:
        """Read and feed frames (the reader lock is held) until ``opn`` is done or the bus closes;
        the first wait is ``wait`` s (None: as the session says)."""
        fds, rest = self._read_fds, self._rest_time
        while not opn.done and not self._is_closed():
            if wait is None:
                wait = self._step(opn)
                if wait is None:
                    return
            if wait > 0:
                try:
                    select.select(fds, [], [], wait)
                except (OSError, ValueError):  # closed under us
                    if self._is_closed():
                        return
                    raise
            wait = None
            self._read_feed()
            if rest is not None and not opn.done:
                pause = rest()
                if pause > 0:  # part of a frame is here: let the rest arrive rather than wake per byte
                    time.sleep(pause)

    def _read_feed(self) -> None:
        """One non-blocking read of the transport, fed to the session (the reader lock is held)."""
        try:
            frames = self.transport.read_nowait()
        except Exception as exc:
            if not self._closed:
                self._rx_failed(exc)
            return
        if frames:
            self._feed(frames)

    def _take(self, frames: Sequence[Frame], now: float) -> None:
        """Feed received ``frames`` to the session at ``now`` (the lock is held); their events wait in
        ``_events`` for dispatch after the lock."""
        receive, events = self.session.receive, self._events
        for f in frames:
            try:
                event = receive(f, now)
            except Exception:
                _log.exception("dispatching %r failed", f)
                continue
            if event is not None:
                events.append(event)

    def _feed(self, frames: Sequence[Frame]) -> None:
        """Feed received ``frames`` to the session; dispatch their events after the lock."""
        if self.frame_taps:
            for f in frames:
                self._tap(f, False)
        s = self.session
        with self._lock:
            changes = s.changes
            self._take(frames, self._now())
            if s.wants_to_send:
                try:
                    self._flush()
                except Exception as exc:
                    _log.warning("sending after a received frame failed: %s", exc)
            if s.changes != changes:  # new deadlines: sleeping callers must look again
                for wake in list(self._sleepers):
                    wake()
            events = self._take_events()
        if events:
            self._dispatch(events)

    def _rx_failed(self, exc: BaseException) -> None:
        _log.error("receive loop on %s stopped: %s", self.transport.description, exc)
        self._failure = exc
        with self._lock:
            self.session.close(BusClosedError(f"the receive loop stopped: {exc}"), final=False)

    def run(self, op: Runnable[T]) -> T:
        """Run operation ``op`` to completion in the calling thread; returns its result or raises its error."""
        if self._fd is not None:
            return self._run_reading(op)
        if self._clock is not None:
            return self._run_virtual(op)
        opn = self.submit(op)
        if not opn.done:
            self._wait_op(opn)
        return opn.result()

    async def run_async(self, op: Runnable[T]) -> T:
        """Run operation ``op`` to completion on the running event loop; returns its result or raises its error.

        On a transport with a descriptor the event loop takes the reader role and keeps the descriptor
        registered (``loop.add_reader``) while its coroutines use the bus and :data:`_LINGER` s after:
        replies are read and fed in the loop's callback, which wakes the waiting coroutine directly.
        When another thread reads, and on other transports, the coroutine is woken by the thread that
        finished its operation. No thread per call. On a virtual clock the call runs as :meth:`run` does
        (simulated time passes inside it).
        """
        if self._clock is not None:
            return self.run(op)
        import asyncio

        loop = asyncio.get_running_loop()
        if self._fd is not None:
            rd = self._loop_reader
            if rd is None or rd.loop is not loop or rd.fd < 0:
                rd = self._attach_loop(loop)
            if rd is not None:
                return await self._run_async_held(op, rd)
        return await self._run_async_woken(op, loop)

    def _attach_loop(self, loop: asyncio.AbstractEventLoop) -> _LoopReader | None:
        """Give the reader role to ``loop`` if it is free (None when another thread or loop holds it)."""
        self.check_open()
        self._take_back()
        self._enter_reading()
        if not self._reader.acquire(False):
            self._leave_reading()
            return None
        if self._is_closed():
            self._release_reader()
            self._leave_reading()
            raise BusClosedError(f"the bus ({self.transport.description}) is closed")
        rd = _LoopReader(self, loop)
        self._loop_reader = rd
        try:
            rd.register()
        except BaseException:
            self._loop_reader = None
            self._release_reader()
            self._leave_reading()
            raise
        return rd

    def _take_back(self) -> None:
        """Take the reader role back from an event loop that cannot read now (see :meth:`_LoopReader.stalled`)."""
        rd = self._loop_reader
        if rd is not None and rd.stalled():
            rd.let_go()

    async def _run_async_held(self, op: Runnable[T], rd: _LoopReader) -> T:
        """:meth:`run_async` while this coroutine's event loop holds the reader role."""

        loop = rd.loop
        holder: list[asyncio.Future[None]] = [loop.create_future()]
        wake = _waker(loop, holder)
        rd.users += 1
        self._sleepers.add(wake)  # new deadlines (a frame fed in the callback) must be looked at
        opn: Operation[T] | None = None
        try:
            opn, wait = self._submit_timed(op, wake)
            while not opn.done:
                if wait is None:
                    wait = await self._step_async(opn)
                    if wait is None:
                        break
                if wait > 0:
                    fut = holder[0]
                    if not fut.done():
                        rd.wake_at(wake, _monotonic() + wait)
                        await fut
                    holder[0] = loop.create_future()
                wait = None
                if self._is_closed():
                    break
        except BaseException:
            if opn is not None:
                with self._lock:
                    self.session.cancel(opn)
            raise
        finally:
            self._sleepers.discard(wake)
            rd.waits.pop(wake, None)
            rd.users -= 1
            rd.last = _monotonic()
        self._end_closed(opn)
        return opn.result()

    async def _step_async(self, opn: Operation[Any]) -> float | None:
        """:meth:`_step` from a coroutine: a transport's blocking wait for a confirmation runs in a worker
        thread, never on the event loop (then 0.0: step again at once)."""
        with self._lock:
            confirm = self.session.awaiting_confirmation
        if confirm:
            import asyncio

            await asyncio.to_thread(self._step, opn)
            return 0.0
        return self._step(opn)

    async def _run_async_woken(self, op: Runnable[T], loop: asyncio.AbstractEventLoop) -> T:
        """:meth:`run_async` when the event loop does not hold the reader role: a coroutine that gets the
        role reads on the loop through ``loop.add_reader`` while it waits; others (and every coroutine on a
        transport without a descriptor) are woken by the thread that finished their operation."""

        holder: list[asyncio.Future[None]] = [loop.create_future()]
        wake = _waker(loop, holder)

        def readable() -> None:
            _wake(holder[0])

        fd = self._fd
        reading = False
        if fd is not None:
            self._enter_reading()
            if self._reader.acquire(False):
                reading = True
                loop.add_reader(fd, readable)
        if not reading:  # woken when the reader's turn may be ours, or a deadline changed
            self._sleepers.add(wake)
        opn: Operation[T] | None = None
        try:
            opn, wait = self._submit_timed(op, wake)
            while not opn.done:
                if fd is not None and not reading and self._reader.acquire(False):
                    reading = True
                    loop.add_reader(fd, readable)
                    self._read_feed()
                    continue
                if wait is None:
                    wait = await self._step_async(opn)
                    if wait is None:
                        break
                if wait > 0:
                    fut = holder[0]
                    if not fut.done():
                        timer = loop.call_later(wait, _wake, fut)
                        try:
                            await fut
                        finally:
                            timer.cancel()
                    if reading:
                        self._read_feed()
                    holder[0] = loop.create_future()
                    wait = None
                    continue
                wait = None
                if reading:
                    if self._is_closed():
                        break
                    self._read_feed()
        except BaseException:
            if opn is not None:
                with self._lock:
                    self.session.cancel(opn)
            raise
        finally:
            self._sleepers.discard(wake)
            if reading:
                loop.remove_reader(fd)  # type: ignore[arg-type]
                self._release_reader(wake)
            if fd is not None:
                self._leave_reading()
        self._end_closed(opn)
        return opn.result()

    # ------------------------------------------------------------------ receiving

    def _rx_loop(self) -> None:
        """The receive thread of a transport without a descriptor: every frame is fed as a caller's are."""
        recv, feed = self.transport.recv, self._feed
        try:
            while not self._closed:
                frame = recv(_RX_SLICE)
                if frame is not None:
                    feed((frame,))
        except Exception as exc:
            if not self._closed:
                self._rx_failed(exc)

    def _rx_loop_fd(self) -> None:
        """The receive thread of a transport with a descriptor: reads while no caller does."""
        fd = self._fd
        assert fd is not None
        fds = [fd, self._poke_r, self._close_r]
        gate, reader = self._gate, self._reader
        try:
            while not self._is_closed():
                orphan: _LoopReader | None = None
                with gate:
                    while not self._is_closed():
                        rd = self._loop_reader
                        if rd is not None and rd.stalled():  # a loop closed or stopped while holding the role
                            orphan = rd
                            break
                        left = _LINGER if self._callers else self._last_caller + _LINGER - _monotonic()
                        if left <= 0:
                            break
                        gate.wait(left)
                    if self._is_closed():
                        return
                    if orphan is None:
                        self._rx_selecting = True
                if orphan is not None:
                    if not orphan.let_go():
                        time.sleep(_LINGER / 4)  # its callback reads this instant: look again shortly
                    continue
                try:
                    ready = select.select(fds, [], [])[0]  # no timeout: the pipes wake it
                finally:
                    with gate:
                        self._rx_selecting = False
                if self._is_closed():
                    return
                if self._poke_r in ready:
                    drain(self._poke_r)
                if fd not in ready or not reader.acquire(False):
                    continue  # a caller reads: park
                try:
                    self._read_feed()
                finally:
                    self._release_reader()  # wakes a caller that found the role taken
        except Exception as exc:
            if not self._closed:
                self._rx_failed(exc)

    # ------------------------------------------------------------------ closing

    def _let_go_loop(self, lock_timeout: float) -> None:
        """On close: the event loop holding the reader role gives it up (its duplicate descriptor is
        unregistered in its own thread, so closing the transport never waits for the loop)."""
        rd = self._loop_reader
        if rd is not None:
            rd.let_go(lock_timeout, force=True)

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
            stops = self.session.stop_frames()  # tried after a receive failure too: writing may still work
            try:
                self._send_frames(stops, lock_timeout)
            except Exception as exc:
                _log.warning("stopping the motors on close failed: %s", exc)
            self._closed = True
            self.closed_event.set()
            if self._pipes:
                try:
                    os.write(self._close_w, b"c")  # wakes every select on this bus, for good
                except OSError:
                    pass
                if self._gate_lock.acquire(timeout=lock_timeout):  # a signal may interrupt its holder
                    try:
                        self._gate.notify_all()
                    finally:
                        self._gate_lock.release()
            self._let_go_loop(lock_timeout)
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
            if self._thread is not None and self._thread is not threading.current_thread():
                self._thread.join(1.0)
