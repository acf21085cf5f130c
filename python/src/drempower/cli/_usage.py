"""Usage errors found after argparse: exit 2 with argparse's message, naming the user's option.

argparse checks each word on its own; some mistakes only show when words are put
together (three angles for two motors, two connections) or when the client
library encodes a value (a speed beyond what its field holds). Those raise
:class:`UsageError`, which ``main`` reports as argparse reports its own errors:
the subcommand's usage line, ``drempower CMD: error: ...`` and exit code 2.
"""

from __future__ import annotations

import re
from collections.abc import Iterator, Mapping
from contextlib import contextmanager

from ..errors import FieldRangeError, UsageError

__all__ = ["UsageError", "cli_words", "options_named"]


_LIBRARY_WORDS = (("force=True", "--force"),)
"""Words of the library's messages and what the command line calls the same thing."""


def cli_words(text: str) -> str:
    """A library message in the command line's words: ``force=True`` -> ``--force``."""
    for library, cli in _LIBRARY_WORDS:
        text = text.replace(library, cli)
    return text


_PER_MOTOR = re.compile(r"^(?P<field>.+) \(motor (?P<node>\d+)\)$")
"""A field of a value given per motor, as the library names it: ``angle_list (motor 3)``."""


def _shown(value: object) -> str:
    return f"{value:g}" if isinstance(value, float) else str(value)


@contextmanager
def options_named(names: Mapping[str, str]) -> Iterator[None]:
    """Turn a :class:`FieldRangeError` of a field in ``names`` into a :class:`UsageError` naming the option.

    ``names`` maps the library's field names (``param``, ``torque_ff``,
    ``angle_list``...) to what the user typed (``--torque-ff``, ``ANGLES``...);
    a value of one motor (``angle_list (motor 3)``) is named with its motor.
    Errors of other fields pass unchanged.
    """
    try:
        yield
    except FieldRangeError as exc:
        m = _PER_MOTOR.match(exc.field)
        field, motor = (m["field"], f" (motor {m['node']})") if m else (exc.field, "")
        option = names.get(field)
        if option is None:
            raise
        text = str(exc)
        prefix = f"{exc.field}={exc.value!r} "
        rest = text[len(prefix) :] if text.startswith(prefix) else f"is out of range: allowed {exc.low:g}..{exc.high:g}"
        raise UsageError(f"argument {option}: {_shown(exc.value)}{motor} {rest}") from None
