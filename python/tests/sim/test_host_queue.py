"""Each host's transmit queue: fifo keeps the order sent, priority:N mailboxes arbitrate by id."""

from __future__ import annotations

import pytest

import drempower
from drempower.cli import build_parser
from drempower.protocol import Frame, PresetQ, Start, StartKind
from drempower.sim import SimBus
from drempower.sim.bus import parse_host_queue


def _batch() -> list[Frame]:
    """A three-motor preset batch and its broadcast start, as a host sends them."""
    return [PresetQ(n, 30.0 * n, 0.5, 100).encode() for n in (1, 2, 3)] + [Start(0, StartKind.Q).encode()]


def _wire_order(host_queue: str) -> tuple[list[int], SimBus]:
    sim = SimBus([1, 2, 3], bitrate=1_000_000, host_queue=host_queue)
    seen: list[int] = []
    sim.add_listener(lambda f: seen.append(f.arbitration_id), host_frames=True)
    for f in _batch():
        sim.send(f)
    sim.advance(0.005)
    return seen, sim


def test_fifo_keeps_the_order_sent() -> None:
    seen, sim = _wire_order("fifo")
    assert seen == [0x02C, 0x04C, 0x06C, 0x008]
    sim.advance(1.0)
    assert [sim.motors[n].position for n in (1, 2, 3)] == pytest.approx([30, 60, 90], abs=0.05)


def test_priority_mailboxes_let_the_start_overtake_its_presets() -> None:
    """Three mailboxes: the first preset goes at once, the start takes its freed mailbox and wins."""
    seen, sim = _wire_order("priority:3")
    assert seen == [0x02C, 0x008, 0x04C, 0x06C]
    assert sim.host_pending() == 0
    sim.advance(1.0)
    assert [sim.motors[n].position for n in (1, 2, 3)] == pytest.approx([30, 0, 0], abs=0.05)
    assert sim.motors[2].preset is not None  # left for the next start to fire


def test_host_pending_counts_frames_not_yet_on_the_wire() -> None:
    sim = SimBus([1, 2, 3], bitrate=1_000_000, host_queue="priority:3")
    for f in _batch():
        sim.send(f)
    assert sim.host_pending() == 4
    sim.advance(0.0003)  # about two frames' time
    assert 0 < sim.host_pending() < 4


@pytest.mark.parametrize("text, slots", [("fifo", 1), ("priority:1", 1), ("priority:3", 3), ("priority:32", 32)])
def test_parse_host_queue(text: str, slots: int) -> None:
    assert parse_host_queue(text) == slots


@pytest.mark.parametrize("bad", ["", "lifo", "priority", "priority:0", "priority:33", "priority:x"])
def test_bad_host_queues_are_refused(bad: str, capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(ValueError, match="host_queue"):
        SimBus([1], host_queue=bad)
    with pytest.raises(SystemExit) as info:
        build_parser().parse_args(["sim", "--host-queue", bad])
    assert info.value.code == 2 and "--host-queue" in capsys.readouterr().err


@pytest.mark.parametrize("host_queue", ["priority:3", "fifo"])
@pytest.mark.parametrize("reply_state", [False, True])
def test_client_batch_moves_every_motor_with_mailboxes(host_queue: str, reply_state: bool) -> None:
    """The client sends the start only once the presets are on the wire: all three motors move."""
    with drempower.open_bus(
        "sim", motors=[1, 2, 3], bitrate=1_000_000, host_queue=host_queue, stop_on_close=False
    ) as bus:
        sim = bus.transport.bus  # type: ignore[attr-defined]
        for n in (1, 2, 3):
            bus.motor(n).enable_reply_state(reply_state)
        bus.set_angles([1, 2, 3], [90, -45, 180], 120, 300, 1)
        done = bus.positions_done([1, 2, 3], timeout=10)
        assert [done[n].angle for n in (1, 2, 3)] == pytest.approx([90, -45, 180], abs=0.5)
        assert [sim.motors[n].preset for n in (1, 2, 3)] == [None] * 3
        bus.motor(2).impedance_control(-40, 0, 0, 5, 0.1)  # one motor: preset and start to node 2
        bus.motor(2).set_angle(-40, 60, 300, 1)
        assert bus.motor(2).wait_position_done(10).angle == pytest.approx(-40, abs=0.5)
