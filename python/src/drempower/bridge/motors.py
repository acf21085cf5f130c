"""The motors a bridge serves as the command service sees them (:class:`drempower.actions.Motors`).

A bus served alone is keyed by motor id and names a motor ``motor_<id>`` (a joint
given another name: ``elbow (motor 1)``); the buses of a robot are keyed
``bus index * 64 + id`` and name a joint as the dashboard does: ``elbow (bus
right, motor 1)``.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from ..errors import ValidationError
from ..naming import motor_name
from ..robot.config import JointSpec

__all__ = ["KEYS_PER_BUS", "ServedMotors"]

KEYS_PER_BUS = 64
"""Keys of one bus of a robot (motor ids are 1..63)."""


class ServedMotors:
    """The motors of ``buses``: each a (bus name, threaded bus, the joints served on it)."""

    def __init__(self, buses: Sequence[tuple[str, Any, Sequence[JointSpec]]]) -> None:
        self._buses = [(name, bus, list(joints)) for name, bus, joints in buses]
        self._joints = {self._key(k, j.id): (name, j) for k, (name, _, js) in enumerate(self._buses) for j in js}

    def _key(self, index: int, node: int) -> int:
        return node if len(self._buses) == 1 else index * KEYS_PER_BUS + node

    def served(self) -> list[list[int]]:
        """The keys of the motors served, bus by bus, in the order of the joints."""
        return [[self._key(k, j.id) for j in js] for k, (_, _, js) in enumerate(self._buses)]

    def every_bus(self) -> Sequence[Any]:
        return [bus for _, bus, _ in self._buses]

    def key(self, args: dict[str, Any]) -> int:
        value = args.get("id")
        if isinstance(value, bool) or not isinstance(value, int) or value not in self._joints:
            raise ValidationError(f"id={value!r}: not a motor the bridge serves")
        return value

    def where(self, key: int) -> tuple[Any, int]:
        index, node = divmod(key, KEYS_PER_BUS) if len(self._buses) > 1 else (0, key)
        return self._buses[index][1], node

    def label(self, key: int) -> str:
        """``motor_<id>`` on a bus served alone (a joint named otherwise: its name and motor); a robot's
        joint by its name, bus and motor."""
        got = self._joints.get(key)
        node = self.where(key)[1]
        if got is None or (not got[0] and got[1].name == motor_name(node)):
            return motor_name(node)
        bus, j = got
        return f"{j.name} (bus {bus}, motor {node})" if bus else f"{j.name} (motor {node})"
