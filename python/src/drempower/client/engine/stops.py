"""What stopping sends: the emergency stop, the idle writes, and what closing the bus sends (``stop_on_close``)."""

from __future__ import annotations

from collections.abc import Iterable
from typing import Literal

from ...protocol.addresses import AXIS0_REQUESTED_STATE
from ...protocol.ids import Frame, SysCmd
from ...protocol.messages import SystemCommand, Velocity, WriteParam
from ...protocol.parameters import DataType

__all__ = ["StopOnClose", "estop_frames", "hold_frames", "idle_frames", "stop_frames"]

StopOnClose = bool | Literal["idle", "estop"]
"""What closing the bus does to the motors it commanded: see :class:`~drempower.client.engine.session.BusSession`."""

_IDLE = 1  # axis0.requested_state value for IDLE


def estop_frames(nodes: Iterable[int]) -> list[Frame]:
    """An emergency stop to each of motors ``nodes`` (0: every motor)."""
    return [SystemCommand(n, SysCmd.ESTOP).encode() for n in nodes]


def idle_frames(nodes: Iterable[int]) -> list[Frame]:
    """The writes of ``axis0.requested_state`` = IDLE that stop motors ``nodes`` driving (0: every motor)."""
    return [WriteParam(n, AXIS0_REQUESTED_STATE, DataType.U32, _IDLE).encode() for n in nodes]


def hold_frames(nodes: Iterable[int]) -> list[Frame]:
    """Speed 0 to each of motors ``nodes``: a motor in closed loop holds where it is (a joint's ``hold``)."""
    return [Velocity(n, 0.0).encode() for n in nodes]


def stop_frames(stop_on_close: StopOnClose, commanded: Iterable[int], hold: Iterable[int] = ()) -> list[Frame]:
    """The frames ``stop_on_close`` sends to the ``commanded`` motors: idle writes, estops or nothing.

    With ``True``, the motors in ``hold`` (a robot file's joints whose ``on_timeout`` is ``hold``) get
    speed 0 instead of idle, so an arm under gravity is not dropped; ``"idle"`` idles every motor."""
    if not stop_on_close:
        return []
    nodes = sorted(commanded)
    if stop_on_close == "estop":
        return estop_frames(nodes)
    held = set(hold) if stop_on_close is True else set()
    return hold_frames([n for n in nodes if n in held]) + idle_frames([n for n in nodes if n not in held])
