"""Command ids, system sub-commands and the 11-bit arbitration id layout.

An arbitration id is ``(node << 5) | command``: bits 10..5 hold the node id
(0..63, 0 = broadcast) and bits 4..0 the command.
"""

from __future__ import annotations

import re
from enum import IntEnum
from typing import NamedTuple

from ..errors import FieldRangeError, ProtocolError, ValidationError

__all__ = [
    "TimedFrame",
    "timed",
    "BROADCAST",
    "MAX_NODE",
    "Cmd",
    "SysCmd",
    "StartKind",
    "arbitration_id",
    "split_arbitration_id",
    "check_node",
    "Frame",
    "parse_int",
    "parse_float",
    "STATE_CMDS",
    "HOST_CMDS",
]

BROADCAST = 0
"""Node id 0 addresses every motor on the bus."""
MAX_NODE = 63


class Cmd(IntEnum):
    """The 5-bit command field of host frames."""

    SYSTEM = 0x08
    PRESET = 0x0C
    POSITION_T = 0x19
    POSITION_Q = 0x1A
    POSITION_P = 0x1B
    VELOCITY = 0x1C
    TORQUE = 0x1D
    READ = 0x1E
    WRITE = 0x1F


class SysCmd(IntEnum):
    """``sys_num`` of the system command 0x08."""

    INIT_CONFIG = 0x00
    SAVE_CONFIG = 0x01
    ERASE_CONFIG = 0x02
    REBOOT = 0x03
    CLEAR_ERRORS = 0x04
    SET_ZERO_POSITION = 0x05
    ESTOP = 0x06
    ENTER_DFU_MODE = 0x07
    START_T = 0x10
    START_Q = 0x11
    START_P = 0x12
    START_V = 0x13
    START_C = 0x14
    START_D = 0x15


class StartKind(IntEnum):
    """Which preset interpretation a broadcast start selects (its ``sys_num``)."""

    T = 0x10
    Q = 0x11
    P = 0x12
    V = 0x13
    C = 0x14
    D = 0x15


class Frame(NamedTuple):
    """One CAN frame as it travels: 11-bit (or 29-bit) id and its data bytes."""

    arbitration_id: int
    data: bytes
    is_extended: bool = False
    is_remote: bool = False


class TimedFrame(Frame):
    """A received frame with ``time``: when it was on the wire by its transport's own clock (the
    simulator's time, a CAN interface's receive timestamp), on the scale of :func:`time.monotonic` (s).
    The client keeps it as the time of a state (``bus.frame_time(id)``): a fit of dynamics uses it
    rather than when a busy host got round to reading the frame."""

    time: float


def timed(frame: Frame, time: float) -> TimedFrame:
    """``frame`` with its ``time`` (s, monotonic scale)."""
    out = TimedFrame(*frame)
    out.time = time
    return out


def check_node(node: object, field: str = "node") -> int:
    """Return ``node`` if it is a valid node id (0..63, 0 = broadcast), else raise."""
    if isinstance(node, bool) or not isinstance(node, int):
        raise FieldRangeError(field, node, 0, MAX_NODE, "motor ids are integers, 0 is broadcast")
    if not 0 <= node <= MAX_NODE:
        raise FieldRangeError(field, node, 0, MAX_NODE, "motor ids are 0..63, 0 is broadcast")
    return node


def arbitration_id(node: int, cmd: int) -> int:
    """Pack node (0..63) and command (0..31) into an 11-bit arbitration id."""
    check_node(node)
    if not 0 <= cmd <= 0x1F:
        raise FieldRangeError("command", cmd, 0, 0x1F, "5-bit command field")
    return (node << 5) | cmd


def split_arbitration_id(arb_id: int) -> tuple[int, int]:
    """Split an 11-bit arbitration id into ``(node, command)``."""
    if not 0 <= arb_id <= 0x7FF:
        raise ProtocolError(f"arbitration id 0x{arb_id:X} is not an 11-bit standard id")
    return arb_id >> 5, arb_id & 0x1F


# Text to numbers: ASCII only. ``int()`` and ``float()`` also take other scripts' digits
# ("\u0661" is 1) and underscores ("1_0" is 10); a motor id or a target typed or read from a file
# must be what it looks like to a reader of the wire's hex and the docs.
_INT = {
    10: re.compile(r"[+-]?[0-9]+"),
    16: re.compile(r"[+-]?(?:0[xX])?[0-9A-Fa-f]+"),
    0: re.compile(r"[+-]?(?:0[xX][0-9A-Fa-f]+|0[oO][0-7]+|0[bB][01]+|[1-9][0-9]*|0+)"),
}
_FLOAT = re.compile(r"[+-]?(?:(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?|inf|infinity|nan)", re.IGNORECASE)
_SPACE = " \t\r\n"


def parse_int(text: str, field: str = "value", *, base: int = 10) -> int:
    """A whole number written with ASCII digits (``base`` 10, 16, or 0 for a ``0x``/``0o``/``0b`` prefix).

    Surrounding spaces are allowed; other scripts' digits, underscores and
    anything else raise :class:`~drempower.errors.ValidationError` (a
    ``ValueError``) naming ``field`` and the text.
    """
    pattern = _INT.get(base)
    if pattern is None:
        raise ValueError(f"base {base} is not one of 0, 10, 16")
    t = text.strip(_SPACE) if isinstance(text, str) else None
    if t is None or pattern.fullmatch(t) is None:
        kind = {10: "a whole number", 16: "a hex number", 0: "a whole number (0x, 0o, 0b prefixes allowed)"}[base]
        raise ValidationError(f"{field}: {text!r} is not {kind} in ASCII digits")
    return int(t, base)


def parse_float(text: str, field: str = "value") -> float:
    """A number written with ASCII digits (``12``, ``-1.5e3``, ``.5``; ``inf`` and ``nan`` too: check finiteness).

    Other scripts' digits, underscores and anything else raise
    :class:`~drempower.errors.ValidationError` (a ``ValueError``) naming ``field`` and the text.
    """
    t = text.strip(_SPACE) if isinstance(text, str) else None
    if t is None or _FLOAT.fullmatch(t) is None:
        raise ValidationError(f"{field}: {text!r} is not a number in ASCII digits")
    return float(t)


STATE_CMDS = frozenset(range(0x01, 0x18, 2))
"""Command values that are a motor's state frame whoever sent them: bit 0 set, bits 3-4 not both set
(0x01..0x17, odd).

0x19, 0x1B, 0x1D and 0x1F are also the host commands T, P, C and write: the client takes one as a
state only by the rule of spec/PROTOCOL.md section 1.6 (:mod:`drempower.client.engine.status_bits`); a
sniffer without requests to pair them with shows them as host commands."""
HOST_CMDS = frozenset((0x08, 0x0C, 0x19, 0x1A, 0x1B, 0x1C, 0x1D, 0x1E, 0x1F))
"""Command values a host sends (0x1E is also the motor's parameter reply)."""
