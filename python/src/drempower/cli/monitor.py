"""``drempower monitor``: a live table of motors' state, optionally recorded to CSV."""

from __future__ import annotations

import argparse
import csv
import math
import sys
import time
from contextlib import ExitStack
from typing import Any

from ..client.driver.signals import exit_code
from ..errors import DrEmpowerError
from . import _readings
from ._connect import add_connection_args, add_ids_arg, ids_or_found, open_from_args, positive
from ._fields import SOURCES, parse_fields, run_fields
from ._output import LiveView, add_json_arg, is_terminal, json_line, render_table

GROUP = "bus"
"""Where ``drempower --help`` lists this module's subcommands."""

_HEADERS = ("time/s", *_readings.HEADERS)
_WIDTHS = (7, 2, 12, 9, 9, 4, 11, 6)
"""Least column widths of the plain output, so that readings line up under one header."""


def register(sub: Any) -> None:
    p = sub.add_parser(
        "monitor",
        help="live table of motors' state (redrawn in place on a terminal); Ctrl-C ends it",
        description=(
            "Read the motors RATE times a second and show position, speed, torque, trajectory done, "
            "axis state, bus voltage and errors. On a terminal the table is redrawn in place; "
            "otherwise one line per motor and reading. Without IDS: every motor a quick scan finds."
        ),
    )
    add_ids_arg(p, optional=True)
    p.add_argument("--rate", type=positive, default=10.0, metavar="HZ", help="readings per second (default 10)")
    p.add_argument("--duration", type=positive, metavar="S", help="stop after S seconds (default: at Ctrl-C)")
    p.add_argument("--csv", metavar="FILE", help="also record every reading to FILE")
    p.add_argument(
        "--fields",
        type=parse_fields,
        metavar="F,...",
        help="columns: state channels (position, speed, torque, done, error) and any parameter names; "
        "one record per state sample, the achieved rate shown",
    )
    p.add_argument(
        "--source",
        choices=SOURCES,
        default="poll",
        help="how states are captured with --fields: poll (fast reads at RATE, default), heartbeat (the motors "
        "send them every 1/RATE s; set back at the end) or replies (only those other programs' commands cause)",
    )
    add_json_arg(p)
    add_connection_args(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    ended = 0
    out = sys.stdout
    if args.fields is not None or args.source != "poll":
        if args.fields is None:
            args.fields = parse_fields("position,speed,torque")
        with open_from_args(args) as bus:
            ids_or_found(args, bus)
            return run_fields(args, bus, out)
    live = LiveView(out) if is_terminal(out) and not args.json else None
    with ExitStack() as stack:
        writer: csv.DictWriter[str] | None = None
        if args.csv:
            try:
                fh = stack.enter_context(open(args.csv, "w", newline="", encoding="utf-8"))
            except OSError as exc:
                raise DrEmpowerError(f"cannot write {args.csv}: {exc.strerror}") from None
            writer = csv.DictWriter(fh, ["time_s", *_readings.FIELDS])
            writer.writeheader()
        bus = stack.enter_context(open_from_args(args))
        ids_or_found(args, bus)
        start = time.monotonic()
        deadline = None if args.duration is None else start + args.duration
        k = 0
        try:
            while True:
                t = round(time.monotonic() - start, 3)
                # a motor that misses its fast read is shown as not answering, and costs one timeout
                records = [{"time_s": t, **r.record()} for r in _readings.read(bus, args.ids, missing_ok=True)]
                if writer is not None:
                    writer.writerows(records)
                if args.json:
                    out.write("".join(json_line(r) + "\n" for r in records))
                else:
                    lines = render_table(_HEADERS, [list(r.values()) for r in records], _WIDTHS)
                    if live is not None:
                        live.draw(lines)
                    else:
                        out.write("\n".join(lines if k == 0 else lines[1:]) + "\n")
                out.flush()
                now = time.monotonic()
                # the next reading on the RATE grid; readings that a slow round missed are skipped
                k = max(k + 1, math.ceil((now - start) * args.rate))
                due = start + k / args.rate
                if deadline is not None and (now >= deadline or due > deadline):
                    break
                time.sleep(max(0.0, due - now))
        except KeyboardInterrupt as exc:  # Ctrl-C, SIGTERM, SIGHUP: stop, then exit 128 + n
            ended = exit_code(exc)
    return ended
