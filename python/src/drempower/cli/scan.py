"""``drempower scan``: find the motors on the bus."""

from __future__ import annotations

import argparse
from typing import Any

from ..errors import DrEmpowerError
from . import _readings
from ._connect import add_connection_args, open_from_args, parse_ids
from ._output import Progress, add_json_arg, emit

_HEADERS = ("id", "hw", "fw", "state", "position/deg", "vbus/V", "errors")


def register(sub: Any) -> None:
    p = sub.add_parser(
        "scan",
        help="list the motors that answer: id, versions, state, position, errors",
        description="Fast-read every id at once, then read each motor's versions, state and errors.",
    )
    p.add_argument("--ids", type=parse_ids, default=list(range(1, 64)), help="ids to try (default 1-63)")
    add_json_arg(p)
    add_connection_args(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    with open_from_args(args) as bus, Progress() as progress:
        progress.show(f"scanning {len(args.ids)} ids...")
        found = bus.scan(args.ids, versions=True)
        records = []
        for k, info in enumerate(found, 1):
            progress.show(f"reading motor {info.id} ({k}/{len(found)})...")
            (reading,) = _readings.read(bus, [info.id], missing_ok=True)
            rec = reading.record()
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
    if not records:
        raise DrEmpowerError("no motor answered (check power, wiring, termination and bitrate)")
    emit(args, _HEADERS, records)
    return 0
