"""Per-motor state: the latest state frame of every motor, and callbacks."""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable
from typing import NamedTuple

__all__ = ["MotorState", "StateCache", "Subscription", "StateCallback"]

_log = logging.getLogger("drempower.client")


class MotorState(NamedTuple):
    """One real-time state frame of a motor.

    ``angle`` deg, ``speed`` r/min, ``torque`` Nm (output shaft);
    ``trajectory_done`` is the T bit (target reached), ``error`` the E bit
    (axis error set); ``timestamp`` is :func:`time.monotonic` when it arrived.
    """

    node: int
    angle: float
    speed: float
    torque: float
    trajectory_done: bool
    error: bool
    timestamp: float

    @property
    def age(self) -> float:
        """Seconds since this state arrived."""
        return time.monotonic() - self.timestamp


StateCallback = Callable[[MotorState], None]
"""Called in the bus's receive thread with every new state; keep it short."""


class Subscription:
    """A registered state callback; :meth:`cancel` (or ``with``) removes it."""

    __slots__ = ("_cache", "callback", "node")

    def __init__(self, cache: StateCache, callback: StateCallback, node: int | None) -> None:
        self._cache = cache
        self.callback = callback
        self.node = node

    def cancel(self) -> None:
        self._cache._remove(self)

    def __enter__(self) -> Subscription:
        return self

    def __exit__(self, *exc: object) -> None:
        self.cancel()


class StateCache:
    """Latest :class:`MotorState` per node (the session's table, read without a lock) and subscriptions.

    :meth:`notify` runs in the thread that received the state; callbacks are
    called from an immutable tuple, so subscribing from another thread is safe.
    """

    def __init__(self, states: dict[int, MotorState] | None = None) -> None:
        self._states: dict[int, MotorState] = {} if states is None else states
        self._subs_lock = threading.Lock()
        self._all: tuple[Subscription, ...] = ()
        self._by_node: dict[int, tuple[Subscription, ...]] = {}

    def get(self, node: int) -> MotorState | None:
        """The latest state of ``node``, or None if none has arrived."""
        return self._states.get(node)

    def snapshot(self) -> dict[int, MotorState]:
        """The latest state of every motor heard from."""
        return self._states.copy()

    def clear(self, node: int) -> None:
        """Forget ``node`` (e.g. after its id changed)."""
        self._states.pop(node, None)

    @property
    def subscribed(self) -> bool:
        """True when some callback is registered."""
        return bool(self._all or self._by_node)

    def notify(self, state: MotorState) -> None:
        """Call the callbacks registered for ``state``'s motor and for every motor."""
        for sub in self._all:
            self._call(sub, state)
        subs = self._by_node.get(state.node)
        if subs:
            for sub in subs:
                self._call(sub, state)

    def update(self, state: MotorState) -> None:
        """Store ``state`` as its motor's latest and call the callbacks."""
        self._states[state.node] = state
        self.notify(state)

    @staticmethod
    def _call(sub: Subscription, state: MotorState) -> None:
        try:
            sub.callback(state)
        except Exception:
            _log.exception("state callback %r failed", sub.callback)

    def subscribe(self, callback: StateCallback, node: int | None = None) -> Subscription:
        """Call ``callback(state)`` for every state of ``node`` (every motor when None)."""
        sub = Subscription(self, callback, node)
        with self._subs_lock:
            if node is None:
                self._all = (*self._all, sub)
            else:
                self._by_node[node] = (*self._by_node.get(node, ()), sub)
        return sub

    def _remove(self, sub: Subscription) -> None:
        with self._subs_lock:
            if sub.node is None:
                self._all = tuple(s for s in self._all if s is not sub)
            else:
                rest = tuple(s for s in self._by_node.get(sub.node, ()) if s is not sub)
                if rest:
                    self._by_node[sub.node] = rest
                else:
                    self._by_node.pop(sub.node, None)
