"""What the threaded and the asyncio bus share: the driver, options, the state cache, the safety gate and the
interface of the layers above (robot, motion, apps: see docs/design.md, "Layers")."""

from __future__ import annotations

import dataclasses
import threading
from abc import ABC, abstractmethod
from collections.abc import Callable, Iterable, Mapping, Sequence
from types import MappingProxyType
from typing import Any, Generic, TypeVar

from ...errors import ValidationError
from ...protocol.ids import Frame, check_node
from ...protocol.limits import check_motor
from ...protocol.messages import FastRead, Message, ReadParam, Start, StartImpedance, WriteParam
from ...protocol.parameters import find_parameter, parameter
from ...transports.base import Transport
from ...transports.factory import open_transport
from ..driver.bus_driver import BusDriver, FrameTap
from ..engine.commands import check_ids
from ..engine.effects import Op
from ..engine.gate import Intent, Limit, MotionGate, intents_of, param_kind
from ..engine.operation import Operation
from ..engine.session import DEFAULT_TIMEOUT, BusSession, StartPolicy, StopOnClose
from ..engine.state import MotorState, StateCallback, Subscription
from ..engine.supervisor import HealthEvent, HealthPolicy, Watch, action_messages
from ..engine.timeouts import seconds
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


class BusBase(ABC, Generic[M]):
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

    # ------------------------------------------------------------ the safety gate (see drempower.client.engine.gate)

    def set_limits(
        self,
        id: int,
        *,
        position: tuple[float, float] | None = None,
        speed: float | None = None,
        torque: float | None = None,
        accel: float | None = None,
        max_step: float | None = None,
        where: str | None = None,
        replace: bool = True,
    ) -> None:
        """Set the soft limits of motor ``id`` (replacing its earlier ones; None: no such limit; with
        ``replace`` False, the limits not given here are kept, each with its own ``where``).

        ``position`` (low, high) deg, ``speed`` r/min, ``torque`` Nm, ``accel`` (r/min)/s (by
        magnitude) and ``max_step``, the largest step (deg) a single position command may make
        from the last known position. A motion command beyond one raises
        :class:`~drempower.errors.SoftLimitError` naming it and ``where`` it was set (default:
        this call), before any frame is sent.
        """
        check_motor(id, "id")
        given = {"position": position, "speed": speed, "torque": torque, "accel": accel, "max_step": max_step}
        if not replace:
            given = {k: v for k, v in given.items() if v is not None}
        if where is None:
            args = ", ".join(f"{k}={v!r}" for k, v in given.items() if v is not None)
            where = f"bus.set_limits({id}{', ' if args else ''}{args})"
        self._gate.set_limits(id, where, **given)

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

    def limits(self, id: int) -> dict[str, Limit]:
        """The soft limits of motor ``id`` (see :meth:`set_limits`): name ->
        :class:`~drempower.client.engine.gate.Limit`."""
        return dict(self._gate.limits(id))

    def _passage(
        self, intents: Sequence[Intent], enable: bool, timeout: float | None = None, *, closed_loop: bool = True
    ) -> Op[None] | None:
        """None when ``intents`` pass the gate as they are; else the operation that reads what it needs,
        enables (``enable``) or raises MotorIdleError / SoftLimitError (nothing sent). An intent for every
        motor (node 0) stands for one to each motor the bus knows. ``closed_loop`` False checks the limits
        only (the bridge's remote face: the motor itself ignores motion until enabled)."""
        if enable.__class__ is not bool:
            raise ValidationError(f"enable={enable!r}: expected True or False")
        if any(it.node == 0 for it in intents):
            intents = self._each_motor(intents)
        return self._gate.passage(intents, self._core.states, enable, timeout, self._core.now(), closed_loop)

    def _each_motor(self, intents: Sequence[Intent]) -> list[Intent]:
        """``intents`` with each one to every motor (node 0) replaced by one to each motor the bus knows;
        a ValidationError when it knows none (no motor's limits or state could answer for the command)."""
        known = sorted(self.known_motors())
        if not known:
            raise ValidationError(
                "a motion command to every motor (id 0) is refused: this bus knows no motor to check it "
                "against (address each motor by its id, or scan first)"
            )
        out: list[Intent] = []
        for it in intents:
            out.extend([dataclasses.replace(it, node=n) for n in known] if it.node == 0 else [it])
        return out

    def check_path(self, motion: Iterable[Message]) -> None:
        """The soft limits of a path's commands, streamed in the order they will be sent (no I/O, nothing
        sent): each one's values, each position's step from the one before. The first one's step from
        where the motor is, and its axis state, are :meth:`pass_gate`'s."""
        self._gate.check_path(motion)

    def check_limits(self, motion: Sequence[Message]) -> None:
        """The soft limits that ``motion``'s own values meet (speed, torque, acceleration, absolute
        positions; no I/O, nothing sent): SoftLimitError for the first beyond one. For a whole program
        checked before its first command (a replayed log); each command still passes the gate as it goes."""
        intents = intents_of(motion)
        if any(it.node == 0 for it in intents) and self.known_motors():
            intents = self._each_motor(intents)
        self._gate.check_values(intents)

    def _param_gate(self, node: int, prop: str | int, value: float, force: bool) -> Op[None] | None:
        """The gate for writing ``value`` to parameter ``prop`` of motor ``node`` (0: every motor): the
        value checked against the parameter first (nothing sent), then, for a parameter that commands
        motion (:data:`~drempower.client.engine.gate.MOTION_PARAMETERS`), what a motion command passes."""
        WriteParam.of(node, prop, value, force=force)  # DomainError before any read of the gate
        nodes = sorted(self.known_motors()) if node == 0 else [node]
        intents = self._gate.param_intents(nodes, prop, value)
        if node == 0 and intents and not nodes:
            self._each_motor([Intent(0)])  # refuses
        return self._passage(intents, False) if intents else None

    def _param_sent(self, node: int, prop: str | int, value: float) -> None:
        """Note a parameter write sent: a motion parameter ends its motors' pending timed stops."""
        if param_kind(parameter(prop), value) is not None:
            self._timed.cancel(sorted(self.known_motors()) if node == 0 else [node])

    def _gate_op(self, msgs: Sequence[Message], enable: bool) -> Op[None] | None:
        """:meth:`_passage` of motion messages, with the fast path of motors known in closed loop."""
        if enable.__class__ is bool and self._gate.clear(msgs, self._core.states):
            return None
        return self._passage(intents_of(msgs), enable)

    def _sent(self, msgs: Sequence[Message], duration: float | None = None) -> None:
        """Note what a motion call sent (the gate learns targets; a pending timed stop of its motors ends);
        with ``duration`` (s), schedule the stop of the speeds/torques sent."""
        self._gate.note_sent(msgs)
        self._timed.commanded(msgs, duration)

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

    def health_acted(self, events: Sequence[HealthEvent]) -> None:
        """Note what a supervisor step's actions sent (:func:`~drempower.client.engine.supervisor.action_messages`):
        the safety gate then refuses motion to a joint it idled until it is enabled again."""
        acts = action_messages(events)
        if acts:
            self._sent(acts)

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

    def _moved(self, ids: Sequence[int]) -> None:
        """Note a synchronised move: it ends its motors' pending timed stops."""
        self._timed.cancel(ids)

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
