"""Presets and starts sent one by one (send, send_many, compat's vendor functions) follow the batch rules.

A start never overtakes its presets (priority:3 mailboxes at 1 Mbit/s let id 0x008
win over 0x02C..0x06C), the moves it starts are recorded with their targets for the
waits, and a start consumes the presets it started, nothing else.
"""

from __future__ import annotations

import asyncio
import time
from collections.abc import Iterator

import pytest

import drempower
from drempower import compat
from drempower.client import Bus, MoveError, open_bus_async
from drempower.protocol import FastRead, Frame, PresetQ, PresetT, Start, StartKind
from drempower.sim import SimBus

from ..links import link
from ..scripted import FakeMotors, ScriptedTransport

IDS = [1, 2, 3]
TARGETS = [30.0, -30.0, 60.0]


def _mailbox_bus(**options: object) -> Bus:
    """Three motors on a 1 Mbit/s bus behind a host with three transmit mailboxes, on the virtual clock."""
    options.setdefault("clock", "virtual")
    return drempower.open_bus(
        "sim", motors=IDS, bitrate=1_000_000, host_queue="priority:3", stop_on_close=False, **options
    )


def _positions(bus: Bus) -> list[float]:
    sim = bus.transport.bus  # type: ignore[attr-defined]
    return [sim.motors[n].position for n in IDS]


@pytest.fixture
def compat_bus() -> Iterator[Bus]:
    with _mailbox_bus() as bus:
        compat.use_bus(bus)
        try:
            yield bus
        finally:
            compat.close()


def test_vendor_recipe_through_compat_moves_every_motor(compat_bus: Bus) -> None:
    """preset_angle x3 (Q mode, 1 s) then send_command's broadcast start 0x11: all three reach their targets."""
    for n, a in zip(IDS, TARGETS, strict=True):
        compat.preset_angle(n, a, 0.5, 300, 1)
    compat.send_command(0, 0x08, [0x11, 0, 0, 0, 0, 0, 0, 0])
    assert compat.positions_done(IDS, timeout=10) is True
    assert _positions(compat_bus) == pytest.approx(TARGETS, abs=0.5)
    sim = compat_bus.transport.bus  # type: ignore[attr-defined]
    assert [sim.motors[n].preset for n in IDS] == [None] * 3


@pytest.mark.parametrize("how", ["send_many", "send"])
def test_presets_and_start_through_send_move_every_motor(how: str) -> None:
    msgs = [*(PresetQ(n, a, 0.5, 300) for n, a in zip(IDS, TARGETS, strict=True)), Start(0, StartKind.Q)]
    with _mailbox_bus() as bus:
        if how == "send_many":
            bus.send_many(msgs)
        else:
            for m in msgs:
                bus.send(m)
        done = bus.positions_done(IDS, timeout=10)
        assert [done[n].angle for n in IDS] == pytest.approx(TARGETS, abs=0.5)
        assert _positions(bus) == pytest.approx(TARGETS, abs=0.5)
        assert [bus._core.session.known.moves[n].target for n in IDS] == pytest.approx(TARGETS)
        assert [bus._core.session.known.moves[n].move_time for n in IDS] == [0.5] * 3


@pytest.mark.parametrize("clock", ["virtual", "wall"])  # wall: the start's wait runs in a worker thread
def test_async_send_many_moves_every_motor(clock: str) -> None:
    msgs = [*(PresetQ(n, a, 0.5, 300) for n, a in zip(IDS, TARGETS, strict=True)), Start(0, StartKind.Q)]

    async def run() -> list[float]:
        async with open_bus_async(
            "sim", motors=IDS, bitrate=1_000_000, host_queue="priority:3", stop_on_close=False, clock=clock
        ) as bus:
            await bus.send_many(msgs)
            done = await bus.positions_done(IDS, timeout=10)
            return [done[n].angle for n in IDS]

    assert asyncio.run(run()) == pytest.approx(TARGETS, abs=0.5)


def test_a_sent_start_records_targets_so_the_wait_sees_the_angle_limit() -> None:
    """The wait knows the preset's target: a joint stopped at its limit raises instead of returning done."""
    sim = SimBus(ids=[1, 2])
    with link("inprocess", sim, timeout=1.0) as bus:
        bus.motor(2).set_angle_range(-20, 20)
        bus.send_many([PresetT(1, 10, 20), PresetT(2, 90, 20), Start(0, StartKind.T)])
        with pytest.raises(MoveError) as info:
            bus.positions_done([1, 2], timeout=10)
        assert info.value.node == 2 and info.value.target == 90
        assert info.value.position == pytest.approx(20, abs=0.5)


def test_a_node_start_consumes_only_its_preset_and_later_batches_do_not_fire_the_rest() -> None:
    sim = SimBus(ids=IDS)
    with link("inprocess", sim, timeout=1.0) as bus:
        bus.send_many([PresetT(1, 15, 20), PresetT(2, 25, 20), Start(1, StartKind.T)])
        assert bus.motor(1).wait_position_done(10).angle == pytest.approx(15, abs=0.5)
        bus.set_angles([1, 3], [5, 35], 0, 20, 0)  # motor 2 still holds its preset: starts go per node
        done = bus.positions_done([1, 3], timeout=10)
        assert [done[1].angle, done[3].angle] == pytest.approx([5, 35], abs=0.5)
        assert sim.motors[2].position == pytest.approx(0, abs=0.01)


def test_a_start_through_send_waits_for_the_bus_time_of_its_presets() -> None:
    """Without transmit confirmation the start waits the bus time of what send queued (10 kbit/s: 13.5 ms a frame)."""
    times: list[tuple[float, Frame]] = []
    transport = ScriptedTransport(FakeMotors(IDS))
    transport.wire_bitrate = 10_000
    transport.tx_latency = 0.0
    respond = transport.respond
    transport.respond = lambda f: times.append((time.monotonic(), f)) or respond(f)
    with Bus(transport, timeout=0.5, stop_on_close=False) as bus:
        for n in IDS:
            bus.send(PresetT(n, 10.0 * n, 20))
        bus.send(Start(0, StartKind.T))
    first, start = times[0][0], times[3][0]
    assert times[3][1].arbitration_id == 0x008
    assert start - first >= 3 * 135 / 10_000 - 0.002


def test_the_start_waits_for_frames_queued_by_send_before_its_preset() -> None:
    """Frames handed over by ``send`` (reads here) count in the bus time the start waits for."""
    times: list[tuple[float, Frame]] = []
    transport = ScriptedTransport(FakeMotors(IDS))
    transport.wire_bitrate = 10_000
    transport.tx_latency = 0.0
    respond = transport.respond
    transport.respond = lambda f: times.append((time.monotonic(), f)) or respond(f)
    with Bus(transport, timeout=0.5, stop_on_close=False) as bus:
        for n in IDS:
            bus.send(FastRead(n))
        bus.send_many([PresetT(1, 10.0, 20), Start(1, StartKind.T)])
    first, start = times[0][0], times[4][0]
    assert times[4][1].arbitration_id == 0x028
    assert start - first >= 4 * 135 / 10_000 - 0.002


def test_a_preset_and_a_start_through_send_move_the_motor_over_the_in_order_uart() -> None:
    """The UART keeps frames in order (one motor on the line): the start goes out at once after its preset."""
    sim = SimBus(ids=[1])
    with link("uart", sim, timeout=1.0) as bus:
        assert bus._core.session.tx == "in_order"
        bus.send_many([PresetT(1, 15.0, 20.0), Start(0, StartKind.T)])
        assert bus.motor(1).position_done(timeout=10).angle == pytest.approx(15, abs=0.5)
    assert sim.motors[1].preset is None  # the start consumed it
