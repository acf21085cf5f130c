"""The dashboard's motor keys: where each motor lives (bus and id), how it is named, its joint and units."""

from __future__ import annotations

import os
import re
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any

from ..client import Bus, Motor
from ..errors import ValidationError
from ..naming import motor_name, motor_names
from ..robot.joint import Gearing
from .units import JointUnits

if TYPE_CHECKING:
    from ..robot import Robot

__all__ = ["KEYS_PER_BUS", "MotorKeys", "motor_id"]

KEYS_PER_BUS = 64
"""A motor's key on the page: ``bus index * KEYS_PER_BUS + motor id`` (on one bus: the motor id)."""


def motor_id(args: dict[str, Any], key: str = "id") -> int:
    """``args[key]`` as a motor id: a whole number 1..63 (nothing rounded)."""
    value = args.get(key)
    if isinstance(value, bool) or not isinstance(value, int) or not 1 <= value <= 63:
        raise ValidationError(f"{key}={value!r}: expected a motor id 1..63")
    return value


def _ids(args: dict[str, Any], key: str = "ids") -> list[int]:
    ids = args.get(key)
    if (
        not isinstance(ids, list)
        or not ids
        or not all(isinstance(i, int) and not isinstance(i, bool) and 1 <= i <= 63 for i in ids)
    ):
        raise ValidationError(f"{key}={ids!r}: expected a list of motor ids 1..63")
    return list(ids)


class MotorKeys:
    """The motors of one :class:`Bus`, or of every bus of a :class:`Robot`, by key: the motor id on one
    bus; ``bus index * 64 + id`` over a robot's buses (in file order). ``found``: the motors a scan
    found, by key (what :meth:`names` lists besides the joints)."""

    def __init__(self, bus: Bus | Robot) -> None:
        self.robot: Robot | None = None if isinstance(bus, Bus) else bus
        self.buses: list[tuple[str, Bus]] = [("", bus)] if isinstance(bus, Bus) else list(bus.buses.items())
        self.bus = self.buses[0][1]
        self.found: dict[int, dict[str, Any]] = {}
        self.joints: dict[int, dict[str, Any]] = {}
        """Robot joints by key: ``{"joint", "bus", "id"}``."""
        self.units: dict[int, JointUnits] = {}
        """The page's units of each robot joint by key (deg, r/min, Nm at the joint); a bare motor's are its own."""
        if self.robot is not None:
            index = {name: k for k, (name, _) in enumerate(self.buses)}
            for j in self.robot.spec.joints.values():
                self.joints[index[j.bus] * KEYS_PER_BUS + j.id] = {"joint": j.name, "bus": j.bus, "id": j.id}
                self.units[index[j.bus] * KEYS_PER_BUS + j.id] = JointUnits(Gearing(j))

    # the command service's view (drempower.actions.Motors)

    def every_bus(self) -> Sequence[Bus]:
        return [b for _, b in self.buses]

    def where(self, key: int) -> tuple[Bus, int]:
        """The bus and motor id of ``key``."""
        k, i = divmod(key, KEYS_PER_BUS)
        return self.buses[k][1], i

    def motor(self, key: int) -> Motor:
        bus, i = self.where(key)
        return bus.motor(i)

    def key(self, args: dict[str, Any], field: str = "id") -> int:
        """``args[field]`` as a motor key of this dashboard (a whole number, nothing rounded)."""
        value = args.get(field)
        if len(self.buses) == 1:
            return motor_id(args, field)
        if (
            isinstance(value, bool)
            or not isinstance(value, int)
            or not 1 <= value % KEYS_PER_BUS <= 63
            or not 0 <= value // KEYS_PER_BUS < len(self.buses)
        ):
            raise ValidationError(f"{field}={value!r}: not a motor of this dashboard's buses")
        return value

    def keys(self, args: dict[str, Any], field: str = "ids") -> list[int]:
        ids = args.get(field)
        if not isinstance(ids, list) or not ids:
            raise ValidationError(f"{field}={ids!r}: expected a list of motors")
        if len(self.buses) == 1:
            return _ids(args, field)
        return [self.key({field: i}, field) for i in ids]

    def label(self, key: int) -> str:
        """How messages and log lines name a motor: by :mod:`drempower.naming` (``motor_2``); a joint of
        the robot file by its name, with its bus and motor (``elbow (bus right, motor 1)``)."""
        if self.robot is None:
            return motor_name(key)
        bus, i = self.buses[key // KEYS_PER_BUS][0], key % KEYS_PER_BUS
        j = self.joints.get(key)
        return (
            f"{j['joint']} (bus {bus}, motor {i})" if j else self.names().get(key, {}).get("name", f"{bus}/motor_{i}")
        )

    def scan(self, progress: Callable[[int, int, list[dict[str, Any]]], None]) -> list[dict[str, Any]]:
        """Scan ids 1-63 of every bus in four groups, calling ``progress(done, 63 * buses, found)`` after each;
        returns what was found (``id``: the key; a robot's with its bus, motor and joint)."""
        found: list[dict[str, Any]] = []
        for k, (name, bus) in enumerate(self.buses):
            timeout = min(bus.timeout, 0.2)
            for lo in range(1, 64, 16):
                group = range(lo, min(lo + 16, 64))
                for info in bus.scan(group, timeout=timeout, versions=True):
                    key = k * KEYS_PER_BUS + info.id
                    entry: dict[str, Any] = {"id": key, "hw": info.hw_version, "fw": info.fw_version}
                    if self.robot is not None:
                        entry.update(bus=name, motor=info.id, joint=self.joints.get(key, {}).get("joint"))
                    found.append(entry)
                progress(k * 63 + group[-1], 63 * len(self.buses), found)
        return found

    def enable_fix(self, keys: Sequence[int]) -> str:
        """How to enable the motors of ``keys`` from here: the Enable button, or the command line (a robot's
        joints by name, on the robot file)."""
        if self.robot is None:
            return f"(the Enable button, or drempower enable {','.join(str(self.where(k)[1]) for k in keys)})"
        names = ",".join(self.joints[k]["joint"] if k in self.joints else str(self.where(k)[1]) for k in keys)
        return f"(the Enable button, or drempower enable {names} --robot {self.robot.spec.source})"

    def description(self) -> str:
        """The bus, or every bus of the robot by name."""
        if self.robot is None:
            return self.bus.transport.description
        return f"robot {os.path.basename(self.robot.spec.source)}: " + "; ".join(
            f"{name}: {bus.transport.description}" for name, bus in self.buses
        )

    def bitrate(self) -> int | None:
        """The CAN bit rate (bit/s) when the transport knows it (the slowest bus's over a robot); a serial
        link's baud rate is not the CAN bit rate and is never taken for it."""
        rates = [b.transport.wire_bitrate for _, b in self.buses]
        known = [r for r in rates if r]
        return min(known) if known and len(known) == len(rates) else None

    def names(self) -> dict[int, dict[str, Any]]:
        """How the page names each motor it knows (the joints of a robot file, the motors found), by key:
        ``{"name", "joint", "bus", "id"}``, ``name`` by :mod:`drempower.naming` (``motor_<id>``, a joint's
        name, ``<bus>/motor_<id>`` where buses would collide)."""
        where = {k: (self.buses[k // KEYS_PER_BUS][0], k % KEYS_PER_BUS) for k in sorted({*self.joints, *self.found})}
        joints = {(j["bus"], j["id"]): j["joint"] for j in self.joints.values()}
        named = motor_names(where.values(), joints)
        return {
            k: {"name": named[p], "joint": joints.get(p), "bus": p[0], "id": p[1]}
            | (self.units[k].describe() if k in self.units else {"units": "motor"})
            for k, p in where.items()
        }

    def words(self, text: str, key: int | None) -> str:
        """A message about motor key ``key`` with its joint named: ``motor 3: ...`` -> ``joint elbow (motor
        3): ...`` on a robot (the library's words otherwise unchanged)."""
        j = self.joints.get(key) if key is not None else None
        if j is None or re.search(rf"\b{re.escape(j['joint'])}\b", text):
            return text
        return re.sub(rf"\bmotor {j['id']}\b", f"joint {j['joint']} (motor {j['id']})", text, count=1)
