"""The parts of the two buses that differ by nature: how an operation's effects are run
(blocking waits in the caller's thread, or awaits on the event loop), waiting for a state, closing.

Everything else of :class:`~drempower.client.api.bus_sync.Bus` and :class:`~drempower.client.api.bus_async.AsyncBus`
comes from one source (``api_async.py``, from which ``api_sync.py`` is generated).
"""

from __future__ import annotations

from collections.abc import Awaitable, Callable, Sequence
from typing import TypeVar

from ...protocol.ids import check_node
from ...protocol.messages import Message
from ..engine.effects import Runnable, await_state
from ..engine.session import sequenced
from ..engine.state import MotorState
from ..engine.timeouts import checks_times
from ..engine.timeouts import seconds as _seconds
from .busbase import BusBase

__all__ = ["AsyncBusBase", "AsyncPart", "SyncBusBase", "SyncPart"]

M = TypeVar("M")
T = TypeVar("T")
SyncPart = Callable[[], T]
"""One bus's part of a threaded call over several buses (a robot's, a follower's)."""
AsyncPart = Callable[[], Awaitable[T]]
"""One bus's part of an asyncio call over several buses."""

_WALL_POLL = 0.01
"""How often (s) an asyncio ``pass_time`` on a wall clock looks at its ``until`` and at the bus."""


def _duration(value: float) -> float:
    """A ``pass_time`` duration: 0, or seconds as :func:`~drempower.client.engine.timeouts.seconds` takes them."""
    return 0.0 if value == 0 and value.__class__ is not bool else _seconds(value, "seconds")


@checks_times
class SyncBusBase(BusBase[M]):
    """The threaded bus's own parts: operations run in the session, the caller's thread waits."""

    def run(self, op: Runnable[T]) -> T:
        """Run an operation (a generator of effects, see :mod:`drempower.client.engine.effects`) to completion;
        returns its result and raises what it raises (TimeoutError, ValidationError...)."""
        return self._core.run(op)

    def _send_all(self, msgs: Sequence[Message]) -> None:
        """Send ``msgs`` (a start among them may first wait until its presets are on the wire)."""
        self._core.send_many(msgs)

    def wait_state(self, id: int, timeout: float, newer_than: float | None = None) -> MotorState:
        """Wait for a state of motor ``id`` newer than ``newer_than`` (s on the bus's clock, see
        :meth:`BusDriver.now`; default: now), sending nothing.

        Raises :class:`~drempower.client.errors.TimeoutError` after ``timeout`` s without one,
        :class:`~drempower.client.errors.BusClosedError` when the bus closes meanwhile.
        """
        check_node(id, "id")
        since = self._core.now() if newer_than is None else newer_than
        return self._core.run(await_state(id, since, timeout))

    def pass_time(self, seconds: float, until: Callable[[], bool] | None = None) -> None:
        """Let ``seconds`` (s) of the bus's time pass, taking the frames that arrive meanwhile; end early
        once ``until()`` is true or the bus closes. On a virtual clock no wall time passes; on a wall clock
        it sleeps."""
        self._core.pass_time(_duration(seconds), until)

    def close(self) -> None:
        """Send the pending stops of timed commands, apply ``stop_on_close`` to the motors this bus
        commanded, then release the transport."""
        self.close_now()


@checks_times
class AsyncBusBase(BusBase[M]):
    """The asyncio bus's own parts: operations run in the session, the event loop awaits them (replies
    are handed to it with ``loop.call_soon_threadsafe``, so no thread is used per call)."""

    async def run(self, op: Runnable[T]) -> T:
        """Run an operation (a generator of effects, see :mod:`drempower.client.engine.effects`) to completion;
        returns its result and raises what it raises (TimeoutError, ValidationError...)."""
        return await self._core.run_async(op)  # on a virtual clock it runs inside the call

    async def _send_all(self, msgs: Sequence[Message]) -> None:
        """Send ``msgs``; when a start among them waits until its presets are on the wire, in a worker
        thread, so the event loop never blocks on that wait."""
        import asyncio

        if sequenced(msgs) and not self._core.virtual:
            await asyncio.to_thread(self._core.send_many, msgs)
        else:
            self._core.send_many(msgs)

    async def wait_state(self, id: int, timeout: float, newer_than: float | None = None) -> MotorState:
        """Wait for a state of motor ``id`` newer than ``newer_than`` (s on the bus's clock, see
        :meth:`BusDriver.now`; default: now), sending nothing.

        Raises :class:`~drempower.client.errors.TimeoutError` after ``timeout`` s without one,
        :class:`~drempower.client.errors.BusClosedError` when the bus closes meanwhile.
        """
        check_node(id, "id")
        since = self._core.now() if newer_than is None else newer_than
        return await self.run(await_state(id, since, timeout))

    async def pass_time(self, seconds: float, until: Callable[[], bool] | None = None) -> None:
        """Let ``seconds`` (s) of the bus's time pass, taking the frames that arrive meanwhile; end early
        once ``until()`` is true or the bus closes. On a virtual clock no wall time passes (it runs inside
        the call); on a wall clock the event loop sleeps, looking at ``until()`` every 10 ms."""
        import asyncio

        seconds = _duration(seconds)
        if self._core.virtual:
            self._core.pass_time(seconds, until)
            return
        self._core.check_open()
        end = self._core.now() + seconds
        while not (until is not None and until()) and (left := end - self._core.now()) > 0 and not self.closed:
            await asyncio.sleep(min(left, _WALL_POLL))

    async def close(self) -> None:
        """Apply ``stop_on_close`` to the motors this bus commanded, then release the transport
        (in a worker thread: it may block briefly)."""
        import asyncio

        await asyncio.get_running_loop().run_in_executor(None, self.close_now)
