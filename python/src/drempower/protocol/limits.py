"""Where the protocol's numbers end: node ids, what each command does, and the bounds of command fields.

One home for them, so the client, the robot layer, the simulator, the records and
every front end refuse the same values with the same words:

* node ids: 0..63 on the wire, 0 = broadcast; a motor's own id is 1..63
  (:func:`check_motor`; :func:`~drempower.protocol.ids.check_node` takes broadcast too);
* command sets: which commands move motors (:data:`MOTION_CMDS`), which system
  commands start presets (:data:`START_SYS_CMDS`) or stop (:data:`STOP_SYS_CMDS`),
  which leave a motor out of closed loop (:data:`OPEN_LOOP_SYS_CMDS`),
  which are answered by a state frame when ``enable_reply_state`` is on
  (:data:`REPLY_STATE_CMDS`);
* numeric bounds: an s16 field scaled by 0.01 holds :data:`S16_MIN`..:data:`S16_MAX`
  (PROTOCOL.md 1.8), and that is also the domain of a commanded speed (r/min) and
  torque (Nm): see :data:`SPEED_RANGE`.
"""

from __future__ import annotations

from typing import TypeGuard

from ..errors import FieldRangeError
from .ids import BROADCAST, MAX_NODE, Cmd, SysCmd

__all__ = [
    "BROADCAST",
    "MAX_NODE",
    "MIN_MOTOR",
    "MOTOR_IDS",
    "MOTOR_RANGE_TEXT",
    "MOTION_CMDS",
    "START_SYS_CMDS",
    "STOP_SYS_CMDS",
    "OPEN_LOOP_SYS_CMDS",
    "REPLY_STATE_CMDS",
    "S16_MIN",
    "S16_MAX",
    "SPEED_RANGE",
    "TORQUE_RANGE",
    "check_motor",
    "is_motor",
    "check_speed",
    "check_torque",
]

MIN_MOTOR = 1
"""The smallest id a motor can have (0 is the broadcast address)."""
MOTOR_IDS = range(MIN_MOTOR, MAX_NODE + 1)
"""Every id a motor can have: 1..63."""
MOTOR_RANGE_TEXT = f"motor ids are {MIN_MOTOR}..{MAX_NODE}, 0 is broadcast"
"""How an error message words the range of motor ids."""

MOTION_CMDS: frozenset[int] = frozenset(
    int(c) for c in (Cmd.PRESET, Cmd.POSITION_T, Cmd.POSITION_Q, Cmd.POSITION_P, Cmd.VELOCITY, Cmd.TORQUE)
)
"""Preset and control commands: they move motors (a preset once its start arrives)."""
START_SYS_CMDS: frozenset[int] = frozenset(range(int(SysCmd.START_T), int(SysCmd.START_D) + 1))
"""System sub-commands (``sys_num``) that start the pending presets: they move motors too."""
STOP_SYS_CMDS: frozenset[int] = frozenset((int(SysCmd.ESTOP),))
"""System sub-commands that stop a motor (an idle request is a parameter write, ``axis0.requested_state`` = 1)."""
OPEN_LOOP_SYS_CMDS: frozenset[int] = STOP_SYS_CMDS | frozenset(
    int(c) for c in (SysCmd.CLEAR_ERRORS, SysCmd.REBOOT, SysCmd.INIT_CONFIG, SysCmd.ERASE_CONFIG)
)
"""System sub-commands after which a motor is no longer in closed loop (an estop, a clear, a reboot,
a configuration reset)."""
REPLY_STATE_CMDS: frozenset[int] = MOTION_CMDS
"""Commands a motor answers with a state frame when ``enable_reply_state`` (31214) is on."""

S16_MIN = -327.68
"""Smallest value of an s16 field scaled by 0.01."""
S16_MAX = 327.67
"""Largest value of an s16 field scaled by 0.01."""

SPEED_RANGE = (S16_MIN, S16_MAX)
"""A commanded speed, r/min. The V frame carries it as float32, but every other frame that holds a
speed (state frames, P-mode and impedance feed-forward, Q cruise) is s16 x 0.01: a speed outside
it could not be reported back nor commanded another way, so it is refused, never sent."""
TORQUE_RANGE = (S16_MIN, S16_MAX)
"""A commanded torque, Nm: as :data:`SPEED_RANGE`, the C frame's float32 held to the s16 x 0.01
range of the state frames and the feed-forward fields."""


def is_motor(node: object) -> TypeGuard[int]:
    """True for an int id a motor can have (1..63; no bool, no broadcast)."""
    return node.__class__ is int and MIN_MOTOR <= node <= MAX_NODE


def check_motor(node: object, field: str = "id") -> int:
    """``node`` if it is a motor's id (1..63), else a :class:`FieldRangeError` naming ``field``."""
    if not is_motor(node):
        raise FieldRangeError(field, node, MIN_MOTOR, MAX_NODE, MOTOR_RANGE_TEXT)
    return node


def _bounded(value: float, field: str, bounds: tuple[float, float], unit: str, given: object) -> float:
    low, high = bounds
    try:
        ok = low <= value <= high
    except TypeError:
        ok = False
    if not ok:
        shown = value if given is None else given
        raise FieldRangeError(field, shown, low, high, f"{unit}; the s16 x 0.01 range of the state frames")
    return float(value)


def check_speed(value: float, field: str = "speed", given: object = None) -> float:
    """A commanded speed (r/min) within :data:`SPEED_RANGE`, else a FieldRangeError naming ``field``
    and ``given`` (what the caller wrote, when ``value`` is its conversion)."""
    return _bounded(value, field, SPEED_RANGE, "r/min", given)


def check_torque(value: float, field: str = "torque", given: object = None) -> float:
    """A commanded torque (Nm) within :data:`TORQUE_RANGE`, else a FieldRangeError naming ``field``
    and ``given`` (what the caller wrote, when ``value`` is its conversion)."""
    return _bounded(value, field, TORQUE_RANGE, "Nm", given)
