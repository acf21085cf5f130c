"""Connection options shared by the examples: the simulator by default, real hardware on request.

python3 examples/single_motor.py                          # simulated motors
python3 examples/single_motor.py -i socketcan -c can0     # python-can (any interface)
python3 examples/single_motor.py -i adapter -c /dev/ttyACM0   # vendor USB-CAN adapter
python3 examples/single_motor.py -i uart -c /dev/ttyUSB0      # one G-series motor's UART
python3 examples/single_motor.py -i socketcand -c can0 -o host=127.0.0.1 -o port=29536   # `drempower sim`

The options are those of the ``drempower`` command: ``-i``, ``-c``, ``-b`` (``1M``,
``500k``...), ``-o KEY=VALUE`` for any other python-can bus option (repeatable),
``--timeout`` and ``--retries``.
"""

from __future__ import annotations

import argparse
from typing import Any

import drempower


def bitrate(text: str) -> int:
    """``1000000``, ``1M`` or ``500k``."""
    t = text.strip().lower()
    scale = {"k": 1_000, "m": 1_000_000}.get(t[-1:], 1)
    try:
        return int(float(t[:-1] if scale > 1 else t) * scale)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a bitrate such as 1M or 500k") from None


def can_option(text: str) -> tuple[str, object]:
    """``port=29536`` -> ``("port", 29536)``: numbers and true/false are converted, the rest stays text."""
    key, sep, value = text.partition("=")
    if not sep or not key.strip().isidentifier():
        raise argparse.ArgumentTypeError(f"{text!r}: expected KEY=VALUE, e.g. host=127.0.0.1")
    if value.lower() in ("true", "false"):
        return key.strip(), value.lower() == "true"
    for kind in (int, float):
        try:
            return key.strip(), kind(value)
        except ValueError:
            pass
    return key.strip(), value


def parser(description: str, ids: str = "1") -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(description=description)
    p.add_argument("-i", "--interface", default="sim", help="sim (default), adapter, uart, or a python-can interface")
    p.add_argument("-c", "--channel", help="CAN channel or serial port (not needed for sim)")
    p.add_argument("-b", "--bitrate", type=bitrate, help="CAN bitrate, e.g. 1M or 500k (python-can interfaces)")
    p.add_argument(
        "-o",
        "--can-option",
        metavar="KEY=VALUE",
        action="append",
        type=can_option,
        default=[],
        help="extra python-can bus option, repeatable: -o host=127.0.0.1 -o port=29536 (socketcand)",
    )
    p.add_argument("--timeout", type=float, help="reply timeout per request in seconds")
    p.add_argument("--retries", type=int, default=0, help="send a read that got no reply again, up to N times")
    p.add_argument("--ids", default=ids, help=f"motor ids, comma separated (default {ids})")
    p.add_argument("--time-scale", type=float, default=1.0, help="simulator speed-up (sim only)")
    return p


def motor_ids(args: argparse.Namespace) -> list[int]:
    return [int(x) for x in args.ids.split(",") if x.strip()]


def open_bus(args: argparse.Namespace, **options: Any) -> drempower.Bus:
    """Open the bus the command line describes (the simulator with the --ids motors by default)."""
    options = {"timeout": args.timeout, "retries": args.retries, **options}
    if args.interface == "sim":
        return drempower.open_bus("sim", motors=motor_ids(args), time_scale=args.time_scale, **options)
    return drempower.open_bus(args.interface, args.channel, args.bitrate, **dict(args.can_option), **options)
