"""A start held until the presets queued before it are on the wire: a small state machine.

How the session knows the presets are out depends on the transport
(:data:`TxOrder`). A held start is in one :class:`HoldState`; what the
transport or the motors say moves it by :data:`TRANSITIONS` (an event a state
does not act on leaves it where it is). Whatever its state, the start waits
while frames are still queued before it; then a ``TIMED`` hold goes out once
the bus time of what was written (plus ``tx_latency``) has passed, a
``CONFIRMED`` one at once, and a ``CONFIRMING`` or ``PROBING`` one fails once
its wait is over.
"""

from __future__ import annotations

import enum
from collections.abc import Callable
from typing import TYPE_CHECKING, Literal

from ...errors import TimeoutError
from ...protocol.addresses import AXIS0_CONFIG_CAN_NODE_ID
from ...protocol.messages import ReadParam
from ...protocol.parameters import DataType
from .requests import Waiter, request_key

if TYPE_CHECKING:
    from .outbox import Outbox
    from .requests import Matcher
    from .runner import RequestPolicy
    from .timers import Timers

__all__ = ["TRANSITIONS", "HoldEvent", "HoldState", "StartHold", "TxOrder"]

TxOrder = Literal["in_order", "confirmed", "timed", "answered"]
"""How the session knows a batch's presets are on the wire before it sends their start:
``in_order`` (frames reach the bus in the order written: no wait), ``confirmed`` (the driver
reports :meth:`~drempower.client.engine.session.BusSession.transmitted`), ``timed`` (the bus time of what was
written, plus ``tx_latency``), ``answered`` (a read of each preset's motor, sent after the presets, is
answered: a read has a higher CAN id than the preset of its motor, so no transmit queue that arbitrates
by id or keeps the order sends it first; for links whose delay has no bound, such as socketcand over TCP)."""

_MIN_CONFIRM = 0.1
"""Shortest wait (s) for a transport's confirmation that presets are on the wire."""


class HoldState(enum.Enum):
    """What a held start waits for."""

    TIMED = "timed"
    """The bus time of the frames written, plus ``tx_latency``."""
    CONFIRMING = "confirming"
    """The transport's word that every frame handed to it is on the wire."""
    PROBING = "probing"
    """The answers to reads sent after the presets."""
    CONFIRMED = "confirmed"
    """Nothing: the presets are on the wire."""


class HoldEvent(enum.Enum):
    """What the transport or the motors said."""

    SENT = "sent"
    """The transport: every frame handed to it is on the wire."""
    UNKNOWN = "unknown"
    """The transport cannot tell."""
    NOT_SENT = "not sent"
    """The transport gave up waiting for the frames to go out."""
    ANSWERED = "answered"
    """Every read sent after the presets was answered."""


_S, _E = HoldState, HoldEvent
TRANSITIONS: dict[tuple[HoldState, HoldEvent], HoldState] = {
    (_S.TIMED, _E.SENT): _S.TIMED,
    (_S.TIMED, _E.UNKNOWN): _S.TIMED,
    (_S.TIMED, _E.NOT_SENT): _S.TIMED,
    (_S.CONFIRMING, _E.SENT): _S.CONFIRMED,
    (_S.CONFIRMING, _E.UNKNOWN): _S.TIMED,
    (_S.CONFIRMING, _E.NOT_SENT): _S.CONFIRMING,  # it fails once its wait is over
    (_S.PROBING, _E.ANSWERED): _S.CONFIRMED,
}
"""The next state of a held start per (state, event); a pair not listed is ignored (a probing start does not
listen to the transport; a confirmed one has gone out by the time either could speak)."""

_FIRST: dict[str, HoldState] = {"timed": _S.TIMED, "confirmed": _S.CONFIRMING, "answered": _S.PROBING}


class _Hold:
    """One held start: its state, when its wait ends (s) and what releases or fails it."""

    __slots__ = ("due", "fail", "release", "state")

    def __init__(
        self,
        state: HoldState,
        release: Callable[[], None],
        fail: Callable[[BaseException | None], None],
        due: float,
    ) -> None:
        self.state = state
        self.release = release
        self.fail = fail
        """Fails the start (None: its wait is over; with a probe, its reads are sent again first)."""
        self.due = due


class StartHold:
    """The start held until its presets are on the wire (at most one at a time: starts go in order).

    ``tx`` says how the session knows (:data:`TxOrder`); ``tx_latency`` (s) is
    added to the bus time of a ``timed`` hold. Its collaborators: the ``timers`` (the time now, and a
    count of new deadlines), the ``outbox`` (what is still to hand over, and when the wire is free), and,
    for an ``answered`` hold's probe, the ``matcher`` its reads wait in and the ``policy`` of requests.
    """

    __slots__ = ("current", "matcher", "outbox", "policy", "timers", "tx", "tx_latency")

    def __init__(
        self,
        tx: TxOrder,
        tx_latency: float,
        *,
        timers: Timers,
        outbox: Outbox,
        matcher: Matcher,
        policy: RequestPolicy,
    ) -> None:
        self.timers = timers
        self.outbox = outbox
        self.matcher = matcher
        self.policy = policy
        self.tx: TxOrder = tx
        self.tx_latency = tx_latency
        self.current: _Hold | None = None

    def begin(self, nodes: list[int], release: Callable[[], None], fail: Callable[[BaseException], None]) -> bool:
        """Hold a start to ``nodes`` until the frames queued before it are on the wire, then call
        ``release()``, or ``fail(error)``; False when it need not wait (nothing is held)."""
        tx = self.tx
        if tx == "in_order":
            return False
        wait = max(self.policy.timeout, _MIN_CONFIRM)

        def ready() -> None:
            self.current = None
            release()

        def give_up(error: BaseException | None = None) -> None:
            self.current = None
            fail(TimeoutError(nodes, "the transmission of the presets", wait) if error is None else error)

        hold = self.current = _Hold(_FIRST[tx], ready, give_up, self.timers.now + wait)
        if tx == "answered":
            _Probe(self, hold, nodes, wait)
        self.timers.touch()
        self.check()
        return True

    def event(self, event: HoldEvent) -> None:
        """Move the held start by ``event`` (see :data:`TRANSITIONS`), then release it if it may go."""
        hold = self.current
        if hold is not None:
            state = TRANSITIONS.get((hold.state, event))
            if state is not None:
                hold.state = state
                self.check()

    def check(self) -> None:
        """Release the held start if its presets are on the wire; fail it if its wait is over."""
        hold = self.current
        outbox = self.outbox
        if hold is None or outbox.frames:
            return
        now = self.timers.now
        state = hold.state
        if state is _S.TIMED:
            if now >= outbox.wire_free + self.tx_latency:
                hold.release()
        elif state is _S.CONFIRMED:
            hold.release()
        elif now >= hold.due:
            hold.fail(None)

    def next_due(self) -> float | None:
        """When (s) :meth:`check` has something to do, or None (nothing held, or frames still to hand over)."""
        hold = self.current
        if hold is None or self.outbox.frames:
            return None
        return self.outbox.wire_free + self.tx_latency if hold.state is _S.TIMED else hold.due

    @property
    def awaiting_confirmation(self) -> bool:
        """True when the held start waits for the transport's word and every frame is handed over."""
        hold = self.current
        return hold is not None and hold.state is _S.CONFIRMING and not self.outbox.frames


class _Probe:
    """Reads of each motor's can_node_id (0: any motor), queued after the presets; the hold is confirmed
    once every one is answered. A read has a higher CAN id than its motor's preset and its reply echoes
    the address (a heartbeat cannot pass for it). Unanswered reads are sent again up to ``retries``
    times, ``wait`` s apart; then the hold fails (TimeoutError naming the silent motors)."""

    __slots__ = ("give_up", "hold", "nodes", "part", "tries", "wait", "waiter")

    def __init__(self, part: StartHold, hold: _Hold, nodes: list[int], wait: float) -> None:
        self.part = part
        self.hold = hold
        self.nodes = nodes
        self.wait = wait
        self.tries = 0
        self.give_up = hold.fail
        hold.fail = self.failed
        self.waiter = Waiter([], None)
        self.ask(nodes)

    def ask(self, which: list[int]) -> None:
        reads = [ReadParam(n, AXIS0_CONFIG_CAN_NODE_ID, DataType.U32) for n in which]  # never 0
        part = self.part
        w = self.waiter = Waiter([request_key(r) for r in reads], self.answered, [DataType.U32] * len(reads))
        part.matcher.register(w)
        part.outbox.frames.extend(r.encode() for r in reads)

    def answered(self) -> None:
        if self.part.current is self.hold:
            self.part.event(HoldEvent.ANSWERED)

    def failed(self, error: BaseException | None) -> None:
        part = self.part
        w = self.waiter
        part.matcher.cancel(w)
        missing = [w.keys[i] >> 16 for i in w.missing()]
        if error is None and self.tries < part.policy.retries and missing:
            self.tries += 1
            self.hold.due = part.timers.now + self.wait
            self.ask(missing)
            part.timers.touch()  # a new deadline
            return
        if error is None:
            error = TimeoutError(missing or self.nodes, "reads sent after the presets (the start waits)", self.wait)
        self.give_up(error)
