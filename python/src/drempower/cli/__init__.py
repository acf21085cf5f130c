"""The ``drempower`` command.

Each subcommand lives in its own module of this package and exposes
``register(subparsers)``; modules are discovered automatically, so adding a
subcommand means adding a module (then ``tools/gen_cli_index.py`` adds it to
:mod:`._index`, so that running it imports its module alone: a command the index
does not name still runs, after every module is imported). Each row of :mod:`drempower.actions` that no
module's command carries out becomes a command too (:mod:`.actions`). A module's ``GROUP`` (one of :data:`GROUPS`)
says under which heading ``drempower --help`` lists its subcommands; those of a
module without one are listed last.
"""

from __future__ import annotations

import argparse
import importlib
import pkgutil
import sys
from collections.abc import Sequence
from typing import NoReturn

from .. import __version__
from ..errors import DrEmpowerError, ValidationError
from ._index import ACTION_ROWS, COMMANDS
from ._output import clean
from ._parser import Parser
from ._usage import UsageError, cli_words

__all__ = ["main", "build_parser"]


GROUPS = ("bus", "motion", "parameters", "logs and tools", "simulator")
"""The headings of ``drempower --help``, in order; subcommands of modules without a ``GROUP`` follow."""
OTHER = "other commands"
_GROUP_OF_COMMAND = {
    "record": "logs and tools",
    "replay": "logs and tools",
    "dbc": "logs and tools",
    "dash": "bus",
    "bridge": "bus",
}
"""Groups of subcommands whose modules name none (a module's ``GROUP`` wins)."""
_FIRST = [
    "scan",
    "state",
    "monitor",
    "errors",
    "sniff",
    "move",
    "speed",
    "torque",
    "impedance",
    "stop",
    "clear",
    "idle",
    "enable",
    "zero",
    "calibrate",
    "get",
    "set",
    "params",
    "backup",
    "diff",
    "restore",
    "set-id",
    "set-bitrate",
    "save",
    "reboot",
    "dfu",
    "decode",
    "completion",
    "udev",
    "demo",
    "sim",
]
"""The order of the subcommands within their group; others follow in the order they were found."""


class _Parser(Parser):
    """argparse, with control characters of the arguments it quotes escaped in its errors."""

    def error(self, message: str) -> NoReturn:
        super().error(clean(message))


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The command line's parser: every subcommand, or with ``command`` only the module that makes that one
    (:data:`._index.COMMANDS`), so that a command imports what it needs and no more (``""``: none, for
    ``--version``)."""
    parser = _Parser(
        prog="drempower",
        description="Work with DrEmpower servo joint motors: decode, simulate, drive, configure.",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        usage="%(prog)s [-h] [--version] COMMAND ...",
    )
    parser.add_argument("--version", action="version", version=f"drempower {__version__}")
    # the commands are listed in groups by the epilog, not in argparse's one list
    sub = parser.add_subparsers(prog=parser.prog, dest="command", metavar="COMMAND", help=argparse.SUPPRESS)
    sub.required = True
    group_of: dict[str, str] = {}
    if command is None:
        names = [i.name for i in sorted(pkgutil.iter_modules(__path__), key=lambda i: i.name)]
    else:
        home = COMMANDS.get(command)
        names = [] if home is None or home == ACTION_ROWS else [home]
    for name in names:
        if name.startswith("_"):
            continue
        mod = importlib.import_module(f"{__name__}.{name}")
        register = getattr(mod, "register", None)
        if register is not None:
            before = set(sub.choices)
            register(sub)
            group = getattr(mod, "GROUP", None)
            for name in sub.choices:
                if name not in before:
                    chosen = group or _GROUP_OF_COMMAND.get(name, OTHER)
                    group_of[name] = chosen if chosen in GROUPS else OTHER
    if command is None or COMMANDS.get(command) == ACTION_ROWS:
        from .actions import register_rows

        group_of.update(register_rows(sub))  # the table's rows no module took, last: every name is known
    for each in sub.choices.values():
        each.set_defaults(command_parser=each)
    if command is None:
        parser.epilog = _grouped_help(sub, group_of)
    return parser


def _chosen(argv: Sequence[str]) -> str | None:
    """The one command ``argv`` runs, when the parser can be built for it alone; None: build them all."""
    if not argv:
        return None
    first = argv[0]
    if first == "--version":
        return ""
    return first if first in COMMANDS else None


def _grouped_help(sub: argparse._SubParsersAction[_Parser], group_of: dict[str, str]) -> str:
    """The subcommands and their one-line help under their group's heading (argparse lists them unsorted)."""
    helps = {a.dest: a.help or "" for a in sub._choices_actions}
    width = max(map(len, sub.choices)) + 2
    blocks = []
    for group in (*GROUPS, OTHER):
        names = [n for n in sub.choices if group_of.get(n, OTHER) == group]
        names.sort(key=lambda n: _FIRST.index(n) if n in _FIRST else len(_FIRST))
        if names:
            lines = [f"  {n:<{width}}{helps.get(n, '')}".rstrip() for n in names]
            blocks.append(f"{group}:\n" + "\n".join(lines))
    return "\n\n".join(blocks) + "\n\n`drempower COMMAND --help` tells more."


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``drempower`` console script; returns the exit code."""
    argv_given = argv is not None
    argv = sys.argv[1:] if argv is None else list(argv)
    parser = build_parser(_chosen(argv))
    args = parser.parse_args(argv)
    from ..client.driver.signals import Terminated, exit_code, signals_interrupt
    from ._robot import apply_robot, joint_refusal, run_command

    try:
        apply_robot(args)  # --robot: joint names, the buses the command runs on
        # SIGTERM and SIGHUP end a command as Ctrl-C does; run as the program, a late second signal is absorbed
        with signals_interrupt(until_exit=not argv_given):
            code: int = run_command(args) if getattr(args, "robot_groups", None) else args.func(args)
        return code
    except UsageError as exc:  # reported as argparse reports its own errors, exit code included
        command: argparse.ArgumentParser = args.command_parser
        command.print_usage(sys.stderr)
        print(clean(f"{command.prog}: error: {cli_words(str(exc))}"), file=sys.stderr)
        return 2
    except ValidationError as exc:  # a value, file or option the command cannot use: nothing was sent for it
        print(clean(f"drempower: error: {cli_words(joint_refusal(args, exc))}"), file=sys.stderr)
        return 2
    except DrEmpowerError as exc:  # a failure on the bus (no answer, a motor that refused, a lost device)
        print(clean(f"drempower: error: {cli_words(str(exc))}"), file=sys.stderr)
        return 1
    except KeyboardInterrupt as exc:
        how = f"terminated ({exc})" if isinstance(exc, Terminated) else "interrupted"
        print(f"drempower: {how}", file=sys.stderr)
        return exit_code(exc)
    except BrokenPipeError:
        return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
