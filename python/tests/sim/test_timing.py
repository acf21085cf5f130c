"""Frame lengths with bit stuffing and CRC-15, serialisation and arbitration at a bit rate, bus load."""

from __future__ import annotations

from hypothesis import given
from hypothesis import strategies as st

from drempower.protocol import FastRead, ReadParam, SysCmd, SystemCommand, WriteParam
from drempower.protocol.ids import Frame
from drempower.sim import SimBus, frame_bits
from drempower.sim.behaviour import BOOT_SECONDS
from drempower.sim.timing import crc15, stuff_count

from .helpers import Tap


def test_crc15_check_value() -> None:
    bits = "".join(f"{b:08b}" for b in b"123456789")
    assert crc15(bits) == 0x059E  # CRC-15/CAN check value


def test_stuffing() -> None:
    assert stuff_count("00000") == 1
    assert stuff_count("000001111") == 2  # the stuff bit 1 starts the next run of ones
    assert stuff_count("00000111") == 1
    assert stuff_count("0101010101") == 0
    assert stuff_count("0" * 20) == 4


def test_known_frame_lengths() -> None:
    # all-recessive data stuffs little; 47 + 64 data bits + 13 trailer at minimum
    assert frame_bits(0x7FF, b"\xff" * 8) == 126
    assert frame_bits(0x03E, bytes(8)) == 127
    assert frame_bits(0x000, b"") == 34 + 6 + 13  # 34 zero bits SOF..CRC, a stuff bit after every 5


@given(st.integers(0, 0x7FF), st.binary(min_size=0, max_size=8))
def test_frame_length_bounds(arb: int, data: bytes) -> None:
    unstuffed = 1 + 11 + 3 + 4 + 8 * len(data) + 15
    n = frame_bits(arb, data)
    assert unstuffed + 13 <= n <= unstuffed + (unstuffed - 1) // 4 + 13


def _reference_frame_bits(arb: int, data: bytes) -> int:
    """The textbook computation, one bit at a time."""
    bits = f"0{arb:011b}000{len(data):04b}" + "".join(f"{b:08b}" for b in data)
    crc = 0
    for b in bits:
        top = (crc >> 14) & 1
        crc = (crc << 1) & 0x7FFF
        if int(b) ^ top:
            crc ^= 0x4599
    bits += f"{crc:015b}"
    stuffed, run, last = 0, 0, ""
    for b in bits:
        run = run + 1 if b == last else 1
        last = b
        if run == 5:
            stuffed += 1
            last, run = ("1" if b == "0" else "0"), 1
    return len(bits) + stuffed + 13


@given(st.integers(0, 0x7FF), st.binary(min_size=0, max_size=8))
def test_frame_bits_matches_the_textbook_computation(arb: int, data: bytes) -> None:
    assert frame_bits(arb, data) == _reference_frame_bits(arb, data)


def test_extended_frames_are_longer() -> None:
    assert frame_bits(0x1234567, bytes(8), True) > frame_bits(0x123, bytes(8))


def test_frames_take_their_wire_time_and_replies_follow() -> None:
    bus = SimBus([1], bitrate=1_000_000)
    tap = Tap(bus)
    req = FastRead(1).encode()
    bus.send(req)
    assert tap.frames == []  # nothing happens until time passes
    t_req = frame_bits(req.arbitration_id, req.data) / 1e6
    bus.advance(t_req - 1e-7)
    assert tap.frames == []
    bus.advance(2e-7)
    assert tap.frames == []  # the reply starts now
    reply = bus.motors[1].state_frame()
    bus.advance(frame_bits(reply.arbitration_id, reply.data) / 1e6)
    assert [f.arbitration_id for f in tap.frames] == [0x023]
    s = bus.stats
    assert s.frames == 2 and s.bits == frame_bits(*req[:2]) + frame_bits(*reply[:2])
    assert s.busy == s.bits / 1e6
    assert 0.99 < s.utilisation <= 1.0


def test_lowest_id_wins_arbitration() -> None:
    bus = SimBus([1, 2, 3], bitrate=1_000_000)
    tap = Tap(bus)
    bus.send(ReadParam.of(0, "axis0.config.can_node_id").encode())  # three replies at once
    bus.advance(0.01)
    assert [f.arbitration_id >> 5 for f in tap.frames] == [1, 2, 3]
    # the read of motor 3 goes first (the bus was idle), but its reply (0x063) loses
    # arbitration to the queued reads of motors 1 and 2 and to their replies
    tap.take()
    for n in (3, 1, 2):
        bus.send(FastRead(n).encode())
    bus.advance(0.01)
    assert [f.arbitration_id >> 5 for f in tap.frames] == [1, 2, 3]


def test_bus_load_of_a_polling_loop() -> None:
    bus = SimBus([1, 2], bitrate=1_000_000)
    for _ in range(100):
        for n in (1, 2):
            bus.send(FastRead(n).encode())
        bus.advance(0.001)
    s = bus.stats
    assert s.frames == 400
    assert 0.45 < s.utilisation < 0.55  # 4 frames of ~127 bits every millisecond


def test_a_motor_at_another_bitrate_is_deaf_and_mute_after_reboot() -> None:
    bus = SimBus([1], bitrate=1_000_000)
    tap = Tap(bus)
    bus.send(WriteParam.of(1, "can.config.baud_rate", 500_000).encode())
    bus.send(SystemCommand(1, SysCmd.SAVE_CONFIG).encode())
    bus.send(SystemCommand(1, SysCmd.REBOOT).encode())
    bus.advance(BOOT_SECONDS + 0.01)
    bus.send(FastRead(1).encode())
    bus.advance(0.01)
    assert tap.frames == []
    assert bus.motors[1].bitrate == 500_000


def test_instant_bus_counts_frames_only() -> None:
    bus = SimBus([1])
    bus.send(FastRead(1).encode())
    bus.send(Frame(0x7FF, bytes(8)))
    s = bus.stats
    assert (s.frames, s.bits, s.busy, s.utilisation) == (3, 0, 0.0, 0.0)
