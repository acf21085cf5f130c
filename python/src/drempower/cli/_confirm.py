"""Asking before something that cannot be undone from here (calibration turns the shaft, DFU drops the load)."""

from __future__ import annotations

import argparse
import sys

from ..errors import DrEmpowerError
from ._output import is_terminal
from ._usage import UsageError

__all__ = ["add_yes_arg", "confirm"]


def add_yes_arg(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("-y", "--yes", action="store_true", help="do not ask for confirmation")


def confirm(args: argparse.Namespace, action: str, warning: str) -> None:
    """Ask whether to ``action`` ("calibrate motor 1"), saying ``warning``, unless ``--yes``.

    A "no" ends the command (exit 1) with nothing sent; without a terminal to ask
    on, ``--yes`` is required (exit 2).
    """
    if args.yes:
        return
    if not is_terminal(sys.stdin):
        raise UsageError(f"{action} needs confirmation: give --yes (no terminal to ask on)")
    try:
        answer = input(f"About to {action}: {warning}. Continue? [y/N] ")
    except EOFError:
        answer = ""
    if answer.strip().lower() not in ("y", "yes"):
        raise DrEmpowerError("cancelled; nothing was sent")
