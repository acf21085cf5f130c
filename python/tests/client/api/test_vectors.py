"""The frames the client sends equal the vendor library's (PROTOCOL.md 1.7)."""

from __future__ import annotations

import pytest

from drempower import compat
from drempower.client import Bus, make_angle, make_speed, make_torque

from ..scripted import FakeMotors, ScriptedTransport


def frames(t: ScriptedTransport) -> list[tuple[int, str]]:
    return [(f.arbitration_id, f.data.hex(" ").upper()) for f in t.sent]


@pytest.mark.parametrize(
    ("msg", "arb", "data"),
    [
        (make_angle(1, 90, 0, 10, mode=0), 0x039, "00 00 B4 42 00 00 E8 03"),
        (make_angle(1, -150, 10, 5, mode=1), 0x03A, "00 00 16 C3 E8 03 F4 01"),
        (make_angle(2, 45, 5, 0.5, mode=2), 0x05B, "00 00 34 42 F4 01 32 00"),
        (make_speed(1, 20, 1.5, mode=1), 0x03C, "00 00 A0 41 96 00 01 00"),
        (make_speed(1, 20, 5, mode=2), 0x03C, "00 00 A0 41 F4 01 02 00"),
        (make_torque(1, 0.5, 0, mode=1), 0x03D, "00 00 00 3F 00 00 01 00"),
        (make_torque(1, 0.5, 2, mode=6), 0x03D, "00 00 00 3F C8 00 06 00"),
    ],
)
def test_make_matches_vendor(msg: object, arb: int, data: str) -> None:
    f = msg.encode()  # type: ignore[attr-defined]
    assert (f.arbitration_id, f.data.hex(" ").upper()) == (arb, data)


@pytest.fixture
def compat_bus() -> tuple[ScriptedTransport, Bus]:
    t = ScriptedTransport(FakeMotors([1, 2, 3, 4]))
    bus = compat.use_bus(Bus(t, timeout=0.25, stop_on_close=False, start="broadcast"))
    bus.enable([1, 2, 3, 4])  # known in closed loop: the safety gate reads nothing
    t.sent.clear()
    yield t, bus
    compat.close()


def test_compat_single_frames(compat_bus: tuple[ScriptedTransport, Bus]) -> None:
    """The vendor's frames, and one more: ``set_mode(1, 2)`` is confirmed as every front end confirms an
    enable, by reading ``axis0.current_state`` (30002) back (the vendor's returns without knowing)."""
    t, _ = compat_bus
    compat.estop(3)
    compat.set_mode(1, 2)
    compat.get_state(1)
    compat.read_property(1, "vbus_voltage")
    assert frames(t) == [
        (0x068, "06 00 00 00 00 00 00 00"),
        (0x03F, "33 75 03 00 08 00 00 00"),
        (0x03E, "32 75 03 00 00 00 00 00"),  # the confirmation: current_state read back
        (0x03E, "00 00 00 00 00 00 00 00"),
        (0x03E, "01 00 00 00 00 00 00 00"),
    ]


def test_compat_set_angles_q_time_from_fresh_positions(compat_bus: tuple[ScriptedTransport, Bus]) -> None:
    t, _ = compat_bus
    assert compat.set_angles([1, 2], [90, -90], 10, 20, 1) == 2.0
    sent = [f for f in frames(t) if f[0] & 0x1F != 0x1E]  # leave out the reads of traj_mode and positions
    assert sent == [
        (0x02C, "00 00 B4 42 C8 00 D0 07"),
        (0x04C, "00 00 B4 C2 C8 00 D0 07"),
        (0x008, "11 00 00 00 00 00 00 00"),
    ]


def test_compat_step_angles_relative_start(compat_bus: tuple[ScriptedTransport, Bus]) -> None:
    t, _ = compat_bus
    compat.step_angles([1, 2], [90, -90], 10, 20, 1)
    assert frames(t)[-1] == (0x008, "11 00 00 00 01 00 00 00")


def test_compat_impedance_speeds_torques(compat_bus: tuple[ScriptedTransport, Bus]) -> None:
    t, _ = compat_bus
    compat.impedance_control(1, 180, 0, 0, 0.5, 0.2)
    compat.set_speeds([1], [10], 0, 1)
    compat.set_torques([1], [3], 10, 0)
    assert frames(t) == [
        (0x02C, "00 00 34 43 00 00 00 00"),
        (0x008, "15 00 00 00 32 00 14 00"),
        (0x02C, "00 00 20 41 00 00 64 00"),
        (0x008, "13 00 00 00 00 00 00 00"),
        (0x02C, "00 00 40 40 E8 03 58 02"),
        (0x008, "14 00 00 00 00 00 00 00"),
    ]


def test_rounding_not_truncation() -> None:
    # the vendor's int(x / 0.01) sends 0.29 as 28; the client rounds to 29
    f = make_angle(1, 0, 0.29, 1.15, mode=2).encode()
    assert f.data[4:] == bytes([29, 0, 115, 0])
