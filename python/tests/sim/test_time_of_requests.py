"""The simulated firmware in time: UART answers of now, a Q preset of no move time within limits, a reboot
that takes time."""

from __future__ import annotations

import itertools
import time

import pytest

from drempower.protocol import (
    FastRead,
    Preset,
    ReadParam,
    Start,
    StartKind,
    State,
    SysCmd,
    SystemCommand,
    Velocity,
    WriteParam,
    decode_reply,
)
from drempower.protocol.parameters import DataType
from drempower.sim import SimBus, SimRunner
from drempower.sim.behaviour import BOOT_SECONDS

from .helpers import Tap, exchange, fast_read


def _uart_state(bus: SimBus) -> State:
    (answer,) = bus.uart_request(1, FastRead(1).encode())
    st = decode_reply(answer.arbitration_id, answer.data)
    assert isinstance(st, State)
    return st


def test_uart_requests_bring_the_clock_to_their_time() -> None:
    """A runner's clock (here a scripted one) is brought up to each UART request, as for CAN frames."""
    bus = SimBus([1])
    wall = [0.0]
    bus.clock_sync = lambda: bus.advance(max(0.0, wall[0] - bus.now))
    assert bus.uart_request(1, Velocity(1, 60.0).encode()) == []
    wall[0] += 0.5
    first = _uart_state(bus)
    assert first.speed == pytest.approx(60.0, abs=1.0) and first.position > 100.0  # not 0: time has passed
    angles = [first.position]
    for _ in range(29):
        wall[0] += 0.002
        angles.append(_uart_state(bus).position)
    steps = [b - a for a, b in itertools.pairwise(angles)]
    assert len(set(angles)) == 30
    assert all(s == pytest.approx(0.72, abs=0.05) for s in steps)  # 60 r/min = 0.72 deg per 2 ms


def test_uart_reads_2_ms_apart_of_a_turning_motor_differ_in_real_time() -> None:
    bus = SimBus([1])
    with SimRunner(bus):
        bus.uart_request(1, Velocity(1, 60.0).encode())
        time.sleep(0.3)
        right_after = _uart_state(bus)
        angles = []
        for _ in range(30):
            angles.append(_uart_state(bus).position)
            time.sleep(0.002)
    assert right_after.speed > 30.0
    assert len(set(angles)) == 30


@pytest.mark.parametrize(("accel", "limit"), [(100.0, 100.0), (0.0, 50.0)])
def test_a_q_preset_with_no_move_time_moves_within_the_limits(accel: float, limit: float) -> None:
    """Time 0 (the vendor's STM32 library sends it for every move under 1 s): the trajectory limits hold."""
    bus = SimBus([1])
    m = bus.motors[1]
    exchange(bus, WriteParam(1, 38015, DataType.F32, limit))  # trap_traj_accel_limit, r/min per s
    speed_limit = m.param("axis0.output_shaft.trap_traj_vel_limit")
    exchange(bus, Preset(1, 90.0, 0.0, accel), Start(0, StartKind.Q))
    a = accel or limit
    speeds = []
    for _ in range(4000):
        bus.advance(0.001)
        speeds.append(m.speed)
    assert max(abs(s) for s in speeds) <= speed_limit * 1.05
    # no jump: the speed rises no faster than the acceleration limit allows (plus the loop's lag)
    assert all(abs(s) <= a * (i + 1) * 0.001 + 2.0 for i, s in enumerate(speeds))
    assert speeds[199] == pytest.approx(a * 0.2, rel=0.15)
    assert m.position == pytest.approx(90.0, abs=0.1)


def test_a_q_preset_of_a_distance_below_float_resolution_moves_nothing() -> None:
    bus = SimBus([1])
    exchange(bus, Preset(1, 1e-20, 0.01, 100.0), Start(0, StartKind.Q))
    bus.advance(0.5)
    assert fast_read(bus, 1).position == pytest.approx(0.0, abs=1e-3)


def test_a_reboot_leaves_the_motor_silent_while_it_boots() -> None:
    bus = SimBus([1])
    m = bus.motors[1]
    exchange(bus, WriteParam(1, 21004, DataType.U32, 10))  # heartbeats every 10 ms
    exchange(bus, Velocity(1, 30.0))
    bus.advance(0.2)
    tap = Tap(bus)
    bus.send(SystemCommand(1, SysCmd.REBOOT).encode())
    assert m.booting and not m.drive.active
    bus.advance(BOOT_SECONDS - 0.01)
    bus.send(FastRead(1).encode())
    bus.send(ReadParam(1, 1, DataType.F32).encode())
    assert bus.uart_request(1, FastRead(1).encode()) == []
    assert tap.take() == []  # no heartbeat, no answer on CAN or UART
    bus.advance(0.02)
    assert not m.booting
    st = fast_read(bus, 1)
    assert st.speed == pytest.approx(0.0, abs=0.5)  # unsaved speed command gone: the axis holds
    assert m.param("can.config.heartbeat_ms") == 0  # RAM from the saved configuration
