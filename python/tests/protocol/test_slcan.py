"""The slcan text framing: golden lines both ways, and the decoder of what an adapter sends."""

from __future__ import annotations

import pytest

from drempower.errors import ProtocolError
from drempower.protocol import FastRead
from drempower.protocol.ids import Frame
from drempower.protocol.slcan import MAX_LINE, SlcanDecoder, encode_slcan, parse_slcan

GOLDEN = [
    (FastRead(1).encode(), b"t03E80000000000000000\r"),
    (Frame(0x043, bytes.fromhex("0000b4429600e7ff")), b"t04380000B4429600E7FF\r"),
    (Frame(0x7FF, b""), b"t7FF0\r"),
    (Frame(0x12345678, b"\x0a\x0b", True), b"T1234567820A0B\r"),
    (Frame(0x123, bytes(3), False, True), b"r1233\r"),
    (Frame(0x1ABCDEF0, bytes(2), True, True), b"R1ABCDEF02\r"),
]


@pytest.mark.parametrize(("frame", "line"), GOLDEN)
def test_golden_lines(frame: Frame, line: bytes) -> None:
    assert encode_slcan(frame) == line
    assert parse_slcan(line[:-1].decode()) == frame
    d = SlcanDecoder()
    assert d.feed(line) == [frame]
    assert (d.pending, d.dropped, d.frames) == (0, 0, 1)


@pytest.mark.parametrize(
    ("frame", "words"),
    [(Frame(0x800, b""), ["0x800", "11-bit"]), (Frame(0x1, bytes(9)), ["9"]), (Frame(0x20000000, b"", True), ["29"])],
)
def test_frames_that_do_not_fit_are_refused(frame: Frame, words: list[str]) -> None:
    with pytest.raises(ProtocolError) as info:
        encode_slcan(frame)
    for w in words:
        assert w in str(info.value)


def test_decoder_takes_a_line_cut_anywhere() -> None:
    stream = b"".join(line for _, line in GOLDEN)
    d = SlcanDecoder()
    got: list[Frame] = []
    for i in range(len(stream)):
        got += d.feed(stream[i : i + 1])
    assert got == [f for f, _ in GOLDEN]
    assert d.dropped == 0


def test_decoder_skips_answers_and_counts_refusals() -> None:
    d = SlcanDecoder()
    got = d.feed(b"\r\r\rz\rZ\rF00\rV2003\rN0001\r\at05E80000000000000100\r\a")
    assert got == [Frame(0x05E, bytes.fromhex("0000000000000100"))]
    assert (d.answers, d.refused, d.dropped, d.pending) == (8, 2, 0, 0)


@pytest.mark.parametrize(
    "line",
    [
        b"t03E9AA",
        b"t03E2AA",
        b"tXYZ0",
        b"t8000",
        b"t+3E0",
        b"t03EA",
        b"r0011AA",
        b"q",
        b"T2000000000",
        b"t03E1GG",
        b"t03E1AA123",
        b"t03E1AA12345",
    ],
)
def test_decoder_drops_malformed_lines_and_goes_on(line: bytes) -> None:
    d = SlcanDecoder()
    assert d.feed(line + b"\rt7FF0\r") == [Frame(0x7FF, b"")]
    assert d.dropped == len(line)


def test_decoder_skips_an_adapters_time_stamp() -> None:
    d = SlcanDecoder()
    got = d.feed(b"t04380000B4429600E7FF1A2B\rt7FF0FFFF\rr12330001\rt7FF0GGGG\r")
    assert got == [
        Frame(0x043, bytes.fromhex("0000b4429600e7ff")),
        Frame(0x7FF, b""),
        Frame(0x123, bytes(3), False, True),
    ]
    assert d.dropped == len(b"t7FF0GGGG")


def test_decoder_drops_a_run_without_cr() -> None:
    d = SlcanDecoder()
    assert d.feed(b"t" * (MAX_LINE + 1)) == []
    assert (d.pending, d.dropped) == (0, MAX_LINE + 1)
    assert d.feed(b"\rt7FF0\r") == [Frame(0x7FF, b"")]


def test_pending_needed_and_flush() -> None:
    d = SlcanDecoder()
    assert d.needed == 0
    d.feed(b"t03E8")
    assert (d.pending, d.needed) == (5, 17)  # 16 hex digits and the CR
    d.feed(b"00")
    assert d.needed == 15
    assert d.flush() == 7 and d.pending == 0 and d.dropped == 7
    d.feed(b"r123")
    assert d.needed >= 1
