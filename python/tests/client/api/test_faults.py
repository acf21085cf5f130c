"""Faults injected by the simulator: every case ends in a clear error or a correct result."""

from __future__ import annotations

import pytest

import drempower
from drempower.client.engine.effects import sleep
from drempower.protocol import AxisError, MotorError
from drempower.sim import Faults, SimBus

from ..links import Recorder, link


def test_dropped_frames_give_correct_values_or_timeouts() -> None:
    sim = SimBus(ids=[1, 2], faults=Faults(drop_rate=0.2), seed=3)
    for i in (1, 2):
        sim.motors[i].set_param("axis0.output_shaft.vel_limit", 100.0 + i)
    outcomes = {"ok": 0, "timeout": 0}
    with link("inprocess", sim, timeout=0.02) as bus:
        for k in range(100):
            node = 1 + k % 2
            try:
                assert bus.motor(node).read_property(38012) == 100.0 + node
                outcomes["ok"] += 1
            except drempower.TimeoutError as exc:
                assert exc.nodes == (node,)
                outcomes["timeout"] += 1
    assert outcomes["ok"] > 50 and outcomes["timeout"] > 5


def test_retries_ride_out_dropped_frames() -> None:
    sim = SimBus(ids=[1, 2, 3], faults=Faults(drop_rate=0.2), seed=5)
    with link("inprocess", sim, timeout=0.05, retries=6) as bus:
        for _ in range(3):
            assert [s.node for s in bus.request([drempower.protocol.FastRead(i) for i in (1, 2, 3)])] == [1, 2, 3]
            assert not bus.motor(2).dump_error()


def test_a_silent_motor_is_named_and_nothing_moves() -> None:
    sim = SimBus(ids=[1, 2, 3])
    rec = Recorder(sim)
    with link("inprocess", sim, timeout=0.1) as bus:
        sim.faults.silent.add(2)
        t0 = bus.now()  # the simulated clock
        with pytest.raises(drempower.TimeoutError, match="motor 2"):
            bus.motor(2).get_state()
        assert bus.now() - t0 == pytest.approx(0.1)
        with pytest.raises(drempower.TimeoutError, match="motor 2") as info:
            bus.set_angles([1, 2, 3], [10, 20, 30], 30, 60, 1)
        assert info.value.nodes == (2,)
        with pytest.raises(drempower.TimeoutError, match=r"motors 2: |motor 2"):
            bus.cycle([bus.motor(i).make_speed(0) for i in (1, 2, 3)], reply_state=False)
        with pytest.raises(drempower.TimeoutError, match="motor 2"):
            bus.positions_done([1, 2], timeout=1)
        assert [m.id for m in bus.scan()] == [1, 3]
        assert bus.now() - t0 < 2  # every call ended within its own timeout
    assert not any(f.arbitration_id & 0x1F == 0x0C for f in rec.frames)  # no preset was sent
    assert all(m.position == pytest.approx(0, abs=0.01) for m in sim.motors.values())


def test_late_replies_are_never_taken_for_another_request() -> None:
    sim = SimBus(ids=[1], faults=Faults(reply_delay=0.3))
    with link("inprocess", sim, timeout=0.1) as bus:
        m = bus.motor(1)
        with pytest.raises(drempower.TimeoutError):
            m.read_property("axis0.output_shaft.vel_limit")
        sim.faults.reply_delay = 0.0
        assert m.read_property("axis0.config.can_node_id") == 1
        assert bus.stats["unmatched"] == 0
        bus.run(sleep(0.3))  # the late vel_limit reply arrives meanwhile: nobody asks for it any more
        assert m.read_property("axis0.config.can_node_id") == 1
        assert bus.stats["unmatched"] == 1


@pytest.mark.parametrize("kind", ["adapter", "uart"])
def test_garbage_on_the_serial_line(kind: str) -> None:
    sim = SimBus(ids=[1], faults=Faults(serial_garbage=0.5), seed=11)
    sim.motors[1].set_param("axis0.output_shaft.torque_lim", 12.5)
    with link(kind, sim, time_scale=1, timeout=0.1, retries=3) as bus:
        for _ in range(50):
            assert bus.motor(1).read_property(38013) == 12.5
            assert bus.motor(1).get_state().node == 1
        assert bus.transport.decoder.dropped > 0  # type: ignore[attr-defined]


def test_motor_error_mid_move_ends_the_wait() -> None:
    sim = SimBus(ids=[1, 2])
    with link("inprocess", sim, timeout=1.0) as bus:
        bus.set_angles([1, 2], [180, 180], 10, 20, 1)  # about 3.5 s of simulated time
        sim.schedule(sim.now + 0.5, lambda: sim.motors[2].inject_error(MotorError.DRV_FAULT))
        t0 = bus.now()
        with pytest.raises(drempower.MotorFaultError) as info:
            bus.positions_done([1, 2], timeout=30)
        assert bus.now() - t0 == pytest.approx(0.5, abs=0.05)  # ended by the error, not by the timeout
    err = info.value
    assert err.node == 2 and "DRV_FAULT" in err.flags["axis0.motor.error"]
    assert "motor 2" in str(err)


def test_estop_mid_move_from_another_thread() -> None:
    import threading

    sim = SimBus(ids=[1])
    with link("inprocess", sim, time_scale=2, clock="wall", timeout=1.0) as bus:  # a thread racing: real time
        m = bus.motor(1)
        m.set_angle(360, 10, 20, 1)
        threading.Timer(0.1, m.estop).start()
        with pytest.raises(drempower.MotorFaultError, match="ESTOP_REQUESTED"):
            m.wait_position_done(10)
        assert AxisError.ESTOP_REQUESTED.name in m.dump_error().flags["axis0.error"]


def test_validation_errors_send_nothing_to_the_simulator() -> None:
    sim = SimBus(ids=[1, 2])
    rec = Recorder(sim)
    with link("inprocess", sim) as bus:
        calls = [
            lambda: bus.set_angles([1, 2], [10, 20], 500, 20, 1),
            lambda: bus.set_angles([1, 2], [10], 10, 20, 1),
            lambda: bus.step_angles([1, 2], [10, float("nan")], 10, 20, 1),
            lambda: bus.set_speeds([1, 2], [10, 10], 1000, 2),
            lambda: bus.set_torques([1, 1], [1, 1]),
            lambda: bus.motor(1).set_angle(0, 0, 301, 0),
            lambda: bus.motor(1).impedance_control(0, 0, 0, 400, 0),
            lambda: bus.motor(1).set_mode(4),
            lambda: bus.motor(1).write_property("axis0.error", 0),
            lambda: bus.cycle([bus.motor(1).make_speed(1), bus.motor(2).make_speed(1e6, 400, 2)]),
        ]
        for call in calls:
            with pytest.raises(drempower.ValidationError):
                call()
        assert rec.frames == []


def test_ctrl_c_during_a_request_leaves_nothing_waiting() -> None:
    """An interrupted request must not stay registered and take the next request's reply."""
    import _thread
    import signal
    import threading

    def ctrl_c() -> None:  # a real SIGINT to the main thread interrupts its wait at once
        if hasattr(signal, "pthread_kill"):
            signal.pthread_kill(threading.main_thread().ident or 0, signal.SIGINT)
        else:
            _thread.interrupt_main()

    sim = SimBus(ids=[1])
    with link("inprocess", sim, time_scale=1, clock="wall", timeout=2.0) as bus:  # a real interrupt: real time
        sim.faults.silent.add(1)
        threading.Timer(0.05, ctrl_c).start()
        with pytest.raises(KeyboardInterrupt):
            bus.motor(1).get_state()
        assert len(bus._core.session.matcher) == 0
        sim.faults.silent.discard(1)
        assert bus.motor(1).get_state(timeout=2.0).node == 1
