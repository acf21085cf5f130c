"""Joints' units: the state at the joint (rad, rad/s, Nm) and the gearing between motor and joint.

The joint handles (:class:`~drempower.robot.robot_sync.Joint`, :class:`~drempower.robot.robot_async.AsyncJoint`)
are motor handles that use these.

A joint is motor ``id`` on one bus, seen through ``gear`` (motor output turns
per joint turn; a negative gear reverses the direction) and ``offset`` (the
joint position in rad when the motor reads 0 deg)::

    position_rad = radians(angle_deg) / gear + offset
    velocity_rad_s = speed_rpm * 2 pi / 60 / gear
    torque_Nm_at_joint = torque_Nm_at_motor * gear
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any, NamedTuple

from ..client.engine.state import MotorState
from .config import JointSpec

__all__ = ["JointState", "Gearing"]

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

    def joint_state_angle(self, angle: float) -> float:
        """The joint position (rad) when the motor reads ``angle`` deg."""
        return math.radians(angle) / self.gear + self.offset

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

    def motor_limits(self, limits: Mapping[str, Any]) -> dict[str, Any]:
        """Soft limits at the joint (rad, rad/s, Nm, rad/s^2, rad) in motor units (deg, r/min, Nm,
        (r/min)/s, deg), as :meth:`~drempower.client.api.bus_sync.Bus.set_limits` takes them."""
        out: dict[str, Any] = {}
        for name, v in limits.items():
            if name == "position":
                a, b = self.motor_angle(v[0]), self.motor_angle(v[1])
                out[name] = (min(a, b), max(a, b))
            elif name == "speed":
                out[name] = abs(self.motor_speed(v))
            elif name == "torque":
                out[name] = abs(self.motor_torque(v))
            elif name == "accel":
                out[name] = abs(self.motor_speed(v))  # rad/s^2 -> (r/min)/s: the same factor as a speed
            elif name == "max_step":
                out[name] = abs(self.motor_step(v))
        return out
