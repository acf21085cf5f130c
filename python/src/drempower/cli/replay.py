"""``drempower replay``: play a recorded log onto a bus (the simulator by default)."""

from __future__ import annotations

import argparse
import sys
import time
from typing import Any

from ..client.driver.signals import exit_code
from ..client.engine.session import MOTION_CMDS
from ..errors import DrEmpowerError, ProtocolError
from ..protocol.addresses import AXIS0_REQUESTED_STATE
from ..protocol.describe import CaptureDecoder
from ..protocol.enums import AxisState
from ..protocol.messages import Message, WriteParam, decode_command
from ..records.logs import LogRecord, direction_of
from ._connect import add_connection_args, open_from_args, positive
from ._inputs import log_records
from ._output import add_json_arg, json_line


def register(sub: Any) -> None:
    p = sub.add_parser(
        "replay",
        help="play a log (MCAP, candump, python-can formats) onto a bus, by default the simulator",
        description=(
            "Send the host commands of a log onto a bus at the recorded pace (or --rate frames per second). "
            "Frames the log marks as sent by the recording host are host frames; in logs that do not say, "
            "frames that decode as host commands are. Motors replay commanded are put into IDLE when it ends "
            "(Ctrl-C or SIGTERM too) unless --leave-running. Default connection: simulated motors with the "
            "ids of the log."
        ),
    )
    p.add_argument("file", help="the log: .mcap, .log (candump), .asc, .blf, .csv, .db, .mf4, .trc")
    p.add_argument("--rate", type=positive, metavar="HZ", help="send HZ frames per second instead of the recorded pace")
    p.add_argument("--speed", type=positive, default=1.0, metavar="X", help="play the recorded pace X times faster")
    p.add_argument("--all-frames", action="store_true", help="also send the motors' frames (replies, states)")
    p.add_argument("--leave-running", action="store_true", help="do not put replayed motors into IDLE at the end")
    p.add_argument(
        "--enable",
        action="store_true",
        help="clear the errors of the motors the log drives and put them in closed loop first, and let the "
        "log's own enables through (default: refuse when one is idle or in error, or when the log enables one)",
    )
    add_json_arg(p)
    add_connection_args(p)
    p.set_defaults(func=run)


def _host_frames(records: list[LogRecord], every: bool) -> list[tuple[LogRecord, Message | None]]:
    capture = CaptureDecoder()
    out: list[tuple[LogRecord, Message | None]] = []
    for rec in records:
        arb, data, ext, rtr = rec.frame
        msg: Message | None = None
        who = None
        if not (ext or rtr):
            try:
                who, _ = capture.decode(arb, data, rec.timestamp, direction_of(rec))
                msg = decode_command(arb, data) if who == "host" else None
            except ProtocolError:
                msg = None
        if who == "host" or every:
            out.append((rec, msg))
    return out


_CLOSED_LOOP = AxisState.CLOSED_LOOP_CONTROL


def _driven(frames: list[tuple[LogRecord, Message | None]]) -> list[int]:
    """The motors the log's motion commands drive that the log does not put in closed loop itself, by id."""
    driven: set[int] = set()
    enabled: set[int] = set()
    for _, msg in frames:
        if isinstance(msg, WriteParam) and msg.address == AXIS0_REQUESTED_STATE and msg.value == _CLOSED_LOOP:
            enabled.add(msg.node)
        elif msg is not None and msg.cmd in MOTION_CMDS and msg.node not in enabled:
            driven.add(msg.node)
    return sorted(driven - {0})


def _enables(frames: list[tuple[LogRecord, Message | None]]) -> list[int]:
    """The motors the log itself puts in closed loop (its own enable frames), by id."""
    return sorted(
        {
            msg.node
            for _, msg in frames
            if isinstance(msg, WriteParam) and msg.address == AXIS0_REQUESTED_STATE and msg.value == _CLOSED_LOOP
        }
    )


def _refusals(frames: list[tuple[LogRecord, Message | None]], args: argparse.Namespace) -> None:
    """Refuse, before anything is sent, a log that would enable motors unasked. (Frames the protocol does
    not define, and the motors' own, go out raw only with --all-frames: the explicit ask.)"""
    enables = _enables(frames)
    if enables and not args.enable:
        ids = ",".join(map(str, enables))
        raise DrEmpowerError(
            f"{args.file}: the log enables motors {ids} itself; replay with --enable to let it (nothing was sent)"
        )


def _send(bus: Any, msg: Message) -> None:
    """One command of the log, through the safety gate: motion (limits, closed loop), and parameter writes
    as ``write_property`` takes them (domains; those that command motion as that motion)."""
    if isinstance(msg, WriteParam):
        bus.motor(msg.node).write_property(msg.address, msg.value)
        return
    if msg.cmd in MOTION_CMDS:
        bus.pass_gate([msg])
    bus.send(msg)  # the bus remembers the motors it commanded, to stop them at the end


def _ready(bus: Any, nodes: list[int], args: argparse.Namespace) -> None:
    """Refuse to replay onto motors that would ignore it (idle, in error); with --enable, enable them first."""
    from . import _readings

    if args.enable:
        for node in nodes:
            bus.motor(node).clear_error()
            bus.motor(node).set_mode(2)
    try:
        _readings.require_ready(bus, nodes, args)
    except DrEmpowerError as exc:
        raise DrEmpowerError(f"{exc}; or replay with --enable, which clears and enables them first") from None


def run(args: argparse.Namespace) -> int:
    records = list(log_records(args.file))
    frames = _host_frames(records, args.all_frames)
    if not frames:
        raise DrEmpowerError(f"{args.file}: no frames to replay")
    if args.rate is None and any(r.timestamp is None for r, _ in frames):
        raise DrEmpowerError(f"{args.file}: the log has no timestamps; give --rate HZ")
    if not (args.sim or args.serial or args.uart or args.interface):
        nodes = sorted({r.frame.arbitration_id >> 5 for r, _ in frames} - {0}) or [1]
        args.sim = nodes
        print(f"drempower: replaying onto simulated motors {','.join(map(str, nodes))}", file=sys.stderr)
    _refusals(frames, args)
    sent = 0
    with open_from_args(args, quiet=True) as bus:
        _ready(bus, _driven(frames), args)
        bus.check_limits([msg for _, msg in frames if msg is not None])  # the log's own values, before it starts
        bus.stop_on_close = not args.leave_running
        start = time.monotonic()
        t0 = frames[0][0].timestamp
        try:
            for i, (rec, msg) in enumerate(frames):
                if args.rate is not None:
                    due = start + i / args.rate
                else:
                    assert rec.timestamp is not None and t0 is not None
                    due = start + (rec.timestamp - t0) / args.speed
                pause = due - time.monotonic()
                if pause > 0:
                    time.sleep(pause)
                if msg is not None:
                    _send(bus, msg)
                else:
                    bus.transport.send(rec.frame)
                sent += 1
        except KeyboardInterrupt as exc:  # Ctrl-C, SIGTERM, SIGHUP: the motors stop as the bus closes
            print(f"drempower: replay interrupted after {sent} frames", file=sys.stderr)
            return exit_code(exc)
    if args.json:
        sys.stdout.write(json_line({"file": args.file, "frames_sent": sent, "frames_in_log": len(records)}) + "\n")
    print(f"{sent} frame{'' if sent == 1 else 's'} replayed from {args.file}", file=sys.stderr)
    return 0
