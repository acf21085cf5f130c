"""The preset/start sequencer: presets and starts sent in order, a start held until its presets are out.

Presets (0x0C) are remembered until a start consumes them. A start that would
start a pending preset waits (see :class:`~drempower.client.engine.hold.StartHold`)
until every frame queued before it is on the wire, so it never overtakes its
presets in a controller's mailboxes; the sends and batches queued behind it
wait their turn. The moves a start begins are recorded for the waits
(:class:`~drempower.client.engine.known.MoveRecord`).
"""

from __future__ import annotations

import dataclasses
from collections import deque
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any, Literal

from ...errors import BusStoppedError
from ...protocol.ids import Frame
from ...protocol.messages import (
    Message,
    Preset,
    PresetC,
    PresetD,
    PresetP,
    PresetQ,
    PresetT,
    PresetV,
    Start,
    StartImpedance,
)
from .effects import Batch
from .known import MoveRecord

if TYPE_CHECKING:
    from .hold import StartHold
    from .known import Known
    from .operation import Operation, Operations
    from .outbox import Outbox
    from .timers import Timers

__all__ = ["StartPolicy", "Sequencer", "sequenced"]

StartPolicy = Literal["auto", "broadcast", "node"]
"""Where start commands go: see :class:`~drempower.client.engine.session.BusSession`."""

_POSITION_STARTS = frozenset((0x10, 0x11, 0x12))
_STARTS = (Start, StartImpedance)
_TYPED_PRESETS = (PresetT, PresetQ, PresetP, PresetV, PresetC, PresetD)


def sequenced(msgs: Sequence[Message]) -> bool:
    """Whether sending ``msgs`` involves presets or starts (so a start may wait for its presets)."""
    return any(m.cmd == 0x0C or isinstance(m, _STARTS) for m in msgs)


def _motors(nodes: Sequence[int]) -> str:
    return "every motor" if 0 in nodes else "motor" + ("s " if len(nodes) > 1 else " ") + ", ".join(map(str, nodes))


def _preset_goal(preset: Message, q_start: bool) -> tuple[float, float | None]:
    """The target (deg) a position start gives ``preset``, and its move time (s) for a Q start (else None)."""
    wire = preset if isinstance(preset, Preset) else preset.to_preset() if isinstance(preset, _TYPED_PRESETS) else None
    assert wire is not None
    return wire.p1, (wire.p2 if q_start and wire.p2 > 0 else None)


def _to_node(msg: Message, node: int) -> Message:
    """``msg`` addressed to ``node`` (a broadcast preset or start made node-addressed)."""
    return msg if msg.node == node else dataclasses.replace(msg, node=node)  # type: ignore[type-var]


class _Job:
    """Messages (or a batch) sent in order for an operation (None: nothing waits for them)."""

    __slots__ = ("batch", "frames", "index", "msgs", "op")

    def __init__(
        self, op: Operation[Any] | None, msgs: Sequence[Message], frames: Sequence[Frame], batch: Batch | None
    ):
        self.op = op
        self.msgs = msgs
        self.frames = frames
        self.batch = batch
        self.index = 0


class Sequencer:
    """Sends with presets or starts and batches, one job at a time, in order. ``policy`` chooses where a
    batch's start goes (see :class:`~drempower.client.engine.session.BusSession`); ``motor_ids`` are the bus's
    motors when the transport declares them.

    Its collaborators: the ``timers`` (the time now), what is ``known`` of the motors (the moves a start
    begins, what each command changes), the ``outbox`` its frames go to, the start ``hold`` a start waits
    in until its presets are on the wire, and the ``operations`` a job's outcome resumes."""

    __slots__ = (
        "_busy",
        "_jobs",
        "_preset_msgs",
        "hold",
        "known",
        "motor_ids",
        "operations",
        "outbox",
        "pending_presets",
        "policy",
        "timers",
    )

    def __init__(
        self,
        policy: StartPolicy,
        motor_ids: frozenset[int],
        *,
        timers: Timers,
        known: Known,
        outbox: Outbox,
        hold: StartHold,
        operations: Operations,
    ) -> None:
        self.timers = timers
        self.known = known
        self.outbox = outbox
        self.hold = hold
        self.operations = operations
        self.policy: StartPolicy = policy
        self.motor_ids = motor_ids
        self.pending_presets: set[int] = set()
        """Motors holding a preset no start has consumed yet (0 = a broadcast preset)."""
        self._preset_msgs: dict[int, Message] = {}
        """The last preset sent per motor and not started yet."""
        self._jobs: deque[_Job] = deque()
        self._busy = False

    def send(self, op: Operation[Any], msgs: Sequence[Message], frames: Sequence[Frame]) -> bool:
        """Queue sent messages for ``op``; True when presets or starts among them made it a job in order
        (``op`` then ends when its last frame is queued), False when every frame is queued now."""
        if sequenced(msgs):
            self._run(_Job(op, msgs, frames, None))
            return True
        note, now = self.known.note, self.timers.now
        for m, f in zip(msgs, frames, strict=True):
            if m.cmd != 0x1E:
                note(m, f, now)
        self.outbox.frames.extend(frames)
        return False

    def batch(self, op: Operation[Any], batch: Batch) -> None:
        """Queue ``batch``'s presets and start (in order with other jobs); ``op`` resumes with where the
        start(s) went."""
        frames = [p.encode() for p in batch.presets]
        batch.start.encode()
        self._run(_Job(op, batch.presets, frames, batch))

    def stopped(self, nodes: Sequence[int]) -> None:
        """An emergency stop to ``nodes`` went out: drop the start held for its presets and the jobs queued
        behind it; their operations raise :class:`~drempower.errors.BusStoppedError`."""
        hold = self.hold.current
        if hold is None:
            return
        queued = list(self._jobs)
        self._jobs.clear()
        why = f"an emergency stop to {_motors(nodes)} came before the start went out"
        hold.fail(BusStoppedError(why))
        for job in queued:
            self._end(job, None, BusStoppedError(why))

    def clear(self) -> None:
        """Drop every queued job (their operations are failed by the caller)."""
        self._jobs.clear()
        self._busy = False

    def hold_preset(self, msg: Message) -> None:
        """Remember preset ``msg`` as pending until a start consumes it."""
        node = msg.node
        if node == 0:  # a broadcast preset replaces every motor's
            self._preset_msgs.clear()
        self.pending_presets.add(node)
        self._preset_msgs[node] = msg

    def starts_pending(self, node: int) -> bool:
        """Whether a start to ``node`` (0 = broadcast) would start a pending preset."""
        pending = self.pending_presets
        return bool(pending) if node == 0 else node in pending or 0 in pending

    def start_pending(self, start: Message, frame: Frame, started: list[int]) -> None:
        """Queue ``start`` (its presets are on the wire); record the moves it starts, drop what it consumed."""
        node = start.node
        sent = self.timers.now
        moves = self.known.moves
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
        self.outbox.frames.append(frame)
        pending = self.pending_presets
        if node == 0:
            pending.clear()
            self._preset_msgs.clear()
        else:
            pending.discard(node)
            self._preset_msgs.pop(node, None)

    # ------------------------------------------------------------------ jobs in order

    def _run(self, job: _Job) -> None:
        """Run ``job`` now, or after the job that holds a start (one at a time, in order)."""
        if self._busy:
            self._jobs.append(job)
            return
        self._busy = True
        self._step(job)

    def _end(self, job: _Job, value: Any, error: BaseException | None) -> None:
        """Hand a job's outcome to its operation: a send's own (it ends here) or a generator's effect."""
        op = job.op
        if op is not None:
            self.operations.effect_done(op, value, error)

    def _done(self, job: _Job, value: Any, error: BaseException | None) -> None:
        self._busy = False
        self._end(job, value, error)
        while self._jobs and not self._busy:
            nxt = self._jobs.popleft()
            self._busy = True
            self._step(nxt)

    def _step(self, job: _Job) -> None:
        if job.batch is not None:
            self._step_batch(job)
            return
        known, timers, out = self.known, self.timers, self.outbox.frames
        msgs, frames = job.msgs, job.frames
        while job.index < len(msgs):
            i = job.index
            m, f = msgs[i], frames[i]
            job.index = i + 1
            known.note(m, f, timers.now)
            if m.cmd == 0x0C:
                self.hold_preset(m)
            elif isinstance(m, _STARTS) and self.starts_pending(m.node):
                started = sorted(self.pending_presets) if m.node == 0 else [m.node]

                def release(job: _Job = job, m: Message = m, f: Frame = f, started: list[int] = started) -> None:
                    self.start_pending(m, f, started)
                    self._step(job)

                if self.hold.begin(
                    [n for n in started if n] or [0], release, lambda error: self._done(job, None, error)
                ):
                    return
                self.start_pending(m, f, started)  # in order: no wait
                continue
            out.append(f)
        self._done(job, None, None)

    def _step_batch(self, job: _Job) -> None:
        b = job.batch
        assert b is not None
        known, timers, out = self.known, self.timers, self.outbox.frames
        presets, start = b.presets, b.start
        nodes = [p.node for p in presets]
        policy = self.policy
        # "auto" broadcasts only when no motor outside the move can hold a preset: the bus's motors are
        # known (the simulator declares them) and all in the move. Presets another command left behind
        # (an overtaken or lost start, a program killed between presets and start) are unknown to this bus.
        broadcast = policy == "broadcast" or (
            policy == "auto"
            and len(nodes) > 1
            and bool(self.motor_ids)
            and self.motor_ids.issubset(nodes)
            and self.pending_presets.issubset(nodes)
        )
        where = [0] if broadcast else nodes
        starts = [dataclasses.replace(start, node=n).encode() for n in where]
        self.pending_presets.update(nodes)
        for n in nodes:
            self._preset_msgs.pop(n, None)
        known.commanded.update(nodes)
        out.extend(job.frames)

        def release() -> None:
            sent = timers.now
            moves = known.moves
            if isinstance(start, Start) and start.kind in _POSITION_STARTS:
                goals = b.targets if b.targets is not None else [None] * len(nodes)
                for p, goal in zip(presets, goals, strict=True):
                    n = p.node
                    moves[n] = MoveRecord(goal, sent, b.move_time, None, (p, dataclasses.replace(start, node=n)))
            else:
                for n in nodes:
                    moves.pop(n, None)
            self.outbox.frames.extend(starts)  # the list of now: the outbox hands over a new one each time
            if broadcast:
                self.pending_presets.clear()
                self._preset_msgs.clear()
            else:
                self.pending_presets.difference_update(nodes)
            self._done(job, where, None)

        if not self.hold.begin(nodes, release, lambda error: self._done(job, None, error)):
            release()
