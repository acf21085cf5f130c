"""What the threaded and the asyncio bus share: the core, options and the state cache (no I/O)."""

from __future__ import annotations

import threading
from abc import ABC, abstractmethod
from collections.abc import Callable
from typing import Generic, TypeVar

from ..errors import ValidationError
from ..protocol.ids import Frame, check_node
from ..transports.base import Transport
from .core import DEFAULT_TIMEOUT, BusCore, StartPolicy, StopOnClose
from .state import MotorState, StateCallback, Subscription

__all__ = ["BusBase"]

M = TypeVar("M")


class BusBase(ABC, Generic[M]):
    """Owns a :class:`BusCore` (transport, receive thread, matching, state cache) and the motor handles.

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
        self._core = BusCore(
            transport,
            timeout=timeout,
            retries=retries,
            stop_on_close=stop_on_close,
            start=start,
            on_unsolicited=on_unsolicited,
        )
        self._motors: dict[int, M] = {}
        self._motors_lock = threading.Lock()

    @abstractmethod
    def _new_motor(self, id: int) -> M:
        """A new handle of motor ``id`` for this kind of bus."""

    def motor(self, id: int) -> M:
        """The handle of motor ``id`` (1..63; 0 addresses every motor, reads need a single motor)."""
        m = self._motors.get(id)
        if m is None:
            check_node(id, "id")
            with self._motors_lock:
                m = self._motors.get(id)
                if m is None:
                    m = self._motors[id] = self._new_motor(id)
        return m

    def __getitem__(self, id: int) -> M:
        return self.motor(id)

    @property
    def core(self) -> BusCore:
        """The shared core (transport, matching, state cache)."""
        return self._core

    @property
    def transport(self) -> Transport:
        return self._core.transport

    @property
    def timeout(self) -> float:
        """Default reply timeout (s)."""
        return self._core.timeout

    @timeout.setter
    def timeout(self, value: float) -> None:
        if not value > 0:
            raise ValidationError(f"timeout={value!r}: must be > 0 s")
        self._core.timeout = float(value)

    @property
    def closed(self) -> bool:
        return self._core.closed

    @property
    def stats(self) -> dict[str, int]:
        """Frames received, malformed ones, those that were no reply and no state, and anomalies.

        An anomaly is a reply for a waiting request whose echoed fields (data
        type) differ from the request's: it answers nothing (the request keeps
        waiting or times out) and also counts as unmatched.
        """
        c = self._core
        return {
            "frames_received": c.frames_received,
            "malformed": c.malformed,
            "unmatched": c.unmatched,
            "anomalies": c.anomalies,
        }

    @property
    def on_unsolicited(self) -> Callable[[Frame], None] | None:
        """Hook called in the receive thread with frames that match no request and are no state."""
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
        """Call ``callback(state)`` in the receive thread for each state of motor ``id`` (all when None)."""
        return self._core.states.subscribe(callback, id)

    def __repr__(self) -> str:
        return f"<{type(self).__name__} {self.transport.description}{' closed' if self.closed else ''}>"
