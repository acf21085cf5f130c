"""A command watchdog per controller (no I/O: the caller gives the time and sends what it returns).

A controller is whatever commands motors from outside the program: a remote client,
a ROS publisher, a dashboard page. It registers the motors it drives, feeds the
watchdog on each command, and, when it has a liveness signal (an open WebSocket, a
Zenoh liveliness token), says whether it is alive:

* silence from a controller that is alive holds what it last commanded: nothing is
  done (ros2_control's topic-based systems publish only on change);
* a controller that is gone (``alive(False)``, :meth:`Watchdog.unregister`, or, for
  one without a liveness signal, ``timeout`` s of silence) triggers each of its
  motors' ``on_timeout``: ``"idle"`` releases the motor, ``"hold"`` commands speed 0
  in closed loop (it holds where it is). The default is ``"idle"`` for a bare motor;
  a robot file's joints hold unless they say ``on_timeout = "idle"``.

::

    dog = Watchdog(timeout=0.5)
    dog.register("page-1", [1, 2], now=bus.now(), liveness=True)
    dog.feed("page-1", now)                 # on each command the page sends
    dog.alive("page-1", False)              # its WebSocket closed
    fired = dog.tick(now)                   # each cycle of the owner's loop
    if fired:
        bus.send_many(stop_messages(fired))

:meth:`Watchdog.tick` returns :class:`Fired` records; :func:`stop_messages` turns
them into the messages to send (set_mode(1) writes, speed 0).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field

from ...errors import ValidationError
from ...protocol.limits import check_motor
from ...protocol.messages import Message, Velocity, WriteParam

__all__ = ["Watchdog", "Fired", "OnTimeout", "ON_TIMEOUT_DEFAULT", "stop_messages"]

OnTimeout = str
"""``"idle"`` or ``"hold"``."""
ON_TIMEOUT_DEFAULT = "idle"
"""What a bare motor does when its controller is gone (a robot file's joints default to ``hold``)."""
_ACTIONS = ("idle", "hold")


@dataclass
class _Controller:
    nodes: tuple[int, ...]
    last: float
    liveness: bool
    alive: bool = True
    fired: bool = False


@dataclass(frozen=True)
class Fired:
    """A controller found gone at ``at`` (s): what each of its motors is to do (``{node: "idle"|"hold"}``)."""

    controller: str
    at: float
    actions: Mapping[int, OnTimeout] = field(default_factory=dict)


class Watchdog:
    """The controllers of one bus and their motors; ``timeout`` s of silence ends one without liveness."""

    def __init__(self, timeout: float = 0.5, on_timeout: Mapping[int, OnTimeout] | None = None) -> None:
        if isinstance(timeout, bool) or not isinstance(timeout, (int, float)) or not 0 < timeout < math.inf:
            raise ValidationError(f"timeout={timeout!r}: expected seconds > 0")
        self.timeout = float(timeout)
        self._on: dict[int, OnTimeout] = {}
        for node, action in (on_timeout or {}).items():
            self.set_on_timeout(node, action)
        self._controllers: dict[str, _Controller] = {}

    def set_on_timeout(self, node: int, action: OnTimeout) -> None:
        """What motor ``node`` does when its controller is gone: ``"idle"`` or ``"hold"``."""
        check_motor(node, "node")
        if action not in _ACTIONS:
            raise ValidationError(f"on_timeout={action!r}: expected 'idle' or 'hold'")
        self._on[node] = action

    def on_timeout(self, node: int) -> OnTimeout:
        """Motor ``node``'s action (default :data:`ON_TIMEOUT_DEFAULT`)."""
        return self._on.get(node, ON_TIMEOUT_DEFAULT)

    def register(self, name: str, nodes: Iterable[int], *, now: float, liveness: bool = False) -> None:
        """Add controller ``name`` driving ``nodes``; ``liveness``: it will say whether it is alive
        (:meth:`alive`), so its silence holds; without, ``timeout`` s of silence means gone."""
        if name in self._controllers:
            raise ValidationError(f"controller {name!r} is registered already")
        ids = tuple(check_motor(n, "nodes") for n in nodes)
        self._controllers[name] = _Controller(ids, now, liveness)

    def update(self, name: str, nodes: Iterable[int], *, now: float, liveness: bool) -> None:
        """Controller ``name`` (registered or not) drives ``nodes`` now, with ``liveness`` as it has it now
        (a publisher with a token gone, a later one without); nothing fires."""
        ids = tuple(check_motor(n, "nodes") for n in nodes)
        c = self._controllers.get(name)
        if c is None:
            self._controllers[name] = _Controller(ids, now, liveness)
            return
        c.nodes, c.liveness = ids, liveness

    def _get(self, name: str) -> _Controller:
        c = self._controllers.get(name)
        if c is None:
            raise ValidationError(f"controller {name!r} is not registered")
        return c

    def feed(self, name: str, now: float) -> None:
        """Controller ``name`` sent a command at ``now`` (s); a controller found gone comes back."""
        c = self._get(name)
        c.last = now
        c.fired = False
        c.alive = True

    def alive(self, name: str, alive: bool) -> None:
        """Controller ``name``'s liveness signal changed (token declared or dropped, socket open or closed)."""
        self._get(name).alive = alive

    def unregister(self, name: str, now: float) -> Fired | None:
        """Controller ``name`` left: its motors' actions (None when already fired)."""
        c = self._controllers.pop(name, None)
        if c is None or c.fired:
            return None
        return self._fire(name, c, now)

    def controllers(self) -> list[str]:
        """The registered controllers."""
        return list(self._controllers)

    def next_due(self) -> float | None:
        """The earliest time (s) a silent controller without liveness would be gone, or None."""
        dues = [c.last + self.timeout for c in self._controllers.values() if not c.liveness and not c.fired]
        return min(dues) if dues else None

    def tick(self, now: float) -> list[Fired]:
        """The controllers found gone at ``now`` (each fires once, until fed again)."""
        out: list[Fired] = []
        for name, c in self._controllers.items():
            if c.fired:
                continue
            gone = not c.alive if c.liveness else (not c.alive or now - c.last > self.timeout)
            if gone:
                out.append(self._fire(name, c, now))
        return out

    def _fire(self, name: str, c: _Controller, now: float) -> Fired:
        c.fired = True
        return Fired(name, now, {n: self.on_timeout(n) for n in c.nodes})


def stop_messages(fired: Iterable[Fired]) -> list[Message]:
    """The messages that carry out ``fired``: an idle request (``axis0.requested_state`` = 1) per motor
    to idle, speed 0 per motor to hold; each motor once (idle wins)."""
    actions: dict[int, OnTimeout] = {}
    for f in fired:
        for node, action in f.actions.items():
            if actions.get(node) != "idle":
                actions[node] = action
    out: list[Message] = []
    for node, action in sorted(actions.items()):
        out.append(WriteParam.of(node, "axis0.requested_state", 1) if action == "idle" else Velocity(node, 0.0))
    return out
