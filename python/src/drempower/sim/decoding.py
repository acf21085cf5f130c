"""What the simulated firmware hears in a host frame: its command, or nothing (counted and logged once)."""

from __future__ import annotations

import logging
import math

from ..errors import DrEmpowerError
from ..protocol.ids import Frame
from ..protocol.messages import (
    Command,
    PositionP,
    PositionQ,
    PositionT,
    Preset,
    Torque,
    Velocity,
    WriteParam,
    decode_command,
)

__all__ = ["Decoder"]

_log = logging.getLogger("drempower.sim")

_F32_FIELD: dict[type, str] = {
    PositionT: "position",
    PositionQ: "position",
    PositionP: "position",
    Velocity: "speed",
    Torque: "torque",
    Preset: "p1",
    WriteParam: "value",
}
"""The float32 field of each command that carries one: a NaN or infinity there is ignored."""


class Decoder:
    """Decodes host frames into commands and keeps count of what the firmware ignores."""

    __slots__ = ("_said", "ignored")

    def __init__(self) -> None:
        self.ignored = 0
        """Host frames the simulated firmware could not act on (see :meth:`ignore`)."""
        self._said: set[tuple[int, str]] = set()

    def command(self, frame: Frame) -> Command | None:
        """The command a motor hears in ``frame``; None for what a motor ignores (no DrEmpower command, a
        NaN or infinite float)."""
        if frame.is_extended or frame.is_remote:
            return None
        try:
            msg = decode_command(frame.arbitration_id, frame.data)
        except DrEmpowerError:
            return None
        field = _F32_FIELD.get(msg.__class__)
        if field is not None:
            value = getattr(msg, field)
            if not math.isfinite(value):
                self.ignore(frame, f"{field} is {value}")
                return None
        return msg

    def ignore(self, frame: Frame | None, why: str) -> None:
        """The simulated firmware ignores ``frame`` (None: a motor's own step failed): counted, logged once
        per command value and reason, so that a flood of bad frames never floods the log."""
        self.ignored += 1
        cmd = -1 if frame is None else frame.arbitration_id & 0x1F
        key = (cmd, why if frame is None else why.split(":", 1)[0])
        if key in self._said:
            return
        self._said.add(key)
        what = "a step" if frame is None else f"{frame.arbitration_id:03X}#{frame.data.hex().upper()}"
        _log.warning("simulated firmware ignores %s: %s (said once)", what, why)
