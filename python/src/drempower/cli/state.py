"""``drempower state``: one reading of each motor."""

from __future__ import annotations

import argparse
from typing import Any

from . import _readings
from ._connect import add_connection_args, add_ids_arg, ids_or_found, open_from_args
from ._output import add_json_arg, emit, no_answer
from ._robot import joint_record

GROUP = "bus"
"""Where ``drempower --help`` lists this module's subcommands."""


def register(sub: Any) -> None:
    p = sub.add_parser(
        "state",
        help="position, speed, torque, trajectory done, axis state, bus voltage and errors of motors",
        description=(
            "Read each motor once; `drempower monitor` keeps reading. A motor that does not answer gets a "
            "row saying so, and the exit status is then 1. Without IDS: every motor a quick scan finds."
        ),
    )
    add_ids_arg(p, optional=True)
    add_json_arg(p)
    add_connection_args(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    with open_from_args(args) as bus:
        readings = _readings.read(bus, ids_or_found(args, bus), missing_ok=True)
    records = [joint_record(args, r.record()) for r in readings]  # --robot: a named joint's at the joint
    headers = (*_readings.HEADERS, "units") if records and "units" in records[0] else _readings.HEADERS
    emit(args, headers, records)
    return no_answer([r.id for r in readings if not r.answered])
