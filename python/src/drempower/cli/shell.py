"""``drempower shell``: an interactive Python console with the bus open, as odrivetool and ``moteus_tool --console``.

``bus`` is the open :class:`~drempower.Bus`, ``m1``, ``m2``... its motors (those
given, or those a quick scan finds) and ``drempower`` the package; Tab completes
names and attributes. Ctrl-D (or ``exit()``) leaves: the motors the session
commanded are set to idle, as every motion command does when it ends on a signal,
and the bus is closed. Ctrl-C interrupts the line being run, not the session;
SIGTERM and SIGHUP end it.
"""

from __future__ import annotations

import argparse
import code
import signal
import sys
from types import FrameType
from typing import Any

from ._connect import add_connection_args, add_ids_arg, connection_words, ids_or_found, open_from_args
from ._motion import stop_commanded
from ._output import json_line

GROUP = "bus"
"""Where ``drempower --help`` lists this module's subcommands."""

BANNER = (
    "drempower {version} shell on {how}\n"
    "  bus: the open bus; {motors}drempower: the package. Tab completes; Ctrl-D leaves "
    "(the motors commanded here go idle)."
)


def register(sub: Any) -> None:
    p = sub.add_parser(
        "shell",
        help="interactive Python console with the bus open (bus, m1, m2... and tab completion)",
        description=(
            "A Python console with the bus open: `bus`, `m1`, `m2`... for the motors given (or found by a quick "
            "scan), and `drempower`. Tab completes. Ctrl-D leaves; the motors commanded from the console are set "
            "to idle and the bus closed."
        ),
    )
    add_ids_arg(p, optional=True)
    p.add_argument(
        "--json",
        action="store_true",
        help='the banner as one JSON object on stderr ({"shell": ..., "connection": ..., "motors": [...]})',
    )
    add_connection_args(p)
    p.set_defaults(func=run)


def _completion(namespace: dict[str, Any]) -> None:
    """Tab completion of names and attributes in ``namespace`` (when readline is there: not on every platform)."""
    try:
        import readline
        import rlcompleter
    except ImportError:  # pragma: no cover - Windows without pyreadline
        return
    readline.set_completer(rlcompleter.Completer(namespace).complete)
    readline.parse_and_bind("tab: complete")


def _end(signum: int, frame: FrameType | None) -> None:
    raise SystemExit(128 + signum)  # the console catches KeyboardInterrupt (and so Terminated): this ends it


def run(args: argparse.Namespace) -> int:
    import drempower

    with open_from_args(args) as bus:
        ids = ids_or_found(args, bus, none_ok=True)
        namespace: dict[str, Any] = {"bus": bus, "drempower": drempower, "__name__": "__console__"}
        namespace.update({f"m{i}": bus.motor(i) for i in ids})
        motors = "".join(f"m{i}, " for i in ids)
        motors = f"{motors[:-2]}: its motors; " if ids else ""
        how = f"bus {args.robot_bus} of {args.robot}" if getattr(args, "robot_bus", None) else ""
        how = how or " ".join(connection_words(args)) or "python-can's configuration"
        _completion(namespace)
        # Ctrl-C interrupts a line (Python's own handler), SIGTERM and SIGHUP end the session
        signal.signal(signal.SIGINT, signal.default_int_handler)
        for signum in (signal.SIGTERM, getattr(signal, "SIGHUP", None)):
            if signum is not None and signal.getsignal(signum) is not signal.SIG_IGN:
                signal.signal(signum, _end)
        code_ = 0
        banner = BANNER.format(version=drempower.__version__, how=how, motors=motors)
        if args.json:
            banner = json_line({"shell": drempower.__version__, "connection": how, "motors": ids})
        try:
            code.InteractiveConsole(namespace).interact(banner=banner, exitmsg="")
        except SystemExit as exc:
            code_ = exc.code if isinstance(exc.code, int) else 0
        finally:
            stop_commanded(bus, "shell ended")
    sys.stdout.flush()
    return code_
