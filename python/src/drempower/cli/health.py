"""``drempower health``: each motor's temperatures, effective current limit, derating and errors, with fixes."""

from __future__ import annotations

import argparse
import dataclasses
import sys
import time
from typing import Any

from ..client.engine.health import Health
from ..client.engine.supervisor import HealthPolicy
from ..client.errors import TimeoutError
from ._connect import add_connection_args, add_ids_arg, ids_or_found, open_from_args, positive
from ._output import add_json_arg, json_line, render_table
from ._usage import UsageError

GROUP = "bus"
"""Where ``drempower --help`` lists this module's subcommands."""

_HEADERS = ["motor", "motor/degC", "driver/degC", "limit/A", "derating", "errors"]


def register(sub: Any) -> None:
    p = sub.add_parser(
        "health",
        help="temperatures, effective current limit, derating and errors of motors or joints",
        description=(
            "Read each motor's winding and driver-board temperatures, its effective (thermally derated) current "
            "limit and its errors: five parameter reads per motor in one exchange, seven more for a faulted one. "
            "derating is 0 with the full current available, 1 with none left. Without IDS: every motor a quick "
            "scan finds. Exit 1 when a motor does not answer or reports an error."
        ),
    )
    add_ids_arg(p, optional=True)
    add_json_arg(p)
    p.add_argument(
        "--watch",
        action="store_true",
        help="run the health supervisor until Ctrl-C or --duration: one line per event (warnings before the "
        "firmware derates, stalls, faults with their fix) and what it did; the robot file's [health] and each "
        "joint's on_overheat decide (default: warn only), 12 frames per motor and period",
    )
    p.add_argument("--duration", type=positive, metavar="S", help="with --watch: stop after S seconds")
    add_connection_args(p)
    p.set_defaults(func=run)


def _policy(args: argparse.Namespace) -> HealthPolicy:
    spec = getattr(args, "robot_spec", None)
    if spec is None or spec.health is None:
        return HealthPolicy()
    joints = {j.id: j.on_overheat for j in spec.joints_on(args.robot_bus) if j.on_overheat is not None}
    stalls = {j.id: j.on_stall for j in spec.joints_on(args.robot_bus) if j.on_stall is not None}
    return HealthPolicy(**spec.health, joints=joints, stalls=stalls)


def watch(args: argparse.Namespace) -> int:
    """The supervisor's loop: one step per period, each event as a line (or a JSON object)."""
    policy = _policy(args)
    spec = getattr(args, "robot_spec", None)
    names = {j.id: j.name for j in spec.joints_on(args.robot_bus)} if spec is not None else {}
    worst = 0
    with open_from_args(args) as bus:
        watches = bus.watch_health(ids_or_found(args, bus), policy, names)
        start = time.monotonic()
        try:
            while args.duration is None or time.monotonic() - start < args.duration:
                for e in bus.supervise(watches):
                    worst = max(worst, int(e.level == "error"))
                    if args.json:
                        print(json_line({"time_s": round(e.at, 3), **dataclasses.asdict(e)}), flush=True)
                    else:
                        print(f"{e.at:9.2f} s  {e.level:5}  {e}", flush=True)
                time.sleep(max(0.0, policy.period - (time.monotonic() - start) % policy.period))
        except KeyboardInterrupt:
            pass
    return worst


def run(args: argparse.Namespace) -> int:
    if args.watch:
        return watch(args)
    if args.duration is not None:
        raise UsageError("--duration goes with --watch")
    got: list[Health | int] = []
    spec = getattr(args, "robot_spec", None)
    names = {j.id: j.name for j in spec.joints_on(args.robot_bus)} if spec is not None else {}
    with open_from_args(args) as bus:
        for node in ids_or_found(args, bus):
            try:
                got.append(dataclasses.replace(bus.motor(node).health(), name=names.get(node)))
            except TimeoutError:
                got.append(node)  # shown as not answering; the others still are
    out = sys.stdout
    worst = 0
    rows: list[list[object]] = []
    notes: list[str] = []
    for h in got:
        if isinstance(h, int):
            worst = 1
            if args.json:
                out.write(json_line({"id": h, "answered": False}) + "\n")
            else:
                notes.append(f"motor {h}: no answer")
            continue
        rec = h.as_dict()
        if h.errors:
            worst = 1
        if args.json:
            out.write(json_line(rec) + "\n")
            continue
        rows.append(
            [
                f"{h.name} ({h.id})" if h.name else h.id,
                f"{h.motor_temp_c:.1f}",
                f"{h.driver_temp_c:.1f}",
                f"{h.current_limit_a:.2f}",
                f"{h.derating:.2f}",
                " ".join(rec["errors"]) or "none",
            ]
        )
        notes.extend(rec["faults"])
    if not args.json:
        if rows:
            out.write("\n".join(render_table(_HEADERS, rows, digits=None)) + "\n")
        for n in notes:
            out.write(n + "\n")
    return worst
