"""The request runner: requests sent, their replies matched, retried and expired; its one-request fast path;
control cycles.

Every request that expects an answer registers a :class:`~drempower.client.engine.requests.Waiter`
in the runner's :class:`~drempower.client.engine.requests.Matcher` before its frame is
queued; the inbox resolves replies against it; a timer on the session's
:class:`~drempower.client.engine.timers.Timers` expires it.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any

from ...errors import TimeoutError, ValidationError
from ...protocol.messages import FastRead, Message, ReadParam, Start, StartImpedance
from ...protocol.parameters import find_parameter
from .effects import Cycle, Request, Single
from .requests import Matcher, Waiter, request_dtype, request_key

if TYPE_CHECKING:
    from .grace import ZeroReplyGrace
    from .known import Known
    from .operation import Operation, Operations
    from .outbox import Outbox
    from .sequencer import Sequencer
    from .timers import Timers

__all__ = ["DEFAULT_TIMEOUT", "RequestPolicy", "RequestRunner", "describe_request"]

DEFAULT_TIMEOUT = 0.1
"""Default time (s) a request waits for its reply."""
_STARTS = (Start, StartImpedance)


def describe_request(msg: Message) -> str:
    """Short name of a request for error messages."""
    if isinstance(msg, FastRead):
        return "a fast read (get_state)"
    if isinstance(msg, ReadParam):
        p = find_parameter(msg.address)
        return f"read_property {p.name} ({msg.address})" if p else f"read_property {msg.address}"
    return type(msg).__name__


def _timeout(given: float | None, default: float) -> float:
    timeout = default if given is None else given
    if not timeout > 0:
        raise ValidationError(f"timeout={given!r}: must be > 0 s")
    return timeout


class RequestPolicy:
    """How requests wait: ``timeout`` (s), the default wait for a reply, and ``retries``, how often a read
    whose reply did not come is sent again (shared by the runner and the start hold's probe)."""

    __slots__ = ("retries", "timeout")

    def __init__(self, timeout: float, retries: int) -> None:
        self.timeout = timeout
        self.retries = retries


class RequestRunner:
    """Runs requests and cycles for operations, as ``policy`` says; ``check_request``, when set, is called
    with the messages of every request before it is sent and may raise to refuse it.

    Its collaborators: the ``matcher`` its waiters register in, the ``timers`` that expire them (and give
    the time now), the ``outbox`` its frames go to, what is ``known`` of the motors, the zero-reply
    ``grace`` settled at expiry, the ``operations`` its answers resume, the ``sequencer`` a cycle's
    presets and starts go through, and ``tx_latency`` (s), how late a frame handed over may reach the wire.
    """

    __slots__ = (
        "check_request",
        "grace",
        "known",
        "matcher",
        "operations",
        "outbox",
        "policy",
        "sequencer",
        "timers",
        "tx_latency",
    )

    def __init__(
        self,
        policy: RequestPolicy,
        *,
        matcher: Matcher,
        timers: Timers,
        outbox: Outbox,
        known: Known,
        grace: ZeroReplyGrace,
        operations: Operations,
        sequencer: Sequencer,
        tx_latency: float,
    ) -> None:
        self.policy = policy
        self.matcher = matcher
        self.timers = timers
        self.outbox = outbox
        self.known = known
        self.grace = grace
        self.operations = operations
        self.sequencer = sequencer
        self.tx_latency = tx_latency
        self.check_request: Callable[[Sequence[Message]], None] | None = None

    @property
    def timeout(self) -> float:
        """The default wait (s) for a reply."""
        return self.policy.timeout

    @property
    def retries(self) -> int:
        """How often a read whose reply did not come is sent again."""
        return self.policy.retries

    def single(self, opn: Operation[Any], single: Single[Any]) -> None:
        """Run ``single``'s request as ``opn``'s only effect (its first answer is the result); one message
        whose answer is required takes the fast path."""
        effect = single.request
        if self.check_request is not None:
            self.check_request(effect.messages)
        ex: _Exchange | _OneRequest
        if len(effect.messages) == 1 and effect.expect is None and not effect.missing_ok:
            ex = _OneRequest(self, opn, effect)
        else:
            ex = _Exchange(self, opn, effect)
        ex.start()
        opn._cancel = ex.cancel

    def request(self, opn: Operation[Any], effect: Request) -> None:
        """Run ``effect`` for ``opn``; its answers resume ``opn`` as a list."""
        if self.check_request is not None:
            self.check_request(effect.messages)
        ex = _Exchange(self, opn, effect)
        ex.start()
        opn._cancel = ex.cancel

    def cycle(self, opn: Operation[Any], cycle: Cycle[Any]) -> None:
        """Run control cycle ``cycle`` for ``opn``; its states resume ``opn`` as a dict by node."""
        if self.check_request is not None:
            self.check_request(cycle.messages)
        run = _CycleRun(self, opn, cycle)
        if not opn.done:
            opn._cancel = run.cancel


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
        "runner",
        "timeout",
        "timer",
        "waiter",
        "what",
    )

    def __init__(self, runner: RequestRunner, op: Operation[Any], effect: Request) -> None:
        self.runner = runner
        self.op = op
        msgs = self.msgs = effect.messages
        self.frames = [m.encode() for m in msgs]
        if effect.expect is None:
            self.keys = [request_key(m) for m in msgs]
            self._serial: list[int] | None = [m.node for m in msgs]
            self.retries = runner.retries
        else:
            self.keys = list(effect.expect)
            self._serial = None
            self.retries = 0
        self.timeout = _timeout(effect.timeout, runner.timeout)
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
        r = self.runner
        w = self.waiter = Waiter([keys[i] for i in batch], self._answered, dtypes)
        r.matcher.register(w)
        r.outbox.frames.extend(frames)
        timers = r.timers
        self.timer = timers.add(timers.now + self.timeout, self._expire)

    def cancel(self) -> None:
        self.runner.timers.drop(self.timer)
        if self.waiter is not None:
            self.runner.matcher.drop(self.waiter)

    def _answered(self) -> None:
        self.runner.timers.drop(self.timer)
        self._collect()

    def _expire(self) -> None:
        w = self.waiter
        assert w is not None
        grace = self.runner.grace
        if grace.held:
            grace.settle(0.0, [(w.keys[i] >> 16, w.keys[i] & 0xFFFF) for i in w.missing()])
            if not w.remaining:
                return  # the held-back replies answered it (and _answered ran)
        self.runner.matcher.drop(w)  # a retry registers a waiter of its own
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
        runner = self.runner
        if (failed and not self.missing_ok) or not self._pending:
            if failed and not self.missing_ok:
                nodes = sorted({self.keys[i] >> 16 for i in failed})
                what = self.what or describe_request(self.msgs[failed[0]])
                runner.operations.resume(self.op, None, TimeoutError(nodes, what, self.timeout))
                return
            heard = runner.known.heard
            for r in results:
                node = getattr(r, "node", 0)
                if node:
                    heard.add(node)
            runner.operations.resume(self.op, results, None)
        else:
            self.start()


class _OneRequest(Waiter):
    """A :class:`~drempower.client.engine.effects.Single` request of one message: :class:`_Exchange`'s rules
    (matching on every echoed field, retries, the held-back zero replies at expiry) for the
    commonest call, without its bookkeeping for many requests. It is its own
    :class:`~drempower.client.engine.requests.Waiter` (one object, one call fewer per request)."""

    __slots__ = ("frame", "key", "msg", "op", "runner", "timeout", "timer", "tries")

    def __init__(self, runner: RequestRunner, op: Operation[Any], effect: Request) -> None:
        self.runner = runner
        self.op = op
        msg = self.msg = effect.messages[0]
        self.frame = msg.encode()
        timeout = effect.timeout
        self.timeout = runner.policy.timeout if timeout is None else timeout
        if not self.timeout > 0:
            raise ValidationError(f"timeout={timeout!r}: must be > 0 s")
        self.tries = 0
        if msg.__class__ is FastRead:  # the commonest: its answer is a state frame, with no data type to echo
            key = self.key = msg.node << 16
            self.dtypes = None
        else:
            key = self.key = request_key(msg)
            dtype = request_dtype(msg)
            self.dtypes = None if dtype is None else (dtype,)
        self.keys = (key,)
        self.results = [None]
        self.remaining = 1
        self.on_complete = self._answered
        self.timer = 0

    def start(self) -> None:
        r = self.runner
        self.results[0] = None
        self.remaining = 1
        # Matcher.register for its one key, inline
        table = r.matcher._table
        lst = table.get(self.key)
        if lst is None:
            table[self.key] = [(self, 0)]
        else:
            lst.append((self, 0))
        r.outbox.frames.append(self.frame)
        timers = r.timers
        self.timer = timers.add(timers.now + self.timeout, self._expire)

    def cancel(self) -> None:
        r = self.runner
        r.timers.drop(self.timer)
        r.matcher.drop(self)

    def _answered(self) -> None:
        runner = self.runner
        runner.timers.pending.pop(self.timer, None)  # Timers.drop, inline: the commonest call
        r = self.results[0]
        node = getattr(r, "node", 0)
        if node:
            runner.known.heard.add(node)
        runner.operations.finish(self.op, r, None)

    def _expire(self) -> None:
        r = self.runner
        key = self.key
        grace = r.grace
        if grace.held:
            grace.settle(0.0, [(key >> 16, key & 0xFFFF)])
            if not self.remaining:
                return  # a held-back reply answered it
        r.matcher.cancel(self)
        self.tries += 1
        if self.tries <= r.retries:
            self.start()
            return
        self.on_complete = None  # not answered, for good (see Waiter)
        r.operations.finish(self.op, None, TimeoutError([key >> 16], describe_request(self.msg), self.timeout))


class _CycleRun:
    """A control cycle (:class:`~drempower.client.engine.effects.Cycle`): its frames go out at once, one state
    per motor is awaited (matched as any fast read's), sent once, never retried. What the commands
    change is recorded as for any sent message (commanded motors, moves, learned parameters, presets
    pending until started); a start in a cycle goes out in order with the cycle's frames, without
    waiting for the presets it starts. Answered, a cycle's frames are known to be on the wire, so a
    start sent after it does not wait for its presets."""

    __slots__ = ("last", "nodes", "op", "runner", "timeout", "timer", "waiter")

    def __init__(self, runner: RequestRunner, op: Operation[Any], cycle: Cycle[Any]) -> None:
        """Queue the cycle's frames, expect its states and start its timer."""
        timeout = _timeout(cycle.timeout, runner.timeout)
        msgs, frames = cycle.messages, cycle.frames
        if len(msgs) != len(frames):
            raise ValidationError(f"a cycle of {len(msgs)} messages came with {len(frames)} frames")
        self.runner = runner
        self.op = op
        self.timeout = timeout
        nodes = self.nodes = cycle.nodes
        w = self.waiter = Waiter([n << 16 for n in nodes], self._answered)
        seq, note, now = runner.sequencer, runner.known.note, runner.timers.now
        outbox = runner.outbox
        out = outbox.frames
        for m, f in zip(msgs, frames, strict=True):
            if m.cmd == 0x1E:
                out.append(f)
                continue
            note(m, f, now)
            if m.cmd == 0x0C:  # pending until started, as when sent alone (later starts go per motor)
                seq.hold_preset(m)
            elif isinstance(m, _STARTS) and seq.starts_pending(m.node):
                started = sorted(seq.pending_presets) if m.node == 0 else [m.node]
                seq.start_pending(m, f, started)  # queues it, in order, without waiting
                continue
            out.append(f)
        self.last = outbox.handed + len(out)
        """The count of handed frames once this cycle's are: answered, they (and those before) are on the wire."""
        runner.matcher.register(w)
        self.timer = runner.timers.add(now + timeout, self._expire)

    def cancel(self) -> None:
        r = self.runner
        r.timers.drop(self.timer)
        r.matcher.drop(self.waiter)

    def _answered(self) -> None:
        r = self.runner
        r.timers.drop(self.timer)
        nodes = self.nodes
        r.known.heard.update(nodes)
        outbox = r.outbox
        if outbox.handed <= self.last:  # every frame handed over is on the wire: a start need not wait for them
            outbox.wire_free = min(outbox.wire_free, r.timers.now - r.tx_latency)
        r.operations.effect_done(self.op, dict(zip(nodes, self.waiter.results, strict=True)), None)

    def _expire(self) -> None:
        r = self.runner
        w = self.waiter
        grace = r.grace
        if grace.held:
            grace.settle(0.0, [(k >> 16, k & 0xFFFF) for k in w.keys])
            if not w.remaining:
                return  # held-back replies answered it (and _answered ran)
        r.matcher.drop(w)
        nodes = self.nodes
        silent = sorted(nodes[i] for i in w.missing())
        r.operations.effect_done(self.op, None, TimeoutError(silent, "a control cycle", self.timeout))
