"""``drempower params``: list the parameter table, with filters."""

from __future__ import annotations

import argparse
import json
import sys
from typing import Any

from ..protocol import parameters
from ..protocol.parameters import Parameter

GROUP = "parameters"
"""Where ``drempower --help`` lists this module's subcommands."""


def register(sub: Any) -> None:
    p = sub.add_parser(
        "params",
        help="list the parameter table (name, address, type, access, unit)",
        description="List the motor's parameters. Filters combine; SEARCH matches name or description.",
    )
    p.add_argument("search", nargs="*", help="words that must all appear in the name or description")
    p.add_argument("--writable", action="store_true", help="only parameters that can be written")
    p.add_argument("--user", action="store_true", help="only parameters meant for users to change")
    p.add_argument("--series", choices=("G", "M"), help="only parameters that exist on this motor series")
    p.add_argument("--json", action="store_true", help="one JSON object per parameter (with its domain)")
    p.set_defaults(func=run)


def select(args: argparse.Namespace) -> list[Parameter]:
    words = [w.lower() for w in args.search]
    out = []
    for p in parameters():
        if args.writable and not p.writable:
            continue
        if args.user and not p.user_settable:
            continue
        if args.series and p.series not in ("", args.series):
            continue
        text = f"{p.name} {p.description}".lower()
        if all(w in text for w in words):
            out.append(p)
    return out


def run(args: argparse.Namespace) -> int:
    rows = select(args)
    if not rows:
        print("no parameter matches", file=sys.stderr)
        return 1
    if args.json:
        for p in rows:
            rec = {
                "name": p.name,
                "address": p.address,
                "type": p.dtype.name.lower(),
                "bool": p.is_bool,
                "access": p.access.value,
                "user_settable": p.user_settable,
                "unit": p.unit,
                "series": p.series,
                "description": p.description,
                "domain": p.domain_text() if p.writable else None,
            }
            sys.stdout.write(json.dumps(rec) + "\n")
        return 0
    width = max(len(p.name) for p in rows)
    print(f"{'address':>7}  {'name':<{width}}  type  access  {'unit':<13}  description")
    for p in rows:
        kind = "bool" if p.is_bool else p.dtype.name.lower()
        print(f"{p.address:>7}  {p.name:<{width}}  {kind:<4}  {p.access.value:<6}  {p.unit:<13}  {p.description}")
    return 0
