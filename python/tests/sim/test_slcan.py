"""The slcan codec and session, without a terminal."""

from __future__ import annotations

import pytest

from drempower.protocol.ids import Frame
from drempower.sim.slcan import ERROR, OK, SlcanSession, format_frame, parse_frame


@pytest.mark.parametrize(
    ("line", "frame"),
    [
        ("t03E80102030405060708", Frame(0x03E, bytes(range(1, 9)))),
        ("t7FF0", Frame(0x7FF, b"")),
        ("T1234567820A0B", Frame(0x12345678, b"\x0a\x0b", True)),
        ("r1233", Frame(0x123, bytes(3), False, True)),
    ],
)
def test_frames_round_trip(line: str, frame: Frame) -> None:
    assert parse_frame(line) == frame
    assert format_frame(frame) == line.encode() + b"\r"


@pytest.mark.parametrize("line", ["t03E9" + "00" * 9, "t03E2AA", "t8001", "x03E0", "t0", "r0011AA"])
def test_malformed_frames(line: str) -> None:
    with pytest.raises(ValueError):
        parse_frame(line)


def test_session_rules() -> None:
    s = SlcanSession()
    assert s.handle("t0010") == (ERROR, None)  # closed
    assert s.handle("S4") == (OK, None) and s.bitrate_code == 4
    assert s.handle("S9") == (ERROR, None)
    assert s.handle("L") == (OK, None) and s.listen_only
    assert s.handle("t0010") == (ERROR, None)  # listen only
    assert s.handle("O") == (OK, None)
    assert s.handle("S8") == (ERROR, None)  # not while open
    assert s.handle("t0010") == (b"z\r", Frame(0x001, b""))
    assert s.handle("T000000010") == (b"Z\r", Frame(0x1, b"", True))
    assert s.handle("F") == (b"F00\r", None)
    assert s.handle("?") == (ERROR, None)
    assert s.handle("C") == (OK, None) and not s.is_open
