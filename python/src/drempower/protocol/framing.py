"""Serial framings of CAN frames, with incremental, resynchronising stream decoders.

* The 11-byte frame of a G-series motor's UART (and of the adapter's TTL->CAN
  mode): ``08 idH idL d0..d7``.
* The vendor USB-CAN adapter's 0xAA frame (standard mode):
  ``AA ext flag N id3 id2 id1 id0 data[N]`` with a big-endian 4-byte id; N is a
  byte count (0..8, or a CAN-FD length).

Both decoders take bytes as they arrive (``feed``), return the complete frames,
skip garbage one byte at a time until a plausible header lines up again, and
count what they dropped in ``dropped``. They have no clock: a transport that
sees a long gap inside a frame may call ``flush()`` to discard a stale partial
frame.

Neither framing has a checksum, so a frame that lost a byte on the line would
complete with the first byte of the next frame and swallow that one too. When
the bytes after a complete frame are already at hand (they arrived in the same
chunk) and are no header while a whole frame followed by a header starts inside
it, the decoders drop the short frame and keep the one inside. Fed one byte at
a time they decide as each frame completes, as the C library does.
"""

from __future__ import annotations

import struct

from ..errors import ProtocolError
from .ids import Frame

__all__ = [
    "UART11_LEN",
    "encode_uart11",
    "Uart11Decoder",
    "AA_HEADER",
    "encode_aa",
    "AADecoder",
    "aa_frame_length",
    "FD_LENGTHS",
]

UART11_LEN = 11
AA_HEADER = 0xAA
FD_LENGTHS = frozenset((*range(9), 12, 16, 20, 24, 32, 48, 64))
"""Valid data lengths of a CAN-FD frame (the 0xAA length byte is a byte count)."""

_AA_FLAG_DATA = 0x00
_AA_FLAG_REMOTE = 0x01
_AA_FLAG_FD = 0x02
_AA_FLAG_FD_BRS = 0x06

_new_frame = tuple.__new__
_AA_HEAD = struct.Struct(">BBBBI")
_AA_HEAD_pack = _AA_HEAD.pack
_U32_from = struct.Struct(">I").unpack_from


def encode_uart11(arbitration_id: int, data: bytes) -> bytes:
    """The 11-byte UART frame for a standard-id CAN frame with 8 data bytes."""
    if not 0 <= arbitration_id <= 0x7FF:
        raise ProtocolError(f"arbitration id 0x{arbitration_id:X} does not fit the 11-byte frame (11-bit ids)")
    if len(data) != 8:
        raise ProtocolError(f"the 11-byte frame carries exactly 8 data bytes, not {len(data)}")
    return bytes((0x08, arbitration_id >> 8, arbitration_id & 0xFF)) + bytes(data)


class Uart11Decoder:
    """Incremental decoder of 11-byte UART frames.

    A frame starts with 0x08 followed by an id high byte of at most 0x07. Bytes
    that cannot start a frame are dropped and counted. Since the framing has no
    checksum, a header that lines up by chance inside data is only rejected when
    ``accept`` (optional: ``accept(arbitration_id, data) -> bool``) says no.
    """

    __slots__ = ("_accept", "_buf", "dropped", "frames")

    def __init__(self, accept: object = None) -> None:
        self._buf = bytearray()
        self.dropped = 0
        """Bytes discarded while resynchronising."""
        self.frames = 0
        """Frames decoded so far."""
        self._accept = accept

    @property
    def pending(self) -> int:
        """Bytes held waiting for the rest of a frame."""
        return len(self._buf)

    @property
    def needed(self) -> int:
        """Bytes still to come to complete the partial frame held (0 when none is)."""
        n = len(self._buf)
        return UART11_LEN - n if n else 0

    def flush(self) -> int:
        """Drop a partial frame (e.g. after a gap on the line); returns how many bytes were dropped."""
        n = len(self._buf)
        self.dropped += n
        self._buf.clear()
        return n

    def feed(self, chunk: bytes) -> list[Frame]:
        """Add received bytes; return the frames completed by them."""
        buf = self._buf
        if buf:
            buf += chunk
            b = bytes(buf)
        else:
            b = bytes(chunk)
        out: list[Frame] = []
        append = out.append
        accept = self._accept
        i = 0
        n = len(b)
        last = n - UART11_LEN  # the last index a whole frame can start at
        dropped = 0
        while i < n:
            if b[i] != 0x08:
                # skip to the next possible header in one step
                j = b.find(b"\x08", i + 1)
                if j < 0:
                    j = n
                dropped += j - i
                i = j
                continue
            if i + 1 >= n:
                break
            if b[i + 1] > 0x07:
                i += 1
                dropped += 1
                continue
            if i > last:
                break
            end = i + UART11_LEN
            arb = (b[i + 1] << 8) | b[i + 2]
            data = b[i + 3 : end]
            if (accept is not None and not accept(arb, data)) or (  # type: ignore[operator]
                end < n and not (b[end] == 0x08 and (end + 1 >= n or b[end + 1] <= 0x07)) and self._overlaps(b, i, n)
            ):
                i += 1
                dropped += 1
                continue
            append(_new_frame(Frame, (arb, data, False, False)))
            i = end
        if dropped:
            self.dropped += dropped
        if i:
            if i >= n:
                buf.clear()
            else:
                buf[:] = b[i:]
        elif not buf:
            buf += b
        self.frames += len(out)
        return out

    def _overlaps(self, buf: bytes | bytearray, i: int, n: int) -> bool:
        """True when the frame at ``i`` is not followed by a header (or the end of what
        arrived) while a whole frame that is followed by one starts inside it: bytes were
        lost, and taking the frame at ``i`` would also lose the one inside."""
        if _u11_header(buf, i + UART11_LEN, n):
            return False
        accept = self._accept
        for j in range(i + 1, i + UART11_LEN):
            if not (j + UART11_LEN <= n and buf[j + 1] <= 0x07 and _u11_header(buf, j, n)):
                continue
            if not _u11_header(buf, j + UART11_LEN, n):
                continue
            if accept is None or accept((buf[j + 1] << 8) | buf[j + 2], bytes(buf[j + 3 : j + 11])):  # type: ignore[operator]
                return True
        return False


def _u11_header(buf: bytes | bytearray, k: int, n: int) -> bool:
    """A frame may start at ``k`` (true at the end of the bytes, where anything may follow)."""
    if k >= n:
        return True
    return buf[k] == 0x08 and (k + 1 >= n or buf[k + 1] <= 0x07)


def encode_aa(frame: Frame | tuple[int, bytes]) -> bytes:
    """The adapter's 0xAA frame for ``frame`` (16 bytes for a standard 8-byte data frame)."""
    if isinstance(frame, Frame):
        arb, data, ext, remote = frame
    else:
        (arb, data), ext, remote = frame, False, False
    n = len(data)
    if not ext and 0 <= arb <= 0x7FF and n <= 8:
        return _AA_HEAD_pack(AA_HEADER, 0, _AA_FLAG_REMOTE if remote else _AA_FLAG_DATA, n, arb) + bytes(data)
    limit = 0x1FFFFFFF if ext else 0x7FF
    if not 0 <= arb <= limit:
        raise ProtocolError(f"arbitration id 0x{arb:X} does not fit a {'29' if ext else '11'}-bit id")
    if n > 8:
        raise ProtocolError(f"a CAN frame carries at most 8 data bytes, not {n}")
    return _AA_HEAD_pack(AA_HEADER, 1, _AA_FLAG_REMOTE if remote else _AA_FLAG_DATA, n, arb) + bytes(data)


def aa_frame_length(buf: bytes | bytearray, i: int = 0) -> int:
    """Length of the 0xAA frame starting at ``buf[i]``: 0 if no plausible frame starts
    there, -1 if more bytes are needed to tell, else the total frame length (8 + N).
    """
    if buf[i] != AA_HEADER:
        return 0
    if len(buf) - i >= 8:
        # the whole header is here (the common case): every check at once
        ext = buf[i + 1]
        if ext == 0:
            if buf[i + 4] or buf[i + 5] or buf[i + 6] > 0x07:
                return 0
        elif ext != 1 or buf[i + 4] > 0x1F:
            return 0
        flag = buf[i + 2]
        length = buf[i + 3]
        if flag <= _AA_FLAG_REMOTE:
            if length > 8:
                return 0
        elif (flag != _AA_FLAG_FD and flag != _AA_FLAG_FD_BRS) or length not in FD_LENGTHS:
            return 0
        return 8 + length
    return _aa_partial_length(buf, i)


def _aa_partial_length(buf: bytes | bytearray, i: int) -> int:
    """:func:`aa_frame_length` of a header that has not fully arrived (0 or -1)."""
    avail = len(buf) - i
    if avail >= 2 and buf[i + 1] > 1:
        return 0
    if avail >= 3 and buf[i + 2] not in (0, 1, 2, 6):
        return 0
    if avail >= 4:
        length = buf[i + 3]
        if buf[i + 2] in (0, 1):
            if length > 8:
                return 0
        elif length not in FD_LENGTHS:
            return 0
    else:
        return -1
    # check what we have of the id for plausibility
    if buf[i + 1] == 0:
        for k in (4, 5):
            if avail > k and buf[i + k] != 0:
                return 0
        if avail > 6 and buf[i + 6] > 0x07:
            return 0
    elif avail > 4 and buf[i + 4] > 0x1F:
        return 0
    return -1


class AADecoder:
    """Incremental decoder of the adapter's 0xAA frames.

    A header is plausible when byte 0 is 0xAA, the extended flag is 0 or 1, the
    frame flag is 0 (data), 1 (remote), 2 or 6 (CAN-FD), the length is valid for
    that flag, and the id fits (11 bits with bytes 4-5 zero, or 29 bits). Anything
    else is dropped one byte at a time and counted in ``dropped``. CAN-FD frames
    are decoded too but are marked ``fd``; DrEmpower motors do not send them.
    """

    __slots__ = ("_buf", "dropped", "fd_frames", "frames")

    def __init__(self) -> None:
        self._buf = bytearray()
        self.dropped = 0
        self.frames = 0
        self.fd_frames = 0
        """CAN-FD frames seen (decoded and returned with ``is_remote`` False)."""

    @property
    def pending(self) -> int:
        return len(self._buf)

    @property
    def needed(self) -> int:
        """Bytes still to come to complete the partial frame held (0 when none is; an estimate
        of at least 1 while its length byte or id is still to come)."""
        buf = self._buf
        if not buf:
            return 0
        total = aa_frame_length(buf)
        if total <= 0:
            total = 8 + (buf[3] if len(buf) > 3 else 8)
        return max(1, total - len(buf))

    def flush(self) -> int:
        n = len(self._buf)
        self.dropped += n
        self._buf.clear()
        return n

    def feed(self, chunk: bytes) -> list[Frame]:
        """Add received bytes; return the frames completed by them."""
        buf = self._buf
        if buf:
            buf += chunk
            b = bytes(buf)
        else:
            b = bytes(chunk)
        out: list[Frame] = []
        append = out.append
        frame_length = aa_frame_length
        i = 0
        n = len(b)
        dropped = 0
        fd = 0
        total = frame_length(b, 0) if n else 0
        while i < n:
            if total == 0:
                # skip to the next possible header in one step
                j = b.find(b"\xaa", i + 1)
                if j < 0:
                    j = n
                dropped += j - i
                i = j
                total = frame_length(b, i) if i < n else 0
                continue
            end = i + total
            if total < 0 or end > n:
                break
            # the length of what follows (computed once: it is the next frame's when this one is taken)
            after = frame_length(b, end) if end < n else -1
            if after == 0 and _aa_overlaps(b, i, total, n):
                i += 1
                dropped += 1
                total = frame_length(b, i)
                continue
            flag = b[i + 2]
            if b[i + 1]:
                append(_new_frame(Frame, (_U32_from(b, i + 4)[0], b[i + 8 : end], True, flag == _AA_FLAG_REMOTE)))
            else:
                append(_new_frame(Frame, ((b[i + 6] << 8) | b[i + 7], b[i + 8 : end], False, flag == _AA_FLAG_REMOTE)))
            if flag > _AA_FLAG_REMOTE:
                fd += 1
            i = end
            total = after
        if dropped:
            self.dropped += dropped
        if fd:
            self.fd_frames += fd
        if i:
            if i >= n:
                buf.clear()
            else:
                buf[:] = b[i:]
        elif not buf:
            buf += b
        self.frames += len(out)
        return out


def _aa_overlaps(buf: bytes | bytearray, i: int, total: int, n: int) -> bool:
    """True when the frame at ``i`` (``total`` bytes) is not followed by a plausible header
    (or the end of what arrived) while a whole frame followed by one starts inside it."""
    end = i + total
    if end >= n or aa_frame_length(buf, end) != 0:
        return False
    for j in range(i + 1, end):
        t = aa_frame_length(buf, j)
        if t > 0 and j + t <= n and (j + t == n or aa_frame_length(buf, j + t) != 0):
            return True
    return False
