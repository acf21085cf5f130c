"""The page's units of a joint of a robot file: deg, r/min and Nm at the joint (its gear and offset
applied); a bare motor's are the motor's own (deg, r/min, Nm at the motor).

The hub keeps the bus's values in motor units and turns them here, at the page's edge: the controls
and the Tuning step take joint units, the samples, limits and refusals show them.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from ..robot.joint import Gearing

__all__ = ["JointUnits", "ROW_KINDS"]

ROW_KINDS: dict[str, str] = {
    "speed": "speed",
    "vel": "speed",
    "speed_ff": "speed",
    "accel": "speed",  # (r/min)/s: the same factor as a speed
    "torque": "torque",
    "tff": "torque",
    "torque_ff": "torque",
}
"""The kind of each row argument the page sends that has a unit at the joint (the angles are by row)."""


class JointUnits:
    """Conversions between the page's units at joint ``spec`` (deg, r/min, Nm at the joint) and the
    motor's (deg, r/min, Nm at the motor)."""

    __slots__ = ("gearing",)

    def __init__(self, gearing: Gearing) -> None:
        self.gearing = gearing

    @property
    def gear(self) -> float:
        return self.gearing.gear

    def describe(self) -> dict[str, Any]:
        """What the page says of its units: ``{"units": "joint", "gear", "offset_deg"}``."""
        return {"units": "joint", "gear": self.gear, "offset_deg": round(math.degrees(self.gearing.offset), 6)}

    # motor -> joint (deg, r/min, Nm at the joint)
    def angle(self, motor_deg: float) -> float:
        return math.degrees(self.gearing.joint_state_angle(motor_deg))

    def step(self, motor_deg: float) -> float:
        return motor_deg / self.gear

    def speed(self, motor_rpm: float) -> float:
        return motor_rpm / self.gear

    def torque(self, motor_nm: float) -> float:
        return motor_nm * self.gear

    # joint -> motor
    def motor_angle(self, joint_deg: float) -> float:
        return self.gearing.motor_angle(math.radians(joint_deg))

    def motor_step(self, joint_deg: float) -> float:
        return joint_deg * self.gear

    def motor_speed(self, joint_rpm: float) -> float:
        return joint_rpm * self.gear

    def motor_torque(self, joint_nm: float) -> float:
        return joint_nm / self.gear

    def to_motor(self, row: str, args: Mapping[str, Any]) -> dict[str, Any]:
        """Row ``row``'s arguments from the page (joint units) in motor units; a value that is not a number
        is left for the row to refuse in its words. Kp and Kd (impedance) are the motor's."""
        out = dict(args)
        for k, v in args.items():
            if not isinstance(v, (int, float)) or isinstance(v, bool) or not math.isfinite(v):
                continue
            if k == "angle" and row == "step":
                out[k] = self.motor_step(v)
            elif k in ("angle", "pos"):
                out[k] = self.motor_angle(v)
            elif ROW_KINDS.get(k) == "speed":
                out[k] = abs(self.motor_speed(v)) if k == "accel" else self.motor_speed(v)
            elif ROW_KINDS.get(k) == "torque":
                out[k] = self.motor_torque(v)
        return out

    def limits(self, motor: Mapping[str, Any]) -> dict[str, Any]:
        """The Control view's limits (motor units: ``position`` deg pair, ``speed`` r/min, ``torque`` Nm)
        at the joint; the rest (current, ``set_by``) as they are."""
        out = dict(motor)
        pos = motor.get("position")
        if pos is not None:
            a, b = self.angle(pos[0]), self.angle(pos[1])
            out["position"] = [min(a, b), max(a, b)]
        if motor.get("speed") is not None:
            out["speed"] = abs(self.speed(motor["speed"]))
        if motor.get("torque") is not None:
            out["torque"] = abs(self.torque(motor["torque"]))
        return out | self.describe()

    def refusal(self, limit: str, value: float, low: float, high: float) -> tuple[float, float, float, str] | None:
        """A soft limit's refusal (motor units) at the joint: value, low, high and unit; None for a limit
        without a joint unit."""
        if limit == "position":
            a, b = self.angle(low), self.angle(high)
            return self.angle(value), min(a, b), max(a, b), "deg"
        conv = {"speed": (self.speed, "r/min"), "accel": (self.speed, "(r/min)/s"), "torque": (self.torque, "Nm")}
        if limit not in conv:
            return None
        f, unit = conv[limit]
        a, b = f(low), f(high)
        return f(value), min(a, b), max(a, b), unit
