"""The motion routines that move a robot's joints, for asyncio: :func:`identify`, :func:`step_response`,
:func:`tune` and :func:`teach`.

The one source of both flavours: ``routines_sync.py`` is generated from this file by
``tools/gen_sync.py``. The parts without I/O are in ``identify.py``, ``tune.py`` and ``teach.py``;
:class:`~drempower.robot.robot_async.AsyncJoint` offers ``identify`` and ``tune``,
:class:`~drempower.robot.robot_async.AsyncRobot` ``teach``.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any

from ..client.engine.commands import PositionMode
from ..client.engine.effects import sleep
from ..errors import DrEmpowerError
from .identify import Identification, check_excitation, excitation, from_samples
from .robot_view import RobotView
from .teach import GravityModel, TeachLoop
from .trajectory import Trajectory
from .tune import GAIN_NAMES, Step, TuneReport, gains_for, step_metrics

__all__ = ["identify", "step_response", "teach", "tune"]


async def identify(
    robot: RobotView,
    joint: str,
    *,
    amplitude: float = 0.3,
    seconds: float = 6.0,
    rate: float = 200.0,
    kp: float = 5.0,
    kd: float = 0.2,
    max_torque: float | None = None,
    limits: Mapping[str, Any] | None = None,
) -> Identification:
    """Excite joint ``joint`` of ``robot`` around where it is (``amplitude`` rad peak, for ``seconds`` s,
    ``rate`` Hz) and fit its dynamics (see :mod:`drempower.motion.identify`). The excitation is checked
    against the joint's limits (robot file, model range, ``limits``) before anything moves; a torque above
    ``max_torque`` Nm at the joint, or a tracking error above twice the amplitude, stops it."""
    j = robot.joint(joint)
    bus = robot.bus(robot.spec.joints[joint].bus)
    q0 = (await j.get_joint_state()).position
    check_excitation(robot.spec, robot.twin, joint, q0, amplitude, seconds, rate, limits)
    g = j.gearing
    ts: list[float] = []
    qs: list[float] = []
    vs: list[float] = []
    taus: list[float] = []
    period = 1.0 / rate
    ok = False
    try:
        t0 = bus.now()
        k = 0
        while (t := bus.now() - t0) < seconds:  # the excitation at the time of now: a late host skips samples
            ref, vel = excitation(t, q0, amplitude, seconds)
            await j.impedance_control(g.motor_angle(ref), g.motor_speed(vel), 0.0, kp, kd)
            st = await j.get_joint_state()
            if abs(st.position - ref) > 2 * amplitude or (max_torque is not None and abs(st.torque) > max_torque):
                raise DrEmpowerError(
                    f"identify: joint {joint!r} stopped at {st.position:.3f} rad, torque {st.torque:.3g} Nm: "
                    "it does not follow the excitation (blocked, or max_torque reached)"
                )
            ts.append(bus.frame_time(j.id) or st.timestamp)  # the frame's own time, not when a busy host read it
            qs.append(st.position)
            vs.append(st.velocity)
            taus.append(st.torque)
            k = max(k + 1, int((bus.now() - t0) / period))  # the next sample due (missed ones are not made up)
            wait = t0 + (k + 1) * period - bus.now()
            if wait > 0:
                await bus.run(sleep(wait))
        ok = True
    finally:
        st_last = j.state
        at = st_last.angle if st_last is not None else g.motor_angle(q0)
        if ok:
            await j.set_angle(g.motor_angle(q0), 0.0, 20.0, PositionMode.T)  # back where it was
        else:
            await bus.send_many([j.make_angle(at, 0.0, 20.0, PositionMode.T)])  # hold where it is
    return from_samples(joint, rate, ts, qs, vs, taus, seconds)


async def step_response(
    robot: RobotView,
    joint: str,
    amount: float,
    seconds: float = 1.5,
    rate: float = 500.0,
    trace: list[tuple[float, float]] | None = None,
) -> Step:
    """Step joint ``joint`` by ``amount`` rad (P mode, no feed-forward), watch it for ``seconds`` s, step it
    back; ``trace`` gets (s, fraction of the step) of every state read."""
    j = robot.joint(joint)
    bus = robot.bus(robot.spec.joints[joint].bus)
    q0 = (await j.get_joint_state()).position
    ts: list[float] = []
    ys: list[float] = []
    t0 = bus.now()
    await j.set_angle(j.gearing.motor_angle(q0 + amount), 0.0, 0.0, PositionMode.P)
    try:
        for _ in range(round(seconds * rate)):
            st = await j.get_joint_state()
            ts.append(st.timestamp - t0)
            ys.append((st.position - q0) / amount)
            await bus.run(sleep(1.0 / rate))
    finally:
        await j.set_angle(j.gearing.motor_angle(q0), 0.0, 0.0, PositionMode.P)
        await bus.run(sleep(seconds))
    if trace is not None:
        trace.extend(zip(ts, ys, strict=True))
    return step_metrics(ts, ys)


async def tune(
    robot: RobotView,
    joint: str,
    bandwidth: float,
    *,
    identified: Identification | None = None,
    step: float = 0.15,
    write: bool = True,
    amplitude: float = 0.3,
) -> TuneReport:
    """Identify ``joint`` (unless ``identified`` is given; ``amplitude`` rad peak excursion), compute the
    gains for ``bandwidth`` Hz, step it with its present gains, write the new ones (``write``) and step it
    again (without ``write`` the report's ``after`` is the ``before``)."""
    got = identified or await identify(robot, joint, amplitude=amplitude)
    gains = gains_for(got.inertia, got.viscous, bandwidth, robot.spec.joints[joint].gear)
    before = await step_response(robot, joint, step)
    after = before
    if write:
        j = robot.joint(joint)
        for name, value in zip(GAIN_NAMES, (gains.pos_gain, gains.vel_gain, gains.vel_integrator_gain), strict=True):
            await j.write_property(name, value, verify=True)
        after = await step_response(robot, joint, step)
    return TuneReport(joint, bandwidth, got, gains, before, after)


async def teach(
    robot: RobotView,
    seconds: float | None = None,
    *,
    joints: Sequence[str] | None = None,
    rate: float = 100.0,
    kp: float = 0.0,
    kd: float = 0.05,
    compensate: bool = True,
    on_state: Callable[[float, Mapping[str, float]], None] | None = None,
    stop: Callable[[], bool] | None = None,
) -> Trajectory:
    """Run teach mode (see :mod:`drempower.motion.teach`) on ``joints`` (default all) for ``seconds`` s
    (None: until ``stop()`` is true or Ctrl-C, which then ends it and returns the path); ``on_state(t,
    {joint: rad})`` sees every cycle. Returns the path taught.

    On a virtual clock, joints all on one bus are taught by one operation of that bus, so its cycles keep
    their rate in simulated time while other threads let time pass too; ``on_state`` and ``stop`` then run
    in whichever thread lets it pass: they must not use the bus nor wait for a thread that does (see
    :class:`~.teach.TeachLoop`)."""
    names = list(joints or robot.joints)
    gravity = GravityModel(robot.spec, names) if compensate else None
    first_bus = robot.bus(robot.spec.joints[names[0]].bus)
    states = await robot.joint_states(names)
    loop = TeachLoop(
        robot.spec,
        robot.joints,
        names,
        states,
        first_bus.now,
        seconds=seconds,
        rate=rate,
        kp=kp,
        kd=kd,
        gravity=gravity,
        on_state=on_state,
        stop=stop,
    )
    try:
        if len(loop.lanes) == 1 and first_bus.virtual:
            # one operation: on a virtual clock its cycles stay due on the session's timers, whichever
            # thread lets time pass (see TeachLoop)
            await first_bus.run(loop.operation())
        else:
            steps = loop.steps()
            got: Any = None
            while True:
                try:
                    bus_name, op = steps.send(got)
                except StopIteration:
                    break
                got = await robot.bus(bus_name).run(op)
    except KeyboardInterrupt:
        if seconds is not None:
            raise
    finally:
        for bus_name in loop.lanes:
            await robot.bus(bus_name).send_many(loop.holds(bus_name))
    return loop.path()
