"""The operation runner: runs each submitted operation's generator until it waits for an effect or ends.

Each effect the generator yields is started by the part that runs it, found in one table by the
effect's kind (:attr:`Operations.handlers`: requests and cycles by the request runner, sends and
batches by the sequencer, sleeps on the timers, state waits by the inbox; the session fills it);
when it ends, its result (or error) goes back into the generator.
"""

from __future__ import annotations

from collections.abc import Callable, Generator
from typing import TYPE_CHECKING, Any, Generic, TypeVar

from ...errors import BusClosedError
from .effects import Effect, Sleep

if TYPE_CHECKING:
    from .timers import Timers

__all__ = ["WAIT", "EffectHandler", "Operation", "Operations"]

T = TypeVar("T")

WAIT: Any = object()
"""What starting an effect returns when the operation must wait for it."""


class Operation(Generic[T]):
    """An operation submitted to a :class:`~drempower.client.engine.session.BusSession`: done once its generator
    returned or raised.

    ``on_done`` (given to :meth:`~drempower.client.engine.session.BusSession.submit`) is called once, when it
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


EffectHandler = Callable[["Operation[Any]", Any], Any]
"""Starts an effect for an operation: returns its immediate result, or :data:`WAIT` (the part that runs
it resumes the operation when it ends)."""


class Operations:
    """The running operations by id, and the generators run until they wait. ``timers`` run sleeps (and
    give the time now); every other kind of effect goes to the part :attr:`handlers` names for it."""

    __slots__ = ("closed_error", "handlers", "running", "timers")

    def __init__(self, timers: Timers) -> None:
        self.timers = timers
        self.running: dict[int, Operation[Any]] = {}
        self.closed_error: BaseException | None = None
        """Set once the bus is closed or its receive loop failed: every effect begun after raises it."""
        self.handlers: dict[type, EffectHandler] = {Sleep: self._sleep}
        """How each kind of effect (its class) is started."""

    def add(self, opn: Operation[T]) -> Operation[T]:
        """Count ``opn`` as running (until it finishes)."""
        self.running[id(opn)] = opn
        return opn

    def finish(self, opn: Operation[Any], value: Any, error: BaseException | None, notify: bool = True) -> None:
        """End ``opn`` with ``value`` or ``error``; call its ``on_done`` unless ``notify`` is False."""
        if opn.done:  # cancelled while a held start of its own was still to go out
            return
        opn._value, opn._error, opn.done, opn._cancel = value, error, True, None
        self.running.pop(id(opn), None)
        if notify and opn.on_done is not None:
            opn.on_done()

    def effect_done(self, opn: Operation[Any], value: Any, error: BaseException | None) -> None:
        """An effect of ``opn`` ended: a runnable without a generator ends with it, a generator resumes."""
        if opn._gen is None:
            self.finish(opn, value, error)
        else:
            self.resume(opn, value, error)

    def resume(self, opn: Operation[Any], value: Any, error: BaseException | None) -> None:
        """Run ``opn``'s generator until it waits for an effect or ends (a request without a generator ends
        with its first answer)."""
        if opn.done:
            return
        opn._cancel = None
        gen = opn._gen
        if gen is None:  # a Single request: its first answer is the result
            self.finish(opn, None if value is None else value[0], error)
            return
        begin = self._begin
        while True:
            try:
                effect = gen.send(value) if error is None else gen.throw(error)
            except StopIteration as stop:
                self.finish(opn, stop.value, None)
                return
            except Exception as exc:
                self.finish(opn, None, exc)
                return
            except BaseException as exc:  # Ctrl-C in a thread resuming another's operation: that one ends too
                self.finish(opn, None, exc)
                raise
            try:
                value = begin(opn, effect)
                error = None
            except Exception as exc:
                value, error = None, exc
                continue
            if value is WAIT:
                return

    def _begin(self, opn: Operation[Any], effect: Effect) -> Any:
        """Start ``effect`` for ``opn`` in the part that runs it: its immediate result, or :data:`WAIT`."""
        if self.closed_error is not None:
            raise self.closed_error
        handler = self.handlers.get(effect.__class__)
        if handler is None:
            raise TypeError(f"an operation yielded {effect!r}, which is no effect")
        return handler(opn, effect)

    def _sleep(self, opn: Operation[Any], effect: Sleep) -> Any:
        timers = self.timers
        tid = timers.add(timers.now + effect.seconds, lambda: self.resume(opn, None, None))
        opn._cancel = lambda: timers.drop(tid)
        return WAIT

    def cancel(self, opn: Operation[Any], error: BaseException | None = None) -> None:
        """Stop ``opn`` (its caller gave up): its effect stops waiting, its generator closes; no ``on_done``."""
        if opn.done:
            return
        if opn._cancel is not None:
            opn._cancel()
            opn._cancel = None
        if opn._gen is not None:
            opn._gen.close()
        self.finish(opn, None, error or BusClosedError("the operation was cancelled"), notify=False)

    def fail_all(self, error: BaseException) -> None:
        """End every running operation with ``error`` (their generators closed)."""
        for opn in list(self.running.values()):
            if opn._gen is not None:
                opn._gen.close()
            self.finish(opn, None, error)
