"""The parts of the two buses that differ by nature: how an operation's effects are run
(blocking waits in the caller's thread, or awaits on the event loop), waiting for a state, closing.

Everything else of :class:`~drempower.client.bus.Bus` and :class:`~drempower.client.aio.AsyncBus`
comes from one source (``api_async.py``, from which ``api_sync.py`` is generated).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any, TypeVar

from ..protocol.ids import check_node
from ..protocol.messages import Message
from .busbase import BusBase
from .core import Exchange
from .effects import Batch, Effect, Op, Request, Send, Sleep
from .errors import TimeoutError
from .state import MotorState
from .timeouts import checks_times

if TYPE_CHECKING:
    import asyncio

__all__ = ["AsyncBusBase", "SyncBusBase"]

M = TypeVar("M")
T = TypeVar("T")


@checks_times
class SyncBusBase(BusBase[M]):
    """The threaded bus's own parts: operations run in the caller's thread with blocking waits."""

    def run(self, op: Op[T]) -> T:
        """Run an operation (a generator of effects, see :mod:`drempower.client.effects`) to completion;
        returns its result and raises what it raises (TimeoutError, ValidationError...)."""
        execute = self._execute
        value: Any = None
        error: Exception | None = None
        while True:
            try:
                effect = op.send(value) if error is None else op.throw(error)
            except StopIteration as stop:
                result: T = stop.value
                return result
            try:
                value, error = execute(effect), None
            except Exception as exc:
                value, error = None, exc

    def _send_all(self, msgs: Sequence[Message]) -> None:
        """Send ``msgs`` (a start among them may first wait until its presets are on the wire)."""
        self._core.send_many(msgs)

    def _execute(self, effect: Effect) -> Any:
        core = self._core
        if isinstance(effect, Request):
            self._check_broadcast_reads(effect.messages)
            ex = Exchange(core, effect.messages, effect.timeout, effect.missing_ok, effect.expect, effect.what)
            while True:
                w = ex.start()
                assert w.event is not None
                try:
                    w.event.wait(ex.timeout)
                except BaseException:  # Ctrl-C: the waiter must not take the next request's reply
                    core.matcher.cancel(w)
                    raise
                if ex.collect(w):
                    return self._heard_from(ex.result())
        if isinstance(effect, Send):
            self._send_all(effect.messages)
            return None
        if isinstance(effect, Batch):
            return core.send_batch(effect.presets, effect.start, effect.targets, effect.move_time)
        assert isinstance(effect, Sleep)
        if core.closed_event.wait(effect.seconds):
            core.check_open()
        return None

    def wait_state(self, id: int, timeout: float, newer_than: float | None = None) -> MotorState:
        """Wait for a state of motor ``id`` newer than ``newer_than`` (monotonic s; default: now), sending nothing.

        Raises :class:`~drempower.client.errors.TimeoutError` after ``timeout`` s without one,
        :class:`~drempower.client.errors.BusClosedError` when the bus closes meanwhile.
        """
        check_node(id, "id")
        since = time.monotonic() if newer_than is None else newer_than
        st = self._core.states.wait(id, since, timeout)
        if st is None:
            self._core.check_open()
            raise TimeoutError([id], "a state update", timeout)
        return st

    def close(self) -> None:
        """Apply ``stop_on_close`` to the motors this bus commanded, then release the transport."""
        self._core.close()


def _wake(fut: asyncio.Future[Any], value: Any = None) -> None:
    if not fut.done():
        fut.set_result(value)


def _notifier(loop: asyncio.AbstractEventLoop, fut: asyncio.Future[Any]) -> Callable[[], None]:
    def notify() -> None:
        try:
            loop.call_soon_threadsafe(_wake, fut)
        except RuntimeError:  # the loop is closed; nobody waits any more
            pass

    return notify


@checks_times
class AsyncBusBase(BusBase[M]):
    """The asyncio bus's own parts: replies are handed to the event loop with ``loop.call_soon_threadsafe``,
    so no thread is used per call."""

    async def run(self, op: Op[T]) -> T:
        """Run an operation (a generator of effects, see :mod:`drempower.client.effects`) to completion;
        returns its result and raises what it raises (TimeoutError, ValidationError...)."""
        value: Any = None
        error: Exception | None = None
        while True:
            try:
                effect = op.send(value) if error is None else op.throw(error)
            except StopIteration as stop:
                result: T = stop.value
                return result
            try:
                value, error = await self._execute(effect), None
            except Exception as exc:
                value, error = None, exc

    async def _send_all(self, msgs: Sequence[Message]) -> None:
        """Send ``msgs``; when a start among them waits until its presets are on the wire, in a worker
        thread, so the event loop never blocks on that wait."""
        import asyncio

        if self._core.sequenced(msgs):
            await asyncio.to_thread(self._core.send_many, msgs)
        else:
            self._core.send_many(msgs)

    async def _execute(self, effect: Effect) -> Any:
        import asyncio

        core = self._core
        if isinstance(effect, Request):
            self._check_broadcast_reads(effect.messages)
            ex = Exchange(core, effect.messages, effect.timeout, effect.missing_ok, effect.expect, effect.what)
            loop = asyncio.get_running_loop()
            while True:
                fut: asyncio.Future[None] = loop.create_future()
                w = ex.start(_notifier(loop, fut))
                try:
                    await asyncio.wait((fut,), timeout=ex.timeout)
                except BaseException:
                    core.matcher.cancel(w)
                    raise
                if ex.collect(w):
                    return self._heard_from(ex.result())
        if isinstance(effect, Send):
            await self._send_all(effect.messages)
            return None
        if isinstance(effect, Batch):  # in a thread: the start waits until the presets are on the wire
            return await asyncio.to_thread(
                core.send_batch, effect.presets, effect.start, effect.targets, effect.move_time
            )
        assert isinstance(effect, Sleep)
        await asyncio.sleep(effect.seconds)
        core.check_open()
        return None

    async def wait_state(self, id: int, timeout: float, newer_than: float | None = None) -> MotorState:
        """Wait for a state of motor ``id`` newer than ``newer_than`` (monotonic s; default: now), sending nothing.

        Raises :class:`~drempower.client.errors.TimeoutError` after ``timeout`` s without one,
        :class:`~drempower.client.errors.BusClosedError` when the bus closes meanwhile.
        """
        import asyncio

        check_node(id, "id")
        since = time.monotonic() if newer_than is None else newer_than
        cache = self._core.states
        loop = asyncio.get_running_loop()
        fut: asyncio.Future[MotorState] = loop.create_future()

        def on_state(st: MotorState) -> None:
            if st.timestamp > since:
                loop.call_soon_threadsafe(_wake, fut, st)

        with cache.subscribe(on_state, id):
            st = cache.get(id)
            if st is not None and st.timestamp > since:
                return st
            await asyncio.wait((fut,), timeout=timeout)
        if not fut.done():
            self._core.check_open()
            raise TimeoutError([id], "a state update", timeout)
        return fut.result()

    async def close(self) -> None:
        """Apply ``stop_on_close`` to the motors this bus commanded, then release the transport
        (in a worker thread: it may block briefly)."""
        import asyncio

        await asyncio.get_running_loop().run_in_executor(None, self._core.close)
