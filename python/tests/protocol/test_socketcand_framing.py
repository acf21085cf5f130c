"""The socketcand raw-mode framing: golden commands and messages, the client's decoder fed byte by byte."""

from __future__ import annotations

import pytest

from drempower.errors import ProtocolError
from drempower.protocol.ids import Frame
from drempower.protocol.socketcand import MAX_MESSAGE, FrameDecoder, encode_send, format_frame, parse_send

GOLDEN_SENDS = [
    (Frame(0x023, bytes([0x01, 0xA0]), False), b"< send 023 2 01 A0 >"),
    (Frame(0x7FF, bytes(range(8)), False), b"< send 7FF 8 00 01 02 03 04 05 06 07 >"),
    (Frame(0x123, b"", False), b"< send 123 0 >"),
    (Frame(0x1FFFFFFF, b"\xff", True), b"< send 1FFFFFFF 1 FF >"),
    (Frame(0x5, b"\x0a\x0b", True), b"< send 00000005 2 0A 0B >"),
]


@pytest.mark.parametrize(("frame", "line"), GOLDEN_SENDS)
def test_send_commands_are_the_golden_lines_and_the_server_reads_them_back(frame: Frame, line: bytes) -> None:
    assert encode_send(frame) == line
    assert parse_send(line.decode()[1:-1].strip()) == frame


@pytest.mark.parametrize(
    ("frame", "words"),
    [
        (Frame(0x800, b"", False), "0x800 does not fit a 11-bit id"),
        (Frame(0x20000000, b"", True), "does not fit a 29-bit id"),
        (Frame(0x1, bytes(9), False), "at most 8 data bytes, not 9"),
        (Frame(0x1, bytes(2), False, True), "no remote frames (id 0x1)"),
    ],
)
def test_what_raw_mode_cannot_carry_is_refused_in_words(frame: Frame, words: str) -> None:
    with pytest.raises(ProtocolError, match=words.replace("(", r"\(").replace(")", r"\)")):
        encode_send(frame)


STREAM = (
    b"< hi >< ok >"
    b"< frame 023 12.000100 0102030405060708 >"
    b"< error bad send command >"
    b"junk"
    b"< frame 1FFFFFFF 0.500000  >"
    b"< echo >"
    b"< frame 7E0 3.25 a0b1 >"
)
"""A server's messages: answers, three frames (one without data, one in lower case), an error, junk."""
STREAM_FRAMES = [
    Frame(0x023, bytes(range(1, 9)), False),
    Frame(0x1FFFFFFF, b"", True),
    Frame(0x7E0, b"\xa0\xb1", False),
]


@pytest.mark.parametrize("size", [1, 2, 3, 7, len(STREAM)])
def test_the_decoder_takes_a_stream_cut_anywhere(size: int) -> None:
    d = FrameDecoder()
    got: list[Frame] = []
    for i in range(0, len(STREAM), size):
        got += d.feed(STREAM[i : i + size])
    assert got == STREAM_FRAMES
    assert (d.frames, d.answers, d.errors, d.last_error, d.dropped, d.pending) == (
        3,
        3,
        1,
        "bad send command",
        4,
        0,
    )


@pytest.mark.parametrize(
    "message",
    [
        b"< frame 123456789 1.0 01 >",  # 9 id digits
        b"< frame FFFFFFFF 1.0 01 >",  # above 0x1FFFFFFF
        b"< frame 800 1.0 01 >",  # above 0x7FF
        b"< frame FFF 1.0 01 >",  # above 0x7FF
        b"< frame 023 1.0 012 >",  # odd hex digits
        b"< frame 023 1.0 010203040506070809 >",  # 9 bytes
        b"< frame 023 x1.0 01 >",  # bad time stamp
        b"< frame 023 1.0 0g >",  # not hex
        b"< frame 023 >",  # no time stamp
        b"< frame 023 1.0 01 02 >",  # data in two words
        b"< bogus >",
    ],
)
def test_a_malformed_message_is_dropped_and_counted_and_the_next_frame_still_decodes(message: bytes) -> None:
    d = FrameDecoder()
    assert d.feed(message + b"< frame 001 1.0 AA >") == [Frame(0x001, b"\xaa", False)]
    assert d.dropped == len(message)
    alone = FrameDecoder()  # a chunk that is one message alone (the commonest read) is checked the same
    assert alone.feed(message) == [] and alone.dropped == len(message) and alone.frames == 0
    assert alone.feed(b"< frame 001 1.0 AA >") == [Frame(0x001, b"\xaa", False)] and alone.frames == 1


def test_a_message_without_its_end_is_dropped_past_the_limit() -> None:
    d = FrameDecoder()
    assert d.feed(b"< frame " + b"0" * MAX_MESSAGE) == []
    assert d.pending == 0 and d.dropped == MAX_MESSAGE + 8
    assert d.feed(b"< frame 002 1.0 >") == [Frame(0x002, b"", False)]


def test_the_servers_frames_decode_to_what_was_sent() -> None:
    d = FrameDecoder()
    frames = [f for f, _ in GOLDEN_SENDS]
    stream = b"".join(format_frame(f, 1234.5 + i) for i, f in enumerate(frames))
    assert d.feed(stream) == frames


def test_ids_of_other_widths_read_as_python_can_reads_them_and_a_stray_bracket_costs_only_itself() -> None:
    d = FrameDecoder()
    assert d.feed(b"< frame 23 1.0 01 >") == [Frame(0x23, b"\x01", True)]  # not 3 digits: a 29-bit id
    assert d.feed(b"< frame 1ABCD 1.0 >") == [Frame(0x1ABCD, b"", True)]
    assert d.feed(b"<junk< frame 023 1.0 01 >") == [Frame(0x023, b"\x01", False)]
    assert d.dropped == len(b"<junk")
