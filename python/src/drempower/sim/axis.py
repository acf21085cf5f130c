"""The axis state of a simulated motor: where its state machine is and what was last asked of it."""

from __future__ import annotations

from ..protocol.enums import AxisState

__all__ = ["Axis"]


class Axis:
    """The current axis state (axis0.current_state) and the last requested one (axis0.requested_state)."""

    __slots__ = ("requested", "state")

    def __init__(self) -> None:
        self.state = AxisState.IDLE
        self.requested = 0
