"""What ``decode`` reads: candump text from files or stdin, MCAP recordings and python-can logs.

Each input frame becomes one candump line (with its timestamp, and `` T`` when the
log says the recording host sent it) and the direction to decode it with.
"""

from __future__ import annotations

import contextlib
import io
import sys
from collections.abc import Iterable, Iterator

from ..errors import DrEmpowerError, ValidationError
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


def log_records(path: str) -> Iterator[LogRecord]:
    """The frames of the log at ``path``; a file that cannot be read is a ValidationError (one line, exit 2).

    The readers of MCAP and python-can's formats raise their own errors on a
    corrupt or truncated file (``mcap.exceptions``, ``zlib.error``,
    ``struct.error``, ``BLFParseError``...); each becomes one line naming the
    file and the problem.
    """
    records = read_log(path)
    try:
        while True:
            with contextlib.redirect_stderr(io.StringIO()):  # some readers print parse errors themselves
                rec = next(records, None)
            if rec is None:
                return
            yield rec
    except DrEmpowerError as exc:  # no such file, an extra not installed, a line that is no frame
        raise ValidationError(str(exc)) from None
    except Exception as exc:  # RecursionError too: whatever a third-party reader raises on a damaged file
        what = str(exc) or "the file is damaged or truncated"
        raise ValidationError(f"cannot read {path}: {type(exc).__name__}: {what}") from None


def input_lines(files: list[str], direction: str) -> Iterator[tuple[str, str]]:
    """``(candump line, direction)`` for every frame of ``files`` (stdin when empty or ``-``)."""
    for name in files or ["-"]:
        if name != "-" and is_binary_log(name):
            for rec in log_records(name):
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
        raise ValidationError(f"cannot read {name}: {exc.strerror}") from None
