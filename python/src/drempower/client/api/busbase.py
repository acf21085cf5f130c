"""What the threaded and the asyncio bus share: the driver, options, the state cache, the safety gate (its
face: :mod:`~drempower.client.api.gatebase`) and the interface of the layers above (robot, motion, apps: see
docs/design.md, "Layers")."""

from __future__ import annotations

import threading
from abc import abstractmethod
from collections.abc import Callable, Iterable, Mapping, Sequence
from types import MappingProxyType
from typing import Any, Generic, TypeVar

from ...errors import ValidationError
from ...protocol.ids import Frame, check_node
from ...protocol.limits import check_motor
from ...protocol.messages import FastRead, Message, ReadParam, Start, StartImpedance, WriteParam
from ...protocol.parameters import find_parameter
from ...transports.base import Transport
from ...transports.factory import open_transport
from ..driver.bus_driver import BusDriver, FrameTap
from ..engine.commands import check_ids
from ..engine.effects import Op
from ..engine.gate import MotionGate
from ..engine.operation import Operation
from ..engine.session import DEFAULT_TIMEOUT, BusSession, StartPolicy, StopOnClose
from ..engine.state import MotorState, StateCallback, Subscription
from ..engine.supervisor import HealthPolicy, Watch
from ..engine.timeouts import seconds
from .gatebase import GateBase
from .timed import TimedStops

__all__ = ["BusBase", "connect"]

M = TypeVar("M")
T = TypeVar("T")


def connect(
    interface: str | None, channel: str | int | None, bitrate: int | None, transport: Transport | None, **kwargs: Any
) -> Transport:
    """The transport named by the ``open_bus`` arguments, or ``transport`` itself."""
    if transport is None:
        return open_transport(interface, channel, bitrate, **kwargs)
    if interface is not None or channel is not None or bitrate is not None or kwargs:
        raise ValidationError("pass either transport= or interface/channel/bitrate options, not both")
    return transport


class BusBase(GateBase, Generic[M]):
    """Owns a :class:`BusDriver` (transport, receive thread, the session) and the motor handles.

    ``timeout`` (s) is the default reply timeout; None takes the transport's
    ``default_timeout`` if it has one (0.5 s for the in-process simulator, which
    shares the interpreter with the client), else 0.1 s.
    """

    def __init__(
        self,
        transport: Transport,
        *,
        timeout: float | None = None,
        retries: int = 0,
        stop_on_close: StopOnClose = True,
        start: StartPolicy = "auto",
        on_unsolicited: Callable[[Frame], None] | None = None,
    ) -> None:
        if timeout is None:
            timeout = transport.default_timeout or DEFAULT_TIMEOUT
        self._core = BusDriver(
            transport,
            timeout=timeout,
            retries=retries,
            stop_on_close=stop_on_close,
            start=start,
            on_unsolicited=on_unsolicited,
        )
        self._session: BusSession = self._core.session
        self._session.check_request = self._check_broadcast_reads
        self._motors: dict[int, M] = {}
        self._motors_lock = threading.Lock()
        self._gate = MotionGate(self._core.now)
        self._timed = TimedStops(self._core)
        for (
            node,
            lim,
        ) in self._core.capabilities.limits.items():  # a remote bus: the limits its bridge holds (its robot file)
            self._gate.set_limits(
                node, str(lim.get("where", "the bridge")), **{k: v for k, v in lim.items() if k != "where"}
            )

    @abstractmethod
    def _new_motor(self, id: int) -> M:
        """A new handle of motor ``id`` for this kind of bus."""

    def known_motors(self) -> set[int]:
        """The motors this bus knows are attached: handles made, motors heard from, and those
        the transport declares (``motor_ids``, e.g. the in-process simulator's)."""
        known = set(self._motors) | self._session.known.heard.copy()  # copies in one step: safe while others add
        known.update(self._core.states.snapshot())
        known.update(self._core.capabilities.motor_ids)
        known.discard(0)
        return known

    @staticmethod
    def _commands(commands: object) -> list[Message]:
        """The commands of a cycle as a list of protocol messages; :class:`ValidationError` otherwise."""
        if isinstance(commands, (str, bytes)) or not isinstance(commands, Iterable):
            raise ValidationError(f"commands={commands!r}: expected a list of messages (make_angle, make_speed...)")
        out = list(commands)
        for c in out:
            if not isinstance(c, Message):
                raise ValidationError(f"commands: {c!r} is no protocol message (make_angle, make_speed...)")
        return out

    @staticmethod
    def _check_writes(msgs: Sequence[Message]) -> None:
        """Check raw parameter writes (``send``) against their parameter's domain, as ``write_property`` does
        (without force); writes to addresses outside the table are sent as given."""
        for m in msgs:
            if isinstance(m, WriteParam):
                p = find_parameter(m.address)
                if p is not None:
                    p.check(m.value)

    def _check_broadcast_reads(self, msgs: Sequence[Message]) -> None:
        """Refuse, before sending, a read addressed to every motor (id 0) when the bus knows several:
        each would answer and the reply taken would be any one of them."""
        if len(msgs) == 1 and msgs[0].node:  # the commonest: one request to one motor
            return
        if any(m.node == 0 and isinstance(m, (FastRead, ReadParam)) for m in msgs):
            known = self.known_motors()
            if len(known) > 1:
                ids = ", ".join(map(str, sorted(known)))
                raise ValidationError(
                    f"a read addressed to every motor (id 0) is ambiguous on a bus with motors {ids}: "
                    "read each motor by its id"
                )

    def watch_health(
        self, id_list: Iterable[int], policy: HealthPolicy | None = None, names: dict[int, str] | None = None
    ) -> list[Watch]:
        """Watches for :meth:`supervise` over the motors of ``id_list`` (``names``: joint names to show)."""
        pol = policy or HealthPolicy()
        return [Watch(n, pol, (names or {}).get(n)) for n in check_ids(list(id_list))]

    def hold_on_close(self, ids: Iterable[int]) -> None:
        """Closing with ``stop_on_close=True`` (the default; a signal, Python's exit) holds motors ``ids``
        (speed 0 in closed loop) instead of idling them: a robot file's joints whose ``on_timeout`` is hold."""
        self._session.hold_on_close.update(check_motor(i, "id") for i in ids)

    @property
    def held_on_close(self) -> frozenset[int]:
        """The motors stopping holds instead of idling (see :meth:`hold_on_close`)."""
        return frozenset(self._session.hold_on_close)

    def frame_time(self, id: int) -> float | None:
        """When motor ``id``'s latest state frame was on the wire by its transport's own clock (the
        simulator's time, a CAN interface's receive timestamp; else when it arrived), on the scale of
        the state's ``timestamp`` (s); None before any state. A fit of dynamics uses it: a busy host
        reads a frame late, but the frame's own time stays true."""
        return self._session.known.frame_times.get(id)

    def send_frames(self, frames: Sequence[Frame]) -> None:
        """Send raw CAN frames as given, in order, never waiting (for frames the protocol does not define:
        nothing is checked, the session learns nothing from them; use :meth:`send` for messages)."""
        self._core._send_frames(list(frames))

    # ------------------------------------------------------------------ for the layers above (robot, motion, apps)
    # Blocking in both flavours: on the asyncio bus they return at once, except send_batch (call it from a
    # worker thread there, as the robot does). See docs/design.md, "Layers".

    def now(self) -> float:
        """The bus's clock (s): :func:`time.monotonic`, or the simulated time of a transport with a virtual
        clock (``open_bus("sim", clock="virtual")``). Session times and state timestamps are on it."""
        return self._core.now()

    @property
    def virtual(self) -> bool:
        """True when the bus runs on its transport's simulated time (see :meth:`now`, ``pass_time``)."""
        return self._core.virtual

    def submit(self, op: Op[T]) -> Operation[T]:
        """Start operation ``op`` in the bus's session now and return at once: it goes on as replies come and
        its sleeps come due, while any caller waits on the bus (on a virtual clock: as simulated time
        passes). For what runs beside the caller, such as the robot's health supervisor."""
        return self._core.submit(op)

    def cancel(self, opn: Operation[Any]) -> None:
        """Stop an operation of :meth:`submit` (nothing happens once it is done)."""
        if not opn.done:
            self._core._waits.cancel(opn)

    @property
    def commanded(self) -> frozenset[int]:
        """Motors this bus sent motion commands or a requested state to (0: a broadcast), those
        ``stop_on_close`` stops."""
        return self._core.commanded

    @property
    def stop_on_close(self) -> StopOnClose:
        """What closing the bus does to the motors it commanded: True or ``"idle"`` idles them,
        ``"estop"`` stops them, False leaves them running."""
        return self._session.stop_on_close

    @stop_on_close.setter
    def stop_on_close(self, value: StopOnClose) -> None:
        if not (value.__class__ is bool or value in ("idle", "estop")):
            raise ValidationError(f"stop_on_close={value!r}: True, False, 'idle' or 'estop'")
        self._session.stop_on_close = value

    @property
    def reply_state(self) -> Mapping[int, bool]:
        """What the bus knows of each motor's ``enable_reply_state`` (31214): motor -> on (a live,
        read-only view; a motor missing is unknown)."""
        return MappingProxyType(self._session.known.reply_state)

    @property
    def on_sent(self) -> Callable[[Frame, float], None] | None:
        """Hook called after each frame is handed to the transport, in the sending thread, with the frame
        and :func:`time.monotonic` of the hand-over (s); keep it short. None: no hook."""
        return self._core.on_sent

    @on_sent.setter
    def on_sent(self, hook: Callable[[Frame, float], None] | None) -> None:
        self._core.on_sent = hook

    def add_tap(self, tap: FrameTap) -> None:
        """Call ``tap(frame, tx)`` with every frame this bus sends (``tx`` True, in the sending thread) or
        receives (``tx`` False, in the thread that took it) from now on; keep it short (recorders use it)."""
        self._core.add_tap(tap)

    def remove_tap(self, tap: FrameTap) -> None:
        """Stop calling ``tap`` (see :meth:`add_tap`); a tap not added is ignored."""
        self._core.remove_tap(tap)

    def send_batch(
        self,
        presets: Sequence[Message],
        start: Start | StartImpedance,
        targets: Sequence[float | None] | None = None,
        move_time: float | None = None,
    ) -> list[int]:
        """Send presets and their start as one atomic batch, raw (no safety gate: pass :meth:`pass_gate`
        first); returns the nodes the start(s) went to (bus option ``start``).

        ``targets`` (deg, one per preset, None where unknown) are the absolute goals of a position move,
        which the move waits check; ``move_time`` (s) the planned time of a Q move. Blocks until the
        presets are on the wire, in both flavours (from asyncio: call it in a worker thread).
        """
        where = self._core.send_batch(presets, start, targets, move_time)
        self._sent(presets)
        return where

    def estop_now(self, id_list: Iterable[int] | None = None) -> None:
        """Emergency-stop the listed motors, or every motor (one broadcast frame) when None, in the
        calling thread: sent before anything queued, no reply awaited, in both flavours (what ``estop``
        does; a robot stops its buses at once with it)."""
        nodes = self._estop_nodes(id_list)
        self._core.estop(nodes)
        self._gate.estopped(nodes)

    def close_now(self) -> None:
        """Close the bus in the calling thread, in both flavours (it may block briefly): the pending stops
        of timed commands, ``stop_on_close`` for the motors it commanded, then the transport. Idempotent."""
        self._timed.flush()
        self._core.close()

    def motor(self, id: int) -> M:
        """The handle of motor ``id`` (1..63; 0 addresses every motor, reads need a single motor)."""
        try:
            m = self._motors.get(id)
        except TypeError:  # unhashable: no id at all
            m = None
        if m is None:
            check_node(id, "id")
            with self._motors_lock:
                m = self._motors.get(id)
                if m is None:
                    m = self._motors[id] = self._new_motor(id)
        return m

    def __getitem__(self, id: int) -> M:
        return self.motor(id)

    @staticmethod
    def _estop_nodes(id_list: Iterable[int] | None) -> list[int]:
        """The nodes an estop goes to: [0] (broadcast) for None; an empty list is refused, not a no-op."""
        if id_list is None:
            return [0]
        if isinstance(id_list, (str, bytes)) or not isinstance(id_list, Iterable):
            raise ValidationError(f"id_list={id_list!r}: a list of motor ids, or None for every motor")
        nodes = [check_node(n, "id_list") for n in id_list]
        if not nodes:
            raise ValidationError("id_list is empty: nothing would be stopped; give motor ids, or None for every motor")
        return nodes

    @property
    def transport(self) -> Transport:
        """The transport this bus owns (python-can, adapter, UART, simulator...)."""
        return self._core.transport

    @property
    def timeout(self) -> float:
        """Default reply timeout (s)."""
        return self._session.timeout

    @timeout.setter
    def timeout(self, value: float) -> None:
        self._session.timeout = seconds(value)

    @property
    def closed(self) -> bool:
        """True once the bus is closed (by :meth:`close`, or at exit)."""
        return self._core.closed

    @property
    def stats(self) -> dict[str, int]:
        """Frames received, malformed ones, those that were no reply and no state, anomalies, other
        hosts' frames, and moves sent again because a wait found them lost (``moves_resent``, with
        ``retries``).

        An anomaly is a reply for a waiting request whose echoed fields (data
        type) differ from the request's: it answers nothing (the request keeps
        waiting or times out) and also counts as unmatched. ``foreign`` counts
        frames another host sent (its commands, including 0x19/0x1B/0x1D/0x1F,
        which are never taken as a motor's state; its fast reads and reads): they
        also count as unmatched.
        """
        c = self._session
        return {
            "frames_received": c.frames_received,
            "malformed": c.malformed,
            "unmatched": c.unmatched,
            "anomalies": c.anomalies,
            "foreign": c.foreign,
            "moves_resent": c.moves_resent,
        }

    @property
    def on_unsolicited(self) -> Callable[[Frame], None] | None:
        """Hook called with frames that match no request and are no state (in the thread that took the
        frame: the receive thread, or a caller reading the transport while it waits for a reply)."""
        return self._core.on_unsolicited

    @on_unsolicited.setter
    def on_unsolicited(self, hook: Callable[[Frame], None] | None) -> None:
        self._core.on_unsolicited = hook

    def state(self, id: int) -> MotorState | None:
        """The latest state of motor ``id`` received in any way (no I/O), or None."""
        return self._core.states.get(id)

    def states(self) -> dict[int, MotorState]:
        """The latest state of every motor heard from (no I/O)."""
        return self._core.states.snapshot()

    def subscribe(self, callback: StateCallback, id: int | None = None) -> Subscription:
        """Call ``callback(state)`` for each state of motor ``id`` (all when None), in the thread that took
        the frame (the receive thread, or a caller reading the transport while it waits)."""
        return self._core.states.subscribe(callback, id)

    def __repr__(self) -> str:
        return f"<{type(self).__name__} {self.transport.description}{' closed' if self.closed else ''}>"
