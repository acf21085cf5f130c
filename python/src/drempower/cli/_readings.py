"""What ``scan``, ``state``, ``monitor`` and the motion commands read from a motor, in one exchange."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from ..client import Bus, MotorState
from ..client.errors import TimeoutError
from ..errors import DrEmpowerError, MotorIdleError
from ..naming import state_name
from ..protocol import DataType, FastRead, ReadParam
from ..protocol.addresses import AXIS0_CURRENT_STATE, CAN_CONFIG_TIMEOUT_MS
from ..protocol.enums import AxisState
from ._fields import COLUMNS

__all__ = ["FIELDS", "HEADERS", "Reading", "read", "require_ready", "warn_leftover_watchdog"]

_VBUS = 1
_CURRENT_STATE = AXIS0_CURRENT_STATE

_COLUMNS = ("id", "position", "speed", "torque", "done", "state", "vbus_voltage", "errors")

HEADERS = tuple(COLUMNS[c][1] for c in _COLUMNS)
"""Table columns of :meth:`Reading.record`, in order (named in :data:`~drempower.cli._fields.COLUMNS`)."""

FIELDS = tuple(COLUMNS[c][0] for c in _COLUMNS)
"""Keys of :meth:`Reading.record`, in order: ``id``, ``position_deg``, ``speed_rpm``, ..."""


@dataclass(frozen=True, slots=True)
class Reading:
    """One motor's state frame, supply voltage, axis state and (when its E bit is set) error flags.

    ``state`` is None when the motor did not answer; ``flags`` is None when no
    error word was read (no error, or the read failed), else the set flag names.
    """

    id: int
    state: MotorState | None
    vbus: float | None
    axis_state: int | None
    flags: list[str] | None

    @property
    def answered(self) -> bool:
        return self.state is not None

    def error_text(self) -> str:
        st = self.state
        if st is None:
            return "no answer"
        if not st.error:
            return ""
        return " ".join(self.flags) if self.flags else "error (flags unread)"

    def record(self) -> dict[str, Any]:
        """JSON-ready fields, in the order of :data:`HEADERS`."""
        st = self.state
        values = (
            self.id,
            None if st is None else round(st.angle, 4),
            None if st is None else st.speed,
            None if st is None else st.torque,
            None if st is None else st.trajectory_done,
            state_name(self.axis_state),
            None if self.vbus is None else round(self.vbus, 3),
            self.error_text(),
        )
        return dict(zip(FIELDS, values, strict=True))


def _flags(bus: Bus, node: int) -> list[str] | None:
    try:
        report = bus.motor(node).dump_error()
    except TimeoutError:
        return None
    return [name for names in report.flags.values() for name in names]


def read(bus: Bus, ids: Sequence[int], *, missing_ok: bool = False) -> list[Reading]:
    """Fast read, ``vbus_voltage`` and ``axis0.current_state`` of every motor.

    Error words are read for motors whose E bit is set. A motor that does not
    answer raises :class:`~drempower.client.TimeoutError` naming it. With
    ``missing_ok`` it gives a reading without state instead, and costs one
    timeout: the fast reads go first, and only the motors that answered are
    asked for the rest. Without it, everything goes in one exchange.
    """
    if missing_ok:
        states: list[Any] = bus.request([FastRead(i) for i in ids], missing_ok=True)
        there = [i for i, st in zip(ids, states, strict=True) if st is not None]
        more = bus.request(_extra_reads(there), missing_ok=True) if there else []
        extra = dict(zip(there, _pairs(more), strict=True))
    else:
        replies = bus.request([*(FastRead(i) for i in ids), *_extra_reads(ids)])
        states, extra = replies[: len(ids)], dict(zip(ids, _pairs(replies[len(ids) :]), strict=True))
    out = []
    for node, st in zip(ids, states, strict=True):
        vb, ax = extra.get(node, (None, None))
        flags = _flags(bus, node) if st is not None and st.error else None
        out.append(
            Reading(node, st, None if vb is None else float(vb.value), None if ax is None else int(ax.value), flags)
        )
    return out


def _extra_reads(ids: Sequence[int]) -> list[ReadParam]:
    """The supply voltage, then the axis state, of each motor: one request each, ids in order."""
    return [ReadParam(i, a, t) for i in ids for a, t in ((_VBUS, DataType.F32), (_CURRENT_STATE, DataType.U32))]


def _pairs(replies: Sequence[Any]) -> list[tuple[Any, Any]]:
    """``[v1, s1, v2, s2...]`` -> ``[(v1, s1), (v2, s2)...]``."""
    return list(zip(replies[::2], replies[1::2], strict=True))


def require_ready(bus: Bus, ids: Sequence[int], args: argparse.Namespace | None = None) -> list[Reading]:
    """Check that every motor answers, has no error and is in closed loop; say what to run otherwise.

    The commands suggested carry the connection options of ``args`` (the command line's).
    """
    from ._connect import follow_up

    def cmd(text: str) -> str:
        return f"`drempower {text}`" if args is None else f"`{follow_up(args, text)}`"

    readings = read(bus, ids)
    if args is None or not getattr(args, "watchdog", None):  # --watchdog arms (and restores) its own
        warn_leftover_watchdog(bus, ids, args)
    for r in readings:
        if r.state is not None and r.state.error:
            raise DrEmpowerError(
                f"motor {r.id} reports errors ({r.error_text()}): see {cmd(f'errors {r.id}')}, "
                f"then {cmd(f'clear {r.id}')} and {cmd(f'enable {r.id}')}"
            )
        if r.axis_state is not None and r.axis_state != AxisState.CLOSED_LOOP_CONTROL:
            raise MotorIdleError([r.id], [r.axis_state], fix=f"(run {cmd(f'enable {r.id}')})")
    return readings


def warn_leftover_watchdog(bus: Bus, ids: Sequence[int], args: argparse.Namespace | None = None) -> dict[int, int]:
    """Say on stderr which motors have a CAN watchdog (``can.config.timeout_ms``) armed, and how to clear it.

    A command killed with SIGKILL while its ``--watchdog`` was armed leaves
    the timeout set: every later command then sees its motors go idle that
    long after its last frame. The value is only reported, never changed (it
    may be a deliberate setting). Returns the armed values by motor.
    """
    from ._connect import follow_up

    replies = bus.request([ReadParam(i, CAN_CONFIG_TIMEOUT_MS, DataType.U32) for i in ids], missing_ok=True)
    armed = {i: int(r.value) for i, r in zip(ids, replies, strict=True) if r is not None and int(r.value)}
    for node, ms in armed.items():
        clear = f"drempower set {node} can.config.timeout_ms 0"
        print(
            f"drempower: warning: motor {node} has can.config.timeout_ms = {ms}: it goes idle {ms} ms after "
            f"the last frame it receives (a --watchdog left by a killed command?); to clear it: "
            f"`{clear if args is None else follow_up(args, clear[len('drempower ') :])}`",
            file=sys.stderr,
        )
    return armed
