"""The inbox: every received frame decoded, counted, and handed to what waits for it.

A state frame updates the motor's latest state (and the move it took), answers
the fast read waiting for it and wakes the operations waiting for a newer
state; a parameter reply answers the read waiting for it (a reply of value 0
may first be held back, see :mod:`~drempower.client.engine.grace`); anything else is
counted and returned to the caller.
"""

from __future__ import annotations

import struct
from typing import TYPE_CHECKING, Any

from ...errors import ProtocolError, TimeoutError
from ...protocol.ids import Frame
from ...protocol.messages import HOST_CMDS, decode_reply
from .operation import WAIT
from .requests import MATCHED, MISMATCHED
from .state import MotorState
from .status_bits import StatusBits

if TYPE_CHECKING:
    from .grace import ZeroReplyGrace
    from .known import Known
    from .operation import Operation, Operations
    from .requests import Matcher
    from .stats import BusStats
    from .timers import Timers

__all__ = ["Inbox"]

_HOST_ONLY_CMDS = HOST_CMDS - {0x1E}
"""Commands only a host sends: seeing one that this bus did not send means another host is present."""
_ZERO4 = bytes(4)
_ZERO8 = bytes(8)
_STATE = struct.Struct("<fhh").unpack
_new_state = tuple.__new__


class Inbox:
    """Takes received frames (:meth:`receive`) and keeps the operations waiting for a motor's next state.

    Its collaborators: the ``timers`` (the time now, and the expiry of state waits), what is ``known`` of
    the motors (the latest states), the ``matcher`` that replies resolve, the zero-reply ``grace``, the
    ``stats`` it counts into, and the ``operations`` a state wait resumes. It keeps what each motor's
    state frames hold in bits 3-4 (:attr:`bits`)."""

    __slots__ = ("bits", "grace", "known", "matcher", "operations", "stats", "timers", "waits")

    def __init__(
        self,
        *,
        timers: Timers,
        known: Known,
        matcher: Matcher,
        grace: ZeroReplyGrace,
        stats: BusStats,
        operations: Operations,
    ) -> None:
        self.timers = timers
        self.known = known
        self.matcher = matcher
        self.grace = grace
        self.stats = stats
        self.operations = operations
        self.bits = StatusBits()
        """What each motor's state frames hold in bits 3-4 (spec/PROTOCOL.md section 1.6)."""
        self.waits: dict[int, list[tuple[Operation[Any], float]]] = {}
        """Per motor, the operations waiting for a state newer than a time (s)."""

    def await_state(self, opn: Operation[Any], node: int, since: float, timeout: float) -> Any:
        """``opn`` waits for a state of ``node`` newer than ``since`` (s): the cached one if it is, else
        :data:`~drempower.client.engine.operation.WAIT` (it resumes with the state, or TimeoutError after ``timeout``
        s)."""
        st = self.known.states.get(node)
        if st is not None and st.timestamp > since:
            return st
        entry = (opn, since)
        self.waits.setdefault(node, []).append(entry)
        timers = self.timers
        operations = self.operations

        def expire() -> None:
            self._drop_wait(node, entry)
            operations.resume(opn, None, TimeoutError([node], "a state update", timeout))

        tid = timers.add(timers.now + timeout, expire)

        def cancel() -> None:
            timers.drop(tid)
            self._drop_wait(node, entry)

        opn._cancel = cancel
        return WAIT

    def _drop_wait(self, node: int, entry: tuple[Operation[Any], float]) -> None:
        lst = self.waits.get(node)
        if lst is not None and entry in lst:
            lst.remove(entry)
            if not lst:
                del self.waits[node]

    def receive(self, frame: Frame, now: float) -> MotorState | Frame | None:
        """Take ``frame``, received at ``now`` (s); see :meth:`~drempower.client.engine.session.BusSession.receive`."""
        timers = self.timers
        if now > timers.now:
            timers.now = now
        else:
            now = timers.now
        stats = self.stats
        stats.frames_received += 1
        arb, data, ext, rtr = frame
        if ext or rtr or len(data) != 8:
            stats.malformed += 1
            stats.unmatched += 1
            return frame
        cmd = arb & 0x1F
        if cmd & 1 and (
            cmd < 0x18
            or self.bits.is_state(
                arb >> 5,
                cmd,
                data,
                self.matcher.waiting(arb >> 5, 0) or (arb >> 5) in self.waits,
                self.grace.other_hosts,
            )
        ):
            # a state frame (spec/PROTOCOL.md 1.6, engine.status_bits): decode bits 0-2 only, as decode_reply does
            node = arb >> 5
            pos, vel, tq = _STATE(data)
            st: MotorState = _new_state(MotorState, (node, pos, vel / 100, tq / 100, bool(cmd & 2), bool(cmd & 4), now))
            known = self.known
            known.frame_times[node] = now if frame.__class__ is Frame else getattr(frame, "time", now)
            if not cmd & 2:
                mv = known.moves.get(node)
                if mv is not None and mv.took is None and st.timestamp > mv.sent:
                    mv.took = st.timestamp
            known.states[node] = st
            answered = self.matcher.resolve_state(node, st)
            waits = self.waits.get(node)
            if cmd < 0x18 and (cmd > 0x07 or answered or waits):  # learn from answers, not from heartbeats
                bits = self.bits
                if bits.known.get(node) != ("zero" if cmd < 0x08 else "kept"):  # the commonest: known already
                    bits.saw(node, cmd)
            if waits:
                resume = self.operations.resume
                for opn, since in list(waits):
                    if st.timestamp > since:
                        if opn._cancel is not None:
                            opn._cancel()  # its timer and this entry
                        resume(opn, st, None)
            return st
        grace = self.grace
        if cmd != 0x1E:
            if cmd in _HOST_ONLY_CMDS:  # 0x19/0x1B/0x1D/0x1F that rule 1.6 takes as no state: T, P, C, write
                grace.other_hosts = True
                stats.foreign += 1
            else:
                stats.malformed += 1
            stats.unmatched += 1
            return frame
        if data == _ZERO8:  # a fast read: another host's (its answer is a state frame)
            grace.other_hosts = True
            stats.foreign += 1
            stats.unmatched += 1
            return frame
        try:
            reply: Any = decode_reply(arb, data)
        except ProtocolError:
            stats.malformed += 1
            stats.unmatched += 1
            return frame
        node, address, dtype = reply.node, reply.address, reply.dtype
        matcher = self.matcher
        if data[4:] == _ZERO4:
            # A reply of value 0 has the bytes of a read request: another host's read
            # of the same parameter looks exactly like it (see grace).
            if grace.hold(node, address, dtype, reply, now):
                return None
            outcome = matcher.resolve_reply(node, address, dtype, reply)
            if outcome != MATCHED:
                if outcome == MISMATCHED:
                    stats.anomalies += 1
                else:
                    stats.foreign += 1  # most likely another host's read request
                grace.other_hosts = True
                stats.unmatched += 1
                return frame
            return None
        grace.held.pop((node, address), None)
        outcome = matcher.resolve_reply(node, address, dtype, reply)
        if outcome != MATCHED:
            if outcome == MISMATCHED:
                stats.anomalies += 1
            stats.unmatched += 1
            return frame
        return None
