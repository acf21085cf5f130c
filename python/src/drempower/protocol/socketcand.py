"""The socketcand raw-mode text framing: what a client and a server say to each other over TCP.

A server greets ``< hi >``; the client opens a bus with ``< open can0 >`` and
enters raw mode with ``< rawmode >``, each answered ``< ok >`` (or
``< error ... >``). In raw mode the client sends ``< send ID LEN B0 B1 ... >``
(id 3 hex digits, or 8 for a 29-bit id; the length; each data byte in hex) and
receives ``< frame ID SECS.USECS DATA >`` (the frame's time stamp, its data as
one hex string; an id of 3 digits is an 11-bit id, of any other width up to 8 a
29-bit one, as python-can reads it). Raw mode carries no remote frames.

This module holds both sides: :func:`encode_send` and :class:`FrameDecoder`
for a client, :class:`CommandParser`, :func:`parse_send` and
:func:`format_frame` for a server (the simulator's).
"""

from __future__ import annotations

import binascii
import re

from ..errors import ProtocolError
from .ids import Frame, TimedFrame, parse_int

__all__ = [
    "CommandParser",
    "FrameDecoder",
    "MAX_COMMAND",
    "MAX_MESSAGE",
    "encode_send",
    "format_frame",
    "parse_send",
]

MAX_COMMAND = 256
"""Longest command a server accepts between ``<`` and ``>`` (bytes); the longest valid one is about 40."""
MAX_MESSAGE = 256
"""Longest message a client holds between ``<`` and ``>`` (bytes); the longest frame message is about 50."""

_new_frame = tuple.__new__
_HEX = b"0123456789abcdefABCDEF"
_TIME = b"0123456789."
_FRAME = b"< frame "
_ANSWERS = (b"< ok >", b"< hi >", b"< echo >")
_ONE_FRAME = re.compile(rb"< frame ([0-9A-Fa-f]{1,8}) ([0-9.]+) ((?:[0-9A-Fa-f]{2}){0,8}) >")
"""A chunk that is one whole frame message, the commonest read: parsed in one match."""


def encode_send(frame: Frame) -> bytes:
    """The ``< send ... >`` command that transmits ``frame``; raises :class:`ProtocolError` if raw mode
    cannot carry it (more than 8 bytes, an id too wide, a remote frame)."""
    arb, data, ext, remote = frame
    n = len(data)
    if n > 8:
        raise ProtocolError(f"a CAN frame carries at most 8 data bytes, not {n}")
    if not 0 <= arb <= (0x1FFFFFFF if ext else 0x7FF):
        raise ProtocolError(f"arbitration id 0x{arb:X} does not fit a {'29' if ext else '11'}-bit id")
    if remote:
        raise ProtocolError(f"socketcand's raw mode carries no remote frames (id 0x{arb:X})")
    head = b"< send %08X %d" % (arb, n) if ext else b"< send %03X %d" % (arb, n)
    if not n:
        return head + b" >"
    return head + b" " + binascii.hexlify(data, b" ").upper() + b" >"


def _seconds(stamp: bytes) -> float | None:
    """A ``SECS.USECS`` time stamp in seconds (None when it is not one number)."""
    try:
        return float(stamp)
    except ValueError:
        return None


class FrameDecoder:
    """Incremental decoder of what a socketcand server sends a raw-mode client.

    ``feed`` takes bytes as they arrive and returns the frames completed by
    them. Answers (``< ok >``, ``< hi >``, ``< echo >``) are counted in
    ``answers``; ``< error ... >`` messages in ``errors``, the last one's text
    in ``last_error``. A message that is not valid is dropped and its bytes
    counted in ``dropped``, as are bytes outside ``< >`` and a message longer
    than :data:`MAX_MESSAGE` without its ``>``.

    Each frame is a :class:`~drempower.protocol.ids.TimedFrame` whose ``time`` is the server's time
    stamp as sent (s, on the server's clock; a client puts it on its own scale).
    """

    __slots__ = ("_buf", "answers", "dropped", "errors", "frames", "last_error")

    def __init__(self) -> None:
        self._buf = b""
        self.frames = 0
        """Frames decoded so far."""
        self.answers = 0
        """``< ok >``, ``< hi >`` and ``< echo >`` messages seen."""
        self.errors = 0
        """``< error ... >`` messages seen."""
        self.last_error = ""
        """The text of the last ``< error ... >`` (empty when none came)."""
        self.dropped = 0
        """Bytes of malformed messages and of bytes outside ``< >`` discarded."""

    @property
    def pending(self) -> int:
        """Bytes held waiting for the rest of a message."""
        return len(self._buf)

    def flush(self) -> int:
        """Drop a partial message; returns how many bytes were dropped."""
        n = len(self._buf)
        self.dropped += n
        self._buf = b""
        return n

    def feed(self, chunk: bytes) -> list[Frame]:
        """Add received bytes; return the frames completed by them."""
        if not self._buf and (one := _ONE_FRAME.fullmatch(chunk)) is not None:
            head = one[1]
            arb = int(head, 16)
            ext = len(head) != 3
            stamp = _seconds(one[2])
            if arb <= (0x1FFFFFFF if ext else 0x7FF) and stamp is not None:
                self.frames += 1
                out1 = _new_frame(TimedFrame, (arb, binascii.unhexlify(one[3]), ext, False))
                out1.time = stamp
                return [out1]
        data = self._buf + chunk if self._buf else chunk
        out: list[Frame] = []
        pos, n = 0, len(data)
        while pos < n:
            start = data.find(b"<", pos)
            if start < 0:
                self.dropped += n - pos
                pos = n
                break
            end = data.find(b">", start)
            if end < 0:
                self.dropped += start - pos
                pos = start
                break
            start = data.rfind(b"<", start, end)  # a message starts at the last "<" before its ">"
            if start > pos:
                self.dropped += start - pos
            message = data[start : end + 1]
            pos = end + 1
            if message.startswith(_FRAME):
                frame = self._frame(message)
                if frame is not None:
                    out.append(frame)
            elif message in _ANSWERS:
                self.answers += 1
            elif message.startswith(b"< error"):
                self.errors += 1
                self.last_error = message[7:-1].strip().decode("ascii", "replace")
            else:
                self.dropped += len(message)
        rest = data[pos:]
        if len(rest) > MAX_MESSAGE:
            self.dropped += len(rest)
            rest = b""
        self._buf = rest
        self.frames += len(out)
        return out

    def _frame(self, message: bytes) -> TimedFrame | None:
        """The frame of one ``< frame ID SECS.USECS DATA >`` message (None when malformed: counted, dropped)."""
        parts = message[8:-1].split()
        if len(parts) == 2:
            parts.append(b"")
        if len(parts) != 3:
            self.dropped += len(message)
            return None
        head, stamp, hexdata = parts
        size = len(head)
        if (
            not 1 <= size <= 8
            or head.translate(None, _HEX)
            or not stamp
            or stamp.translate(None, _TIME)
            or len(hexdata) > 16
            or len(hexdata) & 1
        ):
            self.dropped += len(message)
            return None
        arb = int(head, 16)
        ext = size != 3  # as python-can reads it: 3 digits are an 11-bit id, any other width a 29-bit one
        if arb > (0x1FFFFFFF if ext else 0x7FF):
            self.dropped += len(message)
            return None
        seconds = _seconds(stamp)
        try:
            payload = binascii.unhexlify(hexdata)
        except binascii.Error:
            seconds = None
        if seconds is None:
            self.dropped += len(message)
            return None
        out: TimedFrame = _new_frame(TimedFrame, (arb, payload, ext, False))
        out.time = seconds
        return out


class CommandParser:
    """Splits a socketcand byte stream into the commands between ``<`` and ``>``, in one pass (a server's side).

    Bytes outside ``< >`` are skipped; a command longer than ``limit`` bytes is
    reported as None (too long) when its ``>`` arrives, and its bytes are not kept.
    """

    __slots__ = ("_body", "_too_long", "limit")

    def __init__(self, limit: int = MAX_COMMAND) -> None:
        self.limit = limit
        self._body: bytearray | None = None
        self._too_long = False

    def feed(self, chunk: bytes) -> list[str | None]:
        """The commands completed by ``chunk`` (text between the brackets, stripped; None when too long)."""
        out: list[str | None] = []
        pos, n = 0, len(chunk)
        while pos < n:
            if self._body is None:
                start = chunk.find(b"<", pos)
                if start < 0:
                    break
                self._body = bytearray()
                self._too_long = False
                pos = start + 1
            end = chunk.find(b">", pos)
            stop = n if end < 0 else end
            if not self._too_long:
                if len(self._body) + stop - pos > self.limit:
                    self._too_long = True
                    self._body.clear()
                else:
                    self._body += chunk[pos:stop]
            if end < 0:
                break
            out.append(None if self._too_long else self._body.decode("ascii", "replace").strip())
            self._body = None
            pos = end + 1
        return out


def _byte(text: str) -> int:
    if not 1 <= len(text) <= 2:
        raise ValueError(text)
    return parse_int(text, "byte", base=16)


def parse_send(body: str) -> Frame:
    """``send ID LEN B0 ...`` (the text between ``<`` and ``>``) as a frame; raises :class:`ProtocolError`."""
    parts = body.split()
    if len(parts) < 3 or parts[0] != "send":
        raise ProtocolError(f"not a send command: {body!r}")
    try:
        ident, length = parts[1], parse_int(parts[2], "length")
        data = bytes(_byte(b) for b in parts[3:])
        arb = parse_int(ident, "id", base=16)
    except ValueError:
        raise ProtocolError(f"bad send command: {body!r}") from None
    if length != len(data) or length > 8 or len(ident) not in (3, 8) or "x" in ident.lower():
        raise ProtocolError(f"bad send command: {body!r}")
    top = 0x1FFFFFFF if len(ident) == 8 else 0x7FF
    if arb > top:
        raise ProtocolError(f"bad send command: id {ident} is above 0x{top:X}")
    return Frame(arb, data, len(ident) == 8)


def format_frame(frame: Frame, seconds: float) -> bytes:
    """A frame as a server sends it, time stamped ``seconds``."""
    ident = f"{frame.arbitration_id:08X}" if frame.is_extended else f"{frame.arbitration_id:03X}"
    whole = int(seconds)
    return f"< frame {ident} {whole}.{int((seconds - whole) * 1e6):06d} {frame.data.hex().upper()} >".encode()
