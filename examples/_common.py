"""Connection options shared by the examples: the simulator by default, real hardware on request.

python3 examples/single_motor.py                          # simulated motors
python3 examples/single_motor.py -i socketcan -c can0     # python-can (any interface)
python3 examples/single_motor.py -i adapter -c /dev/ttyACM0   # vendor USB-CAN adapter
python3 examples/single_motor.py -i uart -c /dev/ttyUSB0      # one G-series motor's UART
"""

from __future__ import annotations

import argparse
from typing import Any

import drempower


def parser(description: str, ids: str = "1") -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(description=description)
    p.add_argument("-i", "--interface", default="sim", help="sim (default), adapter, uart, or a python-can interface")
    p.add_argument("-c", "--channel", help="CAN channel or serial port (not needed for sim)")
    p.add_argument("-b", "--bitrate", type=int, help="CAN bitrate (python-can interfaces)")
    p.add_argument("--ids", default=ids, help=f"motor ids, comma separated (default {ids})")
    p.add_argument("--time-scale", type=float, default=1.0, help="simulator speed-up (sim only)")
    return p


def motor_ids(args: argparse.Namespace) -> list[int]:
    return [int(x) for x in args.ids.split(",") if x.strip()]


def open_bus(args: argparse.Namespace, **options: Any) -> drempower.Bus:
    """Open the bus the command line describes (the simulator with the --ids motors by default)."""
    if args.interface == "sim":
        return drempower.open_bus("sim", motors=motor_ids(args), time_scale=args.time_scale, **options)
    return drempower.open_bus(args.interface, args.channel, args.bitrate, **options)
