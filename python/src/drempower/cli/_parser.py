"""The argument parser of ``drempower``: negative numbers are values, not options.

argparse takes ``-inf``, ``-1e6`` or ``-5,-inf`` for options (``-inf`` even as
``-i nf``, the interface option with an attached value), so ``move 1 -inf``
failed with a confusing message instead of refusing the angle. Here any
argument that reads as a number, or a comma-separated list of numbers, is a
value; the command then checks it like any other.
"""

from __future__ import annotations

import argparse
from typing import Any

__all__ = ["Parser", "is_number_list"]


def is_number_list(text: str) -> bool:
    """Whether ``text`` is a number or a comma-separated list of numbers (``-inf``, ``-1e6``, ``-5,10``)."""
    try:
        for item in text.split(","):
            float(item)
    except ValueError:
        return False
    return True


class Parser(argparse.ArgumentParser):
    """An :class:`argparse.ArgumentParser` (and its subcommands) that reads negative numbers as values."""

    def _parse_optional(self, arg_string: str) -> Any:
        if arg_string.startswith("-") and is_number_list(arg_string):
            return None  # a positional value
        return super()._parse_optional(arg_string)
