"""The health supervisor run on its own, for a robot whose file has a ``[health]`` section.

:func:`~drempower.robot.open_robot` (and ``open_robot_async``, the dashboard and the bridge over a robot
file) start a :class:`HealthRun` when the file asks for it: one supervisor step
(:mod:`drempower.client.engine.supervisor`) over every joint every ``period`` s, its events logged (the
``drempower.health`` logger: WARNING, ERROR for a fault, INFO when a joint is healthy again), kept
(:attr:`HealthRun.events`) and handed to the listeners, its actions (``on_overheat``, ``on_stall``: hold or
idle, per joint) sent by the step itself. It stops when the robot closes, before the buses do.

How it runs, per bus:

* on a wall clock, a thread per robot (:class:`~drempower.robot.Robot`) or an asyncio task per robot
  (:class:`~drempower.robot.AsyncRobot`, started once its event loop runs) steps every bus in turn;
* on a virtual clock (``clock="virtual"``), an operation of the bus's own session: its steps come due on
  the simulated time, whichever caller lets it pass, so a test sees a step exactly every ``period`` s
  of bus time.

Bus cost: :data:`~drempower.client.engine.supervisor.FRAMES_PER_MOTOR` (12) frames per motor and step, about
1.6 ms of a 1 Mbit/s bus per motor; at the default 1 s period six motors take under 1 % of the bus.
The first step also reads each motor's limits (7 reads per motor); a faulted motor costs one more
exchange (its seven error words) in the step that finds it.
"""

from __future__ import annotations

import logging
import threading
from collections import deque
from collections.abc import Callable, Mapping, Sequence
from typing import TYPE_CHECKING, Any

from ..client.engine.effects import Op, sleep
from ..client.engine.supervisor import HealthEvent, HealthPolicy, Level, Watch, prepare, supervise
from ..errors import BusClosedError, DrEmpowerError
from ..robotfile import RobotSpec

if TYPE_CHECKING:
    from ..client.engine.operation import Operation

__all__ = ["EVENTS_KEPT", "HealthRun", "bus_policy"]

EVENTS_KEPT = 500
"""The latest events :attr:`HealthRun.events` keeps."""
_log = logging.getLogger("drempower.health")
_LOG_LEVEL = {"ok": logging.INFO, "warn": logging.WARNING, "error": logging.ERROR}


def bus_policy(spec: RobotSpec, bus: str | None = None) -> HealthPolicy | None:
    """The supervisor's policy of ``spec``'s ``[health]`` for the joints of bus ``bus`` (their own ``on_overheat``
    and ``on_stall`` by motor id; None: every joint's, for a robot whose motor ids differ across its buses),
    or None when the file has no ``[health]``."""
    if spec.health is None:
        return None
    joints = [j for j in spec.joints.values() if bus is None or j.bus == bus]
    return HealthPolicy(
        **spec.health,
        joints={j.id: j.on_overheat for j in joints if j.on_overheat is not None},
        stalls={j.id: j.on_stall for j in joints if j.on_stall is not None},
    )


class HealthRun:
    """The background supervisor of one robot: the policy, the watches per bus, the events seen.

    ``buses`` by name (sync or asyncio), ``watches`` their :class:`Watch` es (shared with
    :meth:`~drempower.robot.Robot.supervise`: each event is reported once, by whichever step sees it).
    """

    def __init__(
        self, buses: Mapping[str, Any], watches: Mapping[str, list[Watch]], policy: HealthPolicy, source: str
    ) -> None:
        self.policy = policy
        self.source = source
        self.buses = dict(buses)
        self.watches = dict(watches)
        self.events: deque[HealthEvent] = deque(maxlen=EVENTS_KEPT)
        """The events so far (the latest :data:`EVENTS_KEPT`), oldest first."""
        self.steps = 0
        """Supervisor steps done (one per bus and period)."""
        self.failure: str | None = None
        """The latest step's failure (no answer...), None once a step succeeds."""
        self._listeners: tuple[Callable[[HealthEvent], None], ...] = ()
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._ops: list[tuple[Any, Operation[None]]] = []
        self._thread: threading.Thread | None = None
        self.task: Any = None
        """The asyncio task of an :class:`~drempower.robot.AsyncRobot`'s wall-clock buses, once started."""
        self.wall = [b for b, bus in self.buses.items() if not bus.virtual]
        """The buses on a wall clock (a thread or a task steps them); the others run an operation each."""

    # ------------------------------------------------------------------ what it saw

    @property
    def running(self) -> bool:
        """True until :meth:`stop`."""
        return not self._stop.is_set()

    def add_listener(self, fn: Callable[[HealthEvent], None]) -> None:
        """Call ``fn(event)`` with each event from now on (from the thread that ran the step: keep it short,
        no bus calls)."""
        with self._lock:
            self._listeners = (*self._listeners, fn)

    def remove_listener(self, fn: Callable[[HealthEvent], None]) -> None:
        """Stop calling ``fn`` (no error when it is not a listener)."""
        with self._lock:
            self._listeners = tuple(f for f in self._listeners if f is not fn)

    def levels(self) -> dict[tuple[str, int], Level]:
        """Each watched motor's level now (``ok``, ``warn``, ``error``) by (bus, motor id)."""
        return {(b, w.node): w.level for b, ws in self.watches.items() for w in ws}

    def took(self, events: Sequence[HealthEvent]) -> None:
        """A step's events: logged, kept, handed to the listeners."""
        self.steps += 1
        self.failure = None
        for e in events:
            _log.log(_LOG_LEVEL[e.level], "%s: %s", self.source, e)
            self.events.append(e)
            for fn in self._listeners:
                try:
                    fn(e)
                except Exception:
                    _log.exception("health: a listener failed")

    def failed(self, bus: str, exc: BaseException) -> None:
        """A step that got no answer: logged once per distinct failure; the next period tries again."""
        text = f"bus {bus}: {exc}"
        if text != self.failure:
            _log.warning("%s: health supervisor: %s", self.source, text)
        self.failure = text

    # ------------------------------------------------------------------ running

    def start_virtual(self) -> None:
        """Start an operation of the session of every bus on a virtual clock (its first step at once)."""
        for b, bus in self.buses.items():
            if bus.virtual:
                self._ops.append((bus, bus.submit(self._steps(b, bus))))

    def _steps(self, name: str, bus: Any) -> Op[None]:
        """Steps every ``period`` s of the bus's time until stopped (an operation of the bus's session)."""
        watches = self.watches[name]
        while not self._stop.is_set():
            try:
                fresh = [w for w in watches if w.limits.kt != w.limits.kt]
                if fresh:
                    yield from prepare(fresh)
                events = yield from supervise(watches, bus.now())
                bus.health_acted(events)
            except BusClosedError:
                return
            except DrEmpowerError as exc:
                self.failed(name, exc)
            else:
                self.took(events)
            yield from sleep(self.policy.period)

    def start_thread(self) -> None:
        """Step the wall-clock buses of a threaded robot from a thread of their own."""
        if self.wall and self._thread is None:
            self._thread = threading.Thread(target=self._loop, name="drempower health", daemon=True)
            self._thread.start()

    def _loop(self) -> None:
        while not self._stop.is_set():
            for b in self.wall:
                try:
                    self.took(self.buses[b].supervise(self.watches[b]))
                except BusClosedError:
                    return
                except DrEmpowerError as exc:
                    self.failed(b, exc)
            self._stop.wait(self.policy.period)

    async def run_async(self) -> None:
        """Step the wall-clock buses of an asyncio robot (its task's body) until stopped or cancelled."""
        import asyncio

        while not self._stop.is_set():
            for b in self.wall:
                try:
                    self.took(await self.buses[b].supervise(self.watches[b]))
                except BusClosedError:
                    return
                except DrEmpowerError as exc:
                    self.failed(b, exc)
            await asyncio.sleep(self.policy.period)

    def stop(self) -> None:
        """Stop stepping (a step under way ends first on a thread). Idempotent."""
        self._stop.set()
        for bus, opn in self._ops:
            if not opn.done and not bus.closed:
                bus.cancel(opn)
        self._ops.clear()
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join(timeout=5.0)
