"""``drempower record``: write what passes on a bus to an MCAP file (raw frames, joint states, parameters, errors)."""

from __future__ import annotations

import argparse
import copy
import math
import sys
import time
from contextlib import ExitStack
from typing import Any

from ..errors import DrEmpowerError, ValidationError
from ..protocol import FastRead
from ..protocol.limits import MAX_NODE, MIN_MOTOR, is_motor
from ._connect import add_connection_args, add_ids_arg, ascii_digits, count, open_from_args, positive
from ._output import add_json_arg, json_line
from ._usage import UsageError

_HEARTBEAT = "can.config.heartbeat_ms"


def _names(text: str) -> dict[int, str]:
    out: dict[int, str] = {}
    for part in filter(None, text.split(",")):
        key, sep, name = part.partition("=")
        if not sep or not ascii_digits(key) or not is_motor(int(key)) or not name.strip():
            raise argparse.ArgumentTypeError(
                f"{part!r}: expected ID=NAME with ID {MIN_MOTOR}..{MAX_NODE}, e.g. 1=shoulder"
            )
        out[int(key)] = name.strip()
    return out


def _port(text: str) -> int:
    if not ascii_digits(text) or not 0 <= int(text) <= 65535:
        raise argparse.ArgumentTypeError(f"{text!r} is out of range: allowed 0..65535 (0: a free port)")
    return int(text)


def register(sub: Any) -> None:
    p = sub.add_parser(
        "record",
        help="record a bus to an MCAP file: raw frames both ways, joint states, parameter values, errors",
        description=(
            "Record every frame this command sends and receives to an MCAP file (ROS 2 profile): "
            "/can/tx and /can/rx (can_msgs/msg/Frame), /joint_states (sensor_msgs/msg/JointState, rad, rad/s, Nm), "
            "/drempower/parameters and /drempower/errors. With --robot FILE: every bus of the robot (or those of the "
            "joints named), raw frames on /can/<bus>/tx and /can/<bus>/rx, states under the joint names at the joint "
            "(after gear and offset). Foxglove, PlotJuggler, ros2 bag and rosbags open it; "
            "drempower decode reads it back. Without --heartbeat-ms or --poll it only listens. Ctrl-C ends it."
        ),
    )
    add_connection_args(p)
    add_ids_arg(p, optional=True)
    p.add_argument(
        "-w",
        "--output",
        required=True,
        metavar="FILE.mcap",
        help="the MCAP file to write (-o is python-can's bus option, as in every command)",
    )
    p.add_argument("--duration", type=positive, metavar="S", help="stop after S seconds (default: at Ctrl-C)")
    how = p.add_mutually_exclusive_group()
    how.add_argument(
        "--heartbeat-ms",
        type=count,
        metavar="MS",
        help="have the motors IDS send their state every MS ms (can.config.heartbeat_ms, set back to 0 at the end)",
    )
    how.add_argument("--poll", type=positive, metavar="HZ", help="read the state of the motors IDS HZ times a second")
    p.add_argument(
        "--foxglove",
        type=_port,
        metavar="PORT",
        help="also serve the bus live to Foxglove on ws://127.0.0.1:PORT (0: a free port; needs drempower[foxglove])",
    )
    p.add_argument("--names", type=_names, default={}, metavar="ID=NAME,...", help="joint names, e.g. 1=hip,2=knee")
    add_json_arg(p)
    p.set_defaults(func=run, robot_whole=True)


def _buses(args: argparse.Namespace) -> dict[str | None, list[int]]:
    """The buses to record and the motors to watch on each: None is the bus of the connection options."""
    groups: dict[str, list[int]] | None = getattr(args, "robot_groups", None)
    if groups is None:
        return {None: list(args.ids)}
    if args.names:
        raise UsageError("--names: not with --robot (the joint names come from the robot file)")
    return {name: ids for name, ids in groups.items()}


def _open(stack: ExitStack, args: argparse.Namespace, bus: str | None) -> Any:
    if bus is None:
        return stack.enter_context(open_from_args(args))
    part = copy.copy(args)
    part.robot_bus = bus
    return stack.enter_context(open_from_args(part))


def run(args: argparse.Namespace) -> int:
    from ..records.recorder import Recorder

    if not args.output.lower().endswith(".mcap"):
        raise UsageError(f"--output {args.output}: the file name must end in .mcap")
    buses = _buses(args)
    ids = [i for watched in buses.values() for i in watched]
    if (args.heartbeat_ms or args.poll) and not ids:
        raise UsageError("--heartbeat-ms and --poll need the motor IDS")
    if args.heartbeat_ms is not None and not 1 <= args.heartbeat_ms <= 1000:
        raise UsageError(f"--heartbeat-ms {args.heartbeat_ms} is out of range: allowed 1..1000")
    spec = getattr(args, "robot_spec", None)
    started = time.monotonic()
    with ExitStack() as stack:
        try:
            rec = stack.enter_context(Recorder(args.output, names=args.names))
        except ImportError as exc:  # a basic install: MCAP needs the records extra
            raise ValidationError(f"record needs the records extra ({exc})") from None
        live = None
        if args.foxglove is not None:
            from ..records.foxglove_live import FoxgloveLive

            try:
                live = stack.enter_context(FoxgloveLive(port=args.foxglove, names=args.names))
            except ImportError as exc:
                raise ValidationError(str(exc)) from None
            print(f"drempower: Foxglove: open {live.url}", file=sys.stderr, flush=True)
        opened: list[tuple[str | None, Any, list[int]]] = []
        for name, watched in buses.items():
            bus = _open(stack, args, name)
            opened.append((name, bus, watched))
            joints = spec.joints_on(name) if spec is not None and name is not None else []
            rec.attach(bus, name=name, joints=joints)
            if live is not None:
                live.attach(bus, name=name, joints=joints)
        beating: list[tuple[str | None, Any, int]] = []
        try:
            if args.heartbeat_ms:
                for name, bus, watched in opened:
                    for i in watched:
                        bus.motor(i).write_property(_HEARTBEAT, args.heartbeat_ms)
                        beating.append((name, bus, i))
            deadline = None if args.duration is None else started + args.duration
            k = 0
            while deadline is None or time.monotonic() < deadline:
                left = 0.25 if deadline is None else min(0.25, deadline - time.monotonic())
                if args.poll:
                    for _, bus, watched in opened:
                        bus.request([FastRead(i) for i in watched], missing_ok=True)
                    k = max(k + 1, math.ceil((time.monotonic() - started) * args.poll))
                    left = min(left, started + k / args.poll - time.monotonic())
                time.sleep(max(0.0, left))
        except KeyboardInterrupt:
            pass
        finally:
            for name, bus, i in beating:  # stop what this command started
                try:
                    bus.motor(i).write_property(_HEARTBEAT, 0)
                except DrEmpowerError as exc:
                    where = "" if name is None else f"bus {name}: "
                    print(f"drempower: {where}motor {i}: could not stop its heartbeat: {exc}", file=sys.stderr)
            time.sleep(0.05)  # the last frames in flight
            rec.detach()
            if live is not None:
                live.detach()
    s = rec.stats
    took = max(time.monotonic() - started, 1e-9)
    rate = f", {s.states / took / len(ids):.0f} states/s per motor" if ids else ""
    if args.json:
        summary: dict[str, Any] = {"output": args.output, "seconds": round(took, 3), **s.as_dict()}
        if spec is not None:
            summary["buses"] = list(buses)
        if ids:
            summary["states_per_s_per_motor"] = round(s.states / took / len(ids), 1)
        sys.stdout.write(json_line(summary) + "\n")
    print(
        f"{args.output}: {s.frames_written} frames, {s.states} states, {s.parameters} parameter values, "
        f"{s.errors} errors in {took:.1f} s{rate}; {s.frames_lost} frames lost",
        file=sys.stderr,
    )
    return 0
