"""Open a transport from python-can style arguments: a table of interface names and their openers."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from .base import Transport
from .errors import TransportError

__all__ = ["open_transport", "INTERFACES", "Opener", "SERIAL_ADAPTER", "MOTOR_UART", "SIMULATOR", "ZENOH"]

Opener = Callable[[str, str | int | None, int | None, dict[str, Any]], Transport]
"""``opener(interface, channel, bitrate, kwargs)`` -> an open transport, or :class:`TransportError`."""


def _serial_port(interface: str, channel: str | int | None) -> str:
    if channel is None:
        raise TransportError(f"interface {interface!r} needs channel=<serial port>, e.g. '/dev/ttyACM0', 'COM5'")
    return str(channel)


def _adapter(interface: str, channel: str | int | None, bitrate: int | None, kwargs: dict[str, Any]) -> Transport:
    from .serial_adapter import AdapterTransport

    port = _serial_port(interface, channel)
    if bitrate is not None:
        raise TransportError(
            f"cannot open vendor USB-CAN adapter on {port} with bitrate={bitrate}: the adapter's CAN "
            "bitrate is set with the vendor's configuration tool, not by the host; leave bitrate out "
            "(baudrate= sets the serial rate, which a USB adapter does not need)"
        )
    return AdapterTransport(port, **kwargs)


def _uart(interface: str, channel: str | int | None, bitrate: int | None, kwargs: dict[str, Any]) -> Transport:
    from .uart import UartTransport

    port = _serial_port(interface, channel)
    if bitrate is not None:
        baudrate = kwargs.setdefault("baudrate", bitrate)
        if baudrate != bitrate:
            raise TransportError(
                f"cannot open motor UART on {port}: bitrate={bitrate} and baudrate={baudrate} "
                "both give the UART rate; give one"
            )
    return UartTransport(port, **kwargs)


def _sim(interface: str, channel: str | int | None, bitrate: int | None, kwargs: dict[str, Any]) -> Transport:
    from .sim import SimTransport

    if bitrate is not None:
        kwargs.setdefault("bitrate", bitrate)
    try:
        return SimTransport(**kwargs)
    except (TypeError, ValueError) as exc:
        raise TransportError(f"cannot start the simulator ({exc})") from exc


def _zenoh(interface: str, channel: str | int | None, bitrate: int | None, kwargs: dict[str, Any]) -> Transport:
    from .zenoh import ZenohTransport

    if bitrate is not None:
        raise TransportError("a remote bus takes no bitrate: the bridge's bus has its own")
    return ZenohTransport(None if channel is None else str(channel), **kwargs)


def _python_can(
    interface: str | None, channel: str | int | None, bitrate: int | None, kwargs: dict[str, Any]
) -> Transport:
    from .pythoncan import PythonCanTransport

    return PythonCanTransport(interface, channel, bitrate, **kwargs)


INTERFACES: dict[str, Opener] = {
    "adapter": _adapter,
    "serial": _adapter,
    "uart": _uart,
    "sim": _sim,
    "zenoh": _zenoh,
}
"""drempower's own interface names and how each is opened; any other name is a python-can interface.
Add an entry to offer another transport."""

SERIAL_ADAPTER = frozenset(n for n, o in INTERFACES.items() if o is _adapter)
"""Interface names of the vendor USB-CAN adapter (0xAA framing; channel = serial port)."""
MOTOR_UART = frozenset(n for n, o in INTERFACES.items() if o is _uart)
"""Interface name of a G-series motor's UART (11-byte frames; channel = serial port)."""
SIMULATOR = frozenset(n for n, o in INTERFACES.items() if o is _sim)
"""Interface name of the in-process simulator."""
ZENOH = frozenset(n for n, o in INTERFACES.items() if o is _zenoh)
"""Interface name of a remote bus served by ``drempower bridge`` (channel = key prefix)."""
_PYTHON_CAN_PREFIX = "python-can:"


def open_transport(
    interface: str | None = None,
    channel: str | int | None = None,
    bitrate: int | None = None,
    **kwargs: Any,
) -> Transport:
    """Open the transport named by ``interface``.

    * ``"adapter"`` or ``"serial"``: the vendor USB-CAN adapter, ``channel`` = serial
      port or pyserial URL; keyword arguments go to pyserial (``baudrate`` is the
      serial rate). ``bitrate`` is refused: the adapter's CAN bitrate is set with
      the vendor's configuration tool.
    * ``"uart"``: a G-series motor's UART, ``channel`` = serial port or URL,
      ``bitrate`` (or ``baudrate``) = UART rate, 115200 by default.
    * ``"sim"``: the in-process simulator; ``motors=[1, 2, 3]``, ``time_scale``
      and the simulator's other options as keyword arguments.
    * ``"zenoh"``: a bus served by ``drempower bridge``, ``channel`` = its key prefix
      (default ``"drempower"``), ``connect=``/``listen=`` Zenoh endpoints.
    * any other name: a python-can interface (``"socketcan"``, ``"pcan"``,
      ``"slcan"``, ``"virtual"``...) with ``channel``, ``bitrate`` and keyword
      arguments passed on; ``"python-can:serial"`` reaches python-can's own
      ``serial`` interface. ``interface=None`` lets python-can's configuration
      (config file, ``CAN_*`` environment variables) decide. ``send_timeout``
      (s, default 1) bounds a send.

    The names are looked up in :data:`INTERFACES`. Raises
    :class:`TransportError` at once, naming what was tried, when the bus cannot
    be opened.
    """
    opener = None if interface is None else INTERFACES.get(interface)
    if opener is not None:
        assert interface is not None
        return opener(interface, channel, bitrate, kwargs)
    if interface is not None and interface.startswith(_PYTHON_CAN_PREFIX):
        interface = interface[len(_PYTHON_CAN_PREFIX) :]
    return _python_can(interface, channel, bitrate, kwargs)
