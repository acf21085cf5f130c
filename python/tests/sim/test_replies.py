"""State replies after control frames, the state frame's id bits, heartbeats and the CAN watchdog."""

from __future__ import annotations

import pytest

from drempower.protocol import (
    AxisError,
    AxisState,
    FastRead,
    PositionP,
    PositionQ,
    PositionT,
    PresetQ,
    Start,
    StartKind,
    State,
    SysCmd,
    SystemCommand,
    Torque,
    Velocity,
    WriteParam,
)
from drempower.sim import SimBus

from .helpers import Tap, exchange, read, write

CONTROL = [
    PositionT(1, 10.0, bandwidth=20.0),
    PositionQ(1, 10.0, 10.0, 10.0),
    PositionP(1, 10.0),
    Velocity(1, 5.0),
    Torque(1, 0.1),
    PresetQ(1, 10.0, 1.0, 10.0),
]


def test_no_state_replies_by_default_but_fast_read_always() -> None:
    bus = SimBus([1])
    for msg in CONTROL:
        assert exchange(bus, msg) == []
    (s,) = exchange(bus, FastRead(1))
    assert isinstance(s, State) and s.node == 1


def test_enable_reply_state_answers_control_and_preset_frames_only() -> None:
    bus = SimBus([1])
    write(bus, 1, "axis0.config.extra_setting.enable_reply_state", 1)
    for msg in CONTROL:
        (s,) = exchange(bus, msg)
        assert isinstance(s, State) and s.node == 1
    assert exchange(bus, Start(0, StartKind.Q), SystemCommand(1, SysCmd.CLEAR_ERRORS)) == []
    assert exchange(bus, WriteParam.of(1, "axis0.controller.config.pos_gain", 40.0)) == []


def test_replies_continue_in_estop() -> None:
    bus = SimBus([1])
    write(bus, 1, "axis0.config.extra_setting.enable_reply_state", 1)
    exchange(bus, SystemCommand(1, SysCmd.ESTOP))
    (s,) = exchange(bus, Velocity(1, 5.0))
    assert isinstance(s, State) and s.error


def test_state_frame_ids_use_bits_0_to_2_only_and_tell_the_truth() -> None:
    bus = SimBus([3])
    m = bus.motors[3]
    tap = Tap(bus)
    bus.send(FastRead(3).encode())
    exchange(bus, PositionQ(3, 90.0, 30.0, 100.0))
    bus.send(FastRead(3).encode())
    bus.advance(1.0)
    bus.send(FastRead(3).encode())
    m.inject_error(AxisError.ENCODER_FAILED)
    bus.send(FastRead(3).encode())
    ids = [f.arbitration_id for f in tap.take()]
    assert [i >> 5 for i in ids] == [3] * 4
    assert [i & 0x1F for i in ids] == [0x03, 0x01, 0x03, 0x07]


def test_state_frame_saturates_speed_and_torque() -> None:
    bus = SimBus([1])
    m = bus.motors[1]
    m.drive.vel = 10.0  # 600 r/min, beyond the s16 field
    (s,) = exchange(bus, FastRead(1))
    assert isinstance(s, State) and s.speed == 327.67


def test_heartbeats_every_period_in_every_state() -> None:
    bus = SimBus([1, 2])
    tap = Tap(bus)
    write(bus, 1, "can.config.heartbeat_ms", 20)
    bus.advance(1.0)
    frames = tap.take()
    assert len(frames) == 50 and {f.arbitration_id >> 5 for f in frames} == {1}
    exchange(bus, SystemCommand(1, SysCmd.ESTOP))
    bus.advance(0.1)
    assert len(tap.take()) == 5
    write(bus, 1, "can.config.heartbeat_ms", 0)
    bus.advance(0.5)
    assert tap.take() == []


def test_watchdog_idles_the_axis_when_the_host_goes_quiet() -> None:
    bus = SimBus([1])
    m = bus.motors[1]
    write(bus, 1, "can.config.timeout_ms", 100)
    for _ in range(10):  # fed by any frame addressed to the motor
        bus.advance(0.05)
        bus.send(FastRead(1).encode())
    assert m.state is AxisState.CLOSED_LOOP_CONTROL
    bus.advance(0.099)
    assert m.state is AxisState.CLOSED_LOOP_CONTROL
    bus.advance(0.002)
    assert m.state is AxisState.IDLE
    assert read(bus, 1, "axis0.error") == AxisError.WATCHDOG_TIMER_EXPIRED
    m.external_torque = 1.0  # idle damping is on after a timeout
    bus.advance(0.5)
    assert m.speed == pytest.approx(18.0, rel=0.1)
