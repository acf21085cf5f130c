"""The Parameters view: read, write (checked against each parameter's domain), save, back up and restore."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

from ..client import ConfigBackup
from ..errors import ValidationError
from ..protocol.parameters import Parameter, find_parameter, parameters
from .keys import MotorKeys
from .limits import LIMIT_READS, MotorLimits

__all__ = ["Params", "param_table"]


def param_table() -> list[dict[str, Any]]:
    """Every parameter as the page shows it: name, group, address, type, unit, access, description."""
    return [
        {
            "name": p.name,
            "group": p.name.rsplit(".", 1)[0] if "." in p.name else "(top)",
            "address": p.address,
            "type": p.dtype.name.lower(),
            "unit": p.unit,
            "access": p.access.value,
            "bool": p.is_bool,
            "description": p.description,
            "min": p.minimum,
            "max": p.maximum,
            "allowed": list(p.allowed),
            "hard": p.hard,
            "domain": p.domain_text() if p.has_domain else "",
        }
        for p in parameters()
    ]


def number(args: dict[str, Any], key: str, default: float | None = None) -> float:
    """``args[key]`` (else ``default``) as a finite number, or a ValidationError naming it."""
    value = args.get(key, default)
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ValidationError(f"{key}={value!r}: expected a finite number")
    return float(value)


class Params:
    """The parameters of the motors of ``keys``, with which changed this session (``saved``: the baseline
    of each motor); ``control(who, what)`` refuses a write when the dashboard may not send one, else logs it."""

    def __init__(self, keys: MotorKeys, limits: MotorLimits, control: Callable[[str, str], None]) -> None:
        self._keys = keys
        self._limits = limits
        self._control = control
        self.saved: dict[int, dict[str, float]] = {}

    def read(self, i: int) -> dict[str, Any]:
        """Every readable parameter of motor ``i`` (one backup read), with which changed this session.

        The motor cannot tell what its flash holds, so the baseline is this dashboard's first
        read of the motor, replaced by what it holds after each *Save to flash* from here.
        """
        values = self._keys.motor(i).backup().values()
        saved = self.saved.setdefault(i, {})
        for k, v in values.items():  # the first read of each value is its baseline
            saved.setdefault(k, v)
        changed = [k for k, v in values.items() if k in saved and saved[k] != v]
        return {"id": i, "values": values, "changed": changed}

    def write(self, who: str, i: int, name: str, value: Any, force: bool = False) -> dict[str, Any]:
        """Write one parameter, then read it back.

        The value is checked first against the parameter's type, wire range and domain
        (:meth:`Parameter.check`): outside it, the :class:`DomainError` and nothing is sent.
        ``force`` lets a value outside a soft domain through, never outside a hard one.
        """
        p: Parameter | None = find_parameter(name) if isinstance(name, str) else None
        if p is None:
            raise ValidationError(f"parameter {name!r}: no such parameter")
        if not p.writable:
            raise ValidationError(f"parameter {name}: read-only")
        v = number({name: value}, name)
        if p.dtype.name != "F32" and v != int(v):
            raise ValidationError(f"{name}={value!r}: expected a whole number ({p.dtype.name.lower()})")
        sent = p.check(int(v) if p.dtype.name != "F32" else v, force)  # DomainError naming the domain
        forced = ", force=True" if force and p.has_domain and not p.in_domain(sent) else ""
        self._control(who, f"{self._keys.label(i)} write_property({name!r}, {value}{forced})")
        m = self._keys.motor(i)
        baseline = self.saved.setdefault(i, {})
        if p.name not in baseline:  # what it held before this session's first write of it
            baseline[p.name] = m.read_property(name)
        m.write_property(name, sent, force=bool(forced))
        back = m.read_property(name)
        if any(name == n for _, n in LIMIT_READS):
            self._limits.read(i)
        changed = back != baseline[p.name]
        return {"id": i, "name": name, "value": back, "limits": self._limits.shown(i), "changed": changed}

    def save(self, who: str, i: int) -> None:
        """Store motor ``i``'s RAM configuration in flash; what it holds becomes the saved set."""
        self._control(who, f"{self._keys.label(i)} save_config()")
        self._keys.motor(i).save_config()
        self.saved[i] = self._keys.motor(i).backup().values()

    def backup(self, i: int) -> dict[str, Any]:
        return self._keys.motor(i).backup().to_json()

    def restore(self, who: str, i: int, doc: Any, dry_run: bool) -> dict[str, Any]:
        """Restore a backup document: with ``dry_run`` only the diff (name, now, backup) is returned."""
        if not isinstance(doc, dict):
            raise ValidationError("restore: expected a backup document (JSON object)")
        backup = ConfigBackup.from_json(doc)
        if not dry_run:
            self._control(who, f"{self._keys.label(i)} restore(backup of motor {backup.node} from {backup.created})")
        report = self._keys.motor(i).restore(backup, dry_run=dry_run)
        return {
            "id": i,
            "dry_run": dry_run,
            "diff": [list(w) for w in report.written],
            "failed": [list(f) for f in report.failed],
        }
