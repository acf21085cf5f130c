"""A pseudo-terminal that behaves like the vendor USB-CAN adapter in standard mode.

The host may send 16-byte 0xAA binary frames (PROTOCOL.md 4.2) and slcan
commands (:mod:`drempower.sim.slcan`) on the same port; the adapter tells them
apart by the first byte (0xAA starts a binary frame, printable ASCII starts an
slcan line, CR or LF alone is skipped) and drops bytes that fit neither. Frames from the motors go out as
slcan text while the slcan channel is open (after ``O``, until ``C``), otherwise
as 0xAA frames. python-can's ``can.Bus(interface="slcan", channel=path)`` and raw
0xAA clients (the vendor library, :mod:`drempower.transports.serial_adapter`)
both work unchanged.
"""

from __future__ import annotations

from ..protocol.framing import aa_frame_length, encode_aa
from ..protocol.ids import Frame
from .bus import SimBus
from .pty_link import PtyLink
from .slcan import SlcanSession, format_frame

__all__ = ["AdapterPty", "attach_adapter_pty"]

_MAX_LINE = 64
"""Longest slcan command; a longer run without CR, or one with a byte that is not
printable ASCII, is garbage and dropped one byte at a time."""
_AA = 0xAA


class AdapterPty(PtyLink):
    """The simulated USB-CAN adapter on a pty; ``path`` is the port to open. ``dropped`` counts garbage bytes."""

    def __init__(self, bus: SimBus) -> None:
        super().__init__("drempower-sim-adapter")
        self.sim = bus
        self.slcan = SlcanSession()
        self.dropped = 0
        self._buf = bytearray()
        bus.add_listener(self._out, host_frames=True)
        self._start()

    def _out(self, frame: Frame) -> None:
        if self.slcan.is_open:
            self.write(format_frame(frame))
            return
        f = self.sim.faults
        head = b""
        if f.serial_garbage > 0 and self.sim.rng.random() < f.serial_garbage:
            head = self.sim.rng.randbytes(self.sim.rng.randint(1, 8))
        self.write(head + encode_aa(frame))

    def received(self, data: bytes) -> None:
        buf = self._buf
        buf += data
        while buf:
            first = buf[0]
            if first == _AA:
                total = aa_frame_length(buf)
                if total == 0:
                    self._drop()
                    continue
                if total < 0 or len(buf) < total:
                    return
                frame = Frame(int.from_bytes(buf[4:8], "big"), bytes(buf[8:total]), bool(buf[1]), buf[2] == 1)
                del buf[:total]
                self.sim.send(frame, self._out)
            elif 0x20 < first < 0x7F:
                end = buf.find(b"\r")
                line = bytes(buf[: end if end >= 0 else _MAX_LINE + 1])
                if len(line) > _MAX_LINE or not all(0x20 <= b < 0x7F for b in line):
                    self._drop()
                    continue
                if end < 0:
                    return
                del buf[: end + 1]
                answer, sent = self.slcan.handle(line.decode("ascii"))
                self.write(answer)
                if sent is not None:
                    self.sim.send(sent, self._out)
            elif first in (0x0D, 0x0A):
                del buf[:1]
            else:
                self._drop()

    def _drop(self) -> None:
        del self._buf[:1]
        self.dropped += 1

    def close(self) -> None:
        self.sim.remove_listener(self._out)
        super().close()


def attach_adapter_pty(bus: SimBus) -> AdapterPty:
    """Open a pty that behaves like the USB-CAN adapter on ``bus``; connect a client to ``.path``."""
    return AdapterPty(bus)
