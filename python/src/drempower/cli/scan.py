"""``drempower scan``: find the motors on the bus."""

from __future__ import annotations

import argparse
import sys
from typing import Any

from ..errors import DrEmpowerError
from . import _readings
from ._connect import add_connection_args, open_from_args, parse_ids
from ._output import Progress, add_json_arg, emit, no_answer

GROUP = "bus"
"""Where ``drempower --help`` lists this module's subcommands."""

_HEADERS = ("id", "hw", "fw", "state", "position/deg", "vbus/V", "errors")


def register(sub: Any) -> None:
    p = sub.add_parser(
        "scan",
        help="list the motors that answer: id, versions, state, position, errors",
        description="Fast-read every id at once, then read each motor's versions, state and errors.",
    )
    p.add_argument("--ids", type=parse_ids, default=list(range(1, 64)), help="ids to try (default 1-63)")
    p.add_argument(
        "--expect",
        type=parse_ids,
        default=[],
        metavar="IDS",
        help="motors that must answer (tried even if not in --ids): one that does not gets a row and exit status 1",
    )
    add_json_arg(p)
    add_connection_args(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    expected: list[int] = args.expect
    ids = [*args.ids, *(i for i in expected if i not in args.ids)]
    with open_from_args(args) as bus, Progress() as progress:
        progress.show(f"scanning {len(ids)} ids...")
        found = bus.scan(ids, versions=True)
        records: list[dict[str, Any]] = []
        # a motor named in --ids that is not found, or a lost reply of one that is, shows as a row
        # and in the exit status: on a lossy link, --retries gives each read more tries
        incomplete: list[int] = []
        for k, info in enumerate(found, 1):
            progress.show(f"reading motor {info.id} ({k}/{len(found)})...")
            (reading,) = _readings.read(bus, [info.id], missing_ok=True)
            rec = reading.record()
            if not reading.answered or info.hw_version is None or info.fw_version is None:
                incomplete.append(info.id)
            records.append(
                {
                    "id": info.id,
                    "hw_version": info.hw_version,
                    "fw_version": info.fw_version,
                    "state": rec["state"],
                    "position_deg": rec["position_deg"] if reading.answered else round(info.state.angle, 4),
                    "vbus_v": rec["vbus_v"],
                    "errors": rec["errors"],
                }
            )
        there = {info.id for info in found}
        missed = [i for i in expected if i not in there]
    if not found and not expected:
        raise DrEmpowerError("no motor answered (check power, wiring, termination and bitrate)")
    blank = dict.fromkeys(("hw_version", "fw_version", "state", "position_deg", "vbus_v"))
    records += [{"id": i, **blank, "errors": "no answer"} for i in missed]
    records.sort(key=lambda r: ids.index(r["id"]))
    emit(args, _HEADERS, records)
    code = no_answer(missed)
    if incomplete:
        print(f"drempower: some replies of motor {', '.join(map(str, incomplete))} were lost", file=sys.stderr)
    if code or incomplete:
        if not getattr(args, "retries", 0):
            print("drempower: on a lossy link, --retries N asks again", file=sys.stderr)
        return 1
    return 0
