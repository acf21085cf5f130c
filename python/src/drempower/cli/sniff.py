"""``drempower sniff``: a live decoded view of the frames on a bus."""

from __future__ import annotations

import argparse
import sys
import time
from contextlib import ExitStack
from typing import Any

from ..client.driver.signals import exit_code
from ..protocol.describe import CaptureDecoder
from ..protocol.ids import Frame
from ..records.framelog import FrameLog
from ._connect import add_connection_args, count, open_transport_from_args, positive
from ._output import add_json_arg, clean, json_line
from .decode import decode_line

GROUP = "bus"
"""Where ``drempower --help`` lists this module's subcommands."""


def register(sub: Any) -> None:
    p = sub.add_parser(
        "sniff",
        help="show the frames on a bus as they pass, decoded (Ctrl-C ends it)",
        description=(
            "Listen to a bus and decode every frame: commands from hosts and replies from motors. "
            "Frames this command does not send itself, so run it beside the program to watch."
        ),
    )
    p.add_argument("--duration", type=positive, metavar="S", help="stop after S seconds")
    p.add_argument("--count", type=count, metavar="N", help="stop after N frames")
    p.add_argument(
        "--direction",
        choices=("auto", "host", "motor"),
        default="auto",
        help="who sends the frames: host commands, motor replies, or guess per frame (default)",
    )
    p.add_argument(
        "--log",
        metavar="FILE",
        help="also write every frame to FILE, in the format of its extension: "
        ".log (candump), .asc, .blf, .csv, .db, .mf4, .trc (python-can) or .mcap; decode reads it back",
    )
    add_json_arg(p)
    add_connection_args(p)
    p.set_defaults(func=run)


def candump_line(frame: Frame, timestamp: float) -> str:
    """``frame`` as a ``candump -L`` line (without channel)."""
    arb = f"{frame.arbitration_id:08X}" if frame.is_extended else f"{frame.arbitration_id:03X}"
    data = "R" if frame.is_remote else frame.data.hex().upper()
    return f"({timestamp:.6f}) {arb}#{data}"


def run(args: argparse.Namespace) -> int:
    ended = 0
    out = sys.stdout
    with ExitStack() as stack:
        log = stack.enter_context(FrameLog(args.log)) if args.log else None
        transport, how = open_transport_from_args(args)
        stack.enter_context(transport)
        start = time.monotonic()
        seen = 0
        capture = CaptureDecoder()
        try:
            while args.count is None or seen < args.count:
                left = None if args.duration is None else args.duration - (time.monotonic() - start)
                if left is not None and left <= 0:
                    break
                frame = transport.recv(0.25 if left is None else min(0.25, left))
                if frame is None:
                    continue
                seen += 1
                t = time.monotonic() - start
                now = time.time()
                if log is not None:
                    log.write(frame, now)
                rec = decode_line(candump_line(frame, now), args.direction, capture)
                rec.pop("line")
                if args.json:
                    out.write(json_line({"time_s": round(t, 6), **rec}) + "\n")
                elif "error" in rec:
                    line = f"{t:10.6f}  {rec.get('id', '?'):>5} {rec.get('data', ''):<16}  !! {rec['error']}"
                    out.write(clean(line) + "\n")
                else:
                    line = f"{t:10.6f}  {rec['id']:>5} {rec['data']:<16}  {rec['direction']:<5} {rec['text']}"
                    out.write(clean(line) + "\n")
                out.flush()
        except KeyboardInterrupt as exc:  # Ctrl-C, SIGTERM, SIGHUP: stop, then exit 128 + n
            ended = exit_code(exc)
    print(clean(f"{seen} frame{'' if seen == 1 else 's'} on {how}"), file=sys.stderr)
    return ended
