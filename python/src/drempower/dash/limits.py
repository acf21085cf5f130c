"""The limits each motor holds that bound the dashboard's Control inputs, and refusals in a joint's units."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from .. import actions
from ..actions import bandwidth_range
from ..errors import DrEmpowerError, FieldRangeError, SoftLimitError, ValidationError
from .keys import MotorKeys
from .units import ROW_KINDS

__all__ = ["LIMIT_READS", "MotorLimits", "bounds"]

LIMIT_READS = (
    ("speed", "axis0.output_shaft.vel_limit"),
    ("torque", "axis0.output_shaft.torque_lim"),
    ("current", "axis0.motor.config.current_lim"),
    ("torque_constant", "axis0.output_shaft.torque_constant"),
)
"""The limits a motor holds that bound the Control inputs (read at scan and after a write of one)."""


def bounds(raw: dict[str, float | None]) -> dict[str, Any]:
    """Control-input bounds from the limits a motor holds: ``speed`` r/min and ``torque`` Nm (magnitudes,
    None: unknown), ``bandwidth`` [low, high] 1/s; the torque bound is the smaller of the torque
    limit and the current limit times the output torque constant."""
    speed, torque, current, kt = (raw.get(k) for k in ("speed", "torque", "current", "torque_constant"))
    by_current = current * kt if current is not None and kt is not None and kt > 0 else None
    if torque is None or (by_current is not None and by_current < torque):
        torque = by_current
    return {"speed": speed, "torque": torque, "current": current, "bandwidth": list(bandwidth_range())}


def _within(key: str, value: float, bound: float | None, unit: str, what: str) -> None:
    if bound is not None and abs(value) > bound:
        raise ValidationError(f"{key}={value:g}: outside -{bound:g}..{bound:g} {unit}, the {what}")


class MotorLimits:
    """Per motor key, the Control-input :func:`bounds` of the limits it holds (and a robot file's)."""

    def __init__(self, keys: MotorKeys) -> None:
        self._keys = keys
        self.limits: dict[int, dict[str, Any]] = {}

    def read(self, i: int) -> dict[str, Any]:
        """Read the limits motor ``i`` holds and keep the Control-input :func:`bounds` they give."""
        m = self._keys.motor(i)
        raw: dict[str, float | None] = {}
        for key, name in LIMIT_READS:
            try:
                raw[key] = float(m.read_property(name, timeout=0.2))
            except DrEmpowerError:
                raw[key] = None
        out = bounds(raw)
        bus, node = self._keys.where(i)
        gate = bus.limits(node)  # a robot file's limits (and its model's range), in motor units
        for key in ("speed", "torque"):
            lim = gate.get(key)
            if lim is not None and (out[key] is None or lim.high < out[key]):
                out[key] = lim.high
                out.setdefault("set_by", {})[key] = lim.where
        pos = gate.get("position")
        if pos is not None:
            out["position"] = [pos.low, pos.high]
            out.setdefault("set_by", {})["position"] = pos.where
        self.limits[i] = out
        return out

    def shown(self, i: int) -> dict[str, Any] | None:
        """Motor ``i``'s limits as the page shows them: at the joint for a robot joint (with its units)."""
        lim = self.limits.get(i)
        if lim is None:
            return None
        u = self._keys.units.get(i)
        return u.limits(lim) if u is not None else {**lim, "units": "motor"}

    def check(self, act: actions.Action, key: int, typed: Mapping[str, Any]) -> None:
        """A motion's speeds and torques (targets and feed-forwards) within the limits motor ``key`` holds."""
        for field in ("speed", "vel", "speed_ff"):
            if typed.get(field) is not None and act.arg(field).unit == "r/min":
                self._speed(key, field, typed[field])
        for field in ("torque", "tff", "torque_ff"):
            if typed.get(field) is not None:
                self._torque(key, field, typed[field])

    def _speed(self, i: int, key: str, value: float) -> None:
        lim = self.limits.get(i, {}).get("speed")
        by = self.limits.get(i, {}).get("set_by", {}).get("speed")
        held = "holds (axis0.output_shaft.vel_limit)" if by is None else f"has (set by {by})"
        what = f"speed limit {self._keys.label(i)} {held}"
        u = self._keys.units.get(i)
        if u is not None and lim is not None:  # the page's value and the limit at the joint
            _within(key, u.speed(value), abs(u.speed(lim)), "r/min at the joint", what)
        _within(key, value, lim, "r/min", what)

    def _torque(self, i: int, key: str, value: float) -> None:
        lim = self.limits.get(i, {}).get("torque")
        by = self.limits.get(i, {}).get("set_by", {}).get("torque")
        what = f"torque limit {self._keys.label(i)} " + (
            "holds (output_shaft.torque_lim, current_lim x torque_constant)" if by is None else f"has (set by {by})"
        )
        u = self._keys.units.get(i)
        if u is not None and lim is not None:  # the page's value and the limit at the joint
            _within(key, u.torque(value), abs(u.torque(lim)), "Nm at the joint", what)
        _within(key, value, lim, "Nm", what)

    def joint_words(self, key: int, exc: DrEmpowerError) -> DrEmpowerError:
        """A refusal of a robot joint's value, which the page gave at the joint, in the joint's units: a
        soft limit (the gate's words, motor units) or a field's range (the wire's, at the motor) with the
        value typed and the range at the joint, the motor's figures after them; others as they are."""
        u = self._keys.units.get(key)
        if u is None or not isinstance(exc, FieldRangeError) or not isinstance(exc.value, (int, float)):
            return exc
        who = self._keys.label(key)
        if isinstance(exc, SoftLimitError):
            at = u.refusal(exc.limit, float(exc.value), exc.low, exc.high)
            if at is None:
                return exc
            v, lo, hi, unit = at
            return ValidationError(
                f"joint {who}: {exc.limit} {v:g} {unit} at the joint is beyond its soft limit {lo:g}..{hi:g} "
                f"{unit} at the joint (set by {exc.where}; {exc.value:g}, {exc.low:g}..{exc.high:g} at the motor)"
            )
        kind = "angle" if exc.field in ("angle", "pos") else ROW_KINDS.get(exc.field)
        if kind is None:
            return exc
        f = {"angle": u.angle, "speed": u.speed, "torque": u.torque}[kind]
        a, b = f(exc.low), f(exc.high)
        return ValidationError(
            f"joint {who}: {exc.field}={f(float(exc.value)):g} at the joint is out of range: allowed "
            f"{min(a, b):g}..{max(a, b):g} at the joint ({exc.value:g}, {exc.low:g}..{exc.high:g} at the motor)"
        )
