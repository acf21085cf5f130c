"""What the threaded and the asyncio bus share: the core, options and the state cache (no I/O)."""

from __future__ import annotations

import threading
from abc import ABC, abstractmethod
from collections.abc import Callable, Iterable, Sequence
from typing import Generic, TypeVar

from ..errors import ValidationError
from ..protocol.ids import Frame, check_node
from ..protocol.messages import FastRead, Message, ReadParam, WriteParam
from ..protocol.parameters import find_parameter
from ..transports.base import Transport
from .driver import BusDriver
from .session import DEFAULT_TIMEOUT, BusSession, StartPolicy, StopOnClose
from .state import MotorState, StateCallback, Subscription
from .timeouts import seconds

__all__ = ["BusBase"]

M = TypeVar("M")


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

    @abstractmethod
    def _new_motor(self, id: int) -> M:
        """A new handle of motor ``id`` for this kind of bus."""

    def known_motors(self) -> set[int]:
        """The motors this bus knows are attached: handles made, motors heard from, and those
        the transport declares (``motor_ids``, e.g. the in-process simulator's)."""
        known = set(self._motors) | self._session.heard.copy()  # copies in one step: safe while others add
        known.update(self._core.states.snapshot())
        known.update(getattr(self._core.transport, "motor_ids", ()))
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
        if any(m.node == 0 and isinstance(m, (FastRead, ReadParam)) for m in msgs):
            known = self.known_motors()
            if len(known) > 1:
                ids = ", ".join(map(str, sorted(known)))
                raise ValidationError(
                    f"a read addressed to every motor (id 0) is ambiguous on a bus with motors {ids}: "
                    "read each motor by its id"
                )

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
    def core(self) -> BusDriver:
        """The driver (transport, receive thread) and through it the session (matching, learned facts)."""
        return self._core

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
