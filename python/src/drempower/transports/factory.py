"""Open a transport from python-can style arguments: a table of interface names and their openers."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from ..errors import ConfigError
from .base import Transport
from .errors import TransportError, TransportOptionError

__all__ = [
    "open_transport",
    "INTERFACES",
    "Opener",
    "SERIAL_ADAPTER",
    "MOTOR_UART",
    "SLCAN",
    "SOCKETCAND",
    "SIMULATOR",
    "ZENOH",
    "ENTRY_POINT_GROUP",
]

Opener = Callable[[str, str | int | None, int | None, dict[str, Any]], Transport]
"""``opener(interface, channel, bitrate, kwargs)`` -> an open transport, or :class:`TransportError`."""


def _serial_port(interface: str, channel: str | int | None) -> str:
    if channel is None:
        raise TransportError(f"interface {interface!r} needs channel=<serial port>, e.g. '/dev/ttyACM0', 'COM5'")
    return str(channel)


def adapter_bitrate_refusal(port: object, bitrate: object) -> str:
    """Why an ``adapter`` bus takes no ``bitrate`` (the words of the client and of ``drempower sim --robot``)."""
    return (
        f"cannot open vendor USB-CAN adapter on {port} with bitrate={bitrate}: the adapter's CAN "
        "bitrate is set with the vendor's configuration tool, not by the host; leave bitrate out "
        "(baudrate= sets the serial rate, which a USB adapter does not need)"
    )


def _adapter(interface: str, channel: str | int | None, bitrate: int | None, kwargs: dict[str, Any]) -> Transport:
    from .serial_adapter import AdapterTransport

    port = _serial_port(interface, channel)
    if bitrate is not None:
        raise TransportError(adapter_bitrate_refusal(port, bitrate))
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


def _slcan(interface: str, channel: str | int | None, bitrate: int | None, kwargs: dict[str, Any]) -> Transport:
    from .slcan import SlcanTransport

    port = _serial_port(interface, channel)
    if bitrate is None:
        bitrate = _configured(interface, port, ("bitrate",)).get("bitrate")
    if "send_timeout" in kwargs:  # the python-can transports' name for it
        kwargs.setdefault("write_timeout", kwargs.pop("send_timeout"))
    unknown = sorted(set(kwargs) - _SLCAN_OPTIONS)
    if unknown:
        raise TransportOptionError(
            f"cannot open slcan adapter on {port}: unknown option(s) {', '.join(unknown)}; it takes "
            f"{', '.join(sorted(_SLCAN_OPTIONS))} (interface 'python-can:slcan' is python-can's own slcan)"
        )
    return SlcanTransport(port, bitrate, **kwargs)


_SLCAN_OPTIONS = frozenset(("tty_baudrate", "sleep_after_open", "listen_only", "rtscts", "write_timeout", "exclusive"))
"""What the slcan transport takes besides channel and bitrate (``tty_baudrate`` is the serial rate)."""


def _socketcand(interface: str, channel: str | int | None, bitrate: int | None, kwargs: dict[str, Any]) -> Transport:
    from .socketcand import SocketcandTransport

    given: dict[str, Any] = {k: kwargs.pop(k) for k in ("host", "port") if k in kwargs}
    if len(given) < 2 or channel is None:  # python-can's configuration (config file, CAN_* variables) may say
        cfg = _configured(interface, channel, ("host", "port", "channel"), given)
        given = {**cfg, **given}
        if channel is None:
            channel = cfg.get("channel")
    kwargs.pop("tcp_tune", None)  # python-can's option: drempower's connection has TCP_NODELAY on always
    unknown = sorted(set(kwargs) - _SOCKETCAND_OPTIONS)
    where = f"{given.get('host')}:{given.get('port')}"
    if unknown:
        raise TransportOptionError(
            f"cannot open socketcand bus at {where}: unknown option(s) {', '.join(unknown)}; it takes host, port, "
            f"{', '.join(sorted(_SOCKETCAND_OPTIONS))} (interface 'python-can:socketcand' is python-can's own client)"
        )
    if "host" not in given or "port" not in given:
        raise TransportOptionError(f"cannot open socketcand bus: give host= and port= of the server (got {where})")
    return SocketcandTransport(
        given["host"], given["port"], "can0" if channel is None else str(channel), bitrate=bitrate, **kwargs
    )


_SOCKETCAND_OPTIONS = frozenset(("connect_timeout", "send_timeout"))
"""What the socketcand transport takes besides host, port, channel and bitrate."""


def _configured(
    interface: str, channel: str | int | None, keys: tuple[str, ...], given: dict[str, Any] | None = None
) -> dict[str, Any]:
    """``keys`` as python-can's configuration (config file, CAN_* variables) gives them for ``interface``
    (and ``channel`` and ``given``, which take precedence, as in python-can); raises
    :class:`TransportOptionError` when that configuration is invalid."""
    import can.util

    config: dict[str, Any] = {"interface": interface, **(given or {})}
    if channel is not None:
        config["channel"] = channel
    try:
        cfg = can.util.load_config(config=config)
    except (ValueError, TypeError) as exc:
        raise TransportOptionError(
            f"cannot open {interface} bus: python-can's configuration is invalid: {exc}"
        ) from exc
    except Exception:  # no usable configuration (an unknown interface named in it): nothing from it
        return {}
    return {k: cfg[k] for k in keys if cfg.get(k) is not None}


def _sim(interface: str, channel: str | int | None, bitrate: int | None, kwargs: dict[str, Any]) -> Transport:
    from .sim import SimTransport

    if bitrate is not None:
        kwargs.setdefault("bitrate", bitrate)
    try:
        return SimTransport(**kwargs)
    except ConfigError:  # the robot file's (a model_joint the model lacks): the user's to fix, as it is
        raise
    except (TypeError, ValueError) as exc:
        raise TransportError(f"cannot start the simulator ({exc})") from exc


def _zenoh(interface: str, channel: str | int | None, bitrate: int | None, kwargs: dict[str, Any]) -> Transport:
    from .zenoh import ZenohTransport

    if bitrate is not None:
        raise TransportOptionError("a remote bus takes no bitrate: the bridge's bus has its own")
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
    "slcan": _slcan,
    "socketcand": _socketcand,
    "sim": _sim,
    "zenoh": _zenoh,
}
"""drempower's own interface names and how each is opened; any other name is a python-can interface.
Add an entry to offer another transport."""

SERIAL_ADAPTER = frozenset(n for n, o in INTERFACES.items() if o is _adapter)
"""Interface names of the vendor USB-CAN adapter (0xAA framing; channel = serial port)."""
MOTOR_UART = frozenset(n for n, o in INTERFACES.items() if o is _uart)
"""Interface name of a G-series motor's UART (11-byte frames; channel = serial port)."""
SLCAN = frozenset(n for n, o in INTERFACES.items() if o is _slcan)
"""Interface name of an slcan adapter read by drempower (channel = serial port; python-can's: ``python-can:slcan``)."""
SOCKETCAND = frozenset(n for n, o in INTERFACES.items() if o is _socketcand)
"""Interface name of a socketcand server read by drempower (python-can's client: ``python-can:socketcand``)."""
SIMULATOR = frozenset(n for n, o in INTERFACES.items() if o is _sim)
"""Interface name of the in-process simulator."""
ZENOH = frozenset(n for n, o in INTERFACES.items() if o is _zenoh)
"""Interface name of a remote bus served by ``drempower bridge`` (channel = key prefix)."""
_PYTHON_CAN_PREFIX = "python-can:"

ENTRY_POINT_GROUP = "drempower.transports"
"""The entry-point group through which another package offers a transport, as python-can's ``can.interface``
does: ``[project.entry-points."drempower.transports"] mylink = "mypackage.link:MyTransport"``. The object
named is called as ``obj(channel=..., bitrate=..., **options)`` and returns a :class:`Transport` (a
:class:`Transport` subclass with that constructor works as it is)."""


def _registered(interface: str) -> Opener | None:
    """The opener of a transport another package registered under ``interface``, or None."""
    from importlib.metadata import entry_points

    found = [ep for ep in entry_points(group=ENTRY_POINT_GROUP) if ep.name == interface]
    if not found:
        return None
    ep = found[0]
    try:
        factory = ep.load()
    except Exception as exc:  # a broken plug-in: say which, never a traceback
        raise TransportError(f"cannot load transport {interface!r} ({ep.value}): {type(exc).__name__}: {exc}") from exc

    def opener(name: str, channel: str | int | None, bitrate: int | None, kwargs: dict[str, Any]) -> Transport:
        transport = factory(channel=channel, bitrate=bitrate, **kwargs)
        if not isinstance(transport, Transport):
            raise TransportError(
                f"transport {name!r} ({ep.value}) gave a {type(transport).__name__}, not a drempower Transport"
            )
        return transport

    return opener


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
    * ``"slcan"``: an slcan (Lawicel) adapter, ``channel`` = serial port (``PORT@BAUD``
      gives the serial rate), ``bitrate`` = CAN bit rate (from python-can's
      configuration when not given), ``sleep_after_open`` (s, default 2 as in
      python-can), ``listen_only``, ``send_timeout``; read with ``select`` and
      ``os.read`` as the adapter is. ``"python-can:slcan"`` is python-can's own.
    * ``"socketcand"``: a bus served by socketcand, ``host`` and ``port`` of the
      server (from python-can's configuration when not given), ``channel`` = the
      served bus (default ``"can0"``), ``connect_timeout``, ``send_timeout``;
      read with ``select`` and ``recv``. ``"python-can:socketcand"`` is python-can's own.
    * ``"sim"``: the in-process simulator; ``motors=[1, 2, 3]``, ``time_scale``
      and the simulator's other options as keyword arguments.
    * ``"zenoh"``: a bus served by ``drempower bridge``, ``channel`` = its key prefix
      (default ``"drempower"``), ``connect=``/``listen=`` Zenoh endpoints.
    * any other name: a python-can interface (``"socketcan"``, ``"pcan"``,
      ``"virtual"``...) with ``channel``, ``bitrate`` and keyword
      arguments passed on; ``"python-can:serial"`` reaches python-can's own
      ``serial`` interface. ``interface=None`` lets python-can's configuration
      (config file, ``CAN_*`` environment variables) decide. ``send_timeout``
      (s, default 1) bounds a send.

    The names are looked up in :data:`INTERFACES`, then among the transports other packages register
    under the entry-point group :data:`ENTRY_POINT_GROUP` (before python-can's names). Raises
    :class:`TransportError` at once, naming what was tried, when the bus cannot
    be opened.
    """
    opener = None if interface is None else INTERFACES.get(interface)
    if opener is None and interface is not None and not interface.startswith(_PYTHON_CAN_PREFIX):
        opener = _registered(interface)
    if opener is not None:
        assert interface is not None
        return opener(interface, channel, bitrate, kwargs)
    if interface is not None and interface.startswith(_PYTHON_CAN_PREFIX):
        interface = interface[len(_PYTHON_CAN_PREFIX) :]
    return _python_can(interface, channel, bitrate, kwargs)
