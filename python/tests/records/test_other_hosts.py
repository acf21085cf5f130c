"""Recording beside another program: its frames are frames, never motor errors, states or parameters."""

from __future__ import annotations

from collections import Counter
from typing import Any

from drempower.protocol import DataType, ParamValue, PositionQ, PositionT, ReadParam, State, WriteParam
from drempower.protocol.ids import Frame
from drempower.records.events import FrameEvents

OTHER_HOST = [
    Frame(0x05E, bytes(8)),  # fast read of motor 2
    Frame(0x05F, bytes.fromhex("EE79030001000000")),  # write enable_reply_state = 1 to motor 2 (0x1F)
    PositionQ(1, 45.0, 30.0, 100.0).encode(),  # 0x03A
    PositionT(3, -10.0, 0.0, 20.0).encode(),  # 0x079: bit 0 set, a host command all the same
    WriteParam(1, 30003, DataType.U32, 8).encode(),  # requested_state = closed loop
    Frame(0x008, bytes.fromhex("1100000000000000")),  # broadcast Q start
    ReadParam(1, 30001, DataType.U32).encode(),  # a read of axis0.error (value bytes 0)
    Frame(0x7E0, b"\x01\x02"),  # another device's frame
    Frame(0x1ABCDEF0, bytes(8), True),  # an extended id
]


def _events(frames: list[tuple[Frame, bool]]) -> list[tuple[str, dict[str, Any]]]:
    ev = FrameEvents()
    out = []
    for i, (f, tx) in enumerate(frames):
        out += ev(1_700_000_000_000_000_000 + i * 1_000_000, f, tx)
    return out


def test_other_hosts_frames_are_recorded_as_frames_only() -> None:
    out = _events([(f, False) for f in OTHER_HOST])
    assert Counter(topic for topic, _ in out) == {"/can/rx": len(OTHER_HOST)}
    assert [m["id"] for _, m in out] == [f.arbitration_id for f in OTHER_HOST]


def test_motor_errors_still_reach_the_errors_topic() -> None:
    frames = [
        (State(2, 1.0, 0.0, 0.0, True, True).encode(), False),  # E bit set
        (ReadParam(2, 30001, DataType.U32).encode(), True),
        (ParamValue(2, 30001, DataType.U32, 0x800).encode(), False),  # axis0.error with a flag
        (State(2, 1.0, 0.0, 0.0, True, False).encode(), False),  # E bit cleared
    ]
    errors = [m for topic, m in _events(frames) if topic == "/drempower/errors"]
    got = [(e["node"], e["source"], e["code"]) for e in errors]
    assert got == [(2, "state", 1), (2, "axis0.error", 0x800), (2, "state", 0)]


def test_a_reply_of_zero_to_our_read_is_a_parameter_and_another_hosts_read_is_not() -> None:
    read = ReadParam(1, 30001, DataType.U32).encode()  # the reply of value 0 has the same bytes
    ours = _events([(read, True), (read, False)])
    assert [(m["node"], m["address"], m["value"]) for t, m in ours if t == "/drempower/parameters"] == [(1, 30001, 0)]
    theirs = _events([(read, False)])
    assert [t for t, _ in theirs] == ["/can/rx"]
    answered = _events([(read, False), (read, False)])  # another host's read, then the motor's reply
    assert [t for t, _ in answered] == ["/can/rx", "/can/rx", "/drempower/parameters"]
