"""Following a trajectory through the control cycle, for asyncio: :func:`follow_robot` (joints by name,
rad) and :func:`follow_bus` (motor ids, deg).

The one source of both flavours: ``follow_sync.py`` is generated from this file by
``tools/gen_sync.py``. :class:`~drempower.robot.robot_async.AsyncRobot` and
:class:`~drempower.client.api.bus_async.AsyncBus`
offer them as ``follow``.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from typing import TYPE_CHECKING, Any

from ..client.api.flavours import AsyncPart
from ..client.engine.effects import read_states, sleep
from ..client.engine.gate import path_intents
from ..client.engine.state import MotorState
from ..errors import ValidationError
from .plan import (
    AsyncEach,
    FollowError,
    FollowPlan,
    FollowReport,
    Lane,
    Units,
    as_trajectory,
    make_plan,
    model_ranges,
    robot_lanes,
    robot_limits,
)
from .robot_view import RobotView
from .trajectory import Rows, Trajectory

if TYPE_CHECKING:
    from ..client import AsyncBus

__all__ = ["follow_bus", "follow_robot"]

_START_TOLERANCE = 0.1
"""Default largest distance (rad; its deg for motors) between where a joint is and where the trajectory starts."""


async def follow_robot(
    robot: RobotView,
    times: Sequence[float] | Trajectory,
    positions: Rows | None = None,
    *,
    velocities: Rows | None = None,
    joints: Iterable[str] | None = None,
    rate: float = 200.0,
    mode: str = "position",
    max_error: float | Mapping[str, float] | None = None,
    kp: float = 20.0,
    kd: float = 1.0,
    bandwidth: float | None = None,
    limits: Mapping[str, Mapping[str, Any]] | None = None,
    torques: Callable[[float], Sequence[float]] | None = None,
    feedforward: str | None = None,
    start_tolerance: float = _START_TOLERANCE,
    timeout: float | None = None,
    trace: bool = False,
) -> FollowReport:
    """Follow a trajectory with the robot's joints (rad); see :meth:`drempower.robot.robot_async.AsyncRobot.follow`."""
    tr = as_trajectory(times, positions, velocities, joints, list(robot.joints))
    for name in tr.joints:
        robot.joint(name)  # an unknown joint is named before anything else
    lanes = robot_lanes(
        robot.spec,
        tr.joints,
        lambda b: robot.buses[b].transport.wire_bitrate,
        lambda b: robot.buses[b].reply_state,
    )
    twin = robot.twin
    known = robot_limits(robot.spec, tr.joints, None if twin is None else model_ranges(twin.model))
    known.update({name: dict(lim) for name, lim in (limits or {}).items()})
    if feedforward is not None:
        torques = model_torques(robot, tr, feedforward, torques)
    plan = make_plan(
        tr,
        lanes,
        rate=rate,
        mode=mode,
        max_error=max_error,
        limits=known,
        kp=kp,
        kd=kd,
        bandwidth=bandwidth,
        torques=torques,
        timeout=timeout,
    )
    return await stream(plan, robot.buses, robot._each, start_tolerance, trace)


async def follow_bus(
    bus: AsyncBus,
    ids: Sequence[int],
    times: Sequence[float] | Trajectory,
    positions: Rows | None = None,
    *,
    velocities: Rows | None = None,
    rate: float = 200.0,
    mode: str = "position",
    max_error: float | Mapping[str, float] | None = None,
    kp: float = 20.0,
    kd: float = 1.0,
    bandwidth: float | None = None,
    limits: Mapping[str, Mapping[str, Any]] | None = None,
    torques: Callable[[float], Sequence[float]] | None = None,
    start_tolerance: float = math.degrees(_START_TOLERANCE),
    timeout: float | None = None,
    trace: bool = False,
) -> FollowReport:
    """Follow a trajectory in motor units (deg) with motors ``ids``; see :meth:`AsyncBus.follow
    <drempower.client.api.bus_async.AsyncBus.follow>`."""
    if isinstance(ids, str | bytes) or not isinstance(ids, Sequence) or not ids:
        raise ValidationError(f"ids={ids!r}: expected a list of motor ids, one per trajectory column")
    names = [str(i) for i in ids]
    tr = as_trajectory(times, positions, velocities, None, names)
    if len(tr.joints) != len(ids):
        raise ValidationError(f"ids: {len(ids)} motors for {len(tr.joints)} trajectory columns")
    lane = Lane(
        "bus",
        list(tr.joints),
        list(ids),
        [Units(deg=True) for _ in ids],
        list(range(len(ids))),
        ["hold"] * len(ids),
        bus.transport.wire_bitrate,
        bus.reply_state,
    )
    by_id = {str(i): lim for i, lim in (limits or {}).items()}
    plan = make_plan(
        tr,
        [lane],
        rate=rate,
        mode=mode,
        max_error=max_error,
        limits={tr.joints[k]: by_id[n] for k, n in enumerate(names) if n in by_id},
        kp=kp,
        kd=kd,
        bandwidth=bandwidth,
        torques=torques,
        timeout=timeout,
    )

    async def inline(work: Mapping[str, AsyncPart[dict[int, MotorState]]]) -> dict[str, dict[int, MotorState]]:
        return {key: await fn() for key, fn in work.items()}

    return await stream(plan, {"bus": bus}, inline, start_tolerance, trace)


def model_torques(
    robot: RobotView, tr: Trajectory, kind: str, given: Callable[[float], Sequence[float]] | None
) -> Callable[[float], Sequence[float]]:
    """Feed-forward torques (Nm at the joints) along ``tr`` from the robot's model: ``"gravity"`` (holding) or
    ``"inverse"`` (rigid-body inverse dynamics of the path's accelerations too), added to ``given``."""
    from .teach import GravityModel

    if kind not in ("gravity", "inverse"):
        raise ValidationError(f"feedforward={kind!r}: 'gravity', 'inverse' or None")
    model = GravityModel(robot.spec, tr.joints)

    def at(t: float) -> Sequence[float]:
        s = tr.sample(t)
        tau = (
            model.torques(s.positions)
            if kind == "gravity"
            else model.inverse(s.positions, s.velocities, s.accelerations)
        )
        return tau if given is None else [a + b for a, b in zip(tau, given(t), strict=True)]

    return at


async def stream(
    plan: FollowPlan,
    buses: Mapping[str, AsyncBus],
    each: AsyncEach,
    start_tolerance: float,
    trace: bool,
) -> FollowReport:
    """Stream ``plan`` at its rate; stop the joints (hold, or idle per joint) on a tracking error above
    the plan's ``max_error`` or on any interruption."""
    tr = plan.trajectory
    lanes = plan.lanes
    clock_bus = buses[lanes[0].bus]

    def reader(lane: Lane) -> AsyncPart[dict[int, MotorState]]:
        async def read() -> dict[int, MotorState]:
            got = await buses[lane.bus].run(read_states(lane.ids, plan.timeout))
            return {i: st for i, st in zip(lane.ids, got, strict=True) if st is not None}

        return read

    latest = await each({lane.bus: reader(lane) for lane in lanes})
    start = tr.sample(0.0).positions
    for lane in lanes:
        for i, u, j, name in zip(lane.ids, lane.units, lane.index, lane.names, strict=True):
            at = u.position(latest[lane.bus][i])
            if abs(at - start[j]) > start_tolerance:
                raise ValidationError(
                    f"follow: joint {name!r} is at {at:.4g} {u.unit}, the trajectory starts at {start[j]:.4g} "
                    f"{u.unit}: more than start_tolerance={start_tolerance:g} {u.unit} away; move there first; "
                    "nothing was sent"
                )

    for lane in lanes:  # the gate once, before the clock starts: no cycle pays its read
        bus = buses[lane.bus]
        await bus.pass_gate(path_intents(plan.commands[0][lane.bus]))  # the first point from where it is
        bus.check_path(m for cmds in plan.commands for m in cmds[lane.bus])  # each later from the one before

    def part(lane: Lane, k: int) -> AsyncPart[dict[int, MotorState]]:
        bus = buses[lane.bus]
        if plan.mode == "impedance":
            return lambda: bus.run(plan.cycle_op(k, lane))
        return lambda: bus.cycle(plan.commands[k][lane.bus], timeout=plan.timeout)

    report = FollowReport({n: 0.0 for n in tr.joints}, trace=[] if trace else None)
    period = 1.0 / plan.rate
    count = len(plan.times)
    done = False
    t0 = first = last = clock_bus.now()
    try:
        k = 0
        while k < count:
            due = t0 + k * period
            now = clock_bus.now()
            if now < due:
                await clock_bus.run(sleep(due - now))
                now = clock_bus.now()
            if k == 0:
                t0 = first = now
                due = now
            last = now
            got = await each({lane.bus: part(lane, k) for lane in lanes})
            report.cycles += 1
            over = _track(plan, got, t0, report)
            for lane in lanes:
                latest[lane.bus].update(got[lane.bus])
            if over is not None:
                name, err, top = over
                report.stopped = (
                    f"joint {name!r}: tracking error {err:.4g} {plan.unit} above max_error={top:g} {plan.unit}"
                )
                break
            end = clock_bus.now()
            step = 1
            if end > due + period:
                report.late += 1
                step = max(1, math.floor((end - t0) * plan.rate) - k)
            k = min(k + step, count - 1) if k < count - 1 else count
        done = report.stopped is None
    finally:
        report.duration = clock_bus.now() - first
        report.rate = (report.cycles - 1) / (last - first) if report.cycles > 1 and last > first else 0.0
        if not done:
            for lane in lanes:
                await buses[lane.bus].send_many(plan.hold_messages(lane, latest[lane.bus]))
    if report.stopped is not None:
        raise FollowError(f"follow stopped at t={report.duration:.3f} s: {report.stopped}", report)
    return report


def _track(
    plan: FollowPlan, got: Mapping[str, Mapping[int, MotorState]], t0: float, report: FollowReport
) -> tuple[str, float, float] | None:
    """Record each joint's tracking error (measured against the trajectory at the state's time); the
    first joint beyond its ``max_error``, if any."""
    tr = plan.trajectory
    over = None
    row_ref: list[float] = [math.nan] * len(tr.joints)
    row_at: list[float] = [math.nan] * len(tr.joints)
    when = 0.0
    for lane in plan.lanes:
        states = got[lane.bus]
        for i, u, j, name in zip(lane.ids, lane.units, lane.index, lane.names, strict=True):
            st = states[i]
            when = st.timestamp - t0
            ref = tr.sample(when).positions[j]
            at = u.position(st)
            err = abs(at - ref)
            row_ref[j], row_at[j] = ref, at
            if err > report.max_error[name]:
                report.max_error[name] = err
            if err > plan.max_error[j] and over is None:
                over = (name, err, plan.max_error[j])
    if report.trace is not None:
        report.trace.append((when, row_ref, row_at))
    return over
