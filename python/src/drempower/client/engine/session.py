"""The bus session: everything the client knows and decides about one bus, with no I/O.

:class:`BusSession` is sans-I/O, in the manner of h11: no threads, locks,
clocks, sockets or sleeps. A driver (:mod:`drempower.client.driver.bus_driver`) feeds it:

* operations (generators of :mod:`~drempower.client.engine.effects`, see
  :meth:`BusSession.submit`) and messages (:meth:`BusSession.send`), which
  become frames to write, taken with :meth:`BusSession.data_to_send`;
* received frames with their time (:meth:`BusSession.receive`), which answer
  requests, advance operations and return events (a :class:`MotorState`, or
  the frame itself when it answered nothing);
* the time, whenever it likes and at least at :meth:`BusSession.next_deadline`
  (:meth:`BusSession.advance`): requests expire, held-back replies settle,
  operations sleeping wake, a start held until its presets are on the wire
  goes out;
* for transports that confirm transmission, :meth:`BusSession.transmitted`.

Every time is in seconds on the driver's clock (``time.monotonic`` for the
real drivers, a script's clock in tests). The session is a thin facade over
parts, one job each, reached as its attributes: ``timers`` (the scheduler),
``outbox`` (frames to write and their bus time), ``runner`` (requests, the
matcher, cycles), ``inbox`` (received frames, state waits), ``grace`` (the
zero-reply grace), ``sequencer`` (presets and starts in order), ``hold`` (a
start held for its presets), ``known`` (what is known about each motor),
``stats`` (the counters) and ``operations`` (the operation runner). Each part is given the
collaborators it works with when it is made, and none holds the session: as in h11, the state
machines know nothing of what drives them. The kinds of effect an operation yields are dispatched
through one table (:attr:`Operations.handlers`, filled here).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from typing import Any, TypeVar

from ...errors import ValidationError
from ...protocol.ids import Frame
from ...protocol.limits import MOTION_CMDS
from ...protocol.messages import Message
from .effects import AwaitState, Batch, Cycle, Request, Runnable, Send, Single
from .grace import ZERO_REPLY_GRACE, ZeroReplyGrace
from .hold import HoldEvent, StartHold, TxOrder
from .inbox import Inbox
from .known import Known, MoveRecord
from .operation import WAIT, Operation, Operations
from .outbox import ASSUMED_BITRATE, Outbox
from .requests import Matcher
from .runner import DEFAULT_TIMEOUT, RequestPolicy, RequestRunner, describe_request
from .sequencer import Sequencer, StartPolicy, sequenced
from .state import MotorState
from .stats import BusStats
from .stops import StopOnClose, estop_frames, idle_frames, stop_frames
from .timeouts import seconds
from .timers import Timers

__all__ = [
    "BusSession",
    "Operation",
    "MoveRecord",
    "TxOrder",
    "StartPolicy",
    "StopOnClose",
    "DEFAULT_TIMEOUT",
    "DEFAULT_MOVE_TIMEOUT",
    "DEFAULT_POLL_INTERVAL",
    "MOVE_TOLERANCE",
    "MOTION_CMDS",
    "ZERO_REPLY_GRACE",
    "ASSUMED_BITRATE",
    "describe_request",
    "sequenced",
    "idle_frames",
]

T = TypeVar("T")

DEFAULT_MOVE_TIMEOUT = 60.0
"""Default longest wait (s) for a move to finish (position_done and friends)."""
DEFAULT_POLL_INTERVAL = 0.01
"""Default pause (s) between fast reads while waiting for a move to finish."""
MOVE_TOLERANCE = 0.5
"""Default largest distance (deg) between a finished move's position and its target."""

_TX_EVENT = {True: HoldEvent.SENT, False: HoldEvent.NOT_SENT, None: HoldEvent.UNKNOWN}


def _stat(name: str, doc: str) -> Any:
    """A counter of :class:`~drempower.client.engine.stats.BusStats`, read and set through the session."""
    return property(lambda self: getattr(self.stats, name), lambda self, v: setattr(self.stats, name, v), doc=doc)


class BusSession:
    """What the client knows and decides about one bus; no I/O (see the module docstring).

    ``timeout`` (s) is the default wait for a reply and ``retries`` how often a
    read whose reply did not come is sent again. ``start`` chooses where start
    commands go: ``"auto"`` (default) sends one start to each motor of the move,
    so that no preset another command left behind is fired, and one broadcast
    start only when the bus's motors are known (``motor_ids``) and all in the
    move, with none holding a preset of this bus outside it; ``"broadcast"``
    always broadcasts (the vendor library's behaviour); ``"node"`` always
    addresses each motor. ``stop_on_close``:
    ``True`` or ``"idle"`` makes :meth:`stop_frames` put every motor this bus
    sent a motion command or a state request (set_mode) to into IDLE,
    ``"estop"`` sends them an emergency stop, ``False`` nothing. ``tx``,
    ``bitrate`` (bit/s, None: 125 kbit/s assumed) and ``tx_latency`` (s) say
    how a start knows its presets are on the wire (:data:`TxOrder`).
    ``motor_ids`` are the motors the transport declares (the in-process
    simulator's).
    """

    def __init__(
        self,
        *,
        timeout: float = DEFAULT_TIMEOUT,
        retries: int = 0,
        start: StartPolicy = "auto",
        stop_on_close: StopOnClose = True,
        tx: TxOrder = "timed",
        bitrate: int | None = None,
        tx_latency: float = 0.005,
        zero_reply_grace: float = ZERO_REPLY_GRACE,
        motor_ids: Iterable[int] = (),
        now: float = 0.0,
    ) -> None:
        if start not in ("auto", "broadcast", "node"):
            raise ValidationError(f"start={start!r}: 'auto', 'broadcast' or 'node'")
        if stop_on_close not in (True, False, "idle", "estop"):
            raise ValidationError(f"stop_on_close={stop_on_close!r}: True, False, 'idle' or 'estop'")
        if tx not in ("in_order", "confirmed", "timed", "answered"):
            raise ValidationError(f"tx={tx!r}: 'in_order', 'confirmed', 'timed' or 'answered'")
        timeout = seconds(timeout)
        if retries.__class__ is not int or retries < 0:
            raise ValidationError(f"retries={retries!r}: must be an integer >= 0")
        self.stop_on_close = stop_on_close
        self.hold_on_close: set[int] = set()
        """Motors that ``stop_on_close=True`` holds (speed 0) instead of idling: a robot file's joints that hold."""
        self.timers = timers = Timers(now)
        self.outbox = outbox = Outbox(bitrate, now)
        self.known = known = Known()
        self.stats = stats = BusStats()
        self.matcher = matcher = Matcher()
        """Every request waiting for its reply."""
        self.policy = policy = RequestPolicy(float(timeout), retries)
        self.grace = grace = ZeroReplyGrace(matcher, stats, timers, zero_reply_grace)
        self.operations = operations = Operations(timers)
        self.hold = hold = StartHold(tx, tx_latency, timers=timers, outbox=outbox, matcher=matcher, policy=policy)
        self.sequencer = sequencer = Sequencer(
            start, frozenset(motor_ids), timers=timers, known=known, outbox=outbox, hold=hold, operations=operations
        )
        self.runner = runner = RequestRunner(
            policy,
            matcher=matcher,
            timers=timers,
            outbox=outbox,
            known=known,
            grace=grace,
            operations=operations,
            sequencer=sequencer,
            tx_latency=tx_latency,
        )
        self.inbox = inbox = Inbox(
            timers=timers, known=known, matcher=matcher, grace=grace, stats=stats, operations=operations
        )
        operations.handlers.update(_effect_handlers(runner, sequencer, inbox))
        self._direct: dict[type, Callable[[Operation[Any], Any], None]] = {
            Single: runner.single,
            Cycle: runner.cycle,
        }
        """Runnables that are one effect, run without a generator: their answer is the result."""
        self.closed = False
        """True once closed for good (an estop is still sent after a receive failure, not after this)."""

    # ------------------------------------------------------------------ settings and facts of the parts

    @property
    def now(self) -> float:
        """The latest time the driver gave (s)."""
        return self.timers.now

    @now.setter
    def now(self, value: float) -> None:
        self.timers.now = value

    @property
    def closed_error(self) -> BaseException | None:
        """Set once the bus is closed or its receive loop failed: every new operation raises it."""
        return self.operations.closed_error

    @property
    def timeout(self) -> float:
        """The default wait (s) for a reply."""
        return self.policy.timeout

    @timeout.setter
    def timeout(self, value: float) -> None:
        self.policy.timeout = value

    @property
    def retries(self) -> int:
        """How often a read whose reply did not come is sent again."""
        return self.policy.retries

    @property
    def tx(self) -> TxOrder:
        """How a start knows its presets are on the wire (:data:`TxOrder`)."""
        return self.hold.tx

    @property
    def check_request(self) -> Callable[[Sequence[Message]], None] | None:
        """Called with the messages of every request before it is sent; may raise to refuse it."""
        return self.runner.check_request

    @check_request.setter
    def check_request(self, check: Callable[[Sequence[Message]], None] | None) -> None:
        self.runner.check_request = check

    @property
    def zero_reply_grace(self) -> float:
        """How long (s) a reply of value 0 is held back once another host is seen."""
        return self.grace.grace

    @zero_reply_grace.setter
    def zero_reply_grace(self, value: float) -> None:
        self.grace.grace = value

    @property
    def other_hosts(self) -> bool:
        """True once frames of another host were seen (see :meth:`receive`)."""
        return self.grace.other_hosts

    @other_hosts.setter
    def other_hosts(self, value: bool) -> None:
        self.grace.other_hosts = value

    frames_received: int = _stat("frames_received", "Every frame given to :meth:`receive`.")
    malformed: int = _stat("malformed", "Frames that decode to no reply and no state.")
    unmatched: int = _stat("unmatched", "Frames that answered no request and are no state.")
    anomalies: int = _stat("anomalies", "Replies whose echoed fields differ from the waiting request's.")
    foreign: int = _stat("foreign", "Frames another host sent.")
    moves_resent: int = _stat("moves_resent", "Moves sent again because a wait found them lost.")

    def forget(self, node: int) -> None:
        """Drop what is known about ``node`` (every motor for 0): after a reboot, id change or config reset."""
        self.known.forget(node)

    def learn(self, node: int, address: int, value: float) -> None:
        """Record a parameter value this bus read or wrote when the client relies on it (see :class:`Known`)."""
        self.known.learn(node, address, value)

    # ------------------------------------------------------------------ time

    @property
    def changes(self) -> int:
        """A count that grows whenever the session gets a new deadline or starts waiting for a
        confirmation: a driver whose caller sleeps wakes it when this changed."""
        return self.timers.changes

    def next_deadline(self) -> float | None:
        """The earliest time (s) at which :meth:`advance` has something to do, or None."""
        due = self.timers.next_due()
        if self.grace.held:
            g = self.grace.next_due()
            due = g if due is None or (g is not None and g < due) else due
        if self.hold.current is not None:
            h = self.hold.next_due()
            due = h if due is None or (h is not None and h < due) else due
        return due

    def advance(self, now: float) -> None:
        """Act on the time ``now`` (s): expire requests, settle held-back replies, wake sleeping
        operations, release a start whose presets are on the wire."""
        timers = self.timers
        if now > timers.now:
            timers.now = now
        if self.grace.held:
            self.grace.settle(now)
        heap = timers.heap
        if heap and heap[0][0] <= now:  # the check fire_due makes first, without its call on the fast path
            timers.fire_due(now)
        if self.hold.current is not None:
            self.hold.check()

    # ------------------------------------------------------------------ sending

    def data_to_send(self) -> list[Frame]:
        """The frames to hand to the transport now, in order (each is returned once).

        The session takes them as handed over at :attr:`now`: it accounts their
        bus time for starts that wait until their presets are on the wire.
        """
        out = self.outbox.frames
        if not out:
            return out
        out = self.outbox.take(self.timers.now)
        if self.hold.current is not None:
            self.hold.check()
        return out

    @property
    def wants_to_send(self) -> bool:
        """True when :meth:`data_to_send` has frames."""
        return bool(self.outbox.frames)

    @property
    def awaiting_confirmation(self) -> bool:
        """True when a start waits for the transport to confirm its presets are on the wire
        (``tx="confirmed"``): the driver asks the transport, then calls :meth:`transmitted`."""
        return self.hold.awaiting_confirmation

    def transmitted(self, now: float, confirmed: bool | None = True) -> None:
        """The transport says whether every frame handed to it is on the wire: True (a held start
        goes out), False (it gave up: the start's operation fails with :class:`TimeoutError`), None
        (it cannot tell: the start waits the bus time of what was written instead)."""
        if now > self.timers.now:
            self.timers.now = now
        if not self.outbox.frames:
            self.hold.event(_TX_EVENT[confirmed])

    def send(self, msgs: Sequence[Message], on_done: Callable[[], None] | None = None) -> Operation[None] | None:
        """Encode every message first (nothing is sent if one is invalid), then queue them in order.

        Presets and starts go through the :mod:`~drempower.client.engine.sequencer`: a start (0x08, sys
        0x10..0x15) that would start a pending preset goes out only once every preset is on the wire
        (see :data:`TxOrder`), and the moves it starts are recorded in :attr:`moves` (target from each
        motor's position preset, move time from a Q preset; a relative move's target is unknown).
        Returns None when every frame is queued, else the operation that ends once they are.
        """
        frames = [m.encode() for m in msgs]
        if self.closed_error is not None:
            raise self.closed_error
        ops = self.operations
        op: Operation[None] = ops.add(Operation(None, on_done))
        if self.sequencer.send(op, msgs, frames) and not op.done:
            return op
        ops.running.pop(id(op), None)
        return None

    def send_frames(self, frames: Sequence[Frame], *, first: bool = False) -> None:
        """Queue frames as they are (no tracking): ``first`` puts them before anything queued."""
        if first:
            self.outbox.frames[:0] = frames
        else:
            self.outbox.frames.extend(frames)

    def estop(self, nodes: Sequence[int]) -> None:
        """Queue an emergency stop to each of ``nodes`` (0 = every motor) before anything else queued.

        A start held until its presets are on the wire is dropped, and so are the presets and
        starts queued behind it: their operations raise :class:`~drempower.errors.BusStoppedError`
        (the motors keep the presets marked as pending, so no later broadcast start fires them).

        Works even after the receive loop failed; only a closed session refuses.
        """
        frames = estop_frames(nodes)
        if self.closed:
            assert self.closed_error is not None
            raise self.closed_error
        self.outbox.frames[:0] = frames
        self.stopped(nodes)

    def stopped(self, nodes: Sequence[int]) -> None:
        """An emergency stop to ``nodes`` went out: drop the start held for its presets and the presets
        and starts queued behind it; their operations raise :class:`~drempower.errors.BusStoppedError`."""
        self.sequencer.stopped(nodes)

    def stop_frames(self) -> list[Frame]:
        """The frames ``stop_on_close`` sends: idle (hold: :attr:`hold_on_close`) or estop to each commanded motor."""
        return stop_frames(self.stop_on_close, self.known.commanded, self.hold_on_close)

    # ------------------------------------------------------------------ operations

    def submit(self, op: Runnable[T], on_done: Callable[[], None] | None = None) -> Operation[T]:
        """Start running operation ``op`` (a generator of effects) at :attr:`now`.

        Returns its :class:`Operation`, which may already be done; ``on_done``
        is called when it finishes later (from whichever call finished it).
        Raises :class:`BusClosedError` when the session is closed.
        """
        ops = self.operations
        if ops.closed_error is not None:
            raise ops.closed_error
        direct = self._direct.get(op.__class__)
        if direct is not None:
            run: Operation[T] = Operation(None, on_done)
            ops.running[id(run)] = run
            try:
                direct(run, op)
            except Exception as exc:
                ops.finish(run, None, exc)
            return run
        opn: Operation[T] = ops.add(Operation(op, on_done))  # type: ignore[arg-type]
        ops.resume(opn, None, None)
        return opn

    def cancel(self, opn: Operation[Any], error: BaseException | None = None) -> None:
        """Stop ``opn`` (its caller gave up, e.g. on Ctrl-C): its requests stop waiting, its generator closes."""
        self.operations.cancel(opn, error)

    def abort(self, error: BaseException) -> None:
        """Fail every running operation with ``error`` (a write failed); new operations are taken."""
        for w in self.matcher.clear():
            w.on_complete = None
        self.timers.clear()
        self.inbox.waits.clear()
        self.grace.held.clear()
        self.sequencer.clear()
        self.hold.current = None
        self.outbox.frames.clear()
        self.operations.fail_all(error)

    def close(self, error: BaseException, *, final: bool = True) -> None:
        """End the session: every running operation fails with ``error``, and so does every new one.

        ``final`` False (the receive loop failed) still lets :meth:`estop` queue frames."""
        if self.operations.closed_error is None or final:
            self.operations.closed_error = error
        self.closed = self.closed or final
        self.abort(error)

    # ------------------------------------------------------------------ receiving

    def receive(self, frame: Frame, now: float) -> MotorState | Frame | None:
        """Take a received ``frame`` at time ``now`` (s).

        Returns the :class:`MotorState` of a state frame, the frame itself when
        it answered no request and is no state (malformed, another host's, a
        late reply), or None when it answered a request (or is held back: a
        reply of value 0 while other hosts are about, see :data:`ZERO_REPLY_GRACE`).
        """
        return self.inbox.receive(frame, now)


def _effect_handlers(runner: RequestRunner, sequencer: Sequencer, inbox: Inbox) -> dict[type, Any]:
    """The one table of how each kind of effect an operation yields is started (a sleep is the
    operations' own): the part that runs it, and what the operation gets at once (:data:`WAIT`: later)."""

    def request(opn: Operation[Any], effect: Request) -> Any:
        runner.request(opn, effect)
        return WAIT

    def cycle(opn: Operation[Any], effect: Cycle[Any]) -> Any:
        runner.cycle(opn, effect)
        return WAIT

    def send(opn: Operation[Any], effect: Send) -> Any:
        msgs = effect.messages
        return WAIT if sequencer.send(opn, msgs, [m.encode() for m in msgs]) else None

    def batch(opn: Operation[Any], effect: Batch) -> Any:
        sequencer.batch(opn, effect)
        return WAIT

    def await_state(opn: Operation[Any], effect: AwaitState) -> Any:
        return inbox.await_state(opn, effect.node, effect.newer_than, effect.timeout)

    return {Request: request, Cycle: cycle, Send: send, Batch: batch, AwaitState: await_state}
