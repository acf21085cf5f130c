"""The client against the simulator, through every transport."""

from __future__ import annotations

import pytest

import drempower
from drempower.client import PositionMode
from drempower.protocol import PresetQ
from drempower.sim import SimBus

from ..links import TRANSPORTS, link


@pytest.mark.parametrize("kind", TRANSPORTS)
def test_every_transport(kind: str) -> None:
    ids = [1] if kind == "uart" else [1, 2, 3]
    sim = SimBus(ids=ids)
    with link(kind, sim, timeout=2.0) as bus:
        found = bus.scan(timeout=0.3, versions=True)  # the window the absent ids take to time out
        assert [m.id for m in found] == ids
        assert all(m.fw_version == sim.motors[m.id].param("fw_version") for m in found)
        m = bus.motor(1)
        assert m.get_state().angle == pytest.approx(0, abs=0.01)
        assert m.read_property("axis0.config.can_node_id") == 1
        assert m.get_volcur()[0] == pytest.approx(sim.motors[1].param("vbus_voltage"))
        assert not m.dump_error()
        m.write_property("axis0.output_shaft.vel_limit", 200.5, verify=True)
        assert sim.motors[1].param(38012) == 200.5

        targets = [30.0 * (i + 1) for i in range(len(ids))]
        t = bus.set_angles(ids, targets, 60, 300, PositionMode.Q)
        assert t is not None and t > 0
        done = bus.positions_done(ids, timeout=10)
        assert [done[i].angle for i in ids] == pytest.approx(targets, abs=0.05)

        m.step_angle(-10, 60, 300, 1)
        assert m.wait_position_done(10).angle == pytest.approx(20, abs=0.05)
        states = bus.cycle([bus.motor(i).make_angle(0.0, 0, 100) for i in ids])
        assert sorted(states) == ids
        m.estop()
        assert m.dump_error().flags == {"axis0.error": ["ESTOP_REQUESTED"]}
        m.clear_error()
        m.set_mode(2)
        assert not m.dump_error()


def test_sync_q_move_arrives_together() -> None:
    """On a manual clock: halfway through, every motor has covered the same fraction of its move."""
    sim = SimBus(ids=[1, 2, 3])
    with link("inprocess", sim) as bus:
        t = bus.set_angles([1, 2, 3], [90, -45, 180], 30, 60, 1)
        assert t == pytest.approx(1.5)  # 180 deg at 30 r/min, 60 (r/min)/s: v/a + d/(6v)
        sim.advance(t / 2)
        fractions = [sim.motors[i].position / d for i, d in ((1, 90), (2, -45), (3, 180))]
        assert fractions == pytest.approx([0.5] * 3, abs=0.02)
        sim.advance(t / 2 + 0.05)
        assert bus.positions_done([1, 2, 3], timeout=1)
        assert [sim.motors[i].position for i in (1, 2, 3)] == pytest.approx([90, -45, 180], abs=0.05)


def test_q_time_from_real_positions_and_s_curve() -> None:
    sim = SimBus(ids=[1, 2])
    sim.motors[2].set_param("axis0.trap_traj.config.traj_mode", 2)
    with link("inprocess", sim) as bus:
        bus.motor(1).set_angle(60, 60, 300, 1)  # motor 1 moves away; a stale cache would still say 0
        bus.positions_done([1], timeout=5)
        t = bus.set_angles([1, 2], [90, 90], 30, 60, 1)
        assert t == pytest.approx(drempower.client.q_move_time(90, 30, 60, 2), abs=0.011)
        done = bus.positions_done([1, 2], timeout=10)
        assert [done[1].angle, done[2].angle] == pytest.approx([90, 90], abs=0.05)


def test_single_motor_moves_never_start_other_motors() -> None:
    sim = SimBus(ids=[1, 2])
    with link("inprocess", sim, start="auto") as bus:
        bus.send(PresetQ(2, 90, 1.0, 60))  # a preset left on motor 2 (by this or another program)
        bus.motor(1).step_angle(20, 60, 300, 1)
        bus.motor(1).impedance_control(20, 0, 0, 1, 0.05)
        bus.positions_done([1], timeout=5)
        assert bus.motor(2).get_state().angle == pytest.approx(0, abs=0.01)
        bus.motor(1).set_angle(20, 60, 300, 1)  # hold still: the relative move below starts from 20
        bus.positions_done([1], timeout=5)
    with link("inprocess", sim, start="broadcast") as bus:  # the vendor library's way
        bus.motor(1).step_angle(20, 60, 300, 1)
        bus.positions_done([1, 2], timeout=5)
        assert bus.motor(2).get_state().angle == pytest.approx(90, abs=0.05)


def test_set_speeds_torques_and_stop_on_close() -> None:
    sim = SimBus(ids=[1, 2, 3])
    with link("inprocess", sim, stop_on_close=True) as bus:
        bus.set_speeds([1, 2], [30, -30], 300, 2)
        sim.advance(0.5)
        assert [bus.motor(i).get_state().speed for i in (1, 2)] == pytest.approx([30, -30], abs=0.5)
        bus.set_torques([1, 2], [0.0, 0.0])
        bus.motor(3).get_state()  # only read: closing leaves motor 3 alone
    assert [sim.motors[i].state.name for i in (1, 2, 3)] == ["IDLE", "IDLE", "CLOSED_LOOP_CONTROL"]


def test_heartbeats_update_the_cache() -> None:
    sim = SimBus(ids=[1])
    with link("inprocess", sim) as bus:
        bus.motor(1).write_property("can.config.heartbeat_ms", 10)
        seen = []
        with bus.motor(1).subscribe(seen.append):
            first = bus.motor(1).wait_state(1)
            second = bus.wait_state(1, 1, newer_than=first.timestamp)
        assert second.timestamp > first.timestamp and len(seen) >= 2


def test_control_cycle_with_reply_state() -> None:
    sim = SimBus(ids=[1, 2, 3])
    with link("inprocess", sim) as bus:
        for i in (1, 2, 3):
            bus.motor(i).enable_reply_state()
        n = len(sim.motors)
        for k in range(20):
            states = bus.cycle([bus.motor(i).make_angle(k * 0.5, 0, 100) for i in (1, 2, 3)])
            assert sorted(states) == [1, 2, 3]
        assert n == 3


def test_set_id_and_gpio_on_the_simulator() -> None:
    sim = SimBus(ids=[4])
    with link("inprocess", sim) as bus:
        m = bus.motor(4).set_id(7)
        assert m.get_id() == 7 and sim.motors[4].node_id == 7
        m.set_GPIO_mode("step_dir", 256)
        assert m.get_GPIO_mode().mode == "step_dir"
        m.set_angle_range(-90, 90)
        assert sim.motors[4].param(31202) == 1
