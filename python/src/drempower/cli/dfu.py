"""``drempower dfu``: put one motor into firmware-update mode (system command 0x07, ``enter_dfu_mode``)."""

from __future__ import annotations

import argparse
from typing import Any

from ..protocol import SystemCommand
from ..protocol.ids import SysCmd
from ._confirm import add_yes_arg, confirm
from ._connect import add_connection_args, follow_up, open_from_args, parse_ids
from ._output import add_json_arg, report, sent

GROUP = "parameters"
"""Where ``drempower --help`` lists this module's subcommands."""

NEXT_STEPS = (
    "the motor has left normal operation and no longer answers on CAN. Next: connect its USB port, flash the "
    "firmware with the vendor's updater (the DrEmpower host tool's firmware update), power-cycle the motor, then "
    "restore the defaults and recalibrate: `{calibrate}`"
)


def _one_motor(text: str) -> int:
    """A motor id 1..63; broadcast (0, all) is refused: firmware mode is entered one motor at a time."""
    if text.strip().lower() in ("0", "all"):
        raise argparse.ArgumentTypeError(
            f"{text!r} is broadcast: firmware-update mode is entered one motor at a time; give its id"
        )
    ids = parse_ids(text)
    if len(ids) != 1:
        raise argparse.ArgumentTypeError(f"expected one motor id, got {text!r}")
    return ids[0]


def register(sub: Any) -> None:
    p = sub.add_parser(
        "dfu",
        help="put a motor into firmware-update mode (DFU) for the vendor's updater",
        description=(
            "Send enter_dfu_mode (system command 0x07) to one motor, after confirmation (--yes skips it). "
            "The motor releases its load and stops answering on CAN until it is flashed and power-cycled; "
            "then restore the defaults and recalibrate. Broadcast (0, all) is refused."
        ),
    )
    p.add_argument("id", type=_one_motor, metavar="ID", help="the motor's id (1-63)")
    add_yes_arg(p)
    add_json_arg(p)
    add_connection_args(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    confirm(
        args,
        f"put motor {args.id} into firmware-update mode",
        "it releases its load (a held arm drops) and stops answering until flashed and power-cycled",
    )
    with open_from_args(args) as bus:
        bus.motor(args.id).get_state()  # it must be there: a DFU request to nobody would say nothing
        bus.send(SystemCommand(args.id, SysCmd.ENTER_DFU_MODE))
    text = f"motor {args.id}: firmware-update mode requested; " + NEXT_STEPS.format(
        calibrate=follow_up(args, f"calibrate {args.id}")
    )
    report(args, text, sent([args.id], "enter_dfu_mode"))
    return 0
