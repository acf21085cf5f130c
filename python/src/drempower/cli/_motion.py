"""What the motion commands share: value lists, stopping on Ctrl-C, holding for a while."""

from __future__ import annotations

import argparse
import math
import re
import sys
import time
from collections.abc import Iterator, Sequence
from contextlib import contextmanager

from ..client import Bus
from ._connect import add_ids_arg, open_from_args, positive
from ._output import motors_text
from ._usage import UsageError

__all__ = ["add_duration_arg", "add_motion_args", "driving", "hold", "number_list", "per_motor", "stop_commanded"]

_UNSIGNED = r"(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"
_NEGATIVE_LIST = re.compile(rf"^-{_UNSIGNED}(?:,[-+]?{_UNSIGNED})*$")
"""Words such as ``-45`` or ``-45,90`` that argparse must take as values, not as options."""


def number_list(text: str) -> list[float]:
    """An argument type: ``"90,-45,180"`` -> ``[90.0, -45.0, 180.0]`` (finite numbers)."""
    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number or a comma-separated list of numbers") from None
    if not all(math.isfinite(v) for v in values):
        raise argparse.ArgumentTypeError(f"{text!r}: NaN and infinity cannot be sent")
    return values


def add_motion_args(parser: argparse.ArgumentParser, values: str, help: str) -> None:
    """IDS and a VALUES list, and ``--no-stop-on-exit``.

    Negative values such as ``-45,90`` are taken as values, not as options.
    """
    parser._negative_number_matcher = _NEGATIVE_LIST
    add_ids_arg(parser, many=False)
    parser.add_argument("values", type=number_list, metavar=values, help=help + "; one for all motors or one each")
    parser.add_argument(
        "--no-stop-on-exit",
        dest="stop_on_exit",
        action="store_false",
        help="on Ctrl-C, leave the motors as they are (default: set the motors commanded to idle)",
    )


def add_duration_arg(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--duration", type=positive, metavar="S", help="keep it up for S seconds, then set the motors idle"
    )


def per_motor(ids: Sequence[int], values: Sequence[float], what: str) -> list[float]:
    """One value per motor: a single value applies to all."""
    if len(values) == 1:
        return list(values) * len(ids)
    if len(values) != len(ids):
        raise UsageError(f"{len(ids)} motors but {len(values)} {what} values: give one for all or one each")
    return list(values)


def stop_commanded(bus: Bus, why: str) -> None:
    """Set every motor this bus commanded to idle, and say so on stderr."""
    nodes = sorted(bus.core.commanded)
    for node in nodes:
        bus.motor(node).set_mode(1)
    if nodes:
        print(f"drempower: {why}: {motors_text(nodes)} set to idle", file=sys.stderr)


@contextmanager
def driving(args: argparse.Namespace) -> Iterator[Bus]:
    """The bus of a motion command: on Ctrl-C the motors it commanded go idle (unless --no-stop-on-exit)."""
    with open_from_args(args) as bus:
        try:
            yield bus
        except KeyboardInterrupt:
            if args.stop_on_exit:
                stop_commanded(bus, "interrupted")
            raise


def hold(bus: Bus, seconds: float | None) -> None:
    """With ``--duration``: wait, then set the commanded motors idle."""
    if seconds is not None:
        time.sleep(seconds)
        stop_commanded(bus, f"after {seconds:g} s")
