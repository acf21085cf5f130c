"""Operations as generators of effects, run by a threaded or an asyncio driver.

An operation that needs several exchanges with the motors (read positions,
then send presets; poll until a move ends; read seven error words...) is
written once as a generator that yields effects and receives their results.
The :class:`~drempower.client.engine.session.BusSession` runs it on its own time; the
threaded and asyncio drivers only wait for it to finish, so both APIs share
every line of logic.
"""

from __future__ import annotations

from collections.abc import Generator, Sequence
from dataclasses import dataclass
from typing import Any, Generic, TypeAlias, TypeVar

from ...protocol.ids import Frame
from ...protocol.messages import FastRead, Message, ParamValue, ReadParam, Start, StartImpedance
from ...protocol.parameters import Parameter, parameter
from .state import MotorState

__all__ = [
    "Send",
    "Batch",
    "Request",
    "Sleep",
    "AwaitState",
    "Cycle",
    "Effect",
    "Op",
    "Runnable",
    "Single",
    "request",
    "read_params",
    "read_states",
    "sleep",
    "await_state",
]

T = TypeVar("T")


@dataclass(frozen=True, slots=True)
class Send:
    """Send messages (all encoded before the first is sent); result None."""

    messages: Sequence[Message]


@dataclass(frozen=True, slots=True)
class Batch:
    """Send presets and their start atomically (see ``BusSession``); result: where the start(s) went."""

    presets: Sequence[Message]
    start: Start | StartImpedance
    targets: Sequence[float | None] | None = None
    """Target angle (deg) per preset of a position move, recorded for the waits."""
    move_time: float | None = None
    """Planned move time (s) of a Q-mode move."""


@dataclass(frozen=True, slots=True)
class Request:
    """Send ``messages`` and collect their answers; result: answers in order (None if missing and allowed)."""

    messages: Sequence[Message]
    timeout: float | None = None
    missing_ok: bool = False
    expect: Sequence[int] | None = None
    what: str | None = None


@dataclass(frozen=True, slots=True)
class Sleep:
    """Pause for ``seconds``; result None."""

    seconds: float


@dataclass(frozen=True, slots=True)
class AwaitState:
    """Wait, sending nothing, for a state of motor ``node`` that arrived after ``newer_than`` (s, session
    time); result: that :class:`MotorState`, or :class:`TimeoutError` after ``timeout`` s."""

    node: int
    newer_than: float
    timeout: float


@dataclass(slots=True)  # not frozen (treat it as such): a frozen one costs ~0.8 us more to build, per cycle
class Cycle(Generic[T]):
    """One control cycle (see :func:`~drempower.client.engine.batch.cycle`): send ``messages`` (commands, then
    fast reads) as the encoded ``frames`` and collect the next state of each motor of ``nodes``; result:
    ``{node: MotorState}`` in the order of ``nodes``. Sent once, never retried; on expiry (``timeout`` s,
    None: the session's) a :class:`~drempower.client.errors.TimeoutError` names the silent motors.
    Also a :data:`Runnable` by itself: the session runs it without a generator."""

    messages: Sequence[Message]
    frames: Sequence[Frame]
    nodes: Sequence[int]
    timeout: float | None = None


Effect: TypeAlias = Send | Batch | Request | Sleep | AwaitState | Cycle[Any]


@dataclass(frozen=True, slots=True)
class Single(Generic[T]):
    """An operation of one :class:`Request` whose first answer is the result (a fast read...): the
    session runs it without a generator, the shortest path a call can take."""

    request: Request


Op: TypeAlias = Generator[Effect, Any, T]
"""An operation: yields effects, returns ``T``."""
Runnable: TypeAlias = Op[T] | Single[T] | Cycle[T]
"""What a session runs: an operation, a :class:`Single` request or a :class:`Cycle`."""


def request(
    msgs: Sequence[Message], timeout: float | None = None, missing_ok: bool = False, **kw: Any
) -> Op[list[Any]]:
    """Yield one :class:`Request` and return its answers."""
    result: list[Any] = yield Request(msgs, timeout, missing_ok, **kw)
    return result


def read_params(node: int, params: Sequence[str | int | Parameter], timeout: float | None = None) -> Op[list[Any]]:
    """Read several parameters of one motor in a single exchange; returns their values."""
    ps = [parameter(p) for p in params]
    replies: list[ParamValue] = yield from request([ReadParam(node, p.address, p.dtype) for p in ps], timeout)
    return [r.value for r in replies]


def read_states(
    nodes: Sequence[int], timeout: float | None = None, missing_ok: bool = False
) -> Op[list[MotorState | None]]:
    """Fast-read several motors in a single exchange."""
    states: list[MotorState | None] = yield from request([FastRead(n) for n in nodes], timeout, missing_ok)
    return states


def await_state(node: int, newer_than: float, timeout: float) -> Op[MotorState]:
    """Yield one :class:`AwaitState` and return the state."""
    st: MotorState = yield AwaitState(node, newer_than, timeout)
    return st


def sleep(seconds: float) -> Op[None]:
    """Yield one :class:`Sleep`."""
    yield Sleep(seconds)
