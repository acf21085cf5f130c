"""Teach mode: gravity-compensated, low-stiffness joints a person moves by hand, their positions streamed.

The gravity torque of every joint comes from the robot's model (MuJoCo's bias forces at zero velocity,
the ``physics`` extra) at the measured positions, each cycle; the joints run impedance control with no
stiffness (``kp`` 0 by default), a little damping (``kd``) and that torque as feed-forward. The path
taught is returned as a :class:`~drempower.motion.Trajectory` (rad at the joints), ready to save or
``follow``. On the way out, however it ends, every joint holds where it is.

This module is the part without I/O (:class:`TeachLoop`: the cycles, as operations of the buses); the run
is ``teach`` in ``routines_async.py`` (asyncio) and ``routines_sync.py`` (threads), offered as
``robot.teach()``.
"""

from __future__ import annotations

from collections.abc import Callable, Generator, Mapping, Sequence
from typing import TYPE_CHECKING, Any, Protocol, TypeAlias

from ..client.engine.commands import PositionMode, make_angle, make_impedance
from ..client.engine.effects import Batch, Op, read_states, sleep
from ..client.engine.state import MotorState
from ..errors import ConfigError, DrEmpowerError
from ..protocol.messages import Message, StartImpedance
from .trajectory import Trajectory

if TYPE_CHECKING:
    from ..robotfile import RobotSpec

__all__ = ["GravityModel", "TeachLoop", "TeachStep", "teach_cycle"]

TeachStep: TypeAlias = tuple[str, Op[Any]]
"""What :meth:`TeachLoop.steps` yields: the name of a bus and an operation to run on it."""


class GravityModel:
    """The gravity torque (Nm) at each joint of a robot at given positions, from its model file."""

    def __init__(self, spec: RobotSpec, joints: Sequence[str] | None = None) -> None:
        if spec.model is None:
            raise ConfigError(f"{spec.source}: no [model]: gravity compensation needs the robot's model")
        try:
            import mujoco
            import numpy as np
        except ImportError:
            raise DrEmpowerError("gravity compensation needs MuJoCo: pip install 'drempower[physics]'") from None
        self._mj = mujoco
        self._np = np
        try:
            self.model = mujoco.MjModel.from_xml_path(spec.model.file)
        except Exception as exc:  # MuJoCo's parser errors have no common type
            raise ConfigError(f"model {spec.model.file}: {exc}") from None
        self.data = mujoco.MjData(self.model)
        self.joints = list(joints or spec.joints)
        self._adr: list[tuple[int, int]] = []
        for name in self.joints:
            mj_name = spec.joints[name].model_joint or name
            jid = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_JOINT, mj_name)
            if jid < 0:
                raise ConfigError(f"model {spec.model.file}: joint {name!r}: no model joint {mj_name!r}")
            self._adr.append((int(self.model.jnt_qposadr[jid]), int(self.model.jnt_dofadr[jid])))

    def torques(self, positions: Sequence[float]) -> list[float]:
        """Gravity torque (Nm at the joint) of each joint, in order, at ``positions`` (rad), at rest."""
        d = self.data
        for (qadr, _), q in zip(self._adr, positions, strict=True):
            d.qpos[qadr] = q
        d.qvel[:] = 0.0
        self._mj.mj_forward(self.model, d)
        return [float(d.qfrc_bias[dof]) for _, dof in self._adr]

    def inverse(self, positions: Sequence[float], velocities: Sequence[float], accels: Sequence[float]) -> list[float]:
        """Rigid-body inverse dynamics: the torque (Nm at the joint) of each joint that gives ``accels``
        (rad/s^2) at ``positions`` (rad) and ``velocities`` (rad/s): ``M(q) qdd + C(q, qd) + G(q)``."""
        m, d = self.model, self.data
        d.qvel[:] = 0.0
        d.qacc[:] = 0.0
        for (qadr, dof), q, v, a in zip(self._adr, positions, velocities, accels, strict=True):
            d.qpos[qadr] = q
            d.qvel[dof] = v
            d.qacc[dof] = a
        mj = self._mj
        mj.mj_kinematics(m, d)
        mj.mj_comPos(m, d)
        mj.mj_crb(m, d)
        mj.mj_comVel(m, d)
        res = self._np.zeros(m.nv)
        mj.mj_rne(m, d, 1, res)
        return [float(res[dof]) for _, dof in self._adr]


def teach_cycle(
    presets: list[Message], start: StartImpedance, ids: list[int], timeout: float | None
) -> Op[list[MotorState]]:
    """One teach cycle on a bus: the impedance presets and their start, then the states of ``ids``."""
    yield Batch(presets, start)
    states = yield from read_states(ids, timeout)
    return [st for st in states if st is not None]


class _JointState(Protocol):
    """What teach mode uses of a joint's state (a robot's ``JointState``): its position and its motor's state."""

    @property
    def position(self) -> float: ...

    @property
    def motor(self) -> MotorState: ...


class _Gearing(Protocol):
    """What teach mode uses of a joint's gearing: torque at the motor, state at the joint."""

    def motor_torque(self, torque: float) -> float: ...

    def joint_state(self, st: MotorState) -> _JointState: ...


class _Joint(Protocol):
    """What teach mode uses of a joint handle: its motor's id and its gearing."""

    @property
    def id(self) -> int: ...

    @property
    def gearing(self) -> _Gearing: ...


class TeachLoop:
    """The cycles of teach mode on the joints ``names`` of a robot (``spec`` and its joint handles ``joints``)
    from their ``states`` now: each cycle, every bus's joints get their impedance presets (``kp``, ``kd``,
    the ``gravity`` torques at the positions last read, or none) and their start, and are read; then the
    loop waits for the next cycle (``rate`` per s on the clock ``now``, that of the first bus). It runs for
    ``seconds`` (None: for good), or until ``stop()`` is true; ``on_state(t, {joint: rad})`` sees every cycle.

    :meth:`steps` gives the cycles as operations of the buses, each run on its bus by the caller; joints
    all on one bus can run them all as one operation (:meth:`operation`), so that on a virtual clock the
    loop's next deadline is always the session's, whichever thread lets time pass (a caller running
    each step itself leaves the session without one between steps, and another thread's wait then lets
    time pass over the cycles it would have run). Then ``on_state`` and ``stop`` run in the thread that
    lets time pass, inside the bus's session: they must not use the bus nor wait for a thread that does.
    """

    def __init__(
        self,
        spec: RobotSpec,
        joints: Mapping[str, _Joint],
        names: Sequence[str],
        states: Mapping[str, _JointState],
        now: Callable[[], float],
        *,
        seconds: float | None,
        rate: float,
        kp: float,
        kd: float,
        gravity: GravityModel | None,
        on_state: Callable[[float, Mapping[str, float]], None] | None,
        stop: Callable[[], bool] | None,
    ) -> None:
        self.names = list(names)
        self.lanes: dict[str, list[str]] = {}
        """The joints of each bus, in the order of ``names``."""
        for n in self.names:
            self.lanes.setdefault(spec.joints[n].bus, []).append(n)
        self._joints = joints
        self._now = now
        self._seconds, self._period, self._kp, self._kd = seconds, 1.0 / rate, kp, kd
        self._gravity, self._on_state, self._stop = gravity, on_state, stop
        self.pos = {n: states[n].position for n in self.names}
        """The joints' latest positions (rad)."""
        self.latest = {n: states[n].motor for n in self.names}
        """The joints' latest states (wire units)."""
        self.times: list[float] = []
        self.rows: list[list[float]] = []
        self._t0 = now()

    def steps(self) -> Generator[TeachStep, Any, None]:
        """The cycles until their time is over or ``stop()``: ``(bus, operation)`` to run on that bus, each
        sent back its result."""
        names, lanes, joints, now, t0 = self.names, self.lanes, self._joints, self._now, self._t0
        pos, latest, gravity, kp, kd = self.pos, self.latest, self._gravity, self._kp, self._kd
        first = next(iter(lanes))
        k = 0
        while self._seconds is None or now() - t0 < self._seconds:
            if self._stop is not None and self._stop():
                return
            tau = gravity.torques([pos[n] for n in names]) if gravity is not None else [0.0] * len(names)
            by_name = dict(zip(names, tau, strict=True))
            for bus_name, group in lanes.items():
                presets: list[Message] = []
                for n in group:
                    j = joints[n]
                    preset, _ = make_impedance(j.id, latest[n].angle, 0.0, j.gearing.motor_torque(by_name[n]), kp, kd)
                    presets.append(preset)
                ids = [joints[n].id for n in group]
                got = yield bus_name, teach_cycle(presets, StartImpedance(0, kp, kd), ids, None)
                for n, st in zip(group, got, strict=True):
                    latest[n] = st
                    pos[n] = joints[n].gearing.joint_state(st).position
            t = now() - t0
            self.times.append(t)
            self.rows.append([pos[n] for n in names])
            if self._on_state is not None:
                self._on_state(t, dict(pos))
            k += 1
            wait = t0 + k * self._period - now()
            if wait > 0:
                yield first, sleep(wait)

    def operation(self) -> Op[None]:
        """Every step, the joints all on one bus, as one operation of that bus."""
        if len(self.lanes) != 1:
            raise DrEmpowerError(f"teach: joints on buses {', '.join(self.lanes)}: one operation runs on one bus")
        steps = self.steps()
        got: Any = None
        while True:
            try:
                _, op = steps.send(got)
            except StopIteration:
                return
            got = yield from op

    def holds(self, bus: str) -> list[Message]:
        """Where teach ends, however it ends: each joint of ``bus`` holds its latest position (T mode)."""
        j, latest = self._joints, self.latest
        return [make_angle(j[n].id, latest[n].angle, 0.0, 20.0, PositionMode.T) for n in self.lanes[bus]]

    def path(self) -> Trajectory:
        """The path taught (rad at the joints, times from the first cycle)."""
        times = self.times
        if len(times) < 2:
            raise DrEmpowerError("teach: fewer than 2 cycles ran: nothing to return")
        return Trajectory([t - times[0] for t in times], self.rows, joints=self.names)
