"""The shadow twin: the robot's twin run beside the robot, fed the same commands, flagging what it did not expect.

:class:`Shadow` builds the twin of a robot file (its own simulated motors, not the robot's), puts its joints
where the robot's are, and watches every bus of an open :class:`~drempower.robot.Robot`: each command the
program sends is sent to the twin's motors too, at the same time, and each state a motor reports is compared
with the twin's joint at that time. A joint whose position residual (robot - twin) stays beyond
``position`` rad, or torque residual beyond ``torque`` Nm, for longer than ``hold_time`` s is a
*divergence*: an unexpected contact, a payload the model lacks. It is logged, passed to ``on_event``, and
acted on per ``on_divergence``: ``"warn"`` (nothing more), ``"hold"`` (every joint holds where it is) or
``"idle"`` (every motor stops: the emergency stop). Without ``on_divergence`` the robot file says, per
joint: the diverging joint's ``on_divergence``, else ``[model]``'s, else ``"warn"``.

The twin's joints start where the robot's are at their first reported state. The twin keeps the
robot's time: ``clock`` (default the wall clock) gives it; the twin's buses are advanced
to it before each frame is taken (a robot on the virtual clock passes its bus's simulated time).
"""

from __future__ import annotations

import asyncio
import logging
import math
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from functools import partial
from typing import TYPE_CHECKING, Any

from ..errors import ProtocolError, ValidationError
from ..protocol.describe import decode_frame
from ..protocol.ids import Frame
from ..protocol.messages import State
from ..robotfile import ON_DIVERGENCE

if TYPE_CHECKING:
    from .robot_async import AsyncRobot
    from .robot_sync import Robot

__all__ = ["ON_DIVERGENCE", "Divergence", "Shadow"]

_log = logging.getLogger("drempower.shadow")
_DEG = math.pi / 180.0
_RPM = 2.0 * math.pi / 60.0


@dataclass(frozen=True)
class Divergence:
    """A joint that left its twin: ``joint``, the ``kind`` (``"position"`` or ``"torque"``), the residual
    robot - twin (rad or Nm) when flagged, the times (s, the shadow's ``clock``) it began and was flagged."""

    joint: str
    kind: str
    residual: float
    began: float
    flagged: float

    def __str__(self) -> str:
        unit = "rad" if self.kind == "position" else "Nm"
        return (
            f"joint {self.joint!r} diverges from its twin: {self.kind} residual {self.residual:+.4g} {unit} "
            f"for {self.flagged - self.began:.3f} s"
        )


def _positive(value: float | None, what: str) -> float | None:
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, int | float) or not 0 < value < math.inf:
        raise ValidationError(f"{what}={value!r}: expected a positive finite number")
    return float(value)


class Shadow:
    """The twin of ``robot`` run beside it (see the module docstring). Use it as a context manager, or
    :meth:`close` it; :attr:`events` lists the divergences flagged, :attr:`twin` is the twin."""

    def __init__(
        self,
        robot: Robot | AsyncRobot,
        *,
        position: float | None = math.radians(3.0),
        torque: float | None = None,
        hold_time: float = 0.1,
        on_divergence: str | None = None,
        on_event: Callable[[Divergence], None] | None = None,
        clock: Callable[[], float] | None = None,
        model: str | None = None,
    ) -> None:
        from ..sim.bus import SimBus
        from ..sim.twin import couple_robot

        if on_divergence is not None and on_divergence not in ON_DIVERGENCE:
            raise ValidationError(f"on_divergence={on_divergence!r}: one of {', '.join(ON_DIVERGENCE)}")
        self.position = _positive(position, "position")
        self.torque = _positive(torque, "torque")
        if self.position is None and self.torque is None:
            raise ValidationError("position and torque are both None: nothing to watch")
        self.hold_time = float(_positive(hold_time, "hold_time") or 0.0)
        self.on_divergence = on_divergence
        """What every divergence does (None: per joint, as the robot file says: :meth:`action`)."""
        self.on_event = on_event
        self.robot = robot
        spec = robot.spec
        if model is not None:
            from dataclasses import replace

            from ..robotfile import ModelSpec

            spec = replace(spec, model=ModelSpec(model) if spec.model is None else replace(spec.model, file=model))
        if spec.model is None:
            raise ValidationError(f"{spec.source}: no [model]: a shadow needs the robot's twin")
        self.spec = spec
        self._clock = clock or time.monotonic
        self._t0 = self._clock()
        self._buses = {b: SimBus([j.id for j in spec.joints_on(b)]) for b in spec.buses}
        twin = couple_robot(spec, self._buses)
        assert twin is not None
        self.twin = twin
        self._joint = {(j.bus, j.id): j for j in spec.joints.values()}
        self.lock = threading.Lock()
        self.events: list[Divergence] = []
        """The divergences flagged so far."""
        self._since: dict[tuple[str, str], float] = {}
        self._flagged: set[str] = set()
        self.last: dict[str, float] = {}
        """The latest position (rad) the robot reported, per joint."""
        self.residuals: dict[str, tuple[float, float]] = {}
        """The latest (position rad, torque Nm) residual, robot - twin, per joint."""
        self._synced: set[str] = set()
        """Joints put where the robot's are (at their first state seen)."""
        from .robot_async import AsyncRobot

        # an AsyncRobot's loop (a Robot's program may run in a thread that holds some other loop)
        self._loop: asyncio.AbstractEventLoop | None = (
            asyncio.get_running_loop() if isinstance(robot, AsyncRobot) else None
        )
        self._taps = []
        for b, bus in robot.buses.items():
            tap = partial(self._tap, b)
            bus.add_tap(tap)
            self._taps.append((bus, tap))
        self._closed = False
        self.acted = threading.Event()
        """Set once the robot was held or stopped after a divergence."""

    # ------------------------------------------------------------------ time

    def now(self) -> float:
        """The shadow's time (s since it started)."""
        return self._clock() - self._t0

    def _advance(self) -> None:
        t = self.now()
        for sim in self._buses.values():
            if t > sim.now:
                sim.advance(t - sim.now)

    # ------------------------------------------------------------------ frames

    def _tap(self, bus: str, frame: Frame, tx: bool) -> None:
        if self._closed:
            return
        with self.lock:
            self._advance()
            if tx:
                self._buses[bus].send(frame)
                return
            try:
                _, msg = decode_frame(frame.arbitration_id, bytes(frame.data), "motor")
            except ProtocolError:
                return
            if not isinstance(msg, State):
                return
            j = self._joint.get((bus, frame.arbitration_id >> 5))
            if j is None:
                return
            q = msg.position * _DEG / j.gear + j.offset
            tau = msg.torque * j.gear
            self.last[j.name] = q
            if j.name not in self._synced:  # start where the robot is
                self.twin.set_joint(j.name, q, msg.speed * _RPM / j.gear)
                self._synced.add(j.name)
                return
            drive = self._buses[bus].motors[j.id].drive
            rq = q - self.twin.joint_position(j.name)
            rt = tau - drive.torque * j.gear
            self.residuals[j.name] = (rq, rt)
            found = None
            for kind, value, limit in (("position", rq, self.position), ("torque", rt, self.torque)):
                key = (j.name, kind)
                if limit is None or abs(value) <= limit:
                    self._since.pop(key, None)
                    continue
                at = self._clock()
                began = self._since.setdefault(key, at)
                if at - began >= self.hold_time and j.name not in self._flagged:
                    found = Divergence(j.name, kind, value, began, at)
                    self._flagged.add(j.name)
                    self.events.append(found)
        if found is not None:
            self._report(found)

    def action(self, joint: str) -> str:
        """What a divergence of ``joint`` does: ``on_divergence`` as given, else the robot file's for it."""
        return self.on_divergence if self.on_divergence is not None else self.spec.on_divergence(joint)

    def _report(self, event: Divergence) -> None:
        action = self.action(event.joint)
        _log.warning("%s; %s", event, action)
        if self.on_event is not None:
            try:
                self.on_event(event)
            except Exception:
                _log.exception("shadow: on_event failed")
        if action == "warn":
            return
        # act outside the bus's thread: a tap must not wait for the bus it runs on
        threading.Thread(target=self._act, args=(action,), name="drempower-shadow-act", daemon=True).start()

    def _act(self, action: str) -> None:
        try:
            if self._loop is not None:  # an AsyncRobot: on its loop
                asyncio.run_coroutine_threadsafe(self._act_async(action), self._loop).result(timeout=5.0)
            elif action == "idle":
                self.robot.estop()
            else:
                for name, q in dict(self.last).items():
                    self.robot.joint(name).set_position(q)
        except Exception:
            _log.exception("shadow: could not %s the robot", action)
        else:
            self.acted.set()

    async def _act_async(self, action: str) -> None:
        robot: Any = self.robot
        if action == "idle":
            await robot.estop()
        else:
            for name, q in dict(self.last).items():
                await robot.joint(name).set_position(q)

    def twin_positions(self) -> dict[str, float]:
        """Where the twin has each joint now (rad), for a view beside the robot's."""
        with self.lock:
            return {name: self.twin.joint_position(name) for name in self.spec.joints}

    def reset(self) -> None:
        """Forget the divergences flagged (each joint is flagged once until then); the twin's joints are put
        where the robot's are at their next state."""
        with self.lock:
            self._flagged.clear()
            self._since.clear()
            self._synced.clear()

    # ------------------------------------------------------------------ lifetime

    def close(self) -> None:
        """Stop watching the robot. Idempotent."""
        self._closed = True
        for bus, tap in self._taps:
            bus.remove_tap(tap)
        self._taps.clear()

    def __enter__(self) -> Shadow:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()
