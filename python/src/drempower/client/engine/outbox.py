"""The frames the session wants written, and the bus time those already handed over take."""

from __future__ import annotations

from ...protocol.ids import Frame

__all__ = ["ASSUMED_BITRATE", "Outbox"]

ASSUMED_BITRATE = 125_000
"""Bit rate (bit/s) assumed when the transport does not know the bus's: the slowest the motors use."""
_WORST_FRAME_BITS = 135
"""Longest standard 8-byte CAN data frame with stuff bits and interframe space."""


class Outbox:
    """Frames queued in order (``frames``), taken by the driver with :meth:`take`.

    ``handed`` counts the frames taken so far; ``wire_free`` is when (s) the
    bus is through with them at ``bitrate`` (bit/s, None: :data:`ASSUMED_BITRATE`),
    each frame counted at its longest.
    """

    __slots__ = ("bitrate", "frames", "handed", "wire_free")

    def __init__(self, bitrate: int | None = None, now: float = 0.0) -> None:
        self.frames: list[Frame] = []
        self.handed = 0
        """Frames handed to the transport so far."""
        self.wire_free = now
        """When the frames handed over are all on the wire at the latest (s)."""
        self.bitrate = bitrate or ASSUMED_BITRATE

    def take(self, now: float) -> list[Frame]:
        """The queued frames, in order, taken as handed over at ``now`` (s)."""
        out = self.frames
        if not out:
            return out
        self.frames = []
        self.handed += len(out)
        self.wire_free = max(now, self.wire_free) + len(out) * _WORST_FRAME_BITS / self.bitrate
        return out
