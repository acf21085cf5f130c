"""The one naming rule for motors, in every table, CSV, JSON, MCAP topic, JointState and log.

A motor is ``motor_<id>`` (``motor_1``) unless a robot file names it (its joint's
name), and ``<bus>/motor_<id>`` where motors of several buses would otherwise share
a name (two buses each with a motor 1).

A reading is named once too, with its unit (:data:`COLUMNS`): ``position_deg``,
``speed_rpm``... in ``state --json``, ``monitor`` (table, ``--fields``, ``--json``,
``--csv``) and the dashboard's CSV; and shown as text one way (:func:`number_text`).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping

from .protocol.enums import AxisState
from .protocol.limits import check_motor

__all__ = ["COLUMNS", "TIME_COLUMN", "motor_name", "motor_names", "number_text", "state_name"]

COLUMNS: dict[str, tuple[str, str]] = {
    "id": ("id", "id"),
    "position": ("position_deg", "position/deg"),
    "speed": ("speed_rpm", "speed/rpm"),
    "torque": ("torque_nm", "torque/Nm"),
    "done": ("done", "done"),
    "error": ("error", "error"),
    "state": ("state", "state"),
    "vbus_voltage": ("vbus_v", "vbus/V"),
    "errors": ("errors", "errors"),
}
"""The one naming of readings across ``state``, ``monitor`` (table, ``--fields``, ``--json``, ``--csv``)
and the dashboard's CSV: channel or parameter -> (JSON and CSV key with its unit, table header with its unit)."""
TIME_COLUMN = ("time_s", "time/s")
"""The time of a sample (s from the start of a capture): its JSON and CSV key, its table header."""


def motor_name(id: int, bus: str | None = None, *, named: str | None = None) -> str:
    """``named`` when a robot file gives one, else ``motor_<id>``, prefixed ``<bus>/`` when ``bus`` is given
    (give it where buses would collide; :func:`motor_names` decides that for a whole set)."""
    if named:
        return named
    base = f"motor_{check_motor(id)}"
    return f"{bus}/{base}" if bus else base


def motor_names(
    motors: Iterable[tuple[str, int]], joints: Mapping[tuple[str, int], str] | None = None
) -> dict[tuple[str, int], str]:
    """The name of each ``(bus, id)``: its joint's name from ``joints`` if any, else ``motor_<id>``,
    with ``<bus>/`` only when the same id is on more than one bus."""
    pairs = list(dict.fromkeys(motors))
    joints = joints or {}
    buses_of: dict[int, set[str]] = {}
    for bus, node in pairs:
        buses_of.setdefault(node, set()).add(bus)
    return {
        (bus, node): motor_name(node, bus if len(buses_of[node]) > 1 else None, named=joints.get((bus, node)))
        for bus, node in pairs
    }


def number_text(value: float, digits: int | None = 2, width: int = 0) -> str:
    """``value`` with ``digits`` decimals (None: 7 significant digits), right-aligned in ``width``.

    A value that rounds to zero is shown without a sign: ``-0.001`` -> ``"0.00"``, never ``"-0.00"``.
    """
    text = f"{value:.7g}" if digits is None else f"{value:.{digits}f}"
    if text.startswith("-") and math.isfinite(value) and float(text) == 0:
        text = text[1:]
    return text.rjust(width)


def state_name(value: float | None) -> str | None:
    """``8`` -> ``"closed_loop"``, ``1`` -> ``"idle"``; other axis states by their lower-case name."""
    if value is None:
        return None
    try:
        state = AxisState(int(value))
    except ValueError:
        return f"state_{value}"
    return "closed_loop" if state is AxisState.CLOSED_LOOP_CONTROL else state.name.lower()
