"""A lost preset, start or position command: with ``retries`` the wait sends that motor's move again
(to it alone); without, the wait reports the motor that never moved."""

from __future__ import annotations

from collections.abc import Callable

import pytest

from drempower.protocol import Frame
from drempower.sim import Faults, SimBus

from ..links import Recorder, link, lose

PRESET, SYSTEM = 0x0C, 0x08
_POSITION_STARTS = (0x10, 0x11, 0x12)


def _to(node: int, cmd: int) -> Callable[[Frame], bool]:
    return lambda f: f.arbitration_id == node << 5 | cmd


def _starts(frames: list[Frame]) -> list[int]:
    """The node of every start frame among ``frames`` (0 = broadcast)."""
    return [
        f.arbitration_id >> 5
        for f in frames
        if f.arbitration_id & 0x1F == SYSTEM and f.data and f.data[0] in _POSITION_STARTS
    ]


def test_a_lost_preset_is_sent_again_with_a_start_to_that_motor_only() -> None:
    sim = SimBus(ids=[1, 2, 3])
    gone = lose(sim, _to(2, PRESET))
    rec = Recorder(sim)
    with link("inprocess", sim, timeout=0.2, retries=3) as bus:
        bus.set_angles([1, 2, 3], [10, 20, 30], 30, 60)
        states = bus.positions_done([1, 2, 3], timeout=10)
        assert [round(states[i].angle) for i in (1, 2, 3)] == [10, 20, 30]
        assert bus.stats["moves_resent"] == 1
    assert len(gone) == 1
    assert _starts(rec.frames) == [0, 2]  # the batch's broadcast start, then motor 2's own
    assert sum(1 for f in rec.frames if f.arbitration_id == 2 << 5 | PRESET) == 2  # the lost preset, then again


def test_a_lost_start_of_a_one_motor_move_is_sent_again() -> None:
    sim = SimBus(ids=[1, 2])
    gone = lose(sim, _to(1, SYSTEM))
    with link("inprocess", sim, timeout=0.2, retries=2) as bus:
        bus.set_angles([1], [15], 30, 60)
        st = bus.motor(1).position_done(timeout=10)
        assert abs(st.angle - 15) < 0.5 and bus.stats["moves_resent"] == 1
    assert len(gone) == 1 and sim.motors[2].position == pytest.approx(0, abs=0.01)


def test_a_lost_position_command_is_sent_again() -> None:
    sim = SimBus(ids=[1])
    gone = lose(sim, lambda f: f.arbitration_id >> 5 == 1 and f.arbitration_id & 0x1F == 0x19)
    with link("inprocess", sim, timeout=0.2, retries=1) as bus:
        m = bus.motor(1)
        m.set_angle(12, 0, 20, mode=0)
        st = m.position_done(timeout=10)
        assert abs(st.angle - 12) < 0.5 and bus.stats["moves_resent"] == 1
    assert len(gone) == 1


@pytest.mark.parametrize("seed", [3, 5, 7])
def test_moves_on_a_lossy_bus_reach_their_targets(seed: int) -> None:
    sim = SimBus(ids=[1, 2, 3], faults=Faults(drop_rate=0.1), seed=seed)
    with link("inprocess", sim, timeout=0.1, retries=6) as bus:
        bus.set_angles([1, 2, 3], [10, 10, 10], 30, 60)
        states = bus.positions_done([1, 2, 3], timeout=10)
        assert all(abs(states[i].angle - 10) < 0.5 for i in (1, 2, 3))
