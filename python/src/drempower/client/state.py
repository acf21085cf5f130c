"""Per-motor state cache: the latest state frame of every motor, waits and callbacks."""

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
    """Latest :class:`MotorState` per node, with waiting and subscriptions.

    ``update`` runs in the receive thread; it takes the condition's lock only
    when some thread is waiting, and calls callbacks from an immutable tuple.
    """

    def __init__(self) -> None:
        self._states: dict[int, MotorState] = {}
        self._cond = threading.Condition(threading.Lock())
        self._waiters = 0
        self._subs_lock = threading.Lock()
        self._all: tuple[Subscription, ...] = ()
        self._by_node: dict[int, tuple[Subscription, ...]] = {}

    def get(self, node: int) -> MotorState | None:
        """The latest state of ``node``, or None if none has arrived."""
        return self._states.get(node)

    def snapshot(self) -> dict[int, MotorState]:
        """The latest state of every motor heard from."""
        return dict(self._states)

    def clear(self, node: int) -> None:
        """Forget ``node`` (e.g. after its id changed)."""
        self._states.pop(node, None)

    def update(self, state: MotorState) -> None:
        self._states[state.node] = state
        if self._waiters:
            with self._cond:
                self._cond.notify_all()
        for sub in self._all:
            self._call(sub, state)
        subs = self._by_node.get(state.node)
        if subs:
            for sub in subs:
                self._call(sub, state)

    @staticmethod
    def _call(sub: Subscription, state: MotorState) -> None:
        try:
            sub.callback(state)
        except Exception:
            _log.exception("state callback %r failed", sub.callback)

    def wait(self, node: int, newer_than: float, timeout: float) -> MotorState | None:
        """Wait until a state of ``node`` newer than ``newer_than`` arrives; None on timeout."""
        deadline = time.monotonic() + timeout
        with self._cond:
            self._waiters += 1
            try:
                while True:
                    st = self._states.get(node)
                    if st is not None and st.timestamp > newer_than:
                        return st
                    left = deadline - time.monotonic()
                    if left <= 0:
                        return None
                    self._cond.wait(left)
            finally:
                self._waiters -= 1

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
