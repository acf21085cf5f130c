"""The threaded robot: several buses as one, each bus's part of a call run on its own thread."""

from __future__ import annotations

import os
import threading
from collections.abc import Callable, Iterable, Mapping
from concurrent.futures import ThreadPoolExecutor
from types import TracebackType
from typing import Any, TypeVar

from ..client.bus import DEFAULT_MOVE_TIMEOUT, DEFAULT_POLL_INTERVAL, Bus, open_bus
from ..client.commands import PositionMode
from ..client.effects import read_states
from ..client.state import MotorState
from ..client.timeouts import checks_times
from ..errors import BusClosedError, DrEmpowerError, ValidationError
from ..protocol.messages import Message
from .config import RobotSpec, load_robot
from .joint import Joint, JointState
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

__all__ = ["Robot", "open_robot", "bus_options"]

T = TypeVar("T")
_START_GATE = 1.0
"""Longest wait (s) of a bus's sending thread for the others before it sends its start anyway."""


def bus_options(spec: RobotSpec, bus: str, overrides: Mapping[str, Any]) -> dict[str, Any]:
    """``open_bus`` arguments of ``bus``: the file's, then ``overrides`` (None values skipped);
    ``sim`` options go to sim buses only."""
    kw = spec.open_options(bus)
    for key, value in overrides.items():
        if key == "sim":
            if kw["interface"] == "sim" and value:
                kw.update(value)
        elif value is not None:
            kw[key] = value
    return kw


@checks_times
class Robot:
    """Several buses driven as one robot; joints by name.

    Calls that concern several buses (:meth:`cycle`, :meth:`set_angles`,
    :meth:`move_joints`, :meth:`positions_done`, :meth:`get_states`) run each
    bus's part on its own thread at the same time. :meth:`estop` sends to every
    bus at once, from the calling thread for the first and a fresh thread for
    each other, so a bus whose device stopped taking data does not delay the
    others' stop. Errors of one bus's part carry a note naming the bus.
    """

    def __init__(self, spec: RobotSpec, buses: Mapping[str, Bus]) -> None:
        self.spec = spec
        self.buses: dict[str, Bus] = dict(buses)
        """The open buses by name."""
        self.joints: dict[str, Joint] = {name: Joint(self.buses[j.bus], j) for name, j in spec.joints.items()}
        """Every joint by name, in file order."""
        self._clock = StartClock()
        for bus in self.buses.values():
            bus.core.on_sent = self._clock
        self._pool = ThreadPoolExecutor(max(2, 2 * len(self.buses)), thread_name_prefix="drempower robot")
        self._move_lock = threading.Lock()
        self._closed = False

    # ------------------------------------------------------------------ lookup

    def joint(self, name: str) -> Joint:
        """The handle of joint ``name``: a :class:`~drempower.client.motor.Motor` with SI extras."""
        j = self.joints.get(name)
        if j is None:
            raise ValidationError(f"joint {name!r}: no such joint (joints: {', '.join(self.joints)})")
        return j

    __getitem__ = joint

    def bus(self, name: str) -> Bus:
        """The bus ``name`` of the robot file."""
        b = self.buses.get(name)
        if b is None:
            raise ValidationError(f"bus {name!r}: no such bus (buses: {', '.join(self.buses)})")
        return b

    # ------------------------------------------------------------------ running on every bus

    def _each(self, work: Mapping[str, Callable[[], T]]) -> dict[str, T]:
        """Run each bus's part concurrently (inline for one bus); raise the first error, noting its bus."""
        if self._closed:
            raise BusClosedError(f"the robot ({self.spec.source}) is closed")
        if len(work) == 1:
            ((bus, fn),) = work.items()
            try:
                return {bus: fn()}
            except Exception as exc:
                note_bus(exc, bus)
                raise
        futures = {bus: self._pool.submit(fn) for bus, fn in work.items()}
        results: dict[str, T] = {}
        first: Exception | None = None
        for bus, fut in futures.items():
            try:
                results[bus] = fut.result()
            except Exception as exc:  # a bus's error; Ctrl-C while waiting goes on up
                if first is None:
                    note_bus(exc, bus)
                    first = exc
        if first is not None:
            raise first
        return results

    # ------------------------------------------------------------------ control

    def cycle(
        self, commands: Mapping[str, Message], *, timeout: float | None = None, reply_state: bool | None = None
    ) -> dict[str, MotorState]:
        """Send one command per joint (``{name: message}``, e.g. from ``robot.joint(n).make_angle(...)``)
        and return each joint's state; the buses run their cycles at the same time."""
        groups = per_bus(self.spec, commands)
        check_commands(self.spec, commands)

        def part(bus: str, msgs: dict[str, Message]) -> Callable[[], dict[str, MotorState]]:
            def run() -> dict[str, MotorState]:
                got = self.buses[bus].cycle(msgs.values(), timeout=timeout, reply_state=reply_state)
                return {n: got[m.node] for n, m in msgs.items()}

            return run

        out: dict[str, MotorState] = {}
        for states in self._each({b: part(b, m) for b, m in groups.items()}).values():
            out.update(states)
        return {n: out[n] for n in commands}

    def set_angles(
        self,
        angles: Mapping[str, float],
        speed: float = 10.0,
        param: float = 10.0,
        mode: int = PositionMode.Q,
        *,
        relative: bool = False,
        timeout: float | None = None,
    ) -> SyncMove:
        """Synchronised move of joints across buses in wire units: ``{name: motor deg}``, as
        :meth:`~drempower.client.bus.Bus.set_angles` (``relative``: as ``step_angles``).

        In Q mode every motor of every bus gets one move time, the longest any
        needs. Nothing is sent on any bus if a value is invalid. Returns the
        move time and the measured skew between the buses' start frames.
        """
        targets = angle_targets(self.spec, angles, speed, param)
        return self._move(targets, mode, relative, timeout)

    def move_joints(
        self,
        positions: Mapping[str, float],
        speed: float,
        accel: float,
        *,
        relative: bool = False,
        timeout: float | None = None,
    ) -> SyncMove:
        """Synchronised Q-mode move in SI units at the joints: ``{name: rad}``; ``speed`` rad/s and ``accel``
        rad/s² at each joint (converted through its gear). Every joint arrives at the same time."""
        targets = joint_targets(self.spec, positions, speed, accel, relative)
        return self._move(targets, PositionMode.Q, relative, timeout)

    def _move(self, targets: dict[str, list[Target]], mode: int, relative: bool, timeout: float | None) -> SyncMove:
        m = check_targets(targets, mode)
        with self._move_lock:
            move_time: float | None = None
            if m is PositionMode.Q:

                def plan(b: str) -> Callable[[], float]:
                    return lambda: self.buses[b].run(q_time(self.buses[b].core.session, targets[b], relative, timeout))

                times = self._each({b: plan(b) for b in targets})
                move_time = round_move_time(max(times.values()))
            batches = {b: bus_batch(t, m, relative, move_time) for b, t in targets.items()}
            gate = threading.Barrier(len(batches), timeout=_START_GATE)

            def send(bus: str) -> Callable[[], float]:
                def run() -> float:
                    core = self.buses[bus].core
                    presets, start = batches[bus]
                    if len(batches) > 1:
                        try:
                            gate.wait()
                        except threading.BrokenBarrierError:
                            pass  # another bus's thread was late: send anyway, the skew shows it
                    self._clock.take()
                    goals = None if relative else [t.angle for t in targets[bus]]  # relative: from unread positions
                    core.send_batch(presets, start, goals, move_time)
                    when = self._clock.take()
                    assert when is not None
                    return when

                return run

            starts = self._each({b: send(b) for b in batches})
        return SyncMove(move_time, starts)

    def positions_done(
        self,
        names: Iterable[str] | None = None,
        timeout: float = DEFAULT_MOVE_TIMEOUT,
        *,
        poll_interval: float = DEFAULT_POLL_INTERVAL,
    ) -> dict[str, MotorState]:
        """Wait until every listed joint (all when None) reports its move done, the buses polled at the same
        time; raises TimeoutError / MotorFaultError as :meth:`~drempower.client.bus.Bus.positions_done`."""
        groups = by_bus(self.spec, names)

        def part(bus: str, group: list[str]) -> Callable[[], dict[str, MotorState]]:
            def run() -> dict[str, MotorState]:
                ids = [self.joints[n].id for n in group]
                got = self.buses[bus].positions_done(ids, timeout, poll_interval=poll_interval)
                return {n: got[self.joints[n].id] for n in group}

            return run

        out: dict[str, MotorState] = {}
        for states in self._each({b: part(b, g) for b, g in groups.items()}).values():
            out.update(states)
        return out

    def get_states(self, names: Iterable[str] | None = None, *, timeout: float | None = None) -> dict[str, MotorState]:
        """Fresh states (fast reads, wire units) of the listed joints (all when None), the buses read at once."""
        groups = by_bus(self.spec, names)

        def part(bus: str, group: list[str]) -> Callable[[], dict[str, MotorState]]:
            def run() -> dict[str, MotorState]:
                states = self.buses[bus].run(read_states([self.joints[n].id for n in group], timeout))
                return {n: st for n, st in zip(group, states, strict=True) if st is not None}

            return run

        out: dict[str, MotorState] = {}
        for states in self._each({b: part(b, g) for b, g in groups.items()}).values():
            out.update(states)
        return {n: out[n] for g in groups.values() for n in g}

    def joint_states(
        self, names: Iterable[str] | None = None, *, timeout: float | None = None
    ) -> dict[str, JointState]:
        """As :meth:`get_states`, at the joints (rad, rad/s, Nm)."""
        return {n: self.joints[n].gearing.joint_state(st) for n, st in self.get_states(names, timeout=timeout).items()}

    def estop(self, names: Iterable[str] | None = None) -> None:
        """Emergency stop: every motor of every bus (one broadcast frame per bus) when ``names`` is None,
        else the listed joints; sent to all buses at once, no reply awaited. A bus that fails does not
        keep the others from stopping; its error is raised afterwards."""
        groups = (
            {b: [0] for b in self.buses}
            if names is None
            else {b: [self.joints[n].id for n in g] for b, g in by_bus(self.spec, names).items()}
        )
        errors: dict[str, BaseException] = {}

        def stop(bus: str) -> None:
            try:
                self.buses[bus].core.estop(groups[bus])
            except BaseException as exc:
                errors[bus] = exc

        order = list(groups)
        helpers = [threading.Thread(target=stop, args=(b,), name=f"drempower estop {b}") for b in order[1:]]
        for t in helpers:
            t.start()
        stop(order[0])
        for t in helpers:
            t.join()
        for bus in order:
            if bus in errors:
                note_bus(errors[bus], bus)
                raise errors[bus]

    # ------------------------------------------------------------------ lifetime

    @property
    def closed(self) -> bool:
        return self._closed

    def close(self) -> None:
        """Close every bus (each applies its ``stop_on_close``). Idempotent."""
        if self._closed:
            return
        self._closed = True
        self._pool.shutdown(wait=False, cancel_futures=True)
        first: BaseException | None = None
        for bus in self.buses.values():
            try:
                bus.close()
            except Exception as exc:  # close the others anyway
                first = first or exc
        if first is not None:
            raise first

    def __enter__(self) -> Robot:
        return self

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.close()

    def __repr__(self) -> str:
        return f"<Robot {self.spec.source}: buses {', '.join(self.buses)}; joints {', '.join(self.joints)}>"


def open_robot(
    robot: str | os.PathLike[str] | RobotSpec,
    *,
    timeout: float | None = None,
    retries: int | None = None,
    stop_on_close: bool | str | None = None,
    start: str | None = None,
    sim: Mapping[str, Any] | None = None,
) -> Robot:
    """Open every bus of the robot file ``robot`` (or a :class:`RobotSpec`).

    ``timeout``, ``retries``, ``stop_on_close`` and ``start`` (see
    :func:`~drempower.open_bus`) apply to every bus, over what the file says;
    ``sim`` options (``time_scale``, ``bitrate``...) to its sim buses. If a bus
    cannot be opened, the ones already open are closed and the error names the bus.
    """
    spec = robot if isinstance(robot, RobotSpec) else load_robot(robot)
    overrides = {"timeout": timeout, "retries": retries, "stop_on_close": stop_on_close, "start": start, "sim": sim}
    buses: dict[str, Bus] = {}
    try:
        for name in spec.buses:
            try:
                buses[name] = open_bus(**bus_options(spec, name, overrides))
            except DrEmpowerError as exc:
                raise opening_failed(spec, name, exc) from exc
        return Robot(spec, buses)
    except BaseException:
        for b in buses.values():
            b.close()
        raise
