"""The asyncio client: ``async with open_bus_async(...) as bus``.

The same core as the threaded client (one receive thread per bus); replies
are handed to the event loop with ``loop.call_soon_threadsafe``, so no thread
is used per call. :class:`AsyncBus` and :class:`AsyncMotor` (``api_async.py``) are the
one source of both front ends: the threaded :class:`~drempower.client.bus.Bus` and
:class:`~drempower.client.motor.Motor` are generated from them, with the same names,
arguments, defaults and results.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from typing import Any

from ..transports.base import Transport
from .api_async import AsyncBus, AsyncMotor
from .bus import connect
from .profile import FirmwareProfile, apply_profile, load_profile
from .session import StartPolicy, StopOnClose

__all__ = ["AsyncBus", "AsyncMotor", "open_bus_async"]


def open_bus_async(
    interface: str | None = None,
    channel: str | int | None = None,
    bitrate: int | None = None,
    *,
    timeout: float | None = None,
    retries: int = 0,
    stop_on_close: StopOnClose = True,
    start: StartPolicy = "auto",
    transport: Transport | None = None,
    profile: str | os.PathLike[str] | Mapping[str, Any] | FirmwareProfile | None = None,
    **kwargs: Any,
) -> AsyncBus:
    """Open a bus for asyncio (same arguments as :func:`~drempower.client.bus.open_bus`).

    Use as ``async with open_bus_async("sim", motors=[1]) as bus:``.
    """
    prof = load_profile(profile) if profile is not None else None
    transport = connect(interface, channel, bitrate, transport, **kwargs)
    try:
        bus = AsyncBus(transport, timeout=timeout, retries=retries, stop_on_close=stop_on_close, start=start)
        if prof is not None:
            apply_profile(bus._session.inbox.bits, prof)
        return bus
    except BaseException:
        transport.close()
        raise
