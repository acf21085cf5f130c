"""The 11-byte and 0xAA serial framings."""

from __future__ import annotations

import pytest

from drempower.errors import ProtocolError
from drempower.protocol import AADecoder, PositionT, Uart11Decoder, encode_aa, encode_uart11
from drempower.protocol.ids import Frame


def test_uart11_doc_example() -> None:
    # protocol document 2.1: the full 11-byte packet of the T-mode example
    f = PositionT(1, 90.0, 10.0).encode()
    assert encode_uart11(*f[:2]).hex(" ").upper() == "08 00 39 00 00 B4 42 00 00 E8 03"


def test_uart11_rejects_bad_frames() -> None:
    with pytest.raises(ProtocolError):
        encode_uart11(0x800, bytes(8))
    with pytest.raises(ProtocolError):
        encode_uart11(0x39, bytes(7))


def test_uart11_resync_after_fake_header() -> None:
    good = encode_uart11(0x39, bytes(range(8)))
    # 08 FF cannot start a frame (id high byte > 7); a truncated frame followed by a good one
    dec = Uart11Decoder()
    assert dec.feed(b"\x08\xff\x01") == []
    assert dec.dropped == 3
    assert dec.feed(good[:5]) == []
    assert dec.pending == 5
    assert dec.feed(good[5:] + good) == [Frame(0x39, bytes(range(8)))] * 2
    assert dec.frames == 2


def test_uart11_accept_hook_and_flush() -> None:
    stale = b"\x08\x00\x21\x00\x00"  # partial frame, then a gap
    dec = Uart11Decoder()
    dec.feed(stale)
    assert dec.flush() == 5
    assert dec.dropped == 5
    # a predicate can refuse headers that line up by chance
    dec = Uart11Decoder(accept=lambda arb, data: arb & 1 == 1)
    good = encode_uart11(0x21, bytes(8))
    assert dec.feed(b"\x08\x00\x20" + good) == [Frame(0x21, bytes(8))]


def test_aa_vendor_layout() -> None:
    # the vendor library's can_to_uart: AA 00 00 08 00 00 idH idL d0..d7
    f = PositionT(1, 90.0, 10.0).encode()
    assert encode_aa(f).hex(" ").upper() == "AA 00 00 08 00 00 00 39 00 00 B4 42 00 00 E8 03"
    assert encode_aa(Frame(0x12345678, b"\x01", is_extended=True)).hex() == "aa01000112345678" + "01"
    assert encode_aa(Frame(0x123, b"", is_remote=True)).hex() == "aa00010000000123"
    with pytest.raises(ProtocolError):
        encode_aa(Frame(0x800, bytes(8)))
    with pytest.raises(ProtocolError):
        encode_aa(Frame(0x1, bytes(9)))


def test_aa_decoder_flags_and_garbage() -> None:
    dec = AADecoder()
    std = encode_aa(Frame(0x39, bytes(8)))
    ext = encode_aa(Frame(0x1ABCDEF, b"\x05\x06", is_extended=True))
    rtr = encode_aa(Frame(0x7FF, b"", is_remote=True))
    fd12 = bytes([0xAA, 0, 0x06, 12, 0, 0, 0, 0x55]) + bytes(range(12))
    junk = b"\xaa\x05" + b"\xaa\x00\x09" + b"\xaa\x00\x00\x09" + b"\xaa\x00\x00\x08\x01"
    out = dec.feed(junk + std + ext + rtr + fd12)
    assert out == [
        Frame(0x39, bytes(8)),
        Frame(0x1ABCDEF, b"\x05\x06", True, False),
        Frame(0x7FF, b"", False, True),
        Frame(0x55, bytes(range(12))),
    ]
    assert dec.dropped == len(junk)
    assert dec.fd_frames == 1
    assert dec.pending == 0


def test_aa_decoder_waits_for_partial_frames() -> None:
    dec = AADecoder()
    data = encode_aa(Frame(0x21, bytes(range(8))))
    for i in range(len(data) - 1):
        assert dec.feed(data[i : i + 1]) == []
    assert dec.feed(data[-1:]) == [Frame(0x21, bytes(range(8)))]
    assert dec.dropped == 0


def test_serial_vectors() -> None:
    import json

    from ..conftest import REPO_ROOT

    vectors = json.loads((REPO_ROOT / "spec" / "vectors" / "serial" / "framings.json").read_text())["vectors"]
    assert len(vectors) >= 7
    u11, aa = Uart11Decoder(), AADecoder()
    for v in vectors:
        data = bytes.fromhex(v["data"])
        assert encode_uart11(v["id"], data).hex().upper() == v["uart11"], v["name"]
        assert encode_aa(Frame(v["id"], data)).hex().upper() == v["aa"], v["name"]
        assert u11.feed(bytes.fromhex(v["uart11"])) == [Frame(v["id"], data)]
        assert aa.feed(bytes.fromhex(v["aa"])) == [Frame(v["id"], data)]
    assert u11.dropped == aa.dropped == 0


def test_aa_frame_length() -> None:
    from drempower.protocol import aa_frame_length

    full = encode_aa(Frame(0x39, bytes(8)))
    assert aa_frame_length(full) == 16
    assert aa_frame_length(b"\x00" + full, 1) == 16
    assert [aa_frame_length(full[:k]) for k in (1, 3, 7)] == [-1, -1, -1]
    assert aa_frame_length(b"\xaa\x02") == 0  # extended flag must be 0 or 1
    assert aa_frame_length(b"\xaa\x00\x00\x09") == 0  # 9 bytes in a classic CAN frame
    assert aa_frame_length(b"\xaa\x00\x00\x08\x00\x00\x08\x00") == 0  # id above 11 bits
    assert aa_frame_length(b"\x08") == 0


def _states(*positions: float) -> list[Frame]:
    from drempower.protocol import State

    return [State(1, p, 1.5, 0.2, True, False).encode() for p in positions]


def test_a_frame_that_lost_a_byte_is_dropped_not_misread() -> None:
    """Taking the short frame would swallow the start of the next one and misread both."""
    frames = _states(90.0, 91.0, 92.0)
    for encode, decoder in ((lambda f: encode_uart11(*f[:2]), Uart11Decoder()), (encode_aa, AADecoder())):
        first = encode(frames[0])
        stream = first[:6] + first[7:] + b"".join(encode(f) for f in frames[1:])
        assert decoder.feed(stream) == frames[1:]
        assert decoder.dropped == len(first) - 1


def test_stray_header_bytes_before_a_frame_do_not_hide_it() -> None:
    frames = _states(10.0, 20.0)
    dec = Uart11Decoder()
    stream = b"\x08\x03" + b"".join(encode_uart11(*f[:2]) for f in frames)
    assert dec.feed(stream) == frames and dec.dropped == 2


def test_decoders_say_how_many_bytes_a_partial_frame_still_needs() -> None:
    f = _states(5.0)[0]
    for stream, decoder in ((encode_uart11(*f[:2]), Uart11Decoder()), (encode_aa(f), AADecoder())):
        assert decoder.needed == 0
        for k in range(1, len(stream)):
            decoder.feed(stream[k - 1 : k])
            assert decoder.needed >= 1
            if k >= 8:  # the 0xAA length byte and id are in: the count is exact
                assert decoder.needed == len(stream) - k
        assert decoder.feed(stream[-1:]) == [f] and decoder.needed == 0
