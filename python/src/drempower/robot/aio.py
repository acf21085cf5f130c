"""The asyncio robot: several buses as one, each bus's part of a call run as its own task."""

from __future__ import annotations

import asyncio
import os
from collections.abc import Awaitable, Callable, Iterable, Mapping
from types import TracebackType
from typing import Any, TypeVar

from ..client.aio import AsyncBus, open_bus_async
from ..client.bus import DEFAULT_MOVE_TIMEOUT, DEFAULT_POLL_INTERVAL
from ..client.commands import PositionMode
from ..client.effects import read_states
from ..client.state import MotorState
from ..client.timeouts import checks_times
from ..errors import BusClosedError, DrEmpowerError, ValidationError
from ..protocol.messages import Message
from .config import RobotSpec, load_robot
from .joint import AsyncJoint, JointState
from .names import by_bus, check_commands, note_bus, opening_failed, per_bus
from .plan import (
    StartClock,
    SyncMove,
    Target,
    angle_targets,
    bus_batch,
    check_targets,
    joint_targets,
    q_time,
    round_move_time,
)
from .threaded import bus_options

__all__ = ["AsyncRobot", "open_robot_async"]

T = TypeVar("T")


@checks_times
class AsyncRobot:
    """The asyncio counterpart of :class:`~drempower.robot.threaded.Robot` (same methods, as coroutines).

    Each bus's part of a call runs as its own task; :meth:`estop` sends to
    every bus from its own thread, so a bus whose device stopped taking data
    does not delay the others' stop (nor the event loop).
    """

    def __init__(self, spec: RobotSpec, buses: Mapping[str, AsyncBus]) -> None:
        self.spec = spec
        self.buses: dict[str, AsyncBus] = dict(buses)
        """The open buses by name."""
        self.joints: dict[str, AsyncJoint] = {name: AsyncJoint(self.buses[j.bus], j) for name, j in spec.joints.items()}
        """Every joint by name, in file order."""
        self._clock = StartClock()
        for bus in self.buses.values():
            bus.core.on_sent = self._clock
        self._move_lock = asyncio.Lock()
        self._closed = False

    def joint(self, name: str) -> AsyncJoint:
        """The handle of joint ``name``: an :class:`~drempower.client.aio.AsyncMotor` with SI extras."""
        j = self.joints.get(name)
        if j is None:
            raise ValidationError(f"joint {name!r}: no such joint (joints: {', '.join(self.joints)})")
        return j

    __getitem__ = joint

    def bus(self, name: str) -> AsyncBus:
        """The bus ``name`` of the robot file."""
        b = self.buses.get(name)
        if b is None:
            raise ValidationError(f"bus {name!r}: no such bus (buses: {', '.join(self.buses)})")
        return b

    async def _each(self, work: Mapping[str, Callable[[], Awaitable[T]]]) -> dict[str, T]:
        """Run each bus's part as a task; raise the first error (in bus order), noting its bus."""
        if self._closed:
            raise BusClosedError(f"the robot ({self.spec.source}) is closed")
        tasks = {bus: asyncio.ensure_future(fn()) for bus, fn in work.items()}
        try:
            await asyncio.wait(tasks.values())
        except BaseException:  # cancelled: so are the buses' parts
            for task in tasks.values():
                task.cancel()
            raise
        for bus, task in tasks.items():
            exc = task.exception()
            if exc is not None:
                note_bus(exc, bus)
                raise exc
        return {bus: task.result() for bus, task in tasks.items()}

    async def cycle(
        self, commands: Mapping[str, Message], *, timeout: float | None = None, reply_state: bool | None = None
    ) -> dict[str, MotorState]:
        """Send one command per joint and return each joint's state (see :meth:`Robot.cycle`)."""
        groups = per_bus(self.spec, commands)
        check_commands(self.spec, commands)

        def part(bus: str, msgs: dict[str, Message]) -> Callable[[], Awaitable[dict[str, MotorState]]]:
            async def run() -> dict[str, MotorState]:
                got = await self.buses[bus].cycle(msgs.values(), timeout=timeout, reply_state=reply_state)
                return {n: got[m.node] for n, m in msgs.items()}

            return run

        out: dict[str, MotorState] = {}
        for states in (await self._each({b: part(b, m) for b, m in groups.items()})).values():
            out.update(states)
        return {n: out[n] for n in commands}

    async def set_angles(
        self,
        angles: Mapping[str, float],
        speed: float = 10.0,
        param: float = 10.0,
        mode: int = PositionMode.Q,
        *,
        relative: bool = False,
        timeout: float | None = None,
    ) -> SyncMove:
        """Synchronised move in wire units across buses (see :meth:`Robot.set_angles`)."""
        targets = angle_targets(self.spec, angles, speed, param)
        return await self._move(targets, mode, relative, timeout)

    async def move_joints(
        self,
        positions: Mapping[str, float],
        speed: float,
        accel: float,
        *,
        relative: bool = False,
        timeout: float | None = None,
    ) -> SyncMove:
        """Synchronised Q-mode move in SI units at the joints (see :meth:`Robot.move_joints`)."""
        targets = joint_targets(self.spec, positions, speed, accel, relative)
        return await self._move(targets, PositionMode.Q, relative, timeout)

    async def _move(
        self, targets: dict[str, list[Target]], mode: int, relative: bool, timeout: float | None
    ) -> SyncMove:
        m = check_targets(targets, mode)
        async with self._move_lock:
            move_time: float | None = None
            if m is PositionMode.Q:

                def plan(b: str) -> Callable[[], Awaitable[float]]:
                    return lambda: self.buses[b].run(q_time(self.buses[b].core.session, targets[b], relative, timeout))

                times = await self._each({b: plan(b) for b in targets})
                move_time = round_move_time(max(times.values()))
            batches = {b: bus_batch(t, m, relative, move_time) for b, t in targets.items()}
            go = asyncio.Event()

            def send(bus: str) -> Callable[[], Awaitable[float]]:
                async def run() -> float:
                    await go.wait()
                    presets, start = batches[bus]
                    core = self.buses[bus].core
                    goals = None if relative else [t.angle for t in targets[bus]]  # relative: from unread positions

                    def fire() -> float:  # in a thread: the start waits until the presets are on the wire
                        self._clock.take()
                        core.send_batch(presets, start, goals, move_time)
                        when = self._clock.take()
                        assert when is not None
                        return when

                    return await asyncio.to_thread(fire)

                return run

            sending = asyncio.ensure_future(self._each({b: send(b) for b in batches}))
            await asyncio.sleep(0)  # every task waits at the gate
            go.set()
            starts = await sending
        return SyncMove(move_time, starts)

    async def positions_done(
        self,
        names: Iterable[str] | None = None,
        timeout: float = DEFAULT_MOVE_TIMEOUT,
        *,
        poll_interval: float = DEFAULT_POLL_INTERVAL,
    ) -> dict[str, MotorState]:
        """Wait until every listed joint (all when None) reports its move done (see :meth:`Robot.positions_done`)."""
        groups = by_bus(self.spec, names)

        def part(bus: str, group: list[str]) -> Callable[[], Awaitable[dict[str, MotorState]]]:
            async def run() -> dict[str, MotorState]:
                ids = [self.joints[n].id for n in group]
                got = await self.buses[bus].positions_done(ids, timeout, poll_interval=poll_interval)
                return {n: got[self.joints[n].id] for n in group}

            return run

        out: dict[str, MotorState] = {}
        for states in (await self._each({b: part(b, g) for b, g in groups.items()})).values():
            out.update(states)
        return out

    async def get_states(
        self, names: Iterable[str] | None = None, *, timeout: float | None = None
    ) -> dict[str, MotorState]:
        """Fresh states (wire units) of the listed joints (all when None), the buses read at once."""
        groups = by_bus(self.spec, names)

        def part(bus: str, group: list[str]) -> Callable[[], Awaitable[dict[str, MotorState]]]:
            async def run() -> dict[str, MotorState]:
                states = await self.buses[bus].run(read_states([self.joints[n].id for n in group], timeout))
                return {n: st for n, st in zip(group, states, strict=True) if st is not None}

            return run

        out: dict[str, MotorState] = {}
        for states in (await self._each({b: part(b, g) for b, g in groups.items()})).values():
            out.update(states)
        return {n: out[n] for g in groups.values() for n in g}

    async def joint_states(
        self, names: Iterable[str] | None = None, *, timeout: float | None = None
    ) -> dict[str, JointState]:
        """As :meth:`get_states`, at the joints (rad, rad/s, Nm)."""
        states = await self.get_states(names, timeout=timeout)
        return {n: self.joints[n].gearing.joint_state(st) for n, st in states.items()}

    async def estop(self, names: Iterable[str] | None = None) -> None:
        """Emergency stop of every motor (None) or the listed joints on every bus at once (see :meth:`Robot.estop`)."""
        groups = (
            {b: [0] for b in self.buses}
            if names is None
            else {b: [self.joints[n].id for n in g] for b, g in by_bus(self.spec, names).items()}
        )

        def part(bus: str) -> Callable[[], Awaitable[None]]:
            return lambda: asyncio.to_thread(self.buses[bus].core.estop, groups[bus])

        await self._each({b: part(b) for b in groups})

    @property
    def closed(self) -> bool:
        return self._closed

    async def close(self) -> None:
        """Close every bus (each applies its ``stop_on_close``). Idempotent."""
        if self._closed:
            return
        self._closed = True
        first: BaseException | None = None
        for bus in self.buses.values():
            try:
                await bus.close()
            except Exception as exc:  # close the others anyway
                first = first or exc
        if first is not None:
            raise first

    async def __aenter__(self) -> AsyncRobot:
        return self

    async def __aexit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        await self.close()

    def __repr__(self) -> str:
        return f"<AsyncRobot {self.spec.source}: buses {', '.join(self.buses)}; joints {', '.join(self.joints)}>"


def open_robot_async(
    robot: str | os.PathLike[str] | RobotSpec,
    *,
    timeout: float | None = None,
    retries: int | None = None,
    stop_on_close: bool | str | None = None,
    start: str | None = None,
    sim: Mapping[str, Any] | None = None,
) -> AsyncRobot:
    """Open every bus of the robot file ``robot``, for asyncio (options as :func:`~drempower.open_robot`).

    Use as ``async with open_robot_async("robot.toml") as robot:``, like :func:`~drempower.open_bus_async`.
    """
    spec = robot if isinstance(robot, RobotSpec) else load_robot(robot)
    overrides = {"timeout": timeout, "retries": retries, "stop_on_close": stop_on_close, "start": start, "sim": sim}
    buses: dict[str, AsyncBus] = {}
    try:
        for name in spec.buses:
            try:
                buses[name] = open_bus_async(**bus_options(spec, name, overrides))
            except DrEmpowerError as exc:
                raise opening_failed(spec, name, exc) from exc
        return AsyncRobot(spec, buses)
    except BaseException:
        for b in buses.values():
            b.core.close()
        raise
