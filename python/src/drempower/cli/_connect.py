"""Connection options and argument types shared by every subcommand that talks to motors.

The same flags everywhere: python-can's ``-i/--interface``, ``-c/--channel`` and
``-b/--bitrate``; ``--serial PORT`` for the vendor USB-CAN adapter (0xAA framing);
``--uart PORT`` for one motor's UART (11-byte frames); ``--sim IDS`` for the
in-process simulator. With none of them, python-can's own configuration (config
file or ``CAN_INTERFACE``/``CAN_CHANNEL``/``CAN_BITRATE``) is used if there is one,
and the command says so on stderr; ``-c``, ``-b`` and ``-o`` then add to it.

The simulator runs at real time unless ``DREMPOWER_SIM_TIME_SCALE`` (or the hidden
``--sim-time-scale``) says otherwise: 10 makes simulated time pass ten times faster.
"""

from __future__ import annotations

import argparse
import math
import os
import shlex
import sys
from typing import TYPE_CHECKING, Any

from ..client.engine.timeouts import MAX_TIMEOUT
from ..errors import DrEmpowerError
from ..protocol.limits import MAX_NODE, MIN_MOTOR, is_motor
from ..transports.factory import INTERFACES
from ._output import clean
from ._robot import joint_or_ids
from ._usage import UsageError

if TYPE_CHECKING:
    from ..client import Bus
    from ..transports import Transport

__all__ = [
    "TIME_SCALE_ENV",
    "ascii_digits",
    "ascii_float",
    "ascii_int",
    "add_connection_args",
    "add_ids_arg",
    "bitrate",
    "connection_kwargs",
    "count",
    "connection_words",
    "find_adapters",
    "follow_up",
    "ids_or_found",
    "motor_id",
    "number",
    "open_from_args",
    "open_transport_from_args",
    "parse_ids",
    "can_option",
    "parse_targets",
    "positive",
    "retries",
    "sim_time_scale",
]

TIME_SCALE_ENV = "DREMPOWER_SIM_TIME_SCALE"
"""Environment variable: default time scale of the in-process simulator."""


def ascii_int(text: str, base: int = 10) -> int:
    """``int(text, base)`` for ASCII digits only: ``int`` also takes other scripts' digits (``"\u0661"`` is 1)
    and underscores, which no motor id or value on this command line means. Raises :class:`ValueError`."""
    t = text.strip()
    if not t.isascii() or "_" in t:
        raise ValueError(f"{text!r} is not written in ASCII digits")
    return int(t, base)


def ascii_float(text: str) -> float:
    """``float(text)`` for ASCII digits only (see :func:`ascii_int`). Raises :class:`ValueError`."""
    t = text.strip()
    if not t.isascii() or "_" in t:
        raise ValueError(f"{text!r} is not written in ASCII digits")
    return float(t)


def ascii_digits(text: str) -> bool:
    """Whether ``text`` (spaces around allowed) is a whole number in ASCII digits (``isdigit`` takes any script's)."""
    t = text.strip()
    return t.isascii() and t.isdigit()


def parse_ids(text: str) -> list[int]:
    """``"1,2,5-7"`` -> ``[1, 2, 5, 6, 7]`` in the order given; every id must be 1..63, named once."""
    ids: list[int] = []
    for part in text.replace(" ", "").split(","):
        if not part:
            continue
        try:
            if "-" in part:
                lo, hi = (ascii_int(x) for x in part.split("-", 1))
                ids.extend(range(lo, hi + 1))
            else:
                ids.append(ascii_int(part))
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not a list of motor ids such as 1,2,5-7") from None
    bad = [i for i in ids if not is_motor(i)]
    if bad or not ids:
        raise argparse.ArgumentTypeError(f"motor ids are {MIN_MOTOR}..{MAX_NODE} (0 is broadcast); got {text!r}")
    twice = sorted({i for i in ids if ids.count(i) > 1})
    if twice:
        raise argparse.ArgumentTypeError(f"{text!r} names motor {', '.join(map(str, twice))} twice")
    return ids


def motor_id(text: str) -> int:
    """An argument type: one motor id, 1..63."""
    ids = parse_ids(text)
    if len(ids) != 1:
        raise argparse.ArgumentTypeError(f"expected one motor id, got {text!r}")
    return ids[0]


def parse_targets(text: str) -> list[int]:
    """Motor ids as :func:`parse_ids`, or ``all`` -> ``[0]`` (one broadcast frame)."""
    return [0] if text.strip().lower() == "all" else parse_ids(text)


class _Ids(argparse.Action):
    """Joins several IDS words (``1 2,3 5-7``) into one list, each motor named once."""

    def __call__(
        self, parser: argparse.ArgumentParser, ns: argparse.Namespace, values: Any, option_string: str | None = None
    ) -> None:
        ids = [i for part in values for i in part]
        if 0 in ids and len(ids) > 1:
            parser.error("`all` stands alone")
        twice = sorted({i for i in ids if ids.count(i) > 1})
        if twice:
            parser.error(f"motor {', '.join(map(str, twice))} named twice")
        setattr(ns, self.dest, ids)


def add_ids_arg(
    parser: argparse.ArgumentParser, *, many: bool = True, all_ok: bool = False, optional: bool = False
) -> None:
    """The ``IDS`` argument: motor ids such as ``1,2,5-7``.

    ``many``: several words; ``all_ok``: ``all`` (-> ``[0]``, broadcast) is accepted;
    ``optional``: may be left out (the list is then empty).
    """
    what = "motor ids, e.g. 1 or 1,2,3 or 1-4" + (", or all (broadcast)" if all_ok else "")
    what += "; joint names with --robot"
    kind = joint_or_ids(parse_targets if all_ok else parse_ids)
    parser.set_defaults(robot_ids=True)  # --robot: these words may be joint names
    if many:
        nargs = "*" if optional else "+"
        parser.add_argument("ids", nargs=nargs, type=kind, action=_Ids, default=[], metavar="IDS", help=what)
    else:
        parser.add_argument("ids", type=kind, metavar="IDS", help=what)


_SUFFIX = {"k": 1_000, "m": 1_000_000}


def bitrate(text: str) -> int:
    """An argument type: ``1000000``, ``1M``, ``500k``, ``115200``."""
    t = text.strip().lower()
    scale = _SUFFIX.get(t[-1:], 1)
    try:
        value = ascii_float(t[:-1] if scale > 1 else t) * scale
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a bitrate such as 1M, 500k or 115200") from None
    if not (math.isfinite(value) and value >= 1 and value == int(value)):
        raise argparse.ArgumentTypeError(f"{text!r} is not a bitrate such as 1M, 500k or 115200")
    return int(value)


def positive(text: str) -> float:
    """An argument type: a finite number > 0."""
    try:
        value = ascii_float(text)
    except ValueError:
        value = 0.0
    if not 0 < value < math.inf:
        raise argparse.ArgumentTypeError(f"expected a finite number > 0, got {text!r}")
    return value


def seconds(text: str) -> float:
    """An argument type: a time to wait, > 0 s and at most a day (as every ``timeout=`` of the client)."""
    value = positive(text)
    if value > MAX_TIMEOUT:
        raise argparse.ArgumentTypeError(f"expected at most {MAX_TIMEOUT:g} s (one day), got {text!r}")
    return value


def number(text: str) -> float:
    """An argument type: a finite number."""
    try:
        value = ascii_float(text)
    except ValueError:
        value = math.nan
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"expected a finite number, got {text!r}")
    return value


def count(text: str) -> int:
    """An argument type: a whole number >= 1."""
    if not (ascii_digits(text) and int(text) >= 1):
        raise argparse.ArgumentTypeError(f"expected a whole number >= 1, got {text!r}")
    return int(text)


def sim_time_scale(args: argparse.Namespace) -> float | None:
    """The simulator time scale: ``--sim-time-scale``, else ``$DREMPOWER_SIM_TIME_SCALE``, else None."""
    scale: float | None = getattr(args, "sim_time_scale", None)
    if scale is not None:
        return scale
    env = os.environ.get(TIME_SCALE_ENV)
    if not env:
        return None
    try:
        return positive(env)
    except argparse.ArgumentTypeError as exc:
        raise DrEmpowerError(f"{TIME_SCALE_ENV}: {exc}") from None


def can_option(text: str) -> tuple[str, object]:
    """``"port=29536"`` -> ``("port", 29536)``: numbers and true/false are converted, the rest stays text."""
    key, sep, value = text.partition("=")
    if not sep or not key.strip().isidentifier():
        raise argparse.ArgumentTypeError(f"{text!r}: expected KEY=VALUE, e.g. host=127.0.0.1")
    v: object = value
    low = value.lower()
    if low in ("true", "false"):
        v = low == "true"
    else:
        for conv in (ascii_int, ascii_float):
            try:
                v = conv(value)
                break
            except ValueError:
                continue
    return key.strip(), v


def retries(text: str) -> int:
    """An argument type: how often a request that got no reply is sent again, 0..10."""
    if not (ascii_digits(text) and 0 <= int(text) <= 10):
        raise argparse.ArgumentTypeError(f"expected a whole number 0..10, got {text!r}")
    return int(text)


def add_connection_args(parser: argparse.ArgumentParser) -> None:
    g = parser.add_argument_group("connection (one of; default: python-can's configuration)")
    g.add_argument("-i", "--interface", help="python-can interface: socketcan, pcan, kvaser, slcan, gs_usb, ...")
    g.add_argument("-c", "--channel", help="python-can channel, e.g. can0")
    g.add_argument("-b", "--bitrate", type=bitrate, help="CAN bitrate in bit/s, e.g. 1M or 500k")
    g.add_argument("--serial", metavar="PORT", help="vendor USB-CAN adapter on serial PORT (0xAA framing)")
    g.add_argument("--uart", metavar="PORT", help="a single motor's UART on serial PORT (11-byte frames)")
    g.add_argument("--sim", metavar="IDS", type=parse_ids, help="in-process simulated motors, e.g. 1,2,3")
    g.add_argument("--robot", metavar="FILE", help="the buses and joints of a robot file (TOML); joints by name")
    g.add_argument(
        "-o",
        "--can-option",
        metavar="KEY=VALUE",
        action="append",
        type=can_option,
        default=[],
        help="extra bus option, repeatable: -o host=127.0.0.1 -o port=29536 (socketcand), -o index=0 (python-can); "
        "with --sim a firmware knob, e.g. -o status_bits=kept",
    )
    g.add_argument(
        "--profile",
        metavar="FILE",
        help="the motors' firmware profile, as drempower doctor --write-profile saves it (spec/PROTOCOL.md 1.6)",
    )
    g.add_argument("--sim-time-scale", type=positive, help=argparse.SUPPRESS)
    g.add_argument(
        "--timeout",
        type=seconds,
        metavar="S",
        help="reply timeout per request in seconds (default 0.1; 0.5 with --sim)",
    )
    g.add_argument(
        "--retries",
        type=retries,
        metavar="N",
        help="send a read that got no reply again, up to N times (0-10, default 0, or the robot file's): "
        "for lossy links",
    )


_SIM_KNOBS = frozenset(
    ("status_bits", "boot_s", "reply_state", "fast_read", "q_time_zero", "heartbeat", "factory_id", "clock")
)
"""What ``-o KEY=VALUE`` may set with ``--sim``: the simulated firmware's knobs (drempower.sim.firmware),
and ``clock=virtual`` (simulated time passes only while the command waits)."""

_FLAGS = {"serial": "--serial", "uart": "--uart", "sim": "--sim", "interface": "-i/--interface"}


def _described(interface: str, channel: object) -> str:
    """``slcan /dev/ttyACM0``, ``socketcand can0`` (drempower's own readers) or ``python-can pcan PCAN_USBBUS1``."""
    own = interface in INTERFACES
    name = interface.removeprefix("python-can:")
    return f"{'' if own else 'python-can '}{name} {channel or ''}".rstrip()


def connection_kwargs(args: argparse.Namespace) -> tuple[dict[str, Any], str]:
    """The ``open_bus`` keyword arguments for ``args``, and a sentence saying what is used.

    Raises :class:`UsageError` when the options contradict each other: two
    connections, or python-can's ``-c``/``-o`` without a python-can interface.
    """
    chosen = [name for name in ("serial", "uart", "sim") if getattr(args, name, None)]
    if args.interface:
        chosen.append("interface")
    if len(chosen) > 1:
        raise UsageError("give one connection: " + ", ".join(_FLAGS[c] for c in chosen) + " conflict")
    can_only = ["-c/--channel"] if args.channel is not None else []
    can_only += ["-o/--can-option"] if args.can_option else []
    sim_knobs = bool(args.sim) and all(k in _SIM_KNOBS for k, _ in args.can_option) and args.channel is None
    if can_only and chosen and chosen[0] != "interface" and not sim_knobs:
        raise UsageError(f"{' and '.join(can_only)}: only with -i/--interface, not with {_FLAGS[chosen[0]]}")
    if args.bitrate is not None and args.serial:
        raise UsageError(
            "-b/--bitrate: not with --serial; the USB-CAN adapter's CAN bitrate is set with the vendor's "
            "configuration tool (the serial line's rate needs no setting)"
        )
    kw: dict[str, Any]
    if args.sim:
        kw = {"interface": "sim", "motors": args.sim, **dict(args.can_option)}  # -o: firmware knobs
        scale = sim_time_scale(args)
        if scale is not None and kw.get("clock") != "virtual":
            kw["time_scale"] = scale
        how = f"simulated motors {','.join(map(str, args.sim))}"
    elif args.serial:
        kw = {"interface": "adapter", "channel": args.serial}
        how = f"USB-CAN adapter on {args.serial}"
    elif args.uart:
        kw = {"interface": "uart", "channel": args.uart}
        how = f"motor UART on {args.uart}"
    elif args.interface:
        kw = {"interface": args.interface, "channel": args.channel, **dict(args.can_option)}
        how = _described(args.interface, args.channel)
    elif not can_only and args.bitrate is None and len(adapters := find_adapters()) == 1:
        kw = {"interface": "adapter", "channel": adapters[0]}
        how = f"the USB-CAN adapter found on {adapters[0]} (--serial {adapters[0]})"
    else:
        adapters = [] if can_only or args.bitrate is not None else find_adapters()
        cfg = _python_can_config()
        if cfg is None:
            if can_only:
                raise UsageError(f"{can_only[0]} needs -i/--interface (no python-can configuration names an interface)")
            found = (
                f"; USB-CAN adapters found on {', '.join(adapters)}: choose one with --serial PORT" if adapters else ""
            )
            raise DrEmpowerError(
                "no connection given, no USB-CAN adapter found and no python-can configuration: "
                "use --sim IDS, --serial PORT, --uart PORT or -i INTERFACE -c CHANNEL" + found
            )
        # python-can fills in what is not given here (bitrate, ...) from the same configuration
        channel = args.channel if args.channel is not None else cfg.get("channel")
        kw = {"interface": cfg["interface"], "channel": channel, **dict(args.can_option)}
        how = f"python-can configuration: {cfg['interface']} {channel or ''}".rstrip()
    if args.bitrate is not None:
        kw["bitrate"] = args.bitrate
    return kw, how


def find_adapters() -> list[str]:
    """Serial ports of the vendor's USB-CAN adapters plugged in, by their USB ids (those `drempower udev` knows)."""
    from serial.tools import list_ports

    from ._usb import CDC, CH340

    known = {(int(v, 16), int(p, 16)) for v, p in (CDC, CH340)}
    return sorted(port.device for port in list_ports.comports() if (port.vid, port.pid) in known)


def _python_can_config() -> dict[str, Any] | None:
    import can.util

    try:
        cfg = can.util.load_config()
    except Exception:  # python-can raises several types when nothing is configured
        return None
    return dict(cfg) if cfg.get("interface") else None


def _connect(args: argparse.Namespace, quiet: bool) -> tuple[dict[str, Any], str]:
    kw, how = connection_kwargs(args)
    chosen = args.sim or args.serial or args.uart or args.interface
    if not (chosen or quiet):
        print(clean(f"drempower: using {how}"), file=sys.stderr)
    return kw, how


def open_from_args(args: argparse.Namespace, *, quiet: bool = False) -> Bus:
    """Open the bus the connection options describe (saying so on stderr when python-can's configuration chose it).

    Motors keep doing what they were told when the command ends (the bus does
    not stop them on close); motion commands stop them themselves on Ctrl-C.
    """
    from .. import open_bus

    kw, _ = robot_bus_kwargs(args) if getattr(args, "robot_bus", None) else _connect(args, quiet)
    kw["stop_on_close"] = False  # a robot file's too: the commands stop what they started themselves
    if args.timeout is not None:
        kw["timeout"] = args.timeout
    if getattr(args, "retries", None) is not None:
        kw["retries"] = args.retries
    if getattr(args, "profile", None) is not None:
        kw["profile"] = args.profile
    bus: Bus = open_bus(**kw)
    if getattr(args, "robot_bus", None):  # the robot file's joints: their limits, as open_robot gives them
        from ..robot.limits import limit_bus

        try:
            args.robot_limits = limit_bus(bus, args.robot_spec, args.robot_bus)
            joints = args.robot_spec.joints_on(args.robot_bus)  # stopping holds the joints that hold
            bus.hold_on_close(j.id for j in joints if j.on_timeout == "hold")
        except BaseException:
            bus.close()
            raise
    return bus


def ids_or_found(args: argparse.Namespace, bus: Bus, *, none_ok: bool = False) -> list[int]:
    """The motor ids given, or those a quick scan finds (said on stderr: ``found motors 1, 2, 3``).

    For commands whose IDS may be left out (``state``, ``errors``, ``monitor``),
    as moteus_tool finds its targets. No motor answering is a failure (exit 1).
    """
    ids: list[int] = list(args.ids)
    if ids:
        return ids
    found = [m.id for m in bus.scan()]
    if not found and none_ok:
        print("drempower: no motor answered a scan of ids 1-63", file=sys.stderr)
        return []
    if not found:
        raise DrEmpowerError("no motor answered a scan of ids 1-63: check the connection, the bitrate and the power")
    print(f"drempower: found motor{'s' if len(found) > 1 else ''} {', '.join(map(str, found))}", file=sys.stderr)
    args.ids = found
    return found


def connection_words(args: argparse.Namespace) -> list[str]:
    """The connection options the user gave, as words of a command line (for suggested follow-up commands)."""
    words: list[str] = []
    if getattr(args, "sim", None):
        words += ["--sim", ",".join(map(str, args.sim))]
    for name, flag in (("serial", "--serial"), ("uart", "--uart"), ("interface", "-i"), ("channel", "-c")):
        value = getattr(args, name, None)
        if value is not None:
            words += [flag, str(value)]
    if getattr(args, "bitrate", None) is not None:
        words += ["-b", str(args.bitrate)]
    for key, value in getattr(args, "can_option", None) or []:
        words += ["-o", f"{key}={str(value).lower() if isinstance(value, bool) else value}"]
    if getattr(args, "timeout", None) is not None:
        words += ["--timeout", f"{args.timeout:g}"]
    if getattr(args, "retries", 0):
        words += ["--retries", str(args.retries)]
    return words


def follow_up(args: argparse.Namespace, command: str) -> str:
    """``"drempower clear 1"`` with the user's connection options, ready to paste: ``drempower clear 1 --sim 1``."""
    return " ".join(["drempower", command, *map(shlex.quote, connection_words(args))])


def open_transport_from_args(args: argparse.Namespace) -> tuple[Transport, str]:
    """Open the raw transport the connection options describe (for listening), and what it is."""
    from ..transports import open_transport

    kw, how = robot_bus_kwargs(args) if getattr(args, "robot_bus", None) else _connect(args, False)
    return open_transport(**{k: v for k, v in kw.items() if k not in BUS_ONLY}), how


BUS_ONLY = ("timeout", "retries", "stop_on_close", "start")
"""Options of a robot file's bus that belong to ``open_bus``, not to its transport."""


def robot_bus_kwargs(args: argparse.Namespace) -> tuple[dict[str, Any], str]:
    """The ``open_bus`` arguments of the ``--robot`` file's bus this command runs on, and what it is."""
    kw = dict(args.robot_spec.open_options(args.robot_bus))
    scale = sim_time_scale(args)
    if kw["interface"] == "sim" and scale is not None:
        kw["time_scale"] = scale
    return kw, f"bus {args.robot_bus} of {args.robot}"
