"""The Lawicel (slcan) ASCII protocol, as the USB-CAN adapter speaks it in standard mode.

Commands end with CR; the adapter answers CR for success and BEL for an error.
Supported: ``O`` open, ``L`` open listen-only, ``C`` close, ``S0``-``S8`` bit rate,
``sXXXX`` bit-timing registers, ``V`` version, ``N`` serial number, ``F`` status
flags, ``Z`` time stamps, ``M``/``m`` acceptance filter, and the frames ``tIIIL..``,
``TIIIIIIIIL..``, ``rIIIL``, ``RIIIIIIIIL``; anything else gets BEL. Received frames go to the host as
``tIIILDD..`` + CR (``T`` for extended ids).
"""

from __future__ import annotations

from ..errors import ProtocolError
from ..protocol.ids import Frame
from ..protocol.slcan import encode_slcan as format_frame
from ..protocol.slcan import parse_slcan as parse_frame

__all__ = ["OK", "ERROR", "SlcanSession", "format_frame", "parse_frame"]

OK = b"\r"
ERROR = b"\a"
VERSION = b"V2003\r"
"""Hardware 2.0, software 0.3 (the adapter's factory information)."""
SERIAL = b"N0001\r"


class SlcanSession:
    """The adapter's slcan state: channel open or closed, and the requested bit rate.

    ``handle(line)`` runs one command (without its CR) and returns the answer and
    the frame to transmit, if any. The requested bit rate is remembered but the
    simulated bus keeps its own (whether the real adapter honours ``S`` is not
    documented).
    """

    __slots__ = ("bitrate_code", "is_open", "listen_only")

    def __init__(self) -> None:
        self.is_open = False
        self.listen_only = False
        self.bitrate_code = 8

    def handle(self, line: str) -> tuple[bytes, Frame | None]:
        cmd = line[:1]
        if cmd in ("t", "T", "r", "R"):
            if not self.is_open or self.listen_only:
                return ERROR, None
            try:
                frame = parse_frame(line)
            except ProtocolError:
                return ERROR, None
            return (b"Z\r" if cmd in ("T", "R") else b"z\r"), frame
        if cmd in ("O", "L"):
            self.is_open, self.listen_only = True, cmd == "L"
            return OK, None
        if cmd == "C":
            self.is_open = False
            return OK, None
        if cmd == "S":
            if self.is_open or line[1:] not in tuple("012345678"):
                return ERROR, None
            self.bitrate_code = int(line[1:])
            return OK, None
        if cmd == "s":
            return (ERROR if self.is_open else OK), None
        if cmd == "V":
            return VERSION, None
        if cmd == "N":
            return SERIAL, None
        if cmd == "F":
            return (b"F00\r" if self.is_open else ERROR), None
        if cmd in ("Z", "M", "m"):
            return OK, None
        return ERROR, None
