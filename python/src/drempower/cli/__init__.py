"""The ``drempower`` command.

Each subcommand lives in its own module of this package and exposes
``register(subparsers)``; modules are discovered automatically, so adding a
subcommand means adding a module.
"""

from __future__ import annotations

import argparse
import importlib
import pkgutil
import sys
from collections.abc import Sequence
from typing import NoReturn

from .. import __version__
from ..client.signals import Terminated, exit_code, signals_interrupt
from ..errors import DrEmpowerError
from ._output import clean
from ._parser import Parser
from ._robot import apply_robot, run_command
from ._usage import UsageError

__all__ = ["main", "build_parser"]


class _Parser(Parser):
    """argparse, with control characters of the arguments it quotes escaped in its errors."""

    def error(self, message: str) -> NoReturn:
        super().error(clean(message))


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="drempower",
        description="Work with DrEmpower servo joint motors: decode, simulate, drive, configure.",
    )
    parser.add_argument("--version", action="version", version=f"drempower {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    for info in sorted(pkgutil.iter_modules(__path__), key=lambda i: i.name):
        if info.name.startswith("_"):
            continue
        mod = importlib.import_module(f"{__name__}.{info.name}")
        register = getattr(mod, "register", None)
        if register is not None:
            register(sub)
    for command in sub.choices.values():
        command.set_defaults(command_parser=command)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``drempower`` console script; returns the exit code."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        apply_robot(args)  # --robot: joint names, the buses the command runs on
        with signals_interrupt():  # SIGTERM and SIGHUP end a command as Ctrl-C does
            code: int = run_command(args) if getattr(args, "robot_groups", None) else args.func(args)
        return code
    except UsageError as exc:  # reported as argparse reports its own errors, exit code included
        command: argparse.ArgumentParser = args.command_parser
        command.print_usage(sys.stderr)
        print(clean(f"{command.prog}: error: {exc}"), file=sys.stderr)
        return 2
    except DrEmpowerError as exc:
        print(clean(f"drempower: error: {exc}"), file=sys.stderr)
        return 1
    except KeyboardInterrupt as exc:
        how = f"terminated ({exc})" if isinstance(exc, Terminated) else "interrupted"
        print(f"drempower: {how}", file=sys.stderr)
        return exit_code(exc)
    except BrokenPipeError:
        return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
