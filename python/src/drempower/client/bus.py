"""The threaded client: :func:`open_bus` and :class:`Bus`.

:class:`Bus` is generated (``api_sync.py``) from :class:`~drempower.client.aio.AsyncBus`, the one
source of both front ends; its own threaded parts are in :mod:`drempower.client.flavours`.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from typing import Any

from ..errors import ValidationError
from ..transports.base import Transport
from ..transports.factory import open_transport
from .api_sync import Bus
from .profile import FirmwareProfile, apply_profile, load_profile
from .session import DEFAULT_MOVE_TIMEOUT, DEFAULT_POLL_INTERVAL, StartPolicy, StopOnClose

__all__ = ["Bus", "open_bus", "DEFAULT_MOVE_TIMEOUT", "DEFAULT_POLL_INTERVAL"]


def connect(
    interface: str | None, channel: str | int | None, bitrate: int | None, transport: Transport | None, **kwargs: Any
) -> Transport:
    """The transport named by the open_bus arguments, or ``transport`` itself."""
    if transport is None:
        return open_transport(interface, channel, bitrate, **kwargs)
    if interface is not None or channel is not None or bitrate is not None or kwargs:
        raise ValidationError("pass either transport= or interface/channel/bitrate options, not both")
    return transport


def open_bus(
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
) -> Bus:
    """Open a bus: ``open_bus("sim", motors=[1, 2, 3])``, ``open_bus("socketcan", "can0")``,
    ``open_bus("adapter", "/dev/ttyACM0")``, ``open_bus("uart", "/dev/ttyUSB0")``...

    ``interface``/``channel``/``bitrate`` and extra keyword arguments select the
    transport (see :func:`drempower.transports.open_transport`); or pass an open
    ``transport``. Fails at once with :class:`~drempower.transports.TransportError`
    when the bus does not exist. ``profile`` (a file of ``drempower doctor --write-profile``,
    or its mapping) says what the motors' firmware sends (:mod:`drempower.client.profile`).
    The remaining options are those of :class:`Bus`.
    """
    prof = load_profile(profile) if profile is not None else None
    transport = connect(interface, channel, bitrate, transport, **kwargs)
    try:
        bus = Bus(transport, timeout=timeout, retries=retries, stop_on_close=stop_on_close, start=start)
        if prof is not None:
            apply_profile(bus._session.inbox.bits, prof)
        return bus
    except BaseException:
        transport.close()
        raise
