"""Teach mode: gravity-compensated, low-stiffness joints a person moves by hand, their positions streamed.

The gravity torque of every joint comes from the robot's model (MuJoCo's bias forces at zero velocity,
the ``physics`` extra) at the measured positions, each cycle; the joints run impedance control with no
stiffness (``kp`` 0 by default), a little damping (``kd``) and that torque as feed-forward. The path
taught is returned as a :class:`~drempower.motion.Trajectory` (rad at the joints), ready to save or
``follow``. On the way out, however it ends, every joint holds where it is.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import TYPE_CHECKING

from ..client.commands import PositionMode, make_angle, make_impedance
from ..client.effects import Batch, Op, read_states, sleep
from ..client.state import MotorState
from ..errors import ConfigError, DrEmpowerError
from ..protocol.messages import Message, StartImpedance
from .trajectory import Trajectory

if TYPE_CHECKING:
    from ..robot import Robot
    from ..robot.config import RobotSpec

__all__ = ["GravityModel", "teach"]


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


def _cycle(
    presets: list[Message], start: StartImpedance, ids: list[int], timeout: float | None
) -> Op[list[MotorState]]:
    yield Batch(presets, start)
    states = yield from read_states(ids, timeout)
    return [st for st in states if st is not None]


def teach(
    robot: Robot,
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
    """Run teach mode on ``joints`` (default all) for ``seconds`` s (None: until ``stop()`` is true or
    Ctrl-C, which then ends it and returns the path); ``on_state(t, {joint: rad})`` sees every cycle.
    Returns the path taught."""
    names = list(joints or robot.joints)
    gravity = GravityModel(robot.spec, names) if compensate else None
    lanes: dict[str, list[str]] = {}
    for n in names:
        lanes.setdefault(robot.spec.joints[n].bus, []).append(n)
    period = 1.0 / rate
    times: list[float] = []
    rows: list[list[float]] = []
    first_bus = robot.bus(next(iter(lanes)))
    now = first_bus.core.now
    states = robot.joint_states(names)
    pos = {n: states[n].position for n in names}
    latest = {n: states[n].motor for n in names}
    t0 = now()
    k = 0
    try:
        while seconds is None or now() - t0 < seconds:
            if stop is not None and stop():
                break
            tau = gravity.torques([pos[n] for n in names]) if gravity is not None else [0.0] * len(names)
            by_name = dict(zip(names, tau, strict=True))
            for bus_name, group in lanes.items():
                presets: list[Message] = []
                for n in group:
                    j = robot.joints[n]
                    preset, _ = make_impedance(j.id, latest[n].angle, 0.0, j.gearing.motor_torque(by_name[n]), kp, kd)
                    presets.append(preset)
                ids = [robot.joints[n].id for n in group]
                got = robot.bus(bus_name).run(_cycle(presets, StartImpedance(0, kp, kd), ids, None))
                for n, st in zip(group, got, strict=True):
                    latest[n] = st
                    pos[n] = robot.joints[n].gearing.joint_state(st).position
            t = now() - t0
            times.append(t)
            rows.append([pos[n] for n in names])
            if on_state is not None:
                on_state(t, dict(pos))
            k += 1
            wait = t0 + k * period - now()
            if wait > 0:
                first_bus.run(sleep(wait))
    except KeyboardInterrupt:
        if seconds is not None:
            raise
    finally:
        for bus_name, group in lanes.items():
            robot.bus(bus_name).core.send_many(
                [make_angle(robot.joints[n].id, latest[n].angle, 0.0, 20.0, PositionMode.T) for n in group]
            )
    if len(times) < 2:
        raise DrEmpowerError("teach: fewer than 2 cycles ran: nothing to return")
    return Trajectory([t - times[0] for t in times], rows, joints=names)
