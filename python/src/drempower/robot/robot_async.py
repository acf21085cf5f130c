"""Several buses as one robot, for asyncio: each bus's part of a call runs as its own task.

The one source of both robots: ``threaded.py`` (:class:`Robot`, on threads) is generated from this
file by ``tools/gen_sync.py``; the parts that differ by nature are in ``flavours.py``.
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Callable, Iterable, Mapping
from types import TracebackType
from typing import TYPE_CHECKING, Any

from ..client import AsyncBus, AsyncMotor, open_bus_async
from ..client.engine.commands import PositionMode
from ..client.engine.effects import read_states
from ..client.engine.gate import move_intent
from ..client.engine.health import Health, read_healths
from ..client.engine.session import DEFAULT_MOVE_TIMEOUT, DEFAULT_POLL_INTERVAL
from ..client.engine.state import MotorState
from ..client.engine.supervisor import HealthEvent, HealthPolicy, Watch
from ..client.engine.timeouts import checks_times
from ..errors import DrEmpowerError, ValidationError
from ..protocol.messages import Message
from .config import JointSpec, RobotSpec, load_robot
from .flavours import AsyncPart, AsyncRobotBase
from .health_run import HealthRun, bus_policy
from .joint import Gearing, JointState
from .limits import JointLimit, apply_limits, model_range_of, twin_model
from .names import by_bus, check_commands, opening_failed, per_bus
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
from .sim_twin import open_options

if TYPE_CHECKING:
    from collections.abc import Sequence

    from ..motion.identify import Identification
    from ..motion.plan import FollowReport
    from ..motion.trajectory import Rows, Trajectory
    from ..motion.tune import TuneReport
    from ..sim.twin import Twin
    from .shadow import Shadow

__all__ = ["AsyncJoint", "AsyncRobot", "open_robot_async"]


@checks_times
class AsyncJoint(AsyncMotor):
    """A motor handle (:class:`AsyncMotor`: every method, in wire units) that also knows its joint.

    ``joint_state`` is the latest state at the joint (no I/O), ``get_joint_state()`` a fresh one;
    ``gearing`` converts values either way; ``robot`` is the robot it belongs to (None: a joint alone).
    """

    __slots__ = ("gearing", "name", "robot")

    def __init__(self, bus: AsyncBus, spec: JointSpec, robot: AsyncRobot | None = None) -> None:
        super().__init__(bus, spec.id)
        self.name = spec.name
        self.gearing = Gearing(spec)
        self.robot = robot

    @property
    def joint_state(self) -> JointState | None:
        """The latest state received from this motor, at the joint (no I/O), or None."""
        st = self.state
        return None if st is None else self.gearing.joint_state(st)

    async def get_joint_state(self, *, timeout: float | None = None) -> JointState:
        """A fresh state (fast read) at the joint: rad, rad/s, Nm."""
        return self.gearing.joint_state(await self.get_state(timeout=timeout))

    async def set_position(self, position: float, bandwidth: float = 20.0, *, enable: bool = False) -> None:
        """Move the joint to ``position`` rad now (T mode: ``bandwidth`` 0..300 1/s filter)."""
        await self.set_angle(self.gearing.motor_angle(position), 0.0, bandwidth, 0, enable=enable)

    async def set_velocity(self, velocity: float, *, duration: float | None = None, enable: bool = False) -> None:
        """Turn the joint at ``velocity`` rad/s (for ``duration`` s, then speed 0, when given)."""
        await self.set_speed(self.gearing.motor_speed(velocity), duration=duration, enable=enable)

    async def set_joint_torque(self, torque: float, *, duration: float | None = None, enable: bool = False) -> None:
        """Apply ``torque`` Nm at the joint (for ``duration`` s, then 0, when given)."""
        await self.set_torque(self.gearing.motor_torque(torque), duration=duration, enable=enable)

    async def health(self, *, timeout: float | None = None) -> Health:
        """The motor's health (:meth:`AsyncMotor.health`), named for the joint."""
        return dataclasses.replace(await super().health(timeout=timeout), name=self.name)

    def _of_robot(self) -> AsyncRobot:
        if self.robot is None:
            raise DrEmpowerError(f"joint {self.name!r}: not part of a robot (open it with open_robot)")
        return self.robot

    async def identify(self, *, write: str | os.PathLike[str] | bool = False, **options: Any) -> Identification:
        """Excite the joint gently and fit its inertia (kg m^2), viscous (Nm s/rad) and Coulomb (Nm) friction
        and gravity term; ``write`` puts the result where the twin uses it (True: the robot file's
        ``[joints.NAME.identified]``; a path ending in ``.xml``: a copy of the model with the joint's armature,
        damping and friction loss). Options: ``amplitude``, ``seconds``, ``rate``, ``kp``, ``kd``,
        ``max_torque``, ``limits``; see :func:`drempower.motion.routines_async.identify` and docs/motion.md."""
        from ..motion.identified import write_identified
        from ..motion.routines_async import identify

        robot = self._of_robot()
        got = await identify(robot, self.name, **options)
        if write is not False:
            write_identified(robot.spec, got, write, twin=robot.twin)
        return got

    async def tune(self, bandwidth: float, **options: Any) -> TuneReport:
        """Gains for a closed-loop ``bandwidth`` Hz from the joint's identified dynamics, a step before and
        after; options ``identified``, ``step`` (rad), ``write`` (False: propose only, nothing written); see
        :func:`drempower.motion.routines_async.tune`."""
        from ..motion.routines_async import tune

        return await tune(self._of_robot(), self.name, bandwidth, **options)

    def __repr__(self) -> str:
        return f"<AsyncJoint {self.name} motor {self.id}>"


@checks_times
class AsyncRobot(AsyncRobotBase):
    """Several buses driven as one robot; joints by name.

    Calls that concern several buses (:meth:`cycle`, :meth:`set_angles`,
    :meth:`move_joints`, :meth:`positions_done`, :meth:`get_states`) run each
    bus's part at the same time (a task per bus with asyncio, a thread per bus
    otherwise). :meth:`estop` sends to every bus at
    once, so a bus whose device stopped taking data does not delay the
    others' stop. Errors of one bus's part carry a note naming the bus.
    """

    def __init__(self, spec: RobotSpec, buses: Mapping[str, AsyncBus], *, supervise: bool = True) -> None:
        self.spec = spec
        self.buses: dict[str, AsyncBus] = dict(buses)
        """The open buses by name."""
        self.joints: dict[str, AsyncJoint] = {
            name: AsyncJoint(self.buses[j.bus], j, self) for name, j in spec.joints.items()
        }
        """Every joint by name, in file order."""
        ranges = model_range_of(spec, next((m for m in map(twin_model, self.buses.values()) if m is not None), None))
        self.limits: dict[str, JointLimit] = {}
        """Each joint's soft limits at the joint (the file's, and the model's range: see :mod:`.limits`)."""
        for b in spec.buses:  # closing holds the joints that hold (an arm is not dropped), idles the others
            self.buses[b].hold_on_close(j.id for j in spec.joints_on(b) if j.on_timeout == "hold")
            self.limits.update(apply_limits(self.buses[b], spec, [j.name for j in spec.joints_on(b)], ranges))
        self._clock = StartClock()
        for bus in self.buses.values():
            bus.on_sent = self._clock
        self._closed = False
        self._watches: dict[str, list[Watch]] | None = None
        self._setup(len(self.buses))
        self.health_run: HealthRun | None = None
        """The health supervisor running on its own (the file's ``[health]``; see :mod:`.health_run`), or None."""
        policy = self.health_policy() if supervise else None
        if policy is not None:
            self.health_run = HealthRun(self.buses, self._watch_all(policy), policy, spec.source)
            self.health_run.start_virtual()
            self._run_health_wall()

    # ------------------------------------------------------------------ lookup

    def joint(self, name: str) -> AsyncJoint:
        """The handle of joint ``name``: a motor handle with SI extras."""
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

    # ------------------------------------------------------------------ control

    async def cycle(
        self, commands: Mapping[str, Message], *, timeout: float | None = None, reply_state: bool | None = None
    ) -> dict[str, MotorState]:
        """Send one command per joint (``{name: message}``, e.g. from ``robot.joint(n).make_angle(...)``)
        and return each joint's state; the buses run their cycles at the same time. Nothing is sent on any
        bus when one bus's safety gate refuses its part."""
        groups = per_bus(self.spec, commands)
        check_commands(self.spec, commands)
        if len(groups) > 1:  # the safety gate of every bus before any bus sends (one bus: its cycle's own)
            for b, msgs in groups.items():
                await self.buses[b].pass_gate(list(msgs.values()))

        def part(bus: str, msgs: dict[str, Message]) -> AsyncPart[dict[str, MotorState]]:
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
        enable: bool = False,
    ) -> SyncMove:
        """Synchronised move of joints across buses in wire units: ``{name: motor deg}``, as
        :meth:`~drempower.client.api.bus_sync.Bus.set_angles` (``relative``: as ``step_angles``).

        In Q mode every motor of every bus gets one move time, the longest any
        needs. Nothing is sent on any bus if a value is invalid. Returns the
        move time and the measured skew between the buses' start frames.
        """
        targets = angle_targets(self.spec, angles, speed, param)
        return await self._move(targets, mode, relative, timeout, enable)

    async def move_joints(
        self,
        positions: Mapping[str, float],
        speed: float,
        accel: float,
        *,
        relative: bool = False,
        timeout: float | None = None,
        enable: bool = False,
    ) -> SyncMove:
        """Synchronised Q-mode move in SI units at the joints: ``{name: rad}``; ``speed`` rad/s and ``accel``
        rad/s² at each joint (converted through its gear). Every joint arrives at the same time."""
        targets = joint_targets(self.spec, positions, speed, accel, relative)
        return await self._move(targets, PositionMode.Q, relative, timeout, enable)

    async def _move(
        self, targets: dict[str, list[Target]], mode: int, relative: bool, timeout: float | None, enable: bool = False
    ) -> SyncMove:
        m = check_targets(targets, mode)
        for b, group in targets.items():  # the safety gate of every bus before any bus sends
            intents = [move_intent(t.id, t.angle, t.speed, t.param, m, relative) for t in group]
            await self.buses[b].pass_gate(intents, enable)
        async with self._move_lock:
            move_time: float | None = None
            if m is PositionMode.Q:

                def plan(b: str) -> AsyncPart[float]:
                    async def run() -> float:
                        bus = self.buses[b]
                        modes = await bus.traj_modes([t.id for t in targets[b]], timeout=timeout)
                        return await bus.run(q_time(modes, targets[b], relative, timeout))

                    return run

                times = await self._each({b: plan(b) for b in targets})
                move_time = round_move_time(max(times.values()))
            batches = {b: bus_batch(t, m, relative, move_time) for b, t in targets.items()}

            def fire(bus: str) -> float:  # blocking: the start waits until the presets are on the wire
                presets, start = batches[bus]
                goals = None if relative else [t.angle for t in targets[bus]]  # relative: from unread positions
                self._clock.take()
                self.buses[bus].send_batch(presets, start, goals, move_time)
                when = self._clock.take()
                assert when is not None
                return when

            starts = await self._together(list(batches), fire)
        return SyncMove(move_time, starts)

    async def positions_done(
        self,
        names: Iterable[str] | None = None,
        timeout: float = DEFAULT_MOVE_TIMEOUT,
        *,
        poll_interval: float = DEFAULT_POLL_INTERVAL,
    ) -> dict[str, MotorState]:
        """Wait until every listed joint (all when None) reports its move done, the buses polled at the same
        time; raises TimeoutError / MotorFaultError as :meth:`~drempower.client.api.bus_sync.Bus.positions_done`."""
        groups = by_bus(self.spec, names)

        def part(bus: str, group: list[str]) -> AsyncPart[dict[str, MotorState]]:
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
        """Fresh states (fast reads, wire units) of the listed joints (all when None), the buses read at once."""
        groups = by_bus(self.spec, names)

        def part(bus: str, group: list[str]) -> AsyncPart[dict[str, MotorState]]:
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

    async def health(self, names: Iterable[str] | None = None, *, timeout: float | None = None) -> dict[str, Health]:
        """The health of the listed joints (all when None), by name; the buses read at once."""
        groups = by_bus(self.spec, names)

        def part(bus: str, group: list[str]) -> AsyncPart[dict[str, Health]]:
            async def run() -> dict[str, Health]:
                got = await self.buses[bus].run(read_healths([self.joints[n].id for n in group], timeout))
                return {n: dataclasses.replace(h, name=n) for n, h in zip(group, got, strict=True)}

            return run

        out: dict[str, Health] = {}
        for healths in (await self._each({b: part(b, g) for b, g in groups.items()})).values():
            out.update(healths)
        return {n: out[n] for g in groups.values() for n in g}

    def health_policy(self) -> HealthPolicy | None:
        """The supervisor's policy of the robot file's ``[health]`` (joints' ``on_overheat``, ``on_stall`` per motor),
        or None."""
        if self.spec.health is None:
            return None
        return bus_policy(self.spec)

    async def supervise(self, policy: HealthPolicy | None = None, *, timeout: float | None = None) -> list[HealthEvent]:
        """One step of the health supervisor over every joint (see :mod:`drempower.client.engine.supervisor`); call it
        every ``policy.period`` s. The first call fixes the policy: ``policy``, else the robot file's
        ``[health]`` (a :class:`ValidationError` when it has none). Returns the events that began, joints named,
        their actions (hold, idle) already sent; the buses are read at once."""
        if self._watches is None:
            pol = policy or self.health_policy()
            if pol is None:
                raise ValidationError(f"{self.spec.source}: no [health] section: give supervise() a HealthPolicy")
            self._watch_all(pol)
        watches = self._watches
        assert watches is not None

        def part(bus: str) -> AsyncPart[list[HealthEvent]]:
            async def run() -> list[HealthEvent]:
                return await self.buses[bus].supervise(watches[bus], timeout=timeout)

            return run

        out: list[HealthEvent] = []
        for events in (await self._each({b: part(b) for b in watches})).values():
            out.extend(events)
        return out

    def _watch_all(self, policy: HealthPolicy) -> dict[str, list[Watch]]:
        """The supervisor's watches of every joint, per bus (made once: the first policy stays; with the file's
        policy, each bus's joints keep their own actions, motor ids repeating across buses or not)."""
        if self._watches is None:
            own = policy == self.health_policy()
            self._watches = {
                b: self.buses[b].watch_health(
                    [j.id for j in self.spec.joints_on(b)],
                    (bus_policy(self.spec, b) or policy) if own else policy,
                    {j.id: j.name for j in self.spec.joints_on(b)},
                )
                for b in self.buses
            }
        return self._watches

    async def estop(self, names: Iterable[str] | None = None) -> None:
        """Emergency stop: every motor of every bus (one broadcast frame per bus) when ``names`` is None,
        else the listed joints; sent to all buses at once, no reply awaited. A bus that fails does not
        keep the others from stopping; its error is raised afterwards."""
        groups = (
            {b: [0] for b in self.buses}
            if names is None
            else {b: [self.joints[n].id for n in g] for b, g in by_bus(self.spec, names).items()}
        )

        def stop(bus: str) -> Callable[[], None]:
            def now() -> None:
                self.buses[bus].estop_now(groups[bus])

            return now

        await self._stop_each({b: stop(b) for b in groups})

    async def follow(
        self, times: Sequence[float] | Trajectory, positions: Rows | None = None, **options: Any
    ) -> FollowReport:
        """Follow a trajectory (rad at the joints) through the control cycle; returns a :class:`FollowReport`.

        ``times`` s from 0 and ``positions`` (one row per time in the order of ``joints=`` or the robot
        file, or joint -> positions), or a :class:`~drempower.motion.Trajectory`. Options: ``velocities``,
        ``joints``, ``rate`` (Hz, default 200), ``mode`` (``"position"``, ``"impedance"``, ``"p"``),
        ``max_error`` (rad, or joint -> rad), ``kp``/``kd`` (impedance), ``limits``, ``trace``; see
        :func:`drempower.motion.follow_async.follow_robot` and docs/motion.md.
        """
        from ..motion.follow_async import follow_robot

        return await follow_robot(self, times, positions, **options)

    def shadow(self, **options: Any) -> Shadow:
        """Run the robot's twin beside it, fed the same commands, flagging a joint whose position (rad) or
        torque (Nm) residual stays beyond ``position``/``torque`` for ``hold_time`` s; ``on_divergence``
        ``"warn"``, ``"hold"`` or ``"idle"`` (default: the robot file's ``on_divergence``, per joint),
        ``on_event(divergence)``, ``clock``, ``model``: see
        :class:`drempower.robot.shadow.Shadow` (needs the physics extra). Close it (or use it in a
        ``with``) to stop."""
        from .shadow import Shadow

        return Shadow(self, **options)

    async def teach(self, seconds: float | None = None, **options: Any) -> Trajectory:
        """Teach mode for ``seconds`` s (None: until ``stop()`` or Ctrl-C): gravity-compensated, low-stiffness
        joints a person moves by hand; returns the path taught. Options: ``joints``, ``rate``, ``kp``,
        ``kd``, ``compensate``, ``on_state``, ``stop``; see :func:`drempower.motion.routines_async.teach`."""
        from ..motion.routines_async import teach

        return await teach(self, seconds, **options)

    @property
    def twin(self) -> Twin | None:
        """The physics twin the robot's simulated buses drive (None: no model, or no sim bus)."""
        from ..sim.twin import twin_of

        for bus in self.buses.values():
            sim = getattr(bus.transport, "bus", None)
            twin = None if sim is None else twin_of(sim)
            if twin is not None:
                return twin
        return None

    # ------------------------------------------------------------------ lifetime

    @property
    def closed(self) -> bool:
        """True once the robot is closed (by :meth:`close`, or its context's end)."""
        return self._closed

    async def close(self) -> None:
        """Close every bus (each applies its ``stop_on_close``). Idempotent."""
        if self._closed:
            return
        await self._stop_health()  # before the buses close: no step runs on a closing bus
        self._closed = True
        self._shutdown()
        first: BaseException | None = None
        for bus in self.buses.values():
            try:
                await bus.close()
            except Exception as exc:  # close the others anyway
                first = first or exc
        if first is not None:
            raise first

    async def __aenter__(self) -> AsyncRobot:
        self._run_health_wall()
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
    supervise: bool = True,
) -> AsyncRobot:
    """Open every bus of the robot file ``robot`` (or a :class:`RobotSpec`).

    ``timeout``, ``retries``, ``stop_on_close`` and ``start`` (see
    :func:`~drempower.open_bus`) apply to every bus, over what the file says;
    ``sim`` options (``time_scale``, ``bitrate``...) to its sim buses. When the file has a ``[health]``
    section the health supervisor runs on its own (:attr:`AsyncRobot.health_run`, see
    :mod:`drempower.robot.health_run`; an asyncio robot's wall-clock steps start with ``async with`` or
    when opened inside a running event loop); ``supervise=False`` leaves it out. If a bus
    cannot be opened, the ones already open are closed and the error names the bus.
    Use it as a context manager.
    """
    spec = robot if isinstance(robot, RobotSpec) else load_robot(robot)
    overrides = {"timeout": timeout, "retries": retries, "stop_on_close": stop_on_close, "start": start, "sim": sim}
    buses: dict[str, AsyncBus] = {}
    try:
        options = open_options(spec, overrides)
        for name in spec.buses:
            try:
                buses[name] = open_bus_async(**options[name])
            except DrEmpowerError as exc:
                raise opening_failed(spec, name, exc) from exc
        return AsyncRobot(spec, buses, supervise=supervise)
    except BaseException:
        for b in buses.values():
            b.close_now()
        raise
