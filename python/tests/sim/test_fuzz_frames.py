"""The simulated firmware survives any frame: random data for every command value, extreme parameter values,
NaN and infinity; afterwards every motor still answers a fast read."""

from __future__ import annotations

import logging
import math
import random
import struct

import pytest

from drempower.protocol import DataType, FastRead, State, WriteParam, decode_reply
from drempower.protocol.ids import Frame
from drempower.protocol.parameters import parameters
from drempower.sim import SimBus
from drempower.sim.behaviour import BOOT_SECONDS

from .helpers import Tap

NAN_T = Frame(0x039, bytes.fromhex("0000c07fe8030000"))
"""Motor 1, T to NaN (golden)."""
_F32_EXTREMES = [math.nan, math.inf, -math.inf, 3.4028234663852886e38, -3.4028234663852886e38, 1e-45, 0.0, -1.0]


def _answers(bus: SimBus) -> None:
    """Every motor answers a fast read at its node id (after leaving firmware-update mode and booting)."""
    for m in bus.motors.values():
        if m.in_dfu:
            m.power_cycle()
    bus.advance(BOOT_SECONDS + 0.01)
    tap = Tap(bus)
    for m in bus.motors.values():
        bus.send(FastRead(m.node_id).encode())
        states = [s for s in tap.replies() if isinstance(s, State)]
        assert any(s.node == m.node_id for s in states), f"motor {m.ident} (id {m.node_id}) is silent"
        assert all(math.isfinite(s.position) for s in states)


def test_a_nan_t_frame_is_ignored_and_logged_once(caplog: pytest.LogCaptureFixture) -> None:
    bus = SimBus([1])
    with caplog.at_level(logging.WARNING, logger="drempower.sim"):
        for _ in range(5):
            bus.send(NAN_T)
            bus.advance(0.01)
    assert bus.motors[1].position == pytest.approx(0.0, abs=0.01)
    assert len([r for r in caplog.records if "039" in r.getMessage()]) == 1
    _answers(bus)


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_random_frames_of_every_command_value(seed: int) -> None:
    rng = random.Random(seed)
    bus = SimBus([1, 2])
    for _ in range(6):
        for cmd in range(32):
            for node in (0, 1, 2):
                bus.send(Frame((node << 5) | cmd, rng.randbytes(8)))
            bus.send(Frame((1 << 5) | cmd, rng.randbytes(rng.randrange(9))))  # any length
            bus.advance(0.002)
        bus.advance(0.05)
    _answers(bus)


def test_extreme_values_of_every_parameter() -> None:
    bus = SimBus([1])
    for p in parameters():
        if p.address == 31001:  # can_node_id: tested above (the motor then answers at its new id)
            continue
        for v in _F32_EXTREMES:
            if p.dtype is DataType.F32:
                data = struct.pack("<HHf", p.address, 0, v)
            else:
                raw = 0xFFFFFFFF if not math.isfinite(v) else int(v) & 0xFFFFFFFF
                data = struct.pack("<HHI", p.address, p.dtype, raw)
            bus.send(Frame(0x03F, data))
            bus.advance(0.002)
        bus.send(Frame(0x03F, WriteParam(1, 30003, DataType.U32, 8).encode().data))  # closed loop again
    bus.advance(0.1)
    _answers(bus)


@pytest.mark.parametrize("cmd", [0x0C, 0x19, 0x1A, 0x1B, 0x1C, 0x1D])
def test_non_finite_and_extreme_motion_values(cmd: int) -> None:
    bus = SimBus([1])
    for v in _F32_EXTREMES:
        for tail in (b"\xe8\x03\xe8\x03", b"\x01\x00\x01\x00", b"\x00\x00\x06\x00", b"\xff\x7f\xff\x7f"):
            bus.send(Frame(0x020 | cmd, struct.pack("<f", v) + tail))
            bus.advance(0.01)
            for kind in (0x10, 0x11, 0x12, 0x13, 0x14):
                bus.send(Frame(0x008, struct.pack("<IHH", kind, 1, 0)))
            bus.send(Frame(0x008, struct.pack("<Ihh", 0x15, 32767, 32767)))
            bus.advance(0.01)
    bus.advance(0.5)
    _answers(bus)
    r = decode_reply(*_fast(bus))
    assert isinstance(r, State) and math.isfinite(r.position) and math.isfinite(r.speed)


def _fast(bus: SimBus) -> tuple[int, bytes]:
    tap = Tap(bus)
    bus.send(FastRead(1).encode())
    (f,) = tap.take()
    return f.arbitration_id, f.data
