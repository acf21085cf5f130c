"""``drempower errors``: a motor's error flags, what they mean and what to do."""

from __future__ import annotations

import argparse
import sys
from typing import Any

from ..client import ErrorReport
from ..client.errors import TimeoutError
from ..protocol import ERROR_WORDS, flag_info
from ._connect import add_connection_args, add_ids_arg, follow_up, ids_or_found, open_from_args
from ._output import add_json_arg, json_line, no_answer

GROUP = "bus"
"""Where ``drempower --help`` lists this module's subcommands."""

_LABEL = {w.name: w.label for w in ERROR_WORDS}


def register(sub: Any) -> None:
    p = sub.add_parser(
        "errors",
        help="decoded error flags of motors, with their meaning and what to do",
        description=(
            "Read the seven error words of each motor and explain every flag that is set. "
            "Without IDS: every motor a quick scan finds."
        ),
    )
    add_ids_arg(p, optional=True)
    add_json_arg(p)
    add_connection_args(p)
    p.set_defaults(func=run)


def explain(report: ErrorReport) -> list[dict[str, Any]]:
    """One record per flag set: error word, its value, flag name, meaning and what to do."""
    out = []
    for word, names in report.flags.items():
        for name in names:
            info = flag_info(_LABEL[word], name)
            value = report.words[word]
            out.append({"word": word, "value": value, "flag": name, "meaning": info.meaning, "action": info.action})
    return out


def run(args: argparse.Namespace) -> int:
    reports: list[ErrorReport | int] = []
    with open_from_args(args) as bus:
        for node in ids_or_found(args, bus):
            try:
                reports.append(bus.motor(node).dump_error())
            except TimeoutError:
                reports.append(node)  # shown as not answering; the others still are
    out = sys.stdout
    for report in reports:
        if isinstance(report, int):
            out.write(
                json_line({"id": report, "errors": None, "answered": False}) + "\n"
                if args.json
                else f"motor {report}: no answer\n"
            )
            continue
        flags = explain(report)
        if args.json:
            out.write(json_line({"id": report.node, "errors": flags}) + "\n")
            continue
        if not flags:
            out.write(f"motor {report.node}: no errors\n")
            continue
        out.write(f"motor {report.node}: {len(flags)} error flag{'s' if len(flags) > 1 else ''}\n")
        word = None
        for f in flags:
            if f["word"] != word:
                word = f["word"]
                out.write(f"  {word} = 0x{f['value']:08X}\n")
            out.write(f"    {f['flag']}: {f['meaning']}\n      what to do: {f['action']}\n")
        n = report.node
        if report.words.get("axis0.encoder.error"):
            # these come back after a plain clear: set the zero first (PROTOCOL.md 3.2)
            steps = (follow_up(args, f"zero {n}"), follow_up(args, f"clear {n}"), follow_up(args, f"enable {n}"))
            out.write(f"  then, with the motor at rest: {' && '.join(steps)}\n")
        else:
            out.write(f"  then: {follow_up(args, f'clear {n}')} && {follow_up(args, f'enable {n}')}\n")
    return no_answer([r for r in reports if isinstance(r, int)])
