"""The session's counters of what came in (and of moves sent again): what ``bus.stats`` shows."""

from __future__ import annotations

import dataclasses

__all__ = ["BusStats"]


@dataclasses.dataclass(slots=True)
class BusStats:
    """Counts since the session began; each only grows."""

    frames_received: int = 0
    """Every frame given to the session."""
    malformed: int = 0
    """Frames that decode to no reply and no state (remote, extended, short, unknown)."""
    unmatched: int = 0
    """Frames that answered no request and are no state (malformed, foreign, late or mismatched replies)."""
    anomalies: int = 0
    """Replies for a waiting request whose echoed fields (data type) differ from it: never taken as answers."""
    foreign: int = 0
    """Frames another host sent (its commands, fast reads and reads): they answer nothing, update no state."""
    moves_resent: int = 0
    """Moves sent again because a wait found them lost (see :func:`~drempower.client.engine.ops.wait_done`)."""
