"""``drempower set-id``, ``set-bitrate``, ``save`` and ``reboot``: link settings and flash."""

from __future__ import annotations

import argparse
import time
from typing import Any

from ..client import Bus
from ..client.engine.ops import CAN_BAUD_RATES, UART_BAUD_RATES
from ..client.errors import TimeoutError
from ..protocol import FastRead
from ._connect import add_connection_args, add_ids_arg, bitrate, motor_id, open_from_args, seconds
from ._output import add_json_arg, motors_text, report, sent
from ._usage import UsageError

GROUP = "parameters"
"""Where ``drempower --help`` lists this module's subcommands."""


def register(sub: Any) -> None:
    i = sub.add_parser(
        "set-id",
        help="give a motor a new id (checked, then saved)",
        description="Change a motor's id, check that it answers at the new one, then save.",
    )
    i.add_argument("id", type=motor_id, metavar="ID", help="the motor's id now")
    i.add_argument("new_id", type=motor_id, metavar="NEW_ID", help="its new id, 1..63")
    add_json_arg(i)
    add_connection_args(i)
    i.set_defaults(func=run_set_id)

    b = sub.add_parser(
        "set-bitrate",
        help="set a motor's CAN bitrate (or UART rate); saved, applies after a reboot",
        description=(
            "Set the CAN bitrate (125k, 250k, 500k, 1M) or, with --link uart, the UART rate of an M-series motor "
            "(9600, 19200, 57600, 115200). The value is checked and saved; it applies after a reboot, "
            "after which the motor is reached at the new rate only."
        ),
    )
    b.add_argument("id", type=motor_id, metavar="ID", help="the motor's id")
    b.add_argument("rate", type=bitrate, metavar="BITRATE", help="bit/s, e.g. 1M, 500k, 115200")
    b.add_argument("--link", choices=("can", "uart"), default="can", help="which rate to set (default can)")
    b.add_argument("--reboot", action="store_true", help="reboot the motor so the new rate applies now")
    add_json_arg(b)
    add_connection_args(b)
    b.set_defaults(func=run_set_bitrate)

    s = sub.add_parser("save", help="store the configuration in flash", description="Store RAM settings in flash.")
    add_ids_arg(s, all_ok=True)
    add_json_arg(s)
    add_connection_args(s)
    s.set_defaults(func=run_save)

    r = sub.add_parser(
        "reboot",
        help="software reset (unsaved settings are lost)",
        description="Reboot motors; settings not saved are lost. --wait waits until they answer again.",
    )
    add_ids_arg(r, all_ok=True)
    r.add_argument("--wait", action="store_true", help="wait until every motor answers again")
    r.add_argument("--wait-timeout", type=seconds, default=5.0, metavar="S", help="longest wait (default 5)")
    add_json_arg(r)
    add_connection_args(r)
    r.set_defaults(func=run_reboot)


def run_set_id(args: argparse.Namespace) -> int:
    with open_from_args(args) as bus:
        bus.motor(args.id).set_id(args.new_id)
    record = {"id": args.id, "new_id": args.new_id, "saved": True}
    report(args, f"motor {args.id} is now motor {args.new_id} (saved)", [record])
    return 0


def run_set_bitrate(args: argparse.Namespace) -> int:
    rates = UART_BAUD_RATES if args.link == "uart" else CAN_BAUD_RATES
    if args.rate not in rates:  # before connecting: a usage error
        what = "UART rates" if args.link == "uart" else "CAN bitrates"
        raise UsageError(f"argument BITRATE: {args.rate}: {what} are {', '.join(map(str, rates))}")
    with open_from_args(args) as bus:
        motor = bus.motor(args.id)
        if args.link == "uart":
            motor.set_uart_baud_rate(args.rate)
        else:
            motor.set_can_baud_rate(args.rate)
        if args.reboot:
            motor.reboot()
    what = "UART rate" if args.link == "uart" else "CAN bitrate"
    when = "now" if args.reboot else "after a reboot"
    record = {"id": args.id, "link": args.link, "bitrate": args.rate, "saved": True, "applies": when}
    report(args, f"motor {args.id}: {what} {args.rate} bit/s saved; it applies {when}", [record])
    return 0


def run_save(args: argparse.Namespace) -> int:
    with open_from_args(args) as bus:
        for node in args.ids:
            bus.motor(node).save_config()
    report(args, f"{motors_text(args.ids)}: save sent", sent(args.ids, "save"))
    return 0


def _wait_answer(bus: Bus, ids: list[int], timeout: float) -> None:
    deadline = time.monotonic() + timeout
    while True:
        try:
            bus.request([FastRead(i) for i in ids])
            return
        except TimeoutError:
            if time.monotonic() > deadline:
                raise TimeoutError(ids, "fast reads after the reboot", timeout) from None


def run_reboot(args: argparse.Namespace) -> int:
    waited = args.wait and args.ids != [0]
    with open_from_args(args) as bus:
        for node in args.ids:
            bus.motor(node).reboot()
        if waited:
            _wait_answer(bus, args.ids, args.wait_timeout)
    text = f"{motors_text(args.ids)}: " + ("rebooted and answering" if waited else "reboot sent")
    report(args, text, sent(args.ids, "reboot", answering=True if waited else None))
    return 0
