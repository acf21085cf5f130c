"""Teach mode: gravity-compensated, low-stiffness joints a person moves by hand, their positions streamed.

The gravity torque of every joint comes from the robot's model (MuJoCo's bias forces at zero velocity,
the ``physics`` extra) at the measured positions, each cycle; the joints run impedance control with no
stiffness (``kp`` 0 by default), a little damping (``kd``) and that torque as feed-forward. The path
taught is returned as a :class:`~drempower.motion.Trajectory` (rad at the joints), ready to save or
``follow``. On the way out, however it ends, every joint holds where it is.

This module is the part without I/O; the run is ``teach`` in ``routines_async.py`` (asyncio) and
``routines_sync.py`` (threads), offered as ``robot.teach()``.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

from ..client.effects import Batch, Op, read_states
from ..client.state import MotorState
from ..errors import ConfigError, DrEmpowerError
from ..protocol.messages import Message, StartImpedance

if TYPE_CHECKING:
    from ..robotfile import RobotSpec

__all__ = ["GravityModel", "teach_cycle"]


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
