"""``drempower dbc``: write a DBC describing every DrEmpower command and reply (for cantools, SavvyCAN...)."""

from __future__ import annotations

import argparse
import sys
from typing import Any

from ..errors import DrEmpowerError
from ..records.dbc import dbc_text, parse_nodes
from ._output import add_json_arg, json_line
from ._usage import UsageError


def _nodes(text: str) -> list[int]:
    try:
        return parse_nodes(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def register(sub: Any) -> None:
    p = sub.add_parser(
        "dbc",
        help="write a DBC of the protocol (every command and reply of every node) for CAN tools",
        description=(
            "Generate a DBC from the protocol tables: motion commands with scaled fields and units, presets, "
            "system commands, parameter read/write multiplexed on the data type, state replies with their T/E "
            "bits, fast read. cantools, SavvyCAN and python-can tools decode DrEmpower frames with it."
        ),
    )
    p.add_argument(
        "-w", "--output", metavar="FILE.dbc", help="write to FILE (default: standard output); -w as for record"
    )
    p.add_argument(
        "--nodes",
        type=_nodes,
        default=list(range(64)),
        metavar="IDS",
        help="node ids to describe, e.g. 1-6 or 0,1,2 (0 = broadcast; default 0-63, all)",
    )
    add_json_arg(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    if args.json and args.output is None:
        raise UsageError("--json needs -o FILE (without it the DBC itself goes to standard output)")
    text = dbc_text(args.nodes)
    if args.output is None:
        sys.stdout.write(text)
        return 0
    try:
        with open(args.output, "w", encoding="ascii", newline="\n") as fh:
            fh.write(text)
    except OSError as exc:
        raise DrEmpowerError(f"cannot write {args.output}: {exc.strerror}") from None
    messages = text.count("\nBO_ ")
    if args.json:
        sys.stdout.write(json_line({"output": args.output, "messages": messages, "nodes": args.nodes}) + "\n")
    else:
        print(f"{args.output}: {messages} messages for {len(args.nodes)} nodes", file=sys.stderr)
    return 0
