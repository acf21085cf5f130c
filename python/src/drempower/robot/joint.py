"""Joints: motor handles that also speak SI units at the joint (rad, rad/s, Nm).

A joint is motor ``id`` on one bus, seen through ``gear`` (motor output turns
per joint turn; a negative gear reverses the direction) and ``offset`` (the
joint position in rad when the motor reads 0 deg)::

    position_rad = radians(angle_deg) / gear + offset
    velocity_rad_s = speed_rpm * 2 pi / 60 / gear
    torque_Nm_at_joint = torque_Nm_at_motor * gear
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, NamedTuple

from ..client.aio import AsyncMotor
from ..client.motor import Motor
from ..client.state import MotorState
from ..client.timeouts import checks_times
from .config import JointSpec

if TYPE_CHECKING:
    from ..client.aio import AsyncBus
    from ..client.bus import Bus

__all__ = ["JointState", "Gearing", "Joint", "AsyncJoint"]

_RPM = 2 * math.pi / 60
"""rad/s per r/min."""


class JointState(NamedTuple):
    """A motor state at the joint: ``position`` rad, ``velocity`` rad/s, ``torque`` Nm; ``motor`` in wire units."""

    name: str
    position: float
    velocity: float
    torque: float
    trajectory_done: bool
    error: bool
    timestamp: float
    motor: MotorState


class Gearing:
    """The conversions between wire units (deg, r/min, Nm at the motor) and the joint (rad, rad/s, Nm)."""

    __slots__ = ("gear", "name", "offset")

    def __init__(self, spec: JointSpec) -> None:
        self.name = spec.name
        self.gear = spec.gear
        self.offset = spec.offset

    def joint_state(self, st: MotorState) -> JointState:
        """``st`` (wire units) at the joint."""
        g = self.gear
        return JointState(
            self.name,
            math.radians(st.angle) / g + self.offset,
            st.speed * _RPM / g,
            st.torque * g,
            st.trajectory_done,
            st.error,
            st.timestamp,
            st,
        )

    def motor_angle(self, position: float) -> float:
        """The motor angle (deg) that puts the joint at ``position`` rad."""
        return math.degrees((position - self.offset) * self.gear)

    def motor_step(self, distance: float) -> float:
        """The motor angle change (deg) that moves the joint by ``distance`` rad."""
        return math.degrees(distance * self.gear)

    def motor_speed(self, velocity: float) -> float:
        """The motor speed (r/min) that turns the joint at ``velocity`` rad/s."""
        return velocity * self.gear / _RPM

    def motor_torque(self, torque: float) -> float:
        """The motor torque (Nm) that gives ``torque`` Nm at the joint."""
        return torque / self.gear


@checks_times
class Joint(Motor):
    """A :class:`~drempower.client.motor.Motor` (every method, in wire units) that also knows its joint.

    ``joint_state`` is the latest state at the joint (no I/O), ``get_joint_state()`` a fresh one;
    ``gearing`` converts values either way.
    """

    __slots__ = ("gearing", "name")

    def __init__(self, bus: Bus, spec: JointSpec) -> None:
        super().__init__(bus, spec.id)
        self.name = spec.name
        self.gearing = Gearing(spec)

    @property
    def joint_state(self) -> JointState | None:
        """The latest state received from this motor, at the joint (no I/O), or None."""
        st = self.state
        return None if st is None else self.gearing.joint_state(st)

    def get_joint_state(self, *, timeout: float | None = None) -> JointState:
        """A fresh state (fast read) at the joint: rad, rad/s, Nm."""
        return self.gearing.joint_state(self.get_state(timeout=timeout))

    def set_position(self, position: float, bandwidth: float = 20.0) -> None:
        """Move the joint to ``position`` rad now (T mode: ``bandwidth`` 0..300 1/s filter)."""
        self.set_angle(self.gearing.motor_angle(position), 0.0, bandwidth, 0)

    def set_velocity(self, velocity: float) -> None:
        """Turn the joint at ``velocity`` rad/s."""
        self.set_speed(self.gearing.motor_speed(velocity))

    def set_joint_torque(self, torque: float) -> None:
        """Apply ``torque`` Nm at the joint."""
        self.set_torque(self.gearing.motor_torque(torque))

    def __repr__(self) -> str:
        return f"<Joint {self.name} motor {self.id}>"


@checks_times
class AsyncJoint(AsyncMotor):
    """The asyncio counterpart of :class:`Joint`: an :class:`~drempower.client.aio.AsyncMotor` that knows its joint."""

    __slots__ = ("gearing", "name")

    def __init__(self, bus: AsyncBus, spec: JointSpec) -> None:
        super().__init__(bus, spec.id)
        self.name = spec.name
        self.gearing = Gearing(spec)

    @property
    def joint_state(self) -> JointState | None:
        """The latest state received from this motor, at the joint (no I/O), or None."""
        st = self.state
        return None if st is None else self.gearing.joint_state(st)

    async def get_joint_state(self, *, timeout: float | None = None) -> JointState:
        """A fresh state (fast read) at the joint: rad, rad/s, Nm."""
        return self.gearing.joint_state(await self.get_state(timeout=timeout))

    async def set_position(self, position: float, bandwidth: float = 20.0) -> None:
        """Move the joint to ``position`` rad now (T mode: ``bandwidth`` 0..300 1/s filter)."""
        await self.set_angle(self.gearing.motor_angle(position), 0.0, bandwidth, 0)

    async def set_velocity(self, velocity: float) -> None:
        """Turn the joint at ``velocity`` rad/s."""
        await self.set_speed(self.gearing.motor_speed(velocity))

    async def set_joint_torque(self, torque: float) -> None:
        """Apply ``torque`` Nm at the joint."""
        await self.set_torque(self.gearing.motor_torque(torque))

    def __repr__(self) -> str:
        return f"<AsyncJoint {self.name} motor {self.id}>"
