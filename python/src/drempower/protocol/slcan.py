"""The Lawicel (slcan) text framing of CAN frames, and an incremental decoder of what an adapter sends.

A frame is one line ending in CR: ``tIIILDD..`` (11-bit id ``III``, length
``L``, data bytes ``DD`` in hex), ``TIIIIIIIILDD..`` (29-bit id), ``rIIIL`` and
``RIIIIIIIIL`` (remote frames). The host sends these to transmit; the adapter
sends them for frames it received. Commands are answered with CR (done) or BEL
(refused, no CR follows); a transmitted frame with ``z`` CR (``Z`` CR for 29-bit).
"""

from __future__ import annotations

import binascii

from ..errors import ProtocolError
from .ids import Frame, parse_int

__all__ = ["encode_slcan", "parse_slcan", "SlcanDecoder", "MAX_LINE"]

MAX_LINE = 64
"""Longest line (bytes, without CR) the decoder holds; a longer run without CR is garbage and dropped.
The longest classic frame line is 26."""

_new_frame = tuple.__new__
_HEX = b"0123456789abcdefABCDEF"
_CR = b"\r"
_BEL = 0x07
_LEN = {ord(str(n)): n for n in range(9)}
"""The length digit's byte -> the data length (0..8)."""
_ID_LEN = {0x74: 3, 0x72: 3, 0x54: 8, 0x52: 8}
"""``t``, ``r``, ``T``, ``R`` -> digits of the id."""


def encode_slcan(frame: Frame) -> bytes:
    """The slcan line (CR-terminated) that carries ``frame``; raises :class:`ProtocolError` if it does not fit."""
    arb, data, ext, remote = frame
    n = len(data)
    if n > 8:
        raise ProtocolError(f"a CAN frame carries at most 8 data bytes, not {n}")
    if not 0 <= arb <= (0x1FFFFFFF if ext else 0x7FF):
        raise ProtocolError(f"arbitration id 0x{arb:X} does not fit a {'29' if ext else '11'}-bit id")
    if remote:
        return (b"R%08X%d\r" if ext else b"r%03X%d\r") % (arb, n)
    return (b"T%08X%d%s\r" if ext else b"t%03X%d%s\r") % (arb, n, binascii.hexlify(data).upper())


def parse_slcan(line: str) -> Frame:
    """A ``t``/``T``/``r``/``R`` line (without CR) as a frame; raises :class:`ProtocolError` when malformed."""
    kind = line[:1]
    id_len = 8 if kind in ("T", "R") else 3
    if kind not in ("t", "T", "r", "R") or len(line) < 2 + id_len:
        raise ProtocolError(f"not an slcan frame: {line!r}")
    try:
        arb = parse_int(line[1 : 1 + id_len], "id", base=16)
        dlc = parse_int(line[1 + id_len], "length")
    except ValueError:
        raise ProtocolError(f"bad id or length: {line!r}") from None
    if dlc > 8 or arb > (0x1FFFFFFF if id_len == 8 else 0x7FF):
        raise ProtocolError(f"bad id or length: {line!r}")
    remote = kind in ("r", "R")
    hexdata = line[2 + id_len :]
    if remote:
        if hexdata:
            raise ProtocolError(f"a remote frame carries no data: {line!r}")
        data = bytes(dlc)
    else:
        if len(hexdata) != 2 * dlc:
            raise ProtocolError(f"length {dlc} does not match the data: {line!r}")
        try:
            data = bytes.fromhex(hexdata)
        except ValueError:
            raise ProtocolError(f"bad data: {line!r}") from None
    return Frame(arb, data, id_len == 8, remote)


class SlcanDecoder:
    """Incremental decoder of the lines an slcan adapter sends: the frames it received.

    ``feed`` takes bytes as they arrive and returns the frames completed by them.
    A frame line may end in a 4-digit time stamp (an adapter with time stamps
    on, ``Z1``), which is skipped. Answers that are no frame (CR alone, ``z``/``Z`` for a transmitted frame,
    ``F``/``V``/``N`` replies) are skipped and counted in ``answers``; each BEL
    (a refused command) is counted in ``refused``. A line that is not valid is
    dropped and its bytes counted in ``dropped``, as is a run of more than
    :data:`MAX_LINE` bytes without CR.
    """

    __slots__ = ("_buf", "answers", "dropped", "frames", "refused")

    def __init__(self) -> None:
        self._buf = b""
        self.dropped = 0
        """Bytes of malformed lines discarded."""
        self.frames = 0
        """Frames decoded so far."""
        self.answers = 0
        """Lines that answered a command or a transmitted frame (no frame in them)."""
        self.refused = 0
        """BEL bytes seen: commands or frames the adapter refused."""

    @property
    def pending(self) -> int:
        """Bytes held waiting for the rest of a line."""
        return len(self._buf)

    @property
    def needed(self) -> int:
        """Bytes still to come to end the partial line held (0 when none is; an estimate while its
        length digit is still to come)."""
        buf = self._buf
        if not buf:
            return 0
        id_len = _ID_LEN.get(buf[0])
        if id_len is None:
            return 1
        n = _LEN.get(buf[1 + id_len], 8) if len(buf) > 1 + id_len else 8
        total = 3 + id_len + (0 if buf[0] in (0x72, 0x52) else 2 * n)
        return max(1, total - len(buf))

    def flush(self) -> int:
        """Drop a partial line (e.g. after a gap on the line); returns how many bytes were dropped."""
        n = len(self._buf)
        self.dropped += n
        self._buf = b""
        return n

    def feed(self, chunk: bytes) -> list[Frame]:
        """Add received bytes; return the frames completed by them."""
        data = self._buf + chunk if self._buf else chunk
        lines = data.split(_CR)
        rest = lines.pop()
        out: list[Frame] = []
        for line in lines:
            if not line:
                self.answers += 1
                continue
            if _BEL in line:
                self.refused += line.count(_BEL)
                line = line.replace(b"\a", b"")
                if not line:
                    continue
            frame = self._frame(line)
            if frame is not None:
                out.append(frame)
        if _BEL in rest:  # a refusal has no CR: count it now, keep what follows
            self.refused += rest.count(_BEL)
            rest = rest.replace(b"\a", b"")
        if len(rest) > MAX_LINE:
            self.dropped += len(rest)
            rest = b""
        self._buf = rest
        self.frames += len(out)
        return out

    def _frame(self, line: bytes) -> Frame | None:
        """The frame of one line (None for an answer; a malformed line is counted and dropped)."""
        kind = line[0]
        id_len = _ID_LEN.get(kind)
        if id_len is None:
            if kind in b"zZFVN":
                self.answers += 1
            else:
                self.dropped += len(line)
            return None
        size = len(line)
        n = _LEN.get(line[1 + id_len], -1) if size > 1 + id_len else -1
        head = line[1 : 1 + id_len]
        remote = kind == 0x72 or kind == 0x52
        end = 2 + id_len + (0 if remote else 2 * n)
        if (
            n < 0
            or head.translate(None, _HEX)
            or (size != end and (size != end + 4 or line[end:].translate(None, _HEX)))
        ):
            self.dropped += size  # (4 more hex digits are the adapter's time stamp, when it is on: ``Z1``)
            return None
        arb = int(head, 16)
        ext = id_len == 8
        if arb > (0x1FFFFFFF if ext else 0x7FF):
            self.dropped += size
            return None
        if remote:
            return _new_frame(Frame, (arb, bytes(n), ext, True))
        try:
            payload = binascii.unhexlify(line[2 + id_len : end])
        except binascii.Error:
            self.dropped += size
            return None
        return _new_frame(Frame, (arb, payload, ext, False))
