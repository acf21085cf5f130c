"""A motor's health: its temperatures, its effective current limit, how far it derates, its errors.

:func:`read_health` reads it in one exchange of five parameter reads (ten frames)
addressed to one motor; only when ``axis0.error`` is non-zero does a second
exchange read the seven error words to name the flags (PROTOCOL.md 1.5: a read
carries one address, so five values take five requests; their replies arrive
together). :func:`read_healths` does the same for several motors in one exchange.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

from ...protocol.addresses import (
    AXIS0_ERROR,
    AXIS0_FET_THERMISTOR_TEMPERATURE,
    AXIS0_MOTOR_CONFIG_CURRENT_LIM,
    AXIS0_MOTOR_EFFECTIVE_CURRENT_LIM,
    AXIS0_MOTOR_THERMISTOR_TEMPERATURE,
)
from ...protocol.flags import flag_info
from ...protocol.messages import ParamValue, ReadParam
from ...protocol.parameters import parameter
from .effects import Op, request
from .ops import dump_error

__all__ = ["Fault", "Health", "HEALTH_KEYS", "HEALTH_PARAMETERS", "read_health", "read_healths"]

HEALTH_PARAMETERS: tuple[int, ...] = (
    AXIS0_MOTOR_THERMISTOR_TEMPERATURE,
    AXIS0_FET_THERMISTOR_TEMPERATURE,
    AXIS0_MOTOR_EFFECTIVE_CURRENT_LIM,
    AXIS0_MOTOR_CONFIG_CURRENT_LIM,
    AXIS0_ERROR,
)
"""What one health reading reads, in this order: 37002, 36002, 33003, 33110, 30001."""

HEALTH_KEYS: tuple[str, ...] = (
    "motor_temp_c",
    "driver_temp_c",
    "current_limit_a",
    "derating",
    "errors",
)
"""The keys of a reading, as ``drempower health`` and ``monitor --fields`` print them."""

_LABELS = {
    "axis0.error": "axis",
    "axis0.motor.error": "motor",
    "axis0.encoder.error": "encoder",
    "axis0.controller.error": "controller",
    "can.error": "can",
    "axis0.fet_thermistor.error": "fet_thermistor",
    "axis0.motor_thermistor.error": "motor_thermistor",
}


@dataclass(frozen=True, slots=True)
class Fault:
    """One error flag of one motor, with what it means and how to fix it."""

    motor: int
    word: str
    """The error word's parameter name, e.g. ``axis0.motor_thermistor.error``."""
    flag: str
    """The flag's name, e.g. ``OVER_TEMP``."""
    meaning: str
    fix: str
    joint: str | None = None

    def __str__(self) -> str:
        who = f"joint {self.joint} (motor {self.motor})" if self.joint else f"motor {self.motor}"
        return f"{who}: {self.word} {self.flag}: {self.meaning} Fix: {self.fix}"


@dataclass(frozen=True, slots=True)
class Health:
    """One reading of a motor's health.

    ``motor_temp_c`` and ``driver_temp_c`` in degC (winding and driver board
    thermistors), ``current_limit_a`` the effective current limit (A, after the
    thermal derating), ``configured_limit_a`` the configured one (current_lim),
    ``errors`` the set flags per non-zero error word (empty: no error).
    """

    id: int
    motor_temp_c: float
    driver_temp_c: float
    current_limit_a: float
    configured_limit_a: float
    errors: dict[str, list[str]] = field(default_factory=dict)
    name: str | None = None
    """The joint's name (a joint's reading), else None."""
    derating: float = field(init=False)
    """How much of the current the temperature takes away: 0 = none, 1 = no current left
    (``1 - current_limit_a / configured_limit_a``)."""

    def __post_init__(self) -> None:
        base = self.configured_limit_a
        d = min(1.0, max(0.0, 1.0 - self.current_limit_a / base)) if base > 0.0 else 0.0
        object.__setattr__(self, "derating", d)

    @property
    def faults(self) -> list[Fault]:
        """Every set error flag with its meaning and fix (the generic axis summaries left out when a
        sub-word says more)."""
        out: list[Fault] = []
        for word, flags in self.errors.items():
            label = _LABELS.get(word, word)
            for flag in flags:
                if label == "axis" and flag.endswith("_FAILED") and len(self.errors) > 1:
                    continue
                info = flag_info(label, flag)
                out.append(Fault(self.id, word, flag, info.meaning, info.action, self.name))
        return out

    def as_dict(self) -> dict[str, Any]:
        """The reading as plain values (JSON): id, name, the :data:`HEALTH_KEYS` and the fixes."""
        return {
            "id": self.id,
            **({"joint": self.name} if self.name else {}),
            "motor_temp_c": round(self.motor_temp_c, 2),
            "driver_temp_c": round(self.driver_temp_c, 2),
            "current_limit_a": round(self.current_limit_a, 3),
            "derating": round(self.derating, 3),
            "errors": [f"{_LABELS.get(w, w)}.{f}" for w, flags in self.errors.items() for f in flags],
            "faults": [str(f) for f in self.faults],
        }


def _requests(node: int) -> list[ReadParam]:
    return [ReadParam(node, a, parameter(a).dtype) for a in HEALTH_PARAMETERS]


def read_healths(nodes: Sequence[int], timeout: float | None = None) -> Op[list[Health]]:
    """Health of ``nodes``: one exchange of five reads per motor, plus one of the error words per faulted motor."""
    msgs = [r for n in nodes for r in _requests(n)]
    replies: list[ParamValue] = yield from request(msgs, timeout)
    out: list[Health] = []
    k = len(HEALTH_PARAMETERS)
    for i, node in enumerate(nodes):
        mt, dt, lim, base, axis = (r.value for r in replies[i * k : (i + 1) * k])
        errors: dict[str, list[str]] = {}
        if int(axis):
            report = yield from dump_error(node, timeout)
            errors = report.flags
        out.append(Health(node, float(mt), float(dt), float(lim), float(base), errors))
    return out


def read_health(node: int, timeout: float | None = None) -> Op[Health]:
    """Health of one motor (see :func:`read_healths`)."""
    (h,) = yield from read_healths([node], timeout)
    return h
