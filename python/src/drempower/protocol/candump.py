"""Parse candump output lines (pure text handling, no I/O).

Accepted forms (what ``candump`` prints with ``-L``, ``-l`` log files, and its
default screen format)::

    (1700000000.123456) can0 039#0000B4420000E803
    039#0000B4420000E803
      can0  039   [8]  00 00 B4 42 00 00 E8 03

Remote frames (``039#R``) and CAN-FD frames (``039##1...``) are recognised and
reported as such; ids of 8 hex digits are extended. The lines ``drempower sniff``
prints (``  0.012345   0x039 0000B4420000E803  host ...``, time since the sniff
began) and those ``drempower decode`` prints are read too.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from ..errors import ProtocolError

__all__ = ["CandumpLine", "parse_candump_line"]


@dataclass(frozen=True, slots=True)
class CandumpLine:
    """One frame read from a candump line."""

    arbitration_id: int
    data: bytes
    timestamp: float | None = None
    channel: str | None = None
    is_extended: bool = False
    is_remote: bool = False
    is_fd: bool = False


_LOG = re.compile(
    r"^\s*(?:\((?P<ts>[0-9]+(?:\.[0-9]+)?)\)\s+)?(?:(?P<ch>\S+)\s+)?(?P<id>[0-9A-Fa-f]{1,8})"
    r"(?P<sep>##?)(?P<rest>\S*)\s*(?:[TR])?\s*$"
)
_SCREEN = re.compile(
    r"^\s*(?:\((?P<ts>[0-9]+(?:\.[0-9]+)?)\)\s+)?(?P<ch>\S+)\s+(?P<id>[0-9A-Fa-f]{1,8})\s+\[(?P<dlc>[0-9]+)\]\s*(?P<rest>.*)$"
)

_SNIFF = re.compile(
    r"^\s*(?:\((?P<pts>[0-9]+(?:\.[0-9]+)?)\)|(?P<ts>[0-9]+\.[0-9]+))?\s*0x(?P<id>[0-9A-Fa-f]{1,8})\s+(?P<data>(?:[0-9A-Fa-f]{2})*)\s+(?:host|motor|!!)\b"
)


def _id(text: str) -> tuple[int, bool]:
    value = int(text, 16)
    extended = len(text) == 8
    if not extended and value > 0x7FF:
        raise ProtocolError(f"id {text} is neither an 11-bit (3 hex digits) nor a 29-bit (8 hex digits) id")
    return value, extended


def parse_candump_line(line: str) -> CandumpLine:
    """Parse one candump line; raise :class:`ProtocolError` when it is not a frame."""
    m = _LOG.match(line)
    if m is not None:
        arb, ext = _id(m["id"])
        ts = float(m["ts"]) if m["ts"] else None
        rest = m["rest"]
        if m["sep"] == "##":
            if not rest:
                raise ProtocolError("CAN-FD line without flags")
            payload = rest[1:]
            fd = True
        else:
            fd = False
            payload = rest
        if payload.upper().startswith("R"):
            return CandumpLine(arb, b"", ts, m["ch"], ext, True, fd)
        payload = payload.replace(".", "")
        if len(payload) % 2:
            raise ProtocolError(f"odd number of hex digits in data {payload!r}")
        try:
            data = bytes.fromhex(payload)
        except ValueError:
            raise ProtocolError(f"data {payload!r} is not hex") from None
        return CandumpLine(arb, data, ts, m["ch"], ext, False, fd)
    s = _SCREEN.match(line)
    if s is not None:
        arb, ext = _id(s["id"])
        rest = s["rest"].strip()
        if rest.lower().startswith("remote"):
            return CandumpLine(arb, b"", None, s["ch"], ext, True)
        try:
            data = bytes.fromhex(rest.split("'")[0])
        except ValueError:
            raise ProtocolError(f"data {rest!r} is not hex bytes") from None
        if len(data) != int(s["dlc"]):
            raise ProtocolError(f"[{s['dlc']}] does not match {len(data)} data bytes")
        ts = float(s["ts"]) if s["ts"] else None
        return CandumpLine(arb, data, ts, s["ch"], ext)
    w = _SNIFF.match(line)
    if w is not None:
        arb, ext = _id(w["id"]) if len(w["id"]) in (3, 8) else (int(w["id"], 16), False)
        stamp = w["pts"] or w["ts"]
        return CandumpLine(arb, bytes.fromhex(w["data"]), float(stamp) if stamp else None, None, ext)
    raise ProtocolError("not a candump frame line")
