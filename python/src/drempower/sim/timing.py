"""CAN frame length on the wire, and bus-load statistics.

:func:`frame_bits` counts the bits a classic CAN data frame occupies: SOF,
arbitration, control and data fields and the CRC-15 (computed for real) with
bit stuffing applied, then the unstuffed CRC delimiter, ACK slot and delimiter,
end of frame (7) and intermission (3).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache, lru_cache

__all__ = ["crc15", "frame_bits", "stuff_count", "BusStats", "TRAILER_BITS"]

TRAILER_BITS = 1 + 2 + 7 + 3
"""CRC delimiter, ACK slot and delimiter, end of frame, intermission: never stuffed."""


def crc15(bits: str, crc: int = 0) -> int:
    """The CAN CRC-15 (polynomial 0x4599) of a bit string such as ``"0110..."``, continuing from ``crc``."""
    for b in bits:
        feedback = (b == "1") ^ bool(crc & 0x4000)
        crc = (crc << 1) & 0x7FFF
        if feedback:
            crc ^= 0x4599
    return crc


_CRC_TABLE = tuple(crc15(f"{byte:08b}", 0) for byte in range(256))
"""CRC-15 of each byte value from a zero register: the byte-at-a-time step."""


def _crc_byte(crc: int, byte: int) -> int:
    return ((crc << 8) & 0x7FFF) ^ _CRC_TABLE[((crc >> 7) ^ byte) & 0xFF]


@cache
def _run(state: tuple[str, int], chunk: str) -> tuple[tuple[str, int], int]:
    """Bit-stuffing over ``chunk`` from ``state`` (last bit, length of its run): new state, stuff bits.
    At most 9 states times 510 chunks of 1 to 8 bits, so the cache stays small."""
    last, run = state
    count = 0
    for b in chunk:
        if b == last:
            run += 1
        else:
            last, run = b, 1
        if run == 5:
            count += 1
            last = "1" if b == "0" else "0"
            run = 1
    return (last, run), count


def stuff_count(bits: str) -> int:
    """Stuff bits a transmitter inserts into ``bits``: one after every 5 equal bits in a row
    (the stuff bit itself starts the next run)."""
    state, count = ("", 0), 0
    for i in range(0, len(bits), 8):
        state, n = _run(state, bits[i : i + 8])
        count += n
    return count


@lru_cache(maxsize=4096)
def _header(arbitration_id: int, dlc: int, is_extended: bool) -> tuple[str, int]:
    """SOF, arbitration and control fields as bits, and the CRC register after them."""
    if is_extended:
        bits = f"0{arbitration_id >> 18:011b}11{arbitration_id & 0x3FFFF:018b}000{dlc:04b}"
    else:
        bits = f"0{arbitration_id:011b}000{dlc:04b}"
    return bits, crc15(bits)


def frame_bits(arbitration_id: int, data: bytes, is_extended: bool = False) -> int:
    """Bits a data frame with ``arbitration_id`` and ``data`` (0..8 bytes) occupies on the bus,
    interframe space included. A standard frame with 8 data bytes takes 111 to 135 bits."""
    return _frame_bits(arbitration_id, bytes(data), is_extended)


@lru_cache(maxsize=4096)
def _frame_bits(arbitration_id: int, data: bytes, is_extended: bool) -> int:
    """:func:`frame_bits`, remembered: fast reads, parameter reads, idle states and repeated set-points
    come back again and again (a miss costs a fraction of the computation)."""
    head, crc = _header(arbitration_id, len(data), is_extended)
    for byte in data:
        crc = _crc_byte(crc, byte)
    body = head + "".join(_BYTE_BITS[b] for b in data) + f"{crc:015b}"
    return len(body) + stuff_count(body) + TRAILER_BITS


_BYTE_BITS = tuple(f"{b:08b}" for b in range(256))


@dataclass(slots=True)
class BusStats:
    """Traffic a bus has carried: ``frames``, ``bits``, ``busy`` time (s) over ``elapsed`` time (s)."""

    frames: int = 0
    bits: int = 0
    busy: float = 0.0
    elapsed: float = 0.0

    @property
    def utilisation(self) -> float:
        """Fraction of the elapsed time the bus was busy (0 when no time has passed)."""
        return self.busy / self.elapsed if self.elapsed > 0 else 0.0
