"""Read CAN logs back: MCAP recordings, every python-can log format, and candump text.

>>> for rec in read_log("session.mcap"):          # doctest: +SKIP
...     print(rec.timestamp, rec.frame, rec.tx)
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from pathlib import Path
from typing import NamedTuple

from ..errors import DrEmpowerError, ProtocolError
from ..protocol.candump import parse_candump_line
from ..protocol.describe import CaptureDecoder, Direction
from ..protocol.ids import Frame
from ..protocol.messages import Message
from . import missing_extra
from .ros2_types import is_frame_topic

__all__ = ["LogRecord", "Decoded", "read_log", "decode_log", "PYTHON_CAN_FORMATS", "is_binary_log", "direction_of"]

PYTHON_CAN_FORMATS = (".asc", ".blf", ".csv", ".db", ".log", ".mf4", ".trc")
"""Extensions python-can reads and writes (``can.LogReader``/``can.Logger``); ``.log`` is candump's format."""
_TEXT = (".log", ".txt", "")


class LogRecord(NamedTuple):
    """One frame of a log: ``timestamp`` (Unix s, None when the log has none), ``tx`` True when
    the recording host sent it, None when the log does not say, and the ``channel`` if named."""

    timestamp: float | None
    frame: Frame
    tx: bool | None = None
    channel: str | None = None


class Decoded(NamedTuple):
    """A log record decoded: ``direction`` "host"/"motor" and ``message``, or ``error`` text."""

    record: LogRecord
    direction: str | None
    message: Message | None
    error: str | None


def is_binary_log(path: str | os.PathLike[str]) -> bool:
    """True for logs read through MCAP or python-can readers rather than as candump text."""
    suffix = Path(path).suffix.lower()
    return suffix == ".mcap" or (suffix in PYTHON_CAN_FORMATS and suffix not in _TEXT)


def _mcap(path: Path) -> Iterator[LogRecord]:
    try:
        from mcap.reader import make_reader
        from mcap_ros2.decoder import DecoderFactory
    except ImportError:
        raise missing_extra("mcap-ros2-support") from None
    with open(path, "rb") as fh:
        reader = make_reader(fh, decoder_factories=[DecoderFactory()])
        summary = reader.get_summary()
        wanted = None if summary is None else [c.topic for c in summary.channels.values() if is_frame_topic(c.topic)]
        for _, channel, message, f in reader.iter_decoded_messages(topics=wanted):
            if not is_frame_topic(channel.topic):
                continue
            data = bytes(f.data)[: f.dlc]
            yield LogRecord(
                message.log_time / 1e9,
                Frame(f.id, data, bool(f.is_extended), bool(f.is_rtr)),
                channel.topic.endswith("/tx"),
                f.header.frame_id or None,
            )


def _candump_text(path: Path) -> Iterator[LogRecord]:
    with open(path, encoding="utf-8", errors="replace") as fh:
        for line in fh:
            if not line.strip() or line.lstrip().startswith("#"):
                continue
            c = parse_candump_line(line)
            tx = True if line.rstrip().endswith(" T") else None
            yield LogRecord(c.timestamp, Frame(c.arbitration_id, c.data, c.is_extended, c.is_remote), tx, c.channel)


def _python_can(path: Path) -> Iterator[LogRecord]:
    import can

    for msg in can.LogReader(path):
        if msg.is_error_frame:
            continue
        channel = None if msg.channel is None else str(msg.channel)
        # a log that does not store the direction reads as received: only "sent" is a fact
        frame = Frame(msg.arbitration_id, bytes(msg.data), msg.is_extended_id, msg.is_remote_frame)
        yield LogRecord(msg.timestamp, frame, None if msg.is_rx else True, channel)


def direction_of(rec: LogRecord, direction: Direction = "auto") -> Direction:
    """How to decode ``rec``: as a host frame when the log says it was sent, else ``direction``.

    A sent read request (0x1E) stays "auto", so that a capture decoder pairs the
    reply of value 0 that repeats it byte for byte.
    """
    if direction == "auto" and rec.tx and rec.frame.arbitration_id & 0x1F != 0x1E:
        return "host"
    return direction


def read_log(path: str | os.PathLike[str]) -> Iterator[LogRecord]:
    """The frames of the log at ``path``, in order; the format follows the extension.

    ``.mcap`` (as written by :class:`~drempower.records.Recorder`), python-can's
    ``.asc .blf .csv .db .mf4 .trc``, and candump text (``.log``, anything else).
    """
    p = Path(path)
    if not p.is_file():
        raise DrEmpowerError(f"cannot read {p}: no such file")
    suffix = p.suffix.lower()
    try:
        if suffix == ".mcap":
            yield from _mcap(p)
        elif is_binary_log(p):
            yield from _python_can(p)
        else:
            yield from _candump_text(p)
    except (OSError, ValueError, NotImplementedError, ImportError) as exc:  # .mf4 without asammdf too
        if isinstance(exc, DrEmpowerError):
            raise
        raise DrEmpowerError(f"cannot read {p}: {exc}") from None


def decode_log(path: str | os.PathLike[str], direction: Direction = "auto") -> Iterator[Decoded]:
    """Every frame of the log decoded, with its record; frames the log marks as sent are host frames."""
    capture = CaptureDecoder()
    for rec in read_log(path):
        arb, data, ext, rtr = rec.frame
        if ext or rtr:
            yield Decoded(rec, None, None, "extended-id or remote frame: DrEmpower uses standard data frames only")
            continue
        try:
            who, msg = capture.decode(arb, data, rec.timestamp, direction_of(rec, direction))
        except ProtocolError as exc:
            yield Decoded(rec, None, None, str(exc))
            continue
        yield Decoded(rec, who, msg, None)
