"""Looking joints up by name, shared by both robot APIs (no I/O)."""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import TypeVar

from ..errors import ConfigError, DrEmpowerError, FieldRangeError, TransportError, ValidationError
from ..protocol.messages import Message
from .config import RobotSpec

__all__ = ["by_bus", "per_bus", "note_bus", "opening_failed", "check_commands"]

V = TypeVar("V")


def _known(spec: RobotSpec, name: str) -> None:
    if name not in spec.joints:
        raise ValidationError(f"joint {name!r}: no such joint (joints: {', '.join(spec.joints)})")


def by_bus(spec: RobotSpec, names: Iterable[str] | None) -> dict[str, list[str]]:
    """Joint names grouped by bus (all joints when None), in file order of the buses; each name once."""
    chosen = list(spec.joints) if names is None else list(names)
    if isinstance(names, str):
        raise ValidationError(f"names={names!r}: give a list of joint names, e.g. [{names!r}]")
    seen: set[str] = set()
    out: dict[str, list[str]] = {}
    for n in chosen:
        _known(spec, n)
        if n in seen:
            raise ValidationError(f"joint {n!r} named twice")
        seen.add(n)
    for bus in spec.buses:
        group = [n for n in chosen if spec.joints[n].bus == bus]
        if group:
            out[bus] = group
    return out


def per_bus(spec: RobotSpec, values: Mapping[str, V]) -> dict[str, dict[str, V]]:
    """``{joint: value}`` split into ``{bus: {joint: value}}``."""
    if not isinstance(values, Mapping):
        raise ValidationError(f"expected a mapping of joint names to values, got {type(values).__name__}")
    groups = by_bus(spec, values)
    return {bus: {n: values[n] for n in names} for bus, names in groups.items()}


def note_bus(exc: BaseException, bus: str) -> None:
    """Add "on bus NAME" to an error raised by one bus's part of a robot call."""
    add = getattr(exc, "add_note", None)
    if add is not None:
        add(f"(on bus {bus!r})")


def opening_failed(spec: RobotSpec, bus: str, exc: DrEmpowerError) -> DrEmpowerError:
    """The error to raise when bus ``bus`` cannot be opened: the same kind, naming the bus entry."""
    where = f"{spec.source}: [buses.{bus}]"
    if isinstance(exc, TransportError):
        return TransportError(f"{where}: {exc}")
    return ConfigError(f"{where}: {exc}")


def check_commands(spec: RobotSpec, commands: Mapping[str, Message]) -> None:
    """Check a control cycle's commands for every bus before any bus sends: each for its joint's motor, valid."""
    for name, msg in commands.items():
        j = spec.joints.get(name)
        if j is not None and msg.node != j.id:
            raise ValidationError(f"joint {name!r} is motor {j.id}; the message is for {msg.node}")
        if msg.cmd == 0x1E:
            raise ValidationError(f"joint {name!r}: a control cycle sends commands; reads are answered by the cycle")
        try:
            msg.encode()
        except FieldRangeError as exc:
            raise FieldRangeError(f"{exc.field} (joint {name})", exc.value, exc.low, exc.high) from None
        except ValidationError as exc:
            raise ValidationError(f"joint {name!r}: {exc}") from None
