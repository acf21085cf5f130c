"""The bus session: everything the client knows and decides about one bus, with no I/O.

:class:`BusSession` is sans-I/O, in the manner of h11: no threads, locks,
clocks, sockets or sleeps. A driver (:mod:`drempower.client.driver`) feeds it:

* operations (generators of :mod:`~drempower.client.effects`, see
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
real drivers, a script's clock in tests). The session owns request matching on
every echoed field, what the bus has learned (trajectory mode, reply-state
setting), pending presets and starts, the motors this bus commanded, the
moves the waits check, the zero-reply grace and the statistics.
"""

from __future__ import annotations

import dataclasses
import struct
from collections import deque
from collections.abc import Callable, Generator, Iterable, Sequence
from heapq import heappop, heappush
from typing import Any, Generic, Literal, TypeVar

from ..errors import BusStoppedError, ProtocolError, ValidationError
from ..protocol.addresses import (
    AXIS0_CONFIG_EXTRA_SETTING_ENABLE_REPLY_STATE,
    AXIS0_REQUESTED_STATE,
    AXIS0_TRAP_TRAJ_CONFIG_TRAJ_MODE,
)
from ..protocol.ids import Frame, SysCmd
from ..protocol.limits import MOTION_CMDS
from ..protocol.messages import (
    FastRead,
    Message,
    PositionP,
    PositionQ,
    PositionT,
    Preset,
    PresetC,
    PresetD,
    PresetP,
    PresetQ,
    PresetT,
    PresetV,
    ReadParam,
    Start,
    StartImpedance,
    SystemCommand,
    WriteParam,
    decode_reply,
)
from ..protocol.parameters import DataType, find_parameter
from .effects import AwaitState, Batch, Cycle, Effect, Request, Runnable, Send, Single, Sleep
from .errors import BusClosedError, TimeoutError
from .requests import MATCHED, MISMATCHED, Matcher, Waiter, request_dtype, request_key
from .state import MotorState
from .timeouts import seconds

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

DEFAULT_TIMEOUT = 0.1
"""Default time (s) a request waits for its reply."""
DEFAULT_MOVE_TIMEOUT = 60.0
"""Default longest wait (s) for a move to finish (position_done and friends)."""
DEFAULT_POLL_INTERVAL = 0.01
"""Default pause (s) between fast reads while waiting for a move to finish."""
MOVE_TOLERANCE = 0.5
"""Default largest distance (deg) between a finished move's position and its target."""
ASSUMED_BITRATE = 125_000
"""Bit rate (bit/s) assumed when the transport does not know the bus's: the slowest the motors use."""
ZERO_REPLY_GRACE = 0.01
"""How long (s) a parameter reply of value 0 is held back once another host is seen on the bus."""

StartPolicy = Literal["auto", "broadcast", "node"]
"""Where start commands go: see :class:`BusSession`."""
StopOnClose = bool | Literal["idle", "estop"]
"""What closing the bus does to the motors it commanded: see :class:`BusSession`."""
TxOrder = Literal["in_order", "confirmed", "timed"]
"""How the session knows a batch's presets are on the wire before it sends their start:
``in_order`` (frames reach the bus in the order written: no wait), ``confirmed`` (the driver
reports :meth:`BusSession.transmitted`), ``timed`` (the bus time of what was written, plus
``tx_latency``)."""

_WORST_FRAME_BITS = 135
"""Longest standard 8-byte CAN data frame with stuff bits and interframe space."""
_POSITION_CMDS = (PositionT, PositionQ, PositionP)
_POSITION_STARTS = frozenset((0x10, 0x11, 0x12))
_STARTS = (Start, StartImpedance)
_TYPED_PRESETS = (PresetT, PresetQ, PresetP, PresetV, PresetC, PresetD)
_HOST_ONLY_CMDS = frozenset((0x08, 0x0C, 0x1A, 0x1C, 0x1F))
"""Commands only a host sends: seeing one that this bus did not send means another host is present."""
_ZERO4 = bytes(4)
_STATE = struct.Struct("<fhh").unpack
_IDLE = 1  # axis0.requested_state value for IDLE
_REQUESTED_STATE = AXIS0_REQUESTED_STATE
_RESETS = frozenset((SysCmd.INIT_CONFIG, SysCmd.ERASE_CONFIG, SysCmd.REBOOT))
_MIN_CONFIRM = 0.1
"""Shortest wait (s) for a transport's confirmation that presets are on the wire."""
_new_state = tuple.__new__
_WAIT: Any = object()
"""What starting an effect returns when the operation must wait for it."""


def _motors(nodes: Sequence[int]) -> str:
    return "every motor" if 0 in nodes else "motor" + ("s " if len(nodes) > 1 else " ") + ", ".join(map(str, nodes))


def sequenced(msgs: Sequence[Message]) -> bool:
    """Whether sending ``msgs`` involves presets or starts (so a start may wait for its presets)."""
    return any(m.cmd == 0x0C or isinstance(m, _STARTS) for m in msgs)


def describe_request(msg: Message) -> str:
    """Short name of a request for error messages."""
    if isinstance(msg, FastRead):
        return "a fast read (get_state)"
    if isinstance(msg, ReadParam):
        p = find_parameter(msg.address)
        return f"read_property {p.name} ({msg.address})" if p else f"read_property {msg.address}"
    return type(msg).__name__


def idle_frames(nodes: Iterable[int]) -> list[Frame]:
    """The writes of ``axis0.requested_state`` = IDLE that stop motors ``nodes`` driving (0: every motor)."""
    return [WriteParam(n, _REQUESTED_STATE, DataType.U32, _IDLE).encode() for n in nodes]


def _preset_goal(preset: Message, q_start: bool) -> tuple[float, float | None]:
    """The target (deg) a position start gives ``preset``, and its move time (s) for a Q start (else None)."""
    wire = preset if isinstance(preset, Preset) else preset.to_preset() if isinstance(preset, _TYPED_PRESETS) else None
    assert wire is not None
    return wire.p1, (wire.p2 if q_start and wire.p2 > 0 else None)


def _to_node(msg: Message, node: int) -> Message:
    """``msg`` addressed to ``node`` (a broadcast preset or start made node-addressed)."""
    return msg if msg.node == node else dataclasses.replace(msg, node=node)  # type: ignore[type-var]


@dataclasses.dataclass(slots=True)
class MoveRecord:
    """The last position move this bus commanded to one motor (what a wait for it checks).

    ``target`` deg (None when unknown), ``sent`` the session time its command
    or start was sent, ``move_time`` the planned duration (s, Q-mode
    synchronised moves) and ``took`` the arrival time of the first state with
    T = 0 after ``sent`` (the motor showed it took the move; None until then).
    ``resend`` holds the node-addressed messages that started it (the motor's
    preset and a start to that motor only, or the direct position command),
    sent again when a wait finds the move lost (see
    :func:`~drempower.client.ops.wait_done`); empty when unknown.
    """

    target: float | None
    sent: float
    move_time: float | None = None
    took: float | None = None
    resend: tuple[Message, ...] = ()


class Operation(Generic[T]):
    """An operation submitted to a :class:`BusSession`: done once its generator returned or raised.

    ``on_done`` (given to :meth:`BusSession.submit`) is called once, when it
    finishes; :meth:`result` returns its value or raises its error.
    """

    __slots__ = ("_cancel", "_error", "_gen", "_value", "done", "on_done")

    def __init__(self, gen: Generator[Effect, Any, T] | None, on_done: Callable[[], None] | None) -> None:
        self._gen = gen
        self.done = False
        self._value: Any = None
        self._error: BaseException | None = None
        self._cancel: Callable[[], None] | None = None
        self.on_done = on_done

    @property
    def error(self) -> BaseException | None:
        """The error it ended with (None while running or when it succeeded)."""
        return self._error

    def result(self) -> T:
        """Its value; raises its error. Only once :attr:`done`."""
        if not self.done:
            raise RuntimeError("the operation has not finished")
        if self._error is not None:
            raise self._error
        value: T = self._value
        return value


class _Exchange:
    """One request/reply exchange of an operation: batches of requests, retries, expiry.

    Requests to the same motor go one at a time: a parameter reply carries the
    same CAN id as every read request to that motor, so a second request sent
    while the reply is due could collide with it on the wire. Requests to
    different motors go out together. A read whose reply did not come is sent
    again up to ``retries`` times. ``expect`` lists the reply keys when they
    are not one per message (a control cycle expects a state frame per motor
    whatever it sends); such an exchange is sent once, never retried. Without
    ``missing_ok`` the exchange ends at the first request that stays unanswered.
    """

    __slots__ = (
        "_batch",
        "_pending",
        "_serial",
        "_tries",
        "failed",
        "frames",
        "keys",
        "missing_ok",
        "msgs",
        "op",
        "results",
        "retries",
        "session",
        "timeout",
        "timer",
        "waiter",
        "what",
    )

    def __init__(self, session: BusSession, op: Operation[Any], effect: Request) -> None:
        self.session = session
        self.op = op
        msgs = self.msgs = effect.messages
        self.frames = [m.encode() for m in msgs]
        if effect.expect is None:
            self.keys = [request_key(m) for m in msgs]
            self._serial: list[int] | None = [m.node for m in msgs]
            self.retries = session.retries
        else:
            self.keys = list(effect.expect)
            self._serial = None
            self.retries = 0
        timeout = effect.timeout
        self.timeout = session.timeout if timeout is None else timeout
        if not self.timeout > 0:
            raise ValidationError(f"timeout={timeout!r}: must be > 0 s")
        self.missing_ok = effect.missing_ok
        self.what = effect.what
        n = len(self.keys)
        self.results: list[object | None] = [None] * n
        self.failed: list[int] = []
        self._pending = list(range(n))
        self._tries = [0] * n
        self._batch: list[int] = []
        self.waiter: Waiter | None = None
        self.timer = 0

    def start(self) -> None:
        """Register the next replies to wait for and queue their requests."""
        serial = self._serial
        if serial is None:
            batch = self._pending
            dtypes = None
            frames = self.frames
        else:
            busy: set[int] = set()
            batch = []
            for i in self._pending:
                node = serial[i]
                if node not in busy:
                    busy.add(node)
                    batch.append(i)
            msgs = self.msgs
            dtypes = [request_dtype(msgs[i]) for i in batch]
            frames = [self.frames[i] for i in batch]
        self._batch = batch
        keys = self.keys
        s = self.session
        w = self.waiter = Waiter([keys[i] for i in batch], self._answered, dtypes)
        s.matcher.register(w)
        s._out.extend(frames)
        self.timer = s._add_timer(s.now + self.timeout, self._expire)

    def cancel(self) -> None:
        s = self.session
        s._timers.pop(self.timer, None)
        if self.waiter is not None:
            s.matcher.cancel(self.waiter)

    def _answered(self) -> None:
        self.session._timers.pop(self.timer, None)
        self._collect()

    def _expire(self) -> None:
        w = self.waiter
        assert w is not None
        s = self.session
        if s._provisional:
            s._settle(0.0, [(w.keys[i] >> 16, w.keys[i] & 0xFFFF) for i in w.missing()])
            if not w.remaining:
                return  # the held-back replies answered it (and _answered ran)
        s.matcher.cancel(w)
        self._collect()

    def _collect(self) -> None:
        w = self.waiter
        assert w is not None
        results, tries, failed = self.results, self._tries, self.failed
        for j, i in enumerate(self._batch):
            r = w.results[j]
            if r is not None:
                results[i] = r
            else:
                tries[i] += 1
                if tries[i] > self.retries:
                    failed.append(i)
        self._pending = [i for i in self._pending if results[i] is None and tries[i] <= self.retries]
        s = self.session
        if (failed and not self.missing_ok) or not self._pending:
            if failed and not self.missing_ok:
                nodes = sorted({self.keys[i] >> 16 for i in failed})
                what = self.what or describe_request(self.msgs[failed[0]])
                s._resume(self.op, None, TimeoutError(nodes, what, self.timeout))
                return
            heard = s.heard
            for r in results:
                node = getattr(r, "node", 0)
                if node:
                    heard.add(node)
            s._resume(self.op, results, None)
        else:
            self.start()


class _OneRequest:
    """A :class:`~drempower.client.effects.Single` request of one message: :class:`_Exchange`'s rules
    (matching on every echoed field, retries, the held-back zero replies at expiry) for the
    commonest call, without its bookkeeping for many requests."""

    __slots__ = ("frame", "key", "msg", "op", "session", "timeout", "timer", "tries", "waiter")

    def __init__(self, session: BusSession, op: Operation[Any], effect: Request) -> None:
        self.session = session
        self.op = op
        msg = self.msg = effect.messages[0]
        self.frame = msg.encode()
        self.key = request_key(msg)
        timeout = effect.timeout
        self.timeout = session.timeout if timeout is None else timeout
        if not self.timeout > 0:
            raise ValidationError(f"timeout={timeout!r}: must be > 0 s")
        self.tries = 0
        dtype = request_dtype(msg)
        self.waiter = Waiter((self.key,), self._answered, None if dtype is None else (dtype,))
        self.timer = 0

    def start(self) -> None:
        s = self.session
        w = self.waiter
        w.results[0] = None
        w.remaining = 1
        s.matcher.register(w)
        s._out.append(self.frame)
        self.timer = s._add_timer(s.now + self.timeout, self._expire)

    def cancel(self) -> None:
        s = self.session
        s._timers.pop(self.timer, None)
        s.matcher.cancel(self.waiter)

    def _answered(self) -> None:
        s = self.session
        s._timers.pop(self.timer, None)
        r = self.waiter.results[0]
        node = getattr(r, "node", 0)
        if node:
            s.heard.add(node)
        s._finish(self.op, r, None)

    def _expire(self) -> None:
        s = self.session
        key = self.key
        if s._provisional:
            s._settle(0.0, [(key >> 16, key & 0xFFFF)])
            if not self.waiter.remaining:
                return  # a held-back reply answered it
        s.matcher.cancel(self.waiter)
        self.tries += 1
        if self.tries <= s.retries:
            self.start()
            return
        s._finish(self.op, None, TimeoutError([key >> 16], describe_request(self.msg), self.timeout))


class _CycleRun:
    """A control cycle (:class:`~drempower.client.effects.Cycle`): its frames go out at once, one state
    per motor is awaited (matched as any fast read's), sent once, never retried. What the commands
    change is recorded as for any sent message (commanded motors, moves, learned parameters, presets
    pending until started); a start in a cycle goes out in order with the cycle's frames, without
    waiting for the presets it starts. Answered, a cycle's frames are known to be on the wire, so a
    start sent after it does not wait for its presets."""

    __slots__ = ("last", "nodes", "op", "session", "timeout", "timer", "waiter")

    def __init__(self, session: BusSession, op: Operation[Any], cycle: Cycle[Any]) -> None:
        """Queue the cycle's frames, expect its states and start its timer."""
        timeout = cycle.timeout
        if timeout is None:
            timeout = session.timeout
        elif not timeout > 0:
            raise ValidationError(f"timeout={timeout!r}: must be > 0 s")
        msgs, frames = cycle.messages, cycle.frames
        if len(msgs) != len(frames):
            raise ValidationError(f"a cycle of {len(msgs)} messages came with {len(frames)} frames")
        self.session = session
        self.op = op
        self.timeout = timeout
        nodes = self.nodes = cycle.nodes
        w = self.waiter = Waiter([n << 16 for n in nodes], self._answered)
        out = session._out
        for m, f in zip(msgs, frames, strict=True):
            if m.cmd == 0x1E:
                out.append(f)
                continue
            session._note(m, f)
            if m.cmd == 0x0C:  # pending until started, as when sent alone (later starts go per motor)
                session._hold_preset(m)
            elif isinstance(m, _STARTS) and session._starts_pending(m.node):
                started = sorted(session.pending_presets) if m.node == 0 else [m.node]
                session._start_pending(m, f, started)  # queues it, in order, without waiting
                continue
            out.append(f)
        self.last = session._handed + len(out)
        """The count of handed frames once this cycle's are: answered, they (and those before) are on the wire."""
        session.matcher.register(w)
        self.timer = session._add_timer(session.now + timeout, self._expire)

    def cancel(self) -> None:
        s = self.session
        s._timers.pop(self.timer, None)
        s.matcher.cancel(self.waiter)

    def _answered(self) -> None:
        s = self.session
        s._timers.pop(self.timer, None)
        nodes = self.nodes
        s.heard.update(nodes)
        if s._handed <= self.last:  # every frame handed over is on the wire: a start need not wait for them
            s._wire_free = min(s._wire_free, s.now - s.tx_latency)
        s._effect_done(self.op, dict(zip(nodes, self.waiter.results, strict=True)), None)

    def _expire(self) -> None:
        s = self.session
        w = self.waiter
        if s._provisional:
            s._settle(0.0, [(k >> 16, k & 0xFFFF) for k in w.keys])
            if not w.remaining:
                return  # held-back replies answered it (and _answered ran)
        s.matcher.cancel(w)
        nodes = self.nodes
        silent = sorted(nodes[i] for i in w.missing())
        s._effect_done(self.op, None, TimeoutError(silent, "a control cycle", self.timeout))


class _SeqJob:
    """Presets and starts being sent in order; a start that starts a pending preset waits until
    the presets are on the wire (see :meth:`BusSession._hold`)."""

    __slots__ = ("batch", "frames", "index", "msgs", "op")

    def __init__(
        self, op: Operation[Any] | None, msgs: Sequence[Message], frames: Sequence[Frame], batch: Batch | None
    ):
        self.op = op
        self.msgs = msgs
        self.frames = frames
        self.batch = batch
        self.index = 0


class _Hold:
    """A start waiting for its presets to be on the wire."""

    __slots__ = ("confirmed", "due", "fail", "release", "timed")

    def __init__(
        self, timed: bool, release: Callable[[], None], fail: Callable[[BaseException | None], None], due: float
    ) -> None:
        self.timed = timed
        self.confirmed = False
        self.release = release
        self.fail = fail
        self.due = due
        """With ``confirmed`` transports: when the confirmation is given up on (s)."""


class BusSession:
    """What the client knows and decides about one bus; no I/O (see the module docstring).

    ``timeout`` (s) is the default wait for a reply and ``retries`` how often a
    read whose reply did not come is sent again. ``start`` chooses where start
    commands go: ``"auto"`` (default) sends the start of a one-motor move to
    that motor only, and the start of a multi-motor move to broadcast unless a
    motor outside the move may still hold a preset from this bus (then to each
    motor of the move); ``"broadcast"`` always broadcasts (the vendor library's
    behaviour); ``"node"`` always addresses each motor. ``stop_on_close``:
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
        if tx not in ("in_order", "confirmed", "timed"):
            raise ValidationError(f"tx={tx!r}: 'in_order', 'confirmed' or 'timed'")
        timeout = seconds(timeout)
        if retries.__class__ is not int or retries < 0:
            raise ValidationError(f"retries={retries!r}: must be an integer >= 0")
        self.timeout = float(timeout)
        self.retries = retries
        self.start_policy: StartPolicy = start
        self.stop_on_close = stop_on_close
        self.tx: TxOrder = tx
        self.bitrate = bitrate or ASSUMED_BITRATE
        self.tx_latency = tx_latency
        self.zero_reply_grace = zero_reply_grace
        self.now = now
        """The latest time the driver gave (s)."""
        self.motor_ids = frozenset(motor_ids)
        self.check_request: Callable[[Sequence[Message]], None] | None = None
        """Called with the messages of every request before it is sent; may raise to refuse it."""
        self.matcher = Matcher()
        self.states: dict[int, MotorState] = {}
        """The latest state of every motor heard from."""
        self.heard: set[int] = set()
        """Motors that answered a request."""
        self.traj_mode: dict[int, int] = {}
        """Known ``traj_mode`` (35104) per motor: read from it or set through this bus."""
        self.reply_state: dict[int, bool] = {}
        """Known ``enable_reply_state`` (31214) per motor."""
        self.moves: dict[int, MoveRecord] = {}
        """The last position move per motor (see :class:`MoveRecord`); other motion commands drop it."""
        self.commanded: set[int] = set()
        """Motors this bus has sent motion commands or a requested state to (0 = broadcast)."""
        self.frames_received = 0
        self.malformed = 0
        self.unmatched = 0
        self.anomalies = 0
        """Replies for a waiting request whose echoed fields (data type) differ from it: never taken as answers."""
        self.moves_resent = 0
        """Moves sent again because a wait found them lost (see :func:`~drempower.client.ops.wait_done`)."""
        self.other_hosts = False
        """True once frames of another host were seen (see :meth:`receive`)."""
        self.pending_presets: set[int] = set()
        """Motors holding a preset no start has consumed yet (0 = a broadcast preset)."""
        self._preset_msgs: dict[int, Message] = {}
        """The last preset sent per motor through :meth:`send` and not started yet."""
        self._provisional: dict[tuple[int, int], tuple[float, Any]] = {}
        self._out: list[Frame] = []
        self._wire_free = now
        self._handed = 0
        """Frames handed to the transport so far."""
        self._timers: dict[int, tuple[float, Callable[[], None]]] = {}
        self._heap: list[tuple[float, int]] = []
        """(due, timer id) of every timer, earliest first; a dropped timer's entry stays until it surfaces."""
        self._timer_seq = 0
        self._ops: dict[int, Operation[Any]] = {}
        self._state_waits: dict[int, list[tuple[Operation[Any], float]]] = {}
        self._seq: deque[_SeqJob] = deque()
        self._seq_busy = False
        self._hold: _Hold | None = None
        self.closed_error: BaseException | None = None
        """Set once the bus is closed or its receive loop failed: every new operation raises it."""
        self.closed = False
        """True once closed for good (an estop is still sent after a receive failure, not after this)."""

    # ------------------------------------------------------------------ learned facts

    def forget(self, node: int) -> None:
        """Drop what is known about ``node`` (every motor for 0): after a reboot, id change or config reset."""
        if node == 0:
            self.traj_mode.clear()
            self.reply_state.clear()
        else:
            self.traj_mode.pop(node, None)
            self.reply_state.pop(node, None)

    def learn(self, node: int, address: int, value: float) -> None:
        """Record a parameter value this bus read or wrote when the client relies on it.

        A broadcast write (node 0) makes the value of every motor unknown until read.
        """
        if address == AXIS0_TRAP_TRAJ_CONFIG_TRAJ_MODE:
            if node == 0:
                self.traj_mode.clear()
            elif value in (1, 2):
                self.traj_mode[node] = int(value)
            else:  # not a mode a move can be timed with: read it again (and refuse it) when needed
                self.traj_mode.pop(node, None)
        elif address == AXIS0_CONFIG_EXTRA_SETTING_ENABLE_REPLY_STATE:
            if node == 0:
                self.reply_state.clear()
            else:
                self.reply_state[node] = bool(value)

    def _note(self, msg: Message, frame: Frame) -> None:
        """Track what a sent message changes: commanded motors, remembered parameters."""
        cmd = msg.cmd
        if cmd in MOTION_CMDS:
            self.commanded.add(msg.node)
            if cmd != 0x0C:  # a preset changes nothing until its start
                self._new_move(msg)
        elif isinstance(msg, WriteParam):
            if msg.address == _REQUESTED_STATE:
                self.commanded.add(msg.node)
            else:
                self.learn(msg.node, msg.address, msg.value)
        elif cmd == 0x08 and frame[1][0] in _RESETS:
            self.forget(msg.node)

    def _new_move(self, msg: Message) -> None:
        """Record the position move a direct command starts; any other motion command ends the record."""
        node = msg.node
        if node == 0:
            self.moves.clear()
        elif isinstance(msg, _POSITION_CMDS):
            self.moves[node] = MoveRecord(msg.position, self.now, resend=(msg,))
        else:
            self.moves.pop(node, None)

    # ------------------------------------------------------------------ time

    @property
    def changes(self) -> int:
        """A count that grows whenever the session gets a new deadline or starts waiting for a
        confirmation: a driver whose caller sleeps wakes it when this changed."""
        return self._timer_seq

    def _add_timer(self, due: float, fire: Callable[[], None]) -> int:
        self._timer_seq = tid = self._timer_seq + 1
        self._timers[tid] = (due, fire)
        heappush(self._heap, (due, tid))
        return tid

    def next_deadline(self) -> float | None:
        """The earliest time (s) at which :meth:`advance` has something to do, or None."""
        heap, timers = self._heap, self._timers
        while heap and heap[0][1] not in timers:  # dropped timers leave their entry behind
            heappop(heap)
        due = heap[0][0] if heap else None
        if self._provisional:
            p = min(d for d, _ in self._provisional.values())
            due = p if due is None or p < due else due
        hold = self._hold
        if hold is not None and not self._out:
            h = self._wire_free + self.tx_latency if hold.timed else hold.due
            due = h if due is None or h < due else due
        return due

    def advance(self, now: float) -> None:
        """Act on the time ``now`` (s): expire requests, settle held-back replies, wake sleeping
        operations, release a start whose presets are on the wire."""
        if now > self.now:
            self.now = now
        if self._provisional:
            self._settle(now)
        heap, timers = self._heap, self._timers
        if heap and heap[0][0] <= now:
            newest = self._timer_seq  # timers set while these fire wait for the next advance
            later: list[tuple[float, int]] = []
            while heap and heap[0][0] <= now:
                item = heappop(heap)
                if item[1] > newest:
                    later.append(item)
                    continue
                entry = timers.pop(item[1], None)
                if entry is not None:
                    entry[1]()
            for item in later:
                heappush(heap, item)
        if self._hold is not None:
            self._check_hold()

    # ------------------------------------------------------------------ sending

    def data_to_send(self) -> list[Frame]:
        """The frames to hand to the transport now, in order (each is returned once).

        The session takes them as handed over at :attr:`now`: it accounts their
        bus time for starts that wait until their presets are on the wire.
        """
        out = self._out
        if not out:
            return out
        self._out = []
        now = self.now
        self._handed += len(out)
        self._wire_free = max(now, self._wire_free) + len(out) * _WORST_FRAME_BITS / self.bitrate
        if self._hold is not None:
            self._check_hold()
        return out

    @property
    def wants_to_send(self) -> bool:
        """True when :meth:`data_to_send` has frames."""
        return bool(self._out)

    @property
    def awaiting_confirmation(self) -> bool:
        """True when a start waits for the transport to confirm its presets are on the wire
        (``tx="confirmed"``): the driver asks the transport, then calls :meth:`transmitted`."""
        hold = self._hold
        return hold is not None and not hold.timed and not hold.confirmed and not self._out

    def transmitted(self, now: float, confirmed: bool | None = True) -> None:
        """The transport says whether every frame handed to it is on the wire: True (a held start
        goes out), False (it gave up: the start's operation fails with :class:`TimeoutError`), None
        (it cannot tell: the start waits the bus time of what was written instead)."""
        if now > self.now:
            self.now = now
        hold = self._hold
        if hold is None or self._out:
            return
        if confirmed is None:
            hold.timed = True
        elif confirmed:
            hold.confirmed = True
        self._check_hold()  # not confirmed: it fails once its time is up

    def send(self, msgs: Sequence[Message], on_done: Callable[[], None] | None = None) -> Operation[None] | None:
        """Encode every message first (nothing is sent if one is invalid), then queue them in order.

        Presets (0x0C) are remembered until a start consumes them. A start
        (0x08, sys 0x10..0x15) that would start a pending preset goes out only
        once every preset is on the wire (see :data:`TxOrder`), so a start
        never overtakes its presets in a controller's mailboxes; the moves it
        starts are then recorded in :attr:`moves` as a batch does (target from
        each motor's position preset, move time from a Q preset; a relative
        move's target is unknown). Returns None when every frame is queued,
        else the operation that ends once they are.
        """
        frames = [m.encode() for m in msgs]
        self._check_open()
        op: Operation[None] = Operation(None, on_done)
        self._ops[id(op)] = op
        if self._queue(op, msgs, frames) and not op.done:
            return op
        self._ops.pop(id(op), None)
        return None

    def _queue(self, op: Operation[Any], msgs: Sequence[Message], frames: Sequence[Frame]) -> bool:
        """Queue sent messages for ``op``; True when presets or starts among them made it a sequenced
        job (``op`` then ends when its last frame is queued), False when every frame is queued now."""
        if sequenced(msgs):
            self._sequence(_SeqJob(op, msgs, frames, None))
            return True
        for m, f in zip(msgs, frames, strict=True):
            if m.cmd != 0x1E:
                self._note(m, f)
        self._out.extend(frames)
        return False

    def send_frames(self, frames: Sequence[Frame], *, first: bool = False) -> None:
        """Queue frames as they are (no tracking): ``first`` puts them before anything queued."""
        if first:
            self._out[:0] = frames
        else:
            self._out.extend(frames)

    def estop(self, nodes: Sequence[int]) -> None:
        """Queue an emergency stop to each of ``nodes`` (0 = every motor) before anything else queued.

        A start held until its presets are on the wire is dropped, and so are the presets and
        starts queued behind it: their operations raise :class:`~drempower.errors.BusStoppedError`
        (the motors keep the presets marked as pending, so no later broadcast start fires them).

        Works even after the receive loop failed; only a closed session refuses.
        """
        frames = [SystemCommand(n, SysCmd.ESTOP).encode() for n in nodes]
        if self.closed:
            assert self.closed_error is not None
            raise self.closed_error
        self._out[:0] = frames
        self.stopped(nodes)

    def stopped(self, nodes: Sequence[int]) -> None:
        """An emergency stop to ``nodes`` went out: drop the start held for its presets and the presets
        and starts queued behind it; their operations raise :class:`~drempower.errors.BusStoppedError`."""
        hold = self._hold
        if hold is None:
            return
        queued = list(self._seq)
        self._seq.clear()
        why = f"an emergency stop to {_motors(nodes)} came before the start went out"
        hold.fail(BusStoppedError(why))
        for job in queued:
            self._end_job(job, None, BusStoppedError(why))

    def stop_frames(self) -> list[Frame]:
        """The frames ``stop_on_close`` sends: idle or estop to every commanded motor."""
        if not self.stop_on_close:
            return []
        nodes = sorted(self.commanded)
        if self.stop_on_close == "estop":
            return [SystemCommand(n, SysCmd.ESTOP).encode() for n in nodes]
        return idle_frames(nodes)

    # ------------------------------------------------------------------ presets and starts

    def _sequence(self, job: _SeqJob) -> None:
        """Run ``job`` now, or after the job that holds a start (one at a time, in order)."""
        if self._seq_busy:
            self._seq.append(job)
            return
        self._seq_busy = True
        self._run_job(job)

    def _end_job(self, job: _SeqJob, value: Any, error: BaseException | None) -> None:
        """Hand a job's outcome to its operation: a send's own (it ends here) or a generator's effect."""
        op = job.op
        if op is not None:
            if op._gen is None:
                self._finish(op, value, error)
            else:
                self._resume(op, value, error)

    def _job_done(self, job: _SeqJob, value: Any, error: BaseException | None) -> None:
        self._seq_busy = False
        self._end_job(job, value, error)
        while self._seq and not self._seq_busy:
            nxt = self._seq.popleft()
            self._seq_busy = True
            self._run_job(nxt)

    def _run_job(self, job: _SeqJob) -> None:
        if job.batch is not None:
            self._run_batch(job)
            return
        msgs, frames = job.msgs, job.frames
        while job.index < len(msgs):
            i = job.index
            m, f = msgs[i], frames[i]
            job.index = i + 1
            self._note(m, f)
            if m.cmd == 0x0C:
                self._hold_preset(m)
            elif isinstance(m, _STARTS) and self._starts_pending(m.node):
                started = sorted(self.pending_presets) if m.node == 0 else [m.node]

                def release(job: _SeqJob = job, m: Message = m, f: Frame = f, started: list[int] = started) -> None:
                    self._start_pending(m, f, started)
                    self._run_job(job)

                if self._hold_start([n for n in started if n] or [0], release, job):
                    return
                self._start_pending(m, f, started)  # in order: no wait
                continue
            self._out.append(f)
        self._job_done(job, None, None)

    def _hold_preset(self, msg: Message) -> None:
        node = msg.node
        if node == 0:  # a broadcast preset replaces every motor's
            self._preset_msgs.clear()
        self.pending_presets.add(node)
        self._preset_msgs[node] = msg

    def _starts_pending(self, node: int) -> bool:
        """Whether a start to ``node`` (0 = broadcast) would start a pending preset."""
        pending = self.pending_presets
        return bool(pending) if node == 0 else node in pending or 0 in pending

    def _start_pending(self, start: Message, frame: Frame, started: list[int]) -> None:
        """Queue ``start`` (its presets are on the wire); record the moves it starts, drop what it consumed."""
        node = start.node
        sent = self.now
        moves = self.moves
        kind = getattr(start, "kind", None)
        if 0 in started:  # a broadcast preset: which motors it reached is unknown
            moves.clear()
        for n in started:
            if n == 0:
                continue
            preset = self._preset_msgs.get(n, self._preset_msgs.get(0))
            if kind in _POSITION_STARTS and preset is not None:
                goal, move_time = _preset_goal(preset, kind == 0x11)
                again = (_to_node(preset, n), _to_node(start, n))
                moves[n] = MoveRecord(None if getattr(start, "relative", False) else goal, sent, move_time, None, again)
            else:
                moves.pop(n, None)
        self._out.append(frame)
        pending = self.pending_presets
        if node == 0:
            pending.clear()
            self._preset_msgs.clear()
        else:
            pending.discard(node)
            self._preset_msgs.pop(node, None)

    def _run_batch(self, job: _SeqJob) -> None:
        b = job.batch
        assert b is not None
        presets, start = b.presets, b.start
        nodes = [p.node for p in presets]
        policy = self.start_policy
        broadcast = policy == "broadcast" or (
            policy == "auto" and len(nodes) > 1 and self.pending_presets.issubset(nodes)
        )
        where = [0] if broadcast else nodes
        starts = [dataclasses.replace(start, node=n).encode() for n in where]
        self.pending_presets.update(nodes)
        for n in nodes:
            self._preset_msgs.pop(n, None)
        self.commanded.update(nodes)
        self._out.extend(job.frames)

        def release() -> None:
            sent = self.now
            moves = self.moves
            if isinstance(start, Start) and start.kind in _POSITION_STARTS:
                goals = b.targets if b.targets is not None else [None] * len(nodes)
                for p, goal in zip(presets, goals, strict=True):
                    n = p.node
                    moves[n] = MoveRecord(goal, sent, b.move_time, None, (p, dataclasses.replace(start, node=n)))
            else:
                for n in nodes:
                    moves.pop(n, None)
            self._out.extend(starts)
            if broadcast:
                self.pending_presets.clear()
                self._preset_msgs.clear()
            else:
                self.pending_presets.difference_update(nodes)
            self._job_done(job, where, None)

        if not self._hold_start(nodes, release, job):
            release()

    def _hold_start(self, nodes: list[int], release: Callable[[], None], job: _SeqJob) -> bool:
        """Hold a start until the presets queued before it are on the wire; False when it need not wait."""
        if self.tx == "in_order":
            return False
        wait = max(self.timeout, _MIN_CONFIRM)

        def ready() -> None:
            self._hold = None
            release()

        def give_up(error: BaseException | None = None) -> None:
            self._hold = None
            if error is None:
                error = TimeoutError(nodes, "the transmission of the presets", wait)
            self._job_done(job, None, error)

        self._hold = _Hold(self.tx == "timed", ready, give_up, self.now + wait)
        self._timer_seq += 1
        self._check_hold()
        return True

    def _check_hold(self) -> None:
        hold = self._hold
        if hold is None or self._out:
            return
        now = self.now
        if hold.timed:
            if now >= self._wire_free + self.tx_latency:
                hold.release()
        elif hold.confirmed:
            hold.release()
        elif now >= hold.due:
            hold.fail(None)

    # ------------------------------------------------------------------ operations

    def submit(self, op: Runnable[T], on_done: Callable[[], None] | None = None) -> Operation[T]:
        """Start running operation ``op`` (a generator of effects) at :attr:`now`.

        Returns its :class:`Operation`, which may already be done; ``on_done``
        is called when it finishes later (from whichever call finished it).
        Raises :class:`BusClosedError` when the session is closed.
        """
        self._check_open()
        if op.__class__ is Single:
            single: Operation[T] = Operation(None, on_done)
            self._ops[id(single)] = single
            effect = op.request
            try:
                if self.check_request is not None:
                    self.check_request(effect.messages)
                ex: _Exchange | _OneRequest
                if len(effect.messages) == 1 and effect.expect is None and not effect.missing_ok:
                    ex = _OneRequest(self, single, effect)
                else:
                    ex = _Exchange(self, single, effect)
                ex.start()
            except Exception as exc:
                self._finish(single, None, exc)
            else:
                single._cancel = ex.cancel
            return single
        if op.__class__ is Cycle:
            run: Operation[T] = Operation(None, on_done)
            self._ops[id(run)] = run
            try:
                if self.check_request is not None:
                    self.check_request(op.messages)
                cyc = _CycleRun(self, run, op)
            except Exception as exc:
                self._finish(run, None, exc)
            else:
                if not run.done:
                    run._cancel = cyc.cancel
            return run
        opn: Operation[T] = Operation(op, on_done)  # type: ignore[arg-type]
        self._ops[id(opn)] = opn
        self._resume(opn, None, None)
        return opn

    def cancel(self, opn: Operation[Any], error: BaseException | None = None) -> None:
        """Stop ``opn`` (its caller gave up, e.g. on Ctrl-C): its requests stop waiting, its generator closes."""
        if opn.done:
            return
        if opn._cancel is not None:
            opn._cancel()
            opn._cancel = None
        if opn._gen is not None:
            opn._gen.close()
        self._finish(opn, None, error or BusClosedError("the operation was cancelled"), notify=False)

    def _finish(self, opn: Operation[Any], value: Any, error: BaseException | None, notify: bool = True) -> None:
        if opn.done:  # cancelled while a held start of its own was still to go out
            return
        opn._value, opn._error, opn.done, opn._cancel = value, error, True, None
        self._ops.pop(id(opn), None)
        if notify and opn.on_done is not None:
            opn.on_done()

    def _effect_done(self, opn: Operation[Any], value: Any, error: BaseException | None) -> None:
        """An effect of ``opn`` ended: a runnable without a generator ends with it, a generator resumes."""
        if opn._gen is None:
            self._finish(opn, value, error)
        else:
            self._resume(opn, value, error)

    def _resume(self, opn: Operation[Any], value: Any, error: BaseException | None) -> None:
        """Run ``opn``'s generator until it waits for an effect or ends."""
        if opn.done:
            return
        opn._cancel = None
        gen = opn._gen
        if gen is None:  # a Single request: its first answer is the result
            self._finish(opn, None if value is None else value[0], error)
            return
        while True:
            try:
                effect = gen.send(value) if error is None else gen.throw(error)
            except StopIteration as stop:
                self._finish(opn, stop.value, None)
                return
            except Exception as exc:
                self._finish(opn, None, exc)
                return
            try:
                value = self._begin(opn, effect)
                error = None
            except Exception as exc:
                value, error = None, exc
                continue
            if value is _WAIT:
                return

    def _begin(self, opn: Operation[Any], effect: Effect) -> Any:
        """Start ``effect`` for ``opn``: its immediate result, or :data:`_WAIT`."""
        self._check_open()
        if isinstance(effect, Request):
            if self.check_request is not None:
                self.check_request(effect.messages)
            ex = _Exchange(self, opn, effect)
            ex.start()
            opn._cancel = ex.cancel
            return _WAIT
        if effect.__class__ is Cycle:
            if self.check_request is not None:
                self.check_request(effect.messages)
            cyc = _CycleRun(self, opn, effect)
            opn._cancel = cyc.cancel
            return _WAIT
        if isinstance(effect, Send):
            msgs = effect.messages
            return _WAIT if self._queue(opn, msgs, [m.encode() for m in msgs]) else None
        if isinstance(effect, Batch):
            frames = [p.encode() for p in effect.presets]
            effect.start.encode()
            self._sequence(_SeqJob(opn, effect.presets, frames, effect))
            return _WAIT
        if isinstance(effect, Sleep):
            tid = self._add_timer(self.now + effect.seconds, lambda: self._resume(opn, None, None))

            def stop_sleeping() -> None:
                self._timers.pop(tid, None)

            opn._cancel = stop_sleeping
            return _WAIT
        assert isinstance(effect, AwaitState)
        node, since = effect.node, effect.newer_than
        st = self.states.get(node)
        if st is not None and st.timestamp > since:
            return st
        entry = (opn, since)
        self._state_waits.setdefault(node, []).append(entry)

        def expire() -> None:
            self._drop_state_wait(node, entry)
            self._resume(opn, None, TimeoutError([node], "a state update", effect.timeout))

        tid = self._add_timer(self.now + effect.timeout, expire)

        def cancel() -> None:
            self._timers.pop(tid, None)
            self._drop_state_wait(node, entry)

        opn._cancel = cancel
        return _WAIT

    def _drop_state_wait(self, node: int, entry: tuple[Operation[Any], float]) -> None:
        lst = self._state_waits.get(node)
        if lst is not None and entry in lst:
            lst.remove(entry)
            if not lst:
                del self._state_waits[node]

    def _check_open(self) -> None:
        if self.closed_error is not None:
            raise self.closed_error

    def abort(self, error: BaseException) -> None:
        """Fail every running operation with ``error`` (a write failed); new operations are taken."""
        for w in self.matcher.clear():
            w.on_complete = None
        self._timers.clear()
        self._heap.clear()
        self._state_waits.clear()
        self._provisional.clear()
        self._seq.clear()
        self._seq_busy = False
        self._hold = None
        self._out.clear()
        for opn in list(self._ops.values()):
            if opn._gen is not None:
                opn._gen.close()
            self._finish(opn, None, error)

    def close(self, error: BaseException, *, final: bool = True) -> None:
        """End the session: every running operation fails with ``error``, and so does every new one.

        ``final`` False (the receive loop failed) still lets :meth:`estop` queue frames."""
        if self.closed_error is None or final:
            self.closed_error = error
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
        if now > self.now:
            self.now = now
        self.frames_received += 1
        arb, data, ext, rtr = frame
        if ext or rtr or len(data) != 8:
            self.malformed += 1
            self.unmatched += 1
            return frame
        cmd = arb & 0x1F
        if cmd & 1:
            # state frame: decode bits 0-2 only (as decode_reply does)
            node = arb >> 5
            pos, vel, tq = _STATE(data)
            st: MotorState = _new_state(
                MotorState, (node, pos, vel / 100, tq / 100, bool(cmd & 2), bool(cmd & 4), self.now)
            )
            if not cmd & 2:
                mv = self.moves.get(node)
                if mv is not None and mv.took is None and st.timestamp > mv.sent:
                    mv.took = st.timestamp
            self.states[node] = st
            self.matcher.resolve_state(node, st)
            waits = self._state_waits.get(node)
            if waits:
                for opn, since in list(waits):
                    if st.timestamp > since:
                        if opn._cancel is not None:
                            opn._cancel()  # its timer and this entry
                        self._resume(opn, st, None)
            return st
        if cmd != 0x1E:
            if cmd in _HOST_ONLY_CMDS:
                self.other_hosts = True
            else:
                self.malformed += 1
            self.unmatched += 1
            return frame
        try:
            reply = decode_reply(arb, data)
        except ProtocolError:
            self.malformed += 1
            self.unmatched += 1
            return frame
        node, address, dtype = reply.node, reply.address, reply.dtype  # type: ignore[union-attr]
        if data[4:] == _ZERO4:
            # A reply of value 0 has the bytes of a read request: another host's read
            # of the same parameter looks exactly like it. With other hosts about, hold
            # it back for the grace: a non-zero reply in the meantime is the answer.
            key = (node, address)
            if key in self._provisional:
                return None  # another such frame: the first one's grace runs on
            if self.other_hosts and self.matcher.waiting(node, address, dtype):
                self._provisional[key] = (self.now + self.zero_reply_grace, reply)
                self._timer_seq += 1  # a new deadline
                return None
            outcome = self.matcher.resolve_reply(node, address, dtype, reply)
            if outcome != MATCHED:
                if outcome == MISMATCHED:
                    self.anomalies += 1
                self.other_hosts = True  # most likely another host's read request
                self.unmatched += 1
                return frame
            return None
        self._provisional.pop((node, address), None)
        outcome = self.matcher.resolve_reply(node, address, dtype, reply)
        if outcome != MATCHED:
            if outcome == MISMATCHED:
                self.anomalies += 1
            self.unmatched += 1
            return frame
        return None

    def _settle(self, now: float, keys: Sequence[tuple[int, int]] | None = None) -> None:
        """Take held-back replies of value 0 as answers: those due by ``now``, or those for ``keys``."""
        provisional = self._provisional
        for key, (due, reply) in list(provisional.items()):
            wanted = due <= now if keys is None else key in keys or (0, key[1]) in keys
            if (
                wanted
                and provisional.pop(key, None) is not None
                and self.matcher.resolve_reply(key[0], key[1], reply.dtype, reply) == MISMATCHED
            ):
                self.anomalies += 1
