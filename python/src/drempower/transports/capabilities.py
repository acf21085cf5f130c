"""What a transport can do, declared in one object the client reads once when it opens a bus."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

__all__ = ["Capabilities"]


@dataclass(frozen=True)
class Capabilities:
    """A transport's abilities (see :attr:`drempower.transports.Transport.capabilities`).

    A transport declares them; the client never probes a transport for methods or checks its type.
    """

    in_order: bool = False
    """Frames reach the bus one at a time in the order sent (a UART to one motor)."""
    wire_bitrate: int | None = None
    """The bus's bit rate (bit/s) when the transport knows it; used to time what is queued."""
    tx_latency: float = 0.005
    """Longest time (s) a sent frame may wait in drivers, adapters or servers before it competes for the bus."""
    unbounded_latency: bool = False
    """A sent frame may wait longer than any ``tx_latency`` (a TCP hop and a server's queue): a start then
    waits for the replies to reads sent after its presets."""
    confirms_sent: bool = False
    """:meth:`~drempower.transports.Transport.wait_sent` tells when every frame sent is on the wire."""
    answers_in_send: bool = False
    """:meth:`~drempower.transports.Transport.send_collect` returns the frames the send caused (the in-process
    simulator with instant delivery answers inside the send)."""
    partial_frames: bool = False
    """A frame arrives in pieces over time (a serial line): :meth:`~drempower.transports.Transport.rest_time`
    says how long the rest of a partly received one takes."""
    virtual_clock: bool = False
    """The transport runs on its own simulated time: :meth:`~drempower.transports.Transport.clock` gives it."""
    motor_ids: frozenset[int] = frozenset()
    """The motors the transport knows are on the bus (the in-process simulator's); empty when unknown."""
    limits: Mapping[int, Mapping[str, Any]] = field(default_factory=dict)
    """Soft limits the far end holds each motor to (motor units, with ``where`` they were set), which a bus on
    the transport holds its commands to as well: a remote bus's bridge declares its robot file's."""
