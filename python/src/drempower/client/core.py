"""The bus core shared by the threaded and asyncio APIs.

It owns the transport and the one receive thread, sends frames, matches
replies to requests, keeps the state cache and the per-motor facts the client
has learned (trajectory mode, reply-state setting), and knows which motors
hold pending presets and which motors this bus has commanded. It never blocks
waiting for a reply: the two front ends (:class:`~drempower.client.bus.Bus`
and :class:`~drempower.client.aio.AsyncBus`) wait in their own way.
"""

from __future__ import annotations

import atexit
import dataclasses
import logging
import struct
import threading
import time
import weakref
from collections.abc import Callable, Iterable, Sequence
from typing import Literal

from ..errors import ProtocolError, ValidationError
from ..protocol.addresses import (
    AXIS0_CONFIG_EXTRA_SETTING_ENABLE_REPLY_STATE,
    AXIS0_REQUESTED_STATE,
    AXIS0_TRAP_TRAJ_CONFIG_TRAJ_MODE,
)
from ..protocol.ids import Frame, SysCmd
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
from ..transports.base import Transport
from . import signals
from .errors import BusClosedError, TimeoutError
from .requests import MATCHED, MISMATCHED, Matcher, Waiter, request_dtype, request_key
from .state import MotorState, StateCache
from .timeouts import seconds

__all__ = [
    "BusCore",
    "Exchange",
    "FrameTap",
    "MoveRecord",
    "MOVE_TOLERANCE",
    "StartPolicy",
    "StopOnClose",
    "DEFAULT_TIMEOUT",
    "DEFAULT_MOVE_TIMEOUT",
    "DEFAULT_POLL_INTERVAL",
    "MOTION_CMDS",
    "describe_request",
    "idle_frames",
]

_log = logging.getLogger("drempower.client")

DEFAULT_TIMEOUT = 0.1
"""Default time (s) a request waits for its reply."""
DEFAULT_MOVE_TIMEOUT = 60.0
"""Default longest wait (s) for a move to finish (position_done and friends)."""
DEFAULT_POLL_INTERVAL = 0.01
"""Default pause (s) between fast reads while waiting for a move to finish."""

StartPolicy = Literal["auto", "broadcast", "node"]
"""Where start commands go: see :class:`BusCore`."""
StopOnClose = bool | Literal["idle", "estop"]
"""What closing the bus does to the motors it commanded: see :class:`BusCore`."""

MOVE_TOLERANCE = 0.5
"""Default largest distance (deg) between a finished move's position and its target."""
ASSUMED_BITRATE = 125_000
"""Bit rate (bit/s) assumed when the transport does not know the bus's: the slowest the motors use."""
_WORST_FRAME_BITS = 135
"""Longest standard 8-byte CAN data frame with stuff bits and interframe space."""
_POSITION_CMDS = (PositionT, PositionQ, PositionP)
_POSITION_STARTS = frozenset((0x10, 0x11, 0x12))
_STARTS = (Start, StartImpedance)
_TYPED_PRESETS = (PresetT, PresetQ, PresetP, PresetV, PresetC, PresetD)


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

    ``target`` deg (None when unknown), ``sent`` the :func:`time.monotonic`
    time just before its command or start was sent, ``move_time`` the planned
    duration (s, Q-mode synchronised moves) and ``took`` the arrival time of
    the first state with T = 0 after ``sent`` (the motor showed it took the
    move; None until then). ``resend`` holds the node-addressed messages that
    started it (the motor's preset and a start to that motor only, or the
    direct position command), sent again when a wait finds the move lost
    (see :func:`~drempower.client.ops.wait_done`); empty when unknown.
    """

    target: float | None
    sent: float
    move_time: float | None = None
    took: float | None = None
    resend: tuple[Message, ...] = ()


_RX_SLICE = 1.0
"""Longest wait (s) of the receive loop for a frame; closing the transport wakes it sooner."""
ZERO_REPLY_GRACE = 0.01
"""How long (s) a parameter reply of value 0 is held back once another host is seen on the bus."""
_HOST_ONLY_CMDS = frozenset((0x08, 0x0C, 0x1A, 0x1C, 0x1F))
"""Commands only a host sends: seeing one that this bus did not send means another host is present."""
_ZERO4 = bytes(4)
_STATE = struct.Struct("<fhh").unpack
MOTION_CMDS = frozenset((0x0C, 0x19, 0x1A, 0x1B, 0x1C, 0x1D))
"""Preset and control commands: they move motors, and with enable_reply_state on each is answered by a state."""
_IDLE = 1  # axis0.requested_state value for IDLE
_REQUESTED_STATE = AXIS0_REQUESTED_STATE
_RESETS = frozenset((SysCmd.INIT_CONFIG, SysCmd.ERASE_CONFIG, SysCmd.REBOOT))
_new_state = tuple.__new__
_monotonic = time.monotonic
_open_cores: weakref.WeakSet[BusCore] = weakref.WeakSet()
_SIGNAL_LOCK_WAIT = 0.2
"""Longest wait (s) for a lock when a signal handler closes a bus: the interrupted code may hold it."""
FrameTap = Callable[[Frame, bool], None]
"""``tap(frame, tx)``: a frame this bus sent (``tx`` True) or received (False)."""


@atexit.register
def _close_open_buses() -> None:
    """Close (and so apply ``stop_on_close`` to) every bus still open when Python exits."""
    for core in list(_open_cores):
        core.close()


def _close_stopping_buses() -> None:
    """From a signal handler: close every open bus with ``stop_on_close``, never waiting long on a lock."""
    for core in list(_open_cores):
        if core.stop_on_close:
            core.close(lock_timeout=_SIGNAL_LOCK_WAIT)


signals.register_stopper(_close_stopping_buses)


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


class BusCore:
    """Transport, receive loop, reply matching and state of one bus.

    ``timeout`` (s) is the default wait for a reply and ``retries`` how often a
    read whose reply did not come is sent again. ``start`` chooses where start
    commands go: ``"auto"`` (default) sends the start of a one-motor move to
    that motor only, and the start of a multi-motor move to broadcast unless a
    motor outside the move may still hold a preset from this bus (then to each
    motor of the move); ``"broadcast"`` always broadcasts (the vendor library's
    behaviour); ``"node"`` always addresses each motor. ``stop_on_close``:
    ``True`` or ``"idle"`` puts every motor this bus sent a motion command or
    a state request (set_mode) to into IDLE when the bus closes, ``"estop"``
    sends them an emergency stop, ``False`` leaves them as they are. With
    ``stop_on_close`` a bus opened in the main thread also makes SIGTERM and
    SIGHUP close it (see :mod:`drempower.client.signals`).
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
        if start not in ("auto", "broadcast", "node"):
            raise ValidationError(f"start={start!r}: 'auto', 'broadcast' or 'node'")
        if stop_on_close not in (True, False, "idle", "estop"):
            raise ValidationError(f"stop_on_close={stop_on_close!r}: True, False, 'idle' or 'estop'")
        timeout = seconds(timeout)
        if retries.__class__ is not int or retries < 0:
            raise ValidationError(f"retries={retries!r}: must be an integer >= 0")
        self.transport = transport
        self.timeout = float(timeout)
        self.retries = retries
        self.stop_on_close = stop_on_close
        self.start_policy: StartPolicy = start
        self.on_unsolicited = on_unsolicited
        """Called in the receive thread with every frame that is no reply to a request and no state frame."""
        self.frame_taps: tuple[FrameTap, ...] = ()
        """Called with every frame this bus sends (``tx`` True, in the sending thread) or receives
        (``tx`` False, in the receive thread) as it passes the transport: for recorders. See :meth:`add_tap`."""
        self.on_sent: Callable[[Frame, float], None] | None = None
        """Called in the sending thread after each frame of a batch, exchange or estop is handed to the
        transport, with the frame and :func:`time.monotonic` of the hand-over (s); keep it short."""
        self.states = StateCache()
        self.matcher = Matcher()
        self.traj_mode: dict[int, int] = {}
        """Known ``traj_mode`` (35104) per motor: read from it or set through this bus."""
        self.reply_state: dict[int, bool] = {}
        """Known ``enable_reply_state`` (31214) per motor."""
        self.moves: dict[int, MoveRecord] = {}
        """The last position move per motor (see :class:`MoveRecord`); other motion commands drop it."""
        self._wire_free = 0.0
        self.frames_received = 0
        self.malformed = 0
        self.unmatched = 0
        self.anomalies = 0
        """Replies for a waiting request whose echoed fields (data type) differ from it: never taken as answers."""
        self.moves_resent = 0
        """Moves sent again because a wait found them lost (see :func:`~drempower.client.ops.wait_done`)."""
        self.other_hosts = False
        """True once frames of another host were seen (see :meth:`_dispatch`)."""
        self.zero_reply_grace = ZERO_REPLY_GRACE
        self._provisional: dict[tuple[int, int], tuple[float, object]] = {}
        self._send_lock = threading.Lock()
        self._batch_lock = threading.Lock()
        self._close_lock = threading.Lock()
        self._pending_presets: set[int] = set()
        """Motors holding a preset no start has consumed yet (0 = a broadcast preset)."""
        self._preset_msgs: dict[int, Message] = {}
        """The last preset sent per motor through :meth:`send`/:meth:`send_many` and not started yet."""
        self._commanded: set[int] = set()
        self._closed = False
        self.closed_event = threading.Event()
        """Set when the bus closes (wakes sleeping operations)."""
        self._failure: BaseException | None = None
        self._thread = threading.Thread(
            target=self._rx_loop, name=f"drempower rx ({transport.description})", daemon=True
        )
        self._thread.start()
        _open_cores.add(self)
        if stop_on_close:
            signals.install_stop_handlers()

    # ------------------------------------------------------------------ state

    @property
    def closed(self) -> bool:
        return self._closed

    @property
    def commanded(self) -> frozenset[int]:
        """Motors this bus has sent motion commands or a requested state to (0 = broadcast)."""
        return frozenset(self._commanded.copy())

    def check_open(self) -> None:
        """Raise :class:`BusClosedError` if the bus is closed or its receive loop stopped."""
        if self._closed:
            raise BusClosedError(f"the bus ({self.transport.description}) is closed")
        if self._failure is not None:
            raise BusClosedError(f"the receive loop stopped: {self._failure}") from self._failure

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
            self._commanded.add(msg.node)
            if cmd != 0x0C:  # a preset changes nothing until its start
                self._new_move(msg)
        elif isinstance(msg, WriteParam):
            if msg.address == _REQUESTED_STATE:
                self._commanded.add(msg.node)
            else:
                self.learn(msg.node, msg.address, msg.value)
        elif cmd == 0x08 and frame[1][0] in _RESETS:
            self.forget(msg.node)

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

    def _new_move(self, msg: Message) -> None:
        """Record the position move a direct command starts; any other motion command ends the record."""
        node = msg.node
        if node == 0:
            self.moves.clear()
        elif isinstance(msg, _POSITION_CMDS):
            self.moves[node] = MoveRecord(msg.position, _monotonic(), resend=(msg,))
        else:
            self.moves.pop(node, None)

    # ------------------------------------------------------------------ sending

    def send(self, msg: Message) -> None:
        """Encode (validating) and send one message; never waits for a reply.

        A preset or start is sequenced as in :meth:`send_many` (a start may wait
        until the presets it starts are on the wire).
        """
        frame = msg.encode()
        self.check_open()
        cmd = msg.cmd
        if cmd == 0x0C or (cmd == 0x08 and isinstance(msg, _STARTS)):
            self._send_sequenced([msg], [frame])
            return
        if cmd != 0x1E:
            self._note(msg, frame)
        self._send_frames((frame,))

    def send_many(self, msgs: Sequence[Message]) -> None:
        """Encode every message first (nothing is sent if one is invalid), then send them in order.

        Presets (0x0C) are remembered until a start consumes them. A start
        (0x08, sys 0x10..0x15) that would start a pending preset is sent only
        once every preset is on the wire (:meth:`presets_on_wire`, so a start
        never overtakes its presets in a controller's mailboxes); the moves
        it starts are then recorded in :attr:`moves` as :meth:`send_batch`
        does (target from each motor's position preset, move time from a Q
        preset; a relative move's target is unknown).
        """
        frames = [m.encode() for m in msgs]
        self.check_open()
        if self.sequenced(msgs):
            self._send_sequenced(msgs, frames)
            return
        for m, f in zip(msgs, frames, strict=True):
            if m.cmd != 0x1E:
                self._note(m, f)
        self._send_frames(frames)

    @staticmethod
    def sequenced(msgs: Sequence[Message]) -> bool:
        """Whether sending ``msgs`` involves presets or starts (and so may wait for the wire: see :meth:`send_many`)."""
        return any(m.cmd == 0x0C or isinstance(m, _STARTS) for m in msgs)

    def _send_sequenced(self, msgs: Sequence[Message], frames: Sequence[Frame]) -> None:
        """Send encoded messages holding presets or starts: track the presets, gate and record the starts."""
        with self._batch_lock:
            chunk: list[Frame] = []
            for m, f in zip(msgs, frames, strict=True):
                self._note(m, f)
                if m.cmd == 0x0C:
                    self._hold_preset(m)
                elif isinstance(m, _STARTS) and self._starts_pending(m.node):
                    if chunk:
                        self._send_frames(chunk)
                        chunk = []
                    self._start_pending(m, f)
                    continue
                chunk.append(f)
            if chunk:
                self._send_frames(chunk)

    def _hold_preset(self, msg: Message) -> None:
        node = msg.node
        if node == 0:  # a broadcast preset replaces every motor's
            self._preset_msgs.clear()
        self._pending_presets.add(node)
        self._preset_msgs[node] = msg

    def _starts_pending(self, node: int) -> bool:
        """Whether a start to ``node`` (0 = broadcast) would start a pending preset."""
        pending = self._pending_presets
        return bool(pending) if node == 0 else node in pending or 0 in pending

    def _start_pending(self, start: Message, frame: Frame) -> None:
        """Send ``start`` once the presets are on the wire; record the moves it starts, drop what it consumed."""
        node = start.node
        pending = self._pending_presets
        started = sorted(pending) if node == 0 else [node]
        self.presets_on_wire([n for n in started if n] or [0])
        sent = _monotonic()
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
        self._send_frames([frame])
        if node == 0:
            pending.clear()
            self._preset_msgs.clear()
        else:
            pending.discard(node)
            self._preset_msgs.pop(node, None)

    def _reserve_wire(self, count: int) -> None:
        """Account ``count`` frames handed to the transport now in :attr:`_wire_free` (when the wire is free)."""
        rate = getattr(self.transport, "wire_bitrate", None) or ASSUMED_BITRATE
        self._wire_free = max(_monotonic(), self._wire_free) + count * _WORST_FRAME_BITS / rate

    def _send_frames(self, frames: Sequence[Frame], lock_timeout: float = -1) -> None:
        """Hand ``frames`` to the transport in order, taking the send lock per frame (so an estop from
        another thread waits one frame at most); with ``lock_timeout`` >= 0 (s), a frame whose lock does
        not come in that time is sent anyway (a signal handler may interrupt the code holding it)."""
        lock, send, sent = self._send_lock, self.transport.send, self.on_sent
        self._reserve_wire(len(frames))
        for f in frames:
            held = lock.acquire(timeout=lock_timeout)
            try:
                send(f)
                if self.frame_taps:
                    self._tap(f, True)
            finally:
                if held:
                    lock.release()
            if sent is not None:
                sent(f, _monotonic())

    def estop(self, nodes: Sequence[int]) -> None:
        """Emergency stop: one frame per node (0 = every motor), sent at once, no reply awaited.

        Works even after the receive loop failed; only a closed bus refuses.
        """
        frames = [SystemCommand(n, SysCmd.ESTOP).encode() for n in nodes]
        if self._closed:
            raise BusClosedError(f"the bus ({self.transport.description}) is closed")
        self._send_frames(frames)

    def send_batch(
        self,
        presets: Sequence[Message],
        start: Start | StartImpedance,
        targets: Sequence[float | None] | None = None,
        move_time: float | None = None,
    ) -> list[int]:
        """Send presets and their start as one atomic batch; returns where the start(s) went.

        Every frame is encoded before the first is sent. The start is sent only
        once every preset is known to be on the wire (:meth:`presets_on_wire`).
        For a position move, ``targets`` (deg per preset) and ``move_time`` (s)
        are recorded in :attr:`moves` for the waits. See the class docstring for
        the start addressing. When a batch fails before its start, its motors
        stay marked as holding a preset: later starts then go to each motor of
        their own batch, never to broadcast, until those motors get a new preset
        and start, so a stale preset never fires.
        """
        nodes = [p.node for p in presets]
        frames = [p.encode() for p in presets]
        start.encode()
        self.check_open()
        with self._batch_lock:
            policy = self.start_policy
            broadcast = policy == "broadcast" or (
                policy == "auto" and len(nodes) > 1 and self._pending_presets.issubset(nodes)
            )
            where = [0] if broadcast else nodes
            starts = [dataclasses.replace(start, node=n).encode() for n in where]
            self._pending_presets.update(nodes)
            for n in nodes:
                self._preset_msgs.pop(n, None)
            self._commanded.update(nodes)
            self._send_frames(frames)
            self.presets_on_wire(nodes)
            sent = _monotonic()
            moves = self.moves
            if isinstance(start, Start) and start.kind in _POSITION_STARTS:
                goals = targets if targets is not None else [None] * len(nodes)
                for p, goal in zip(presets, goals, strict=True):
                    n = p.node
                    moves[n] = MoveRecord(goal, sent, move_time, None, (p, dataclasses.replace(start, node=n)))
            else:
                for n in nodes:
                    moves.pop(n, None)
            self._send_frames(starts)
            if broadcast:
                self._pending_presets.clear()
                self._preset_msgs.clear()
            else:
                self._pending_presets.difference_update(nodes)
        return where

    def presets_on_wire(self, nodes: Sequence[int]) -> None:
        """Return once every frame sent so far (the presets of a batch) is on the wire.

        A transport that delivers in order (``in_order``, the UART) needs no wait;
        one that confirms transmission (``wait_sent``, the in-process simulator)
        is asked, and a refusal within the bus timeout raises :class:`TimeoutError`;
        otherwise the wait lasts the bus time of everything sent and not yet on
        the wire (worst-case frame length at the transport's ``wire_bitrate``, or
        125 kbit/s when unknown) plus the transport's ``tx_latency``.
        """
        t = self.transport
        if getattr(t, "in_order", False):
            return
        wait_sent = getattr(t, "wait_sent", None)
        confirmed = wait_sent(max(self.timeout, 0.1)) if wait_sent is not None else None
        if confirmed:
            return
        if confirmed is False:
            raise TimeoutError(nodes, "the transmission of the presets", max(self.timeout, 0.1))
        delay = self._wire_free + getattr(t, "tx_latency", 0.005) - _monotonic()
        if delay > 0 and self.closed_event.wait(delay):
            self.check_open()

    # ------------------------------------------------------------------ receiving

    def _rx_loop(self) -> None:
        recv = self.transport.recv
        dispatch = self._dispatch
        provisional = self._provisional
        try:
            while not self._closed:
                wait = _RX_SLICE
                if provisional:
                    dues = [d for d, _ in list(provisional.values())]
                    if dues:
                        wait = max(0.0, min(wait, min(dues) - _monotonic()))
                frame = recv(wait)
                if frame is not None:
                    if self.frame_taps:
                        self._tap(frame, False)
                    try:
                        dispatch(frame)
                    except Exception:
                        _log.exception("dispatching %r failed", frame)
                if provisional:
                    self._settle(_monotonic())
        except Exception as exc:
            if not self._closed:
                _log.error("receive loop on %s stopped: %s", self.transport.description, exc)
                self._failure = exc
                self.matcher.fail_all(BusClosedError(f"the receive loop stopped: {exc}"))

    def _dispatch(self, frame: Frame) -> None:
        self.frames_received += 1
        arb, data, ext, rtr = frame
        if ext or rtr or len(data) != 8:
            self.malformed += 1
            self._unsolicited(frame)
            return
        cmd = arb & 0x1F
        if cmd & 1:
            # state frame: decode bits 0-2 only (as decode_reply does)
            node = arb >> 5
            pos, vel, tq = _STATE(data)
            st: MotorState = _new_state(
                MotorState, (node, pos, vel / 100, tq / 100, bool(cmd & 2), bool(cmd & 4), _monotonic())
            )
            if not cmd & 2:
                mv = self.moves.get(node)
                if mv is not None and mv.took is None and st.timestamp > mv.sent:
                    mv.took = st.timestamp
            self.states.update(st)
            self.matcher.resolve(node, 0, st)
            return
        if cmd != 0x1E:
            if cmd in _HOST_ONLY_CMDS:
                self.other_hosts = True
            else:
                self.malformed += 1
            self._unsolicited(frame)
            return
        try:
            reply = decode_reply(arb, data)
        except ProtocolError:
            self.malformed += 1
            self._unsolicited(frame)
            return
        node, address, dtype = reply.node, reply.address, reply.dtype  # type: ignore[union-attr]
        if data[4:] == _ZERO4:
            # A reply of value 0 has the bytes of a read request: another host's read
            # of the same parameter looks exactly like it. With other hosts about, hold
            # it back for the grace: a non-zero reply in the meantime is the answer.
            key = (node, address)
            if key in self._provisional:
                return  # another such frame: the first one's grace runs on
            if self.other_hosts and self.matcher.waiting(node, address, dtype):
                self._provisional[key] = (_monotonic() + self.zero_reply_grace, reply)
                return
            outcome = self.matcher.resolve_reply(node, address, dtype, reply)
            if outcome != MATCHED:
                if outcome == MISMATCHED:
                    self.anomalies += 1
                self.other_hosts = True  # most likely another host's read request
                self._unsolicited(frame)
            return
        self._provisional.pop((node, address), None)
        outcome = self.matcher.resolve_reply(node, address, dtype, reply)
        if outcome != MATCHED:
            if outcome == MISMATCHED:
                self.anomalies += 1
                _log.warning("reply %r does not match the request waiting for it (data type): ignored", reply)
            self._unsolicited(frame)

    def _settle(self, now: float, keys: Sequence[tuple[int, int]] | None = None) -> None:
        """Take held-back replies of value 0 as answers: those due by ``now``, or those for ``keys``."""
        provisional = self._provisional
        for key, (due, reply) in list(provisional.items()):
            wanted = due <= now if keys is None else key in keys or (0, key[1]) in keys
            if (
                wanted
                and provisional.pop(key, None) is not None
                and self.matcher.resolve_reply(key[0], key[1], reply.dtype, reply) == MISMATCHED  # type: ignore[attr-defined]
            ):
                self.anomalies += 1

    def settle_for(self, waiter_keys: Sequence[int]) -> None:
        """Before a request gives up: take the held-back replies it was waiting for."""
        if self._provisional:
            self._settle(0.0, [(k >> 16, k & 0xFFFF) for k in waiter_keys])

    def _unsolicited(self, frame: Frame) -> None:
        self.unmatched += 1
        hook = self.on_unsolicited
        if hook is not None:
            try:
                hook(frame)
            except Exception:
                _log.exception("unsolicited-frame hook %r failed", hook)

    # ------------------------------------------------------------------ closing

    def stop_frames(self) -> list[Frame]:
        """The frames ``stop_on_close`` sends: idle or estop to every commanded motor."""
        if not self.stop_on_close:
            return []
        nodes = sorted(self._commanded.copy())
        if self.stop_on_close == "estop":
            return [SystemCommand(n, SysCmd.ESTOP).encode() for n in nodes]
        return idle_frames(nodes)

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
            stops = self.stop_frames() if self._failure is None else []
            try:
                self._send_frames(stops, lock_timeout)
            except Exception as exc:
                _log.warning("stopping the motors on close failed: %s", exc)
            self._closed = True
            self.closed_event.set()
            _open_cores.discard(self)
        finally:
            self._close_lock.release()
        try:
            self.transport.close()
        finally:
            if self._thread is not threading.current_thread():
                self._thread.join(1.0)
            self.matcher.fail_all(BusClosedError(f"the bus ({self.transport.description}) was closed"))


class Exchange:
    """One request/reply exchange: register, send, and (after the caller waited) collect.

    Requests to the same motor go one at a time: a parameter reply carries the
    same CAN id as every read request to that motor, so a second request sent
    while the reply is due could collide with it on the wire. Requests to
    different motors go out together.
    A read whose reply did not come is sent again up to ``core.retries`` times.
    ``expect`` lists the reply keys when they are not one per message (a
    control cycle expects a state frame per motor whatever it sends); such an
    exchange is sent once, never retried. Without ``missing_ok`` the exchange
    ends at the first request that stays unanswered.
    """

    __slots__ = (
        "_batch",
        "_pending",
        "_serial",
        "_tries",
        "core",
        "failed",
        "frames",
        "keys",
        "missing_ok",
        "msgs",
        "results",
        "retries",
        "timeout",
        "what",
    )

    def __init__(
        self,
        core: BusCore,
        msgs: Sequence[Message],
        timeout: float | None,
        missing_ok: bool = False,
        expect: Sequence[int] | None = None,
        what: str | None = None,
    ) -> None:
        self.core = core
        self.msgs = msgs
        self.frames = [m.encode() for m in msgs]
        if expect is None:
            self.keys = [request_key(m) for m in msgs]
            self._serial: list[int] | None = [m.node for m in msgs]
            self.retries = core.retries
        else:
            self.keys = list(expect)
            self._serial = None
            self.retries = 0
        self.timeout = core.timeout if timeout is None else timeout
        if not self.timeout > 0:
            raise ValidationError(f"timeout={timeout!r}: must be > 0 s")
        self.missing_ok = missing_ok
        self.what = what
        n = len(self.keys)
        self.results: list[object | None] = [None] * n
        self.failed: list[int] = []
        self._pending = list(range(n))
        self._tries = [0] * n
        self._batch: list[int] = []

    def _dtypes(self, batch: Sequence[int]) -> list[DataType | None] | None:
        """The data type each awaited reply must echo (None when the exchange expects state frames)."""
        if self._serial is None:
            return None
        msgs = self.msgs
        return [request_dtype(msgs[i]) for i in batch]

    def _next_batch(self) -> list[int]:
        serial = self._serial
        if serial is None:
            return self._pending
        busy: set[int] = set()
        out = []
        for i in self._pending:
            node = serial[i]
            if node not in busy:
                busy.add(node)
                out.append(i)
        return out

    def start(self, notify: Callable[[], None] | None = None) -> Waiter:
        """Register the next replies to wait for and send their requests."""
        core = self.core
        core.check_open()
        batch = self._batch = self._next_batch()
        w = Waiter([self.keys[i] for i in batch], notify, self._dtypes(batch))
        core.matcher.register(w)
        try:
            core._send_frames(self.frames if self._serial is None else [self.frames[i] for i in batch])
        except BaseException:
            core.matcher.cancel(w)
            raise
        return w

    def collect(self, w: Waiter) -> bool:
        """Take the answers ``w`` got; True when the exchange is over."""
        if w.remaining:
            self.core.settle_for([w.keys[i] for i in w.missing()])
        if w.remaining:
            self.core.matcher.cancel(w)
        if w.error is not None:
            raise w.error
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
        if failed and not self.missing_ok:
            return True
        return not self._pending

    def result(self) -> list[object | None]:
        """The answers in request order; raises :class:`TimeoutError` for missing ones unless ``missing_ok``."""
        if self.failed and not self.missing_ok:
            nodes = sorted({self.keys[i] >> 16 for i in self.failed})
            what = self.what or describe_request(self.msgs[self.failed[0]])
            raise TimeoutError(nodes, what, self.timeout)
        return self.results
