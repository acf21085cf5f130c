"""``drempower decode``: decode captured frames (candump text, MCAP recordings, python-can logs) into
DrEmpower messages."""

from __future__ import annotations

import argparse
import sys
from typing import Any, TextIO

from ..errors import DrEmpowerError
from ..protocol import (
    CaptureDecoder,
    ParamValue,
    ReadParam,
    WriteParam,
    decode_frame,
    describe,
    message_fields,
    message_name,
)
from ..protocol.candump import parse_candump_line
from ..protocol.parameters import find_parameter
from ._inputs import input_lines
from ._output import clean, json_line

GROUP = "logs and tools"
"""Where ``drempower --help`` lists this module's subcommands."""


def register(sub: Any) -> None:
    p = sub.add_parser(
        "decode",
        help="decode captured frames (candump text or stdin, MCAP recordings, python-can logs) into DrEmpower messages",
        description=(
            "Decode candump-format lines, e.g. '(ts) can0 039#0000B4420000E803' or '039#0000B4420000E803', "
            "the lines sniff prints, MCAP files written by record, and python-can logs (by extension), "
            "one message per frame, with its timestamp when the input has one. "
            "Lines that are not frames or do not decode are reported, never fatal; exits 1 when no line is a frame."
        ),
    )
    p.add_argument(
        "files",
        nargs="*",
        help="candump text, .mcap recordings or python-can logs (.asc .blf .csv .db .mf4 .trc) (default: stdin)",
    )
    p.add_argument("--json", action="store_true", help="one JSON object per line")
    p.add_argument(
        "--direction",
        choices=("auto", "host", "motor"),
        default="auto",
        help="who sent the frames: host commands, motor replies, or guess per frame (default)",
    )
    p.set_defaults(func=run)


def decode_line(line: str, direction: str = "auto", capture: CaptureDecoder | None = None) -> dict[str, Any]:
    """Decode one candump line into a JSON-ready dict (``error`` set when it cannot be decoded).

    With ``capture`` (one per capture, fed every line in order), a parameter reply of
    value 0 is told from the read request it repeats.
    """
    out: dict[str, Any] = {"line": line.rstrip("\n")}
    try:
        frame = parse_candump_line(line)
    except DrEmpowerError as exc:
        out["error"] = f"not a frame: {exc}"
        return out
    out["id"] = f"0x{frame.arbitration_id:03X}"
    out["data"] = frame.data.hex().upper()
    if frame.timestamp is not None:
        out["timestamp"] = frame.timestamp
    if frame.channel is not None:
        out["channel"] = frame.channel
    if frame.is_extended or frame.is_remote or frame.is_fd:
        kind = "extended-id" if frame.is_extended else "remote" if frame.is_remote else "CAN-FD"
        out["error"] = f"{kind} frame: DrEmpower uses standard data frames only"
        return out
    try:
        if capture is None:
            who, msg = decode_frame(frame.arbitration_id, frame.data, direction)  # type: ignore[arg-type]
        else:
            who, msg = capture.decode(frame.arbitration_id, frame.data, frame.timestamp, direction)  # type: ignore[arg-type]
    except DrEmpowerError as exc:
        out["error"] = str(exc)
        return out
    out["node"] = msg.node
    out["direction"] = who
    out["command"] = message_name(msg)
    out["fields"] = message_fields(msg)
    if isinstance(msg, (ReadParam, WriteParam, ParamValue)):
        p = find_parameter(msg.address)
        if p is not None:
            out["parameter"] = p.name
            out["unit"] = p.unit
    out["text"] = describe(msg)
    return out


def run(args: argparse.Namespace, out: TextIO | None = None) -> int:
    out = out or sys.stdout
    frames = 0
    capture = CaptureDecoder()
    for line, direction in input_lines(args.files, args.direction):
        if not line.strip() or line.lstrip().startswith("#"):
            continue
        rec = decode_line(line, direction, capture)
        if "id" in rec:
            frames += 1
        if args.json:
            out.write(json_line(rec) + "\n")
        elif "error" in rec:
            out.write(clean(f"{rec['line'].strip()}  !! {rec['error']}") + "\n")
        else:
            stamp = f"({rec['timestamp']:.6f}) " if "timestamp" in rec else ""
            out.write(clean(f"{stamp}{rec['id']:>5} {rec['data']:<16}  {rec['direction']:<5} {rec['text']}") + "\n")
        out.flush()
    if not frames:
        print("drempower decode: no line of the input was a CAN frame", file=sys.stderr)
        return 1
    return 0
