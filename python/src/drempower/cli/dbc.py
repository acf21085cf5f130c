"""``drempower dbc``: write a DBC describing every DrEmpower command and reply (for cantools, SavvyCAN...)."""

from __future__ import annotations

import argparse
import sys
from typing import Any

from ..errors import DrEmpowerError
from ..records.dbc import dbc_text, parse_nodes


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
    p.add_argument("-o", "--output", metavar="FILE.dbc", help="write to FILE (default: standard output)")
    p.add_argument(
        "--nodes",
        type=_nodes,
        default=list(range(64)),
        metavar="IDS",
        help="node ids to describe, e.g. 1-6 or 0,1,2 (0 = broadcast; default 0-63, all)",
    )
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    text = dbc_text(args.nodes)
    if args.output is None:
        sys.stdout.write(text)
        return 0
    try:
        with open(args.output, "w", encoding="ascii", newline="\n") as fh:
            fh.write(text)
    except OSError as exc:
        raise DrEmpowerError(f"cannot write {args.output}: {exc.strerror}") from None
    print(f"{args.output}: {text.count(chr(10) + 'BO_ ')} messages for {len(args.nodes)} nodes", file=sys.stderr)
    return 0
