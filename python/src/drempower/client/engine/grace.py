"""The zero-reply grace: replies of value 0 held back while another host may be reading the same parameter.

A parameter reply of value 0 has the bytes of a read request, so another host's
read of the parameter a request waits for looks exactly like its answer. Once
another host was seen on the bus, such a reply is held back for
:data:`ZERO_REPLY_GRACE`: a non-zero reply in the meantime is the answer, else
the held one is taken when its grace ends or its request expires.
"""

from __future__ import annotations

from collections.abc import Sequence

from ...protocol.messages import ParamValue
from ...protocol.parameters import DataType
from .requests import MISMATCHED, Matcher
from .stats import BusStats
from .timers import Timers

__all__ = ["ZERO_REPLY_GRACE", "ZeroReplyGrace"]

ZERO_REPLY_GRACE = 0.01
"""How long (s) a parameter reply of value 0 is held back once another host is seen on the bus."""


class ZeroReplyGrace:
    """Held-back replies of value 0 per (node, address), each with the time (s) its grace ends."""

    __slots__ = ("grace", "held", "matcher", "other_hosts", "stats", "timers")

    def __init__(self, matcher: Matcher, stats: BusStats, timers: Timers, grace: float = ZERO_REPLY_GRACE) -> None:
        self.matcher = matcher
        self.stats = stats
        self.timers = timers
        self.grace = grace
        """How long (s) a reply of value 0 is held back."""
        self.other_hosts = False
        """True once frames of another host were seen: from then on replies of value 0 are held back."""
        self.held: dict[tuple[int, int], tuple[float, ParamValue]] = {}

    def hold(self, node: int, address: int, dtype: DataType, reply: ParamValue, now: float) -> bool:
        """Hold back ``reply`` (of value 0, from ``node`` for ``address``, received at ``now`` s) when another
        host is about and a request waits for it; True when it is held (or another such reply already is:
        the first one's grace runs on)."""
        key = (node, address)
        if key in self.held:
            return True
        if self.other_hosts and self.matcher.waiting(node, address, dtype):
            self.held[key] = (now + self.grace, reply)
            self.timers.touch()  # a new deadline
            return True
        return False

    def next_due(self) -> float | None:
        """When the earliest grace ends (s), or None."""
        held = self.held
        return min(d for d, _ in held.values()) if held else None

    def settle(self, now: float, keys: Sequence[tuple[int, int]] | None = None) -> None:
        """Take held-back replies as answers: those due by ``now`` (s), or those for ``keys`` (node, address)."""
        held = self.held
        for key, (due, reply) in list(held.items()):
            wanted = due <= now if keys is None else key in keys or (0, key[1]) in keys
            if (
                wanted
                and held.pop(key, None) is not None
                and self.matcher.resolve_reply(key[0], key[1], reply.dtype, reply) == MISMATCHED
            ):
                self.stats.anomalies += 1
