"""Output shared by the subcommands: tables, JSON lines, numbers, progress and live redraws."""

from __future__ import annotations

import argparse
import json
import math
import re
import sys
from collections.abc import Iterable, Mapping, Sequence
from typing import Any, TextIO

from ..naming import number_text

__all__ = [
    "add_json_arg",
    "clean",
    "emit",
    "fmt",
    "is_terminal",
    "json_line",
    "motors_text",
    "no_answer",
    "number_text",
    "Progress",
    "LiveView",
    "render_table",
    "report",
    "sent",
    "significant",
]


_CONTROL = re.compile("[\x00-\x1f\x7f-\x9f\u2028\u2029\u202a-\u202e\u2066-\u2069]")
_NAMED = {"\n": "\\n", "\r": "\\r", "\t": "\\t"}


def _escape(m: re.Match[str]) -> str:
    c = m.group()
    return _NAMED.get(c) or (f"\\x{ord(c):02x}" if ord(c) < 0x100 else f"\\u{ord(c):04x}")


def clean(text: str) -> str:
    """``text`` with control characters (C0, DEL, C1, line and direction overrides) escaped as ``\\x1b``...

    Everything a command prints that came from its input (file lines, names,
    arguments, error messages quoting them) goes through this, so input can
    never move the cursor, ring the bell or retitle the terminal. JSON output
    escapes them by itself.
    """
    return _CONTROL.sub(_escape, text)


def add_json_arg(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--json", action="store_true", help="one JSON object per line instead of a table")


def is_terminal(stream: TextIO) -> bool:
    isatty = getattr(stream, "isatty", None)
    return bool(isatty and isatty())


def fmt(value: object, digits: int | None = 2) -> str:
    """A table cell: floats with ``digits`` decimals (None: 7 significant digits), booleans as yes/no, None as ``-``."""
    if value is None:
        return "-"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, float):
        return number_text(value, digits)
    if isinstance(value, (list, tuple)):
        return clean(" ".join(map(str, value))) or "-"
    return clean(str(value))


def no_answer(ids: Sequence[int]) -> int:
    """Say on stderr which motors did not answer and return the exit status 1 (0 when all answered)."""
    if not ids:
        return 0
    print(f"drempower: no answer from {motors_text(sorted(ids))}", file=sys.stderr)
    return 1


def motors_text(ids: Sequence[int]) -> str:
    """``"motor 3"``, ``"motors 1, 2"``; ``[0]`` reads ``"all motors (broadcast)"``."""
    if list(ids) == [0]:
        return "all motors (broadcast)"
    return ("motor " if len(ids) == 1 else "motors ") + ", ".join(map(str, ids))


def _numeric(cell: str) -> bool:
    try:
        float(cell)
    except ValueError:
        return cell == "-"
    return True


def render_table(
    headers: Sequence[str], rows: Iterable[Sequence[object]], min_widths: Sequence[int] = (), digits: int | None = 2
) -> list[str]:
    """Lines of a table: numeric columns right-aligned, others left-aligned; columns at least ``min_widths``.

    Floats get ``digits`` decimals (None: 7 significant digits, for parameter values).
    """
    cells = [[fmt(c, digits) for c in row] for row in rows]
    least = list(min_widths) + [0] * (len(headers) - len(min_widths))
    widths = [max([len(h), least[i]] + [len(r[i]) for r in cells]) for i, h in enumerate(headers)]
    right = [bool(cells) and all(_numeric(r[i]) for r in cells) for i in range(len(headers))]

    def line(row: Sequence[str]) -> str:
        out = [c.rjust(w) if r else c.ljust(w) for c, w, r in zip(row, widths, right, strict=True)]
        return "  ".join(out).rstrip()

    return [line(list(headers))] + [line(r) for r in cells]


def _finite(value: Any) -> Any:
    """``value`` with NaN and infinities (which JSON cannot hold) as "nan", "inf", "-inf"; -0.0 as 0.0."""
    if isinstance(value, float):
        return value + 0.0 if math.isfinite(value) else str(value)
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_finite(v) for v in value]
    return value


def json_line(record: Mapping[str, Any]) -> str:
    """One line of strict JSON (a motor can report NaN or infinity: they become strings; -0.0 becomes 0.0)."""
    return json.dumps(_finite(record), allow_nan=False)


def significant(value: int | float) -> int | float:
    """A float to 7 significant digits (what a float32 parameter holds): 0.30000001192 -> 0.3; ints unchanged."""
    return float(f"{value:.7g}") if isinstance(value, float) else value


def emit(
    args: argparse.Namespace,
    headers: Sequence[str],
    records: Sequence[Mapping[str, Any]],
    *,
    digits: int | None = 2,
) -> None:
    """Print ``records`` as JSON lines (``--json``) or as a table (nothing when there are none).

    ``headers`` are the table's column titles in the order of each record's keys;
    ``digits`` as in :func:`render_table`.
    """
    if getattr(args, "json", False):
        spec, bus = getattr(args, "robot_spec", None), getattr(args, "robot_bus", None)
        names = {} if spec is None or bus is None else {j.id: j.name for j in spec.joints_on(bus)}
        for rec in records:
            ident = rec.get("id")
            if isinstance(ident, int) and ident in names and "joint" not in rec:  # --robot: the joint's name
                rec = {"joint": names[ident], **rec}
            sys.stdout.write(json_line(rec) + "\n")
    elif records:
        rows = [list(r.values()) for r in records]
        spec, bus = getattr(args, "robot_spec", None), getattr(args, "robot_bus", None)
        if spec is not None and bus is not None and list(headers[:1]) == ["id"]:  # --robot: joints by name
            names = {j.id: j.name for j in spec.joints_on(bus)}
            headers = ["joint", *headers[1:]]
            rows = [[names.get(r[0], f"motor_{r[0]}"), *r[1:]] if isinstance(r[0], int) else r for r in rows]
        for line in render_table(headers, rows, digits=digits):
            sys.stdout.write(line + "\n")


def report(args: argparse.Namespace, text: str, records: Sequence[Mapping[str, Any]]) -> None:
    """Print the line ``text``, or with ``--json`` the ``records`` (one JSON object per line)."""
    if getattr(args, "json", False):
        emit(args, (), records)
    else:
        sys.stdout.write(clean(text) + "\n")


def sent(ids: Sequence[int], command: str, **fields: Any) -> list[dict[str, Any]]:
    """Status records of ``command`` sent to ``ids``: one per motor, or one with id 0 for ``[0]`` (broadcast)."""
    return [{"id": i, "broadcast": i == 0, "command": command, "sent": True, **fields} for i in ids]


class Progress:
    """A one-line progress message on stderr, shown only when stderr is a terminal."""

    def __init__(self, stream: TextIO | None = None) -> None:
        self._stream = stream or sys.stderr
        self._on = is_terminal(self._stream)

    def show(self, text: str) -> None:
        if self._on:
            self._stream.write("\r\x1b[K" + text)
            self._stream.flush()

    def clear(self) -> None:
        self.show("")

    def __enter__(self) -> Progress:
        return self

    def __exit__(self, *exc: object) -> None:
        self.clear()


class LiveView:
    """Redraws a block of lines in place on a terminal (ANSI cursor movement)."""

    def __init__(self, stream: TextIO) -> None:
        self._stream = stream
        self._height = 0

    def draw(self, lines: Sequence[str]) -> None:
        parts = [f"\x1b[{self._height}F"] if self._height else []
        parts += [f"\x1b[2K{line}\n" for line in lines]
        if len(lines) < self._height:
            parts.append("\x1b[J")
        self._stream.write("".join(parts))
        self._stream.flush()
        self._height = len(lines)
