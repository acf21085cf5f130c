"""What ``decode`` reads: candump text from files or stdin, MCAP recordings and python-can logs.

Each input frame becomes one candump line (with its timestamp, and `` T`` when the
log says the recording host sent it) and the direction to decode it with.
"""

from __future__ import annotations

import sys
from collections.abc import Iterable, Iterator

from ..errors import DrEmpowerError
from ..protocol.candump import parse_candump_line
from ..protocol.ids import Frame
from ..records.logs import LogRecord, direction_of, is_binary_log, read_log


def record_line(rec: LogRecord) -> str:
    """``rec`` as a ``candump -L`` line: ``(ts) channel id#data``, `` T`` when sent by the recording host."""
    arb, data, ext, rtr = rec.frame
    parts = []
    if rec.timestamp is not None:
        parts.append(f"({rec.timestamp:.6f})")
    if rec.channel:
        parts.append(rec.channel.replace(" ", "_"))
    ident = f"{arb:08X}" if ext else f"{arb:03X}"
    parts.append(f"{ident}#{'R' if rtr else data.hex().upper()}")
    if rec.tx:
        parts.append("T")
    return " ".join(parts)


def input_lines(files: list[str], direction: str) -> Iterator[tuple[str, str]]:
    """``(candump line, direction)`` for every frame of ``files`` (stdin when empty or ``-``)."""
    for name in files or ["-"]:
        if name != "-" and is_binary_log(name):
            for rec in read_log(name):
                yield record_line(rec), direction_of(rec, direction)  # type: ignore[arg-type]
            continue
        for line in _text(name):
            yield line, _text_direction(line, direction)


def _text_direction(line: str, direction: str) -> str:
    if direction != "auto" or not line.rstrip().endswith(" T"):
        return direction
    try:
        c = parse_candump_line(line)
    except DrEmpowerError:
        return direction
    return direction_of(LogRecord(c.timestamp, Frame(c.arbitration_id, c.data), True))


def _text(name: str) -> Iterable[str]:
    if name == "-":
        yield from sys.stdin
        return
    try:
        with open(name, encoding="utf-8", errors="replace") as fh:
            yield from fh
    except OSError as exc:
        raise DrEmpowerError(f"cannot read {name}: {exc.strerror}") from None
