"""Reply matching, timeouts, unsolicited frames, closing: the core's guarantees."""

from __future__ import annotations

import builtins
import threading
import time

import pytest

import drempower
from drempower.client import Bus, BusClosedError, MotorState
from drempower.protocol import DataType, FastRead, ParamValue, ReadParam, State
from drempower.protocol.ids import Frame

from ..scripted import FakeMotors, ScriptedTransport


def test_get_state_and_cache(bus: Bus, motors: FakeMotors) -> None:
    motors.positions[2] = 12.5
    st = bus.motor(2).get_state()
    assert isinstance(st, MotorState)
    assert (st.node, st.angle, st.trajectory_done, st.error) == (2, 12.5, True, False)
    assert bus.motor(2).state == st
    assert bus.state(2) == st and bus.states() == {2: st}
    assert st.timestamp == bus.now()  # stamped on the bus's clock (scripted here)


def test_state_age_is_wall_seconds_since_arrival(motors: FakeMotors) -> None:
    with Bus(ScriptedTransport(motors), timeout=0.5, stop_on_close=False) as bus:  # a wall-clock bus
        st = bus.motor(2).get_state()
        assert st.timestamp <= time.monotonic() and 0 <= st.age < 5


def test_timeout_names_motor_and_request(bus: Bus, motors: FakeMotors) -> None:
    motors.silent.add(3)
    t0 = time.monotonic()
    with pytest.raises(drempower.TimeoutError) as info:
        bus.motor(3).read_property("axis0.trap_traj.config.traj_mode", timeout=0.02)
    assert time.monotonic() - t0 < 10  # no hang
    err = info.value
    assert isinstance(err, builtins.TimeoutError) and isinstance(err, drempower.DrEmpowerError)
    assert err.nodes == (3,)
    assert "motor 3" in str(err) and "axis0.trap_traj.config.traj_mode (35104)" in str(err)


def test_reply_for_other_parameter_is_not_an_answer() -> None:
    unsolicited: list[Frame] = []

    def wrong_address(f: Frame) -> list[Frame]:  # answers every read with address 1
        return [ParamValue(f.arbitration_id >> 5, 1, DataType.F32, 24.0).encode()]

    t = ScriptedTransport(wrong_address)
    with Bus(t, timeout=0.25, stop_on_close=False) as bus:
        bus.on_unsolicited = unsolicited.append
        with pytest.raises(drempower.TimeoutError):
            bus.motor(1).read_property("axis0.error", timeout=0.02)
        assert bus.motor(1).read_property("vbus_voltage") == 24.0
    assert len(unsolicited) == 1 and bus.stats["unmatched"] == 1


def test_state_frames_are_cached_not_answers_to_reads(bus: Bus, scripted: ScriptedTransport) -> None:
    seen: list[MotorState] = []
    sub = bus.subscribe(seen.append)
    scripted.inject(State(5, 1.0, 2.0, 3.0, False, True, spare_bits=2).encode())  # bit 4 set: still a state
    st = bus.wait_state(5, timeout=1, newer_than=0)
    assert (st.angle, st.speed, st.torque, st.trajectory_done, st.error) == (1.0, 2.0, 3.0, False, True)
    assert seen == [st]
    sub.cancel()
    scripted.time += 0.001  # a moment later on the scripted clock
    with bus.motor(5).subscribe(seen.append):
        scripted.inject(State(5, 2.0, 0, 0, True, False).encode())
        bus.wait_state(5, timeout=1, newer_than=st.timestamp)
    scripted.inject(State(5, 3.0, 0, 0, True, False).encode())
    bus.wait_state(5, timeout=1, newer_than=st.timestamp + 1e-9)
    assert [s.angle for s in seen] == [1.0, 2.0]


def test_wait_state_times_out(bus: Bus) -> None:
    with pytest.raises(drempower.TimeoutError, match="motor 7"):
        bus.motor(7).wait_state(0.02)


def test_callback_exception_does_not_stop_the_loop(bus: Bus, scripted: ScriptedTransport) -> None:
    def boom(_: MotorState) -> None:
        raise RuntimeError("user bug")

    bus.subscribe(boom)
    scripted.inject(State(1, 0, 0, 0, True, False).encode())
    assert bus.motor(1).get_state().node == 1


def test_malformed_frames_are_counted_and_skipped(bus: Bus, scripted: ScriptedTransport) -> None:
    scripted.inject(Frame(0x03E, b"\x01\x00\x09\x00\x00\x00\x00\x00"))  # data type 9
    scripted.inject(Frame(0x021, b"\x00\x01"))  # short
    scripted.inject(Frame(0x1234, bytes(8), True))  # extended id
    assert bus.motor(1).get_state().node == 1
    assert bus.stats["malformed"] == 3


def test_broadcast_read_answered_by_the_single_motor() -> None:
    t = ScriptedTransport(FakeMotors([7]))
    with Bus(t, timeout=0.25, stop_on_close=False) as bus:
        assert bus.motor(0).get_id() == 7
        assert bus.motor(0).get_state().node == 7


def test_reads_of_one_motor_are_not_pipelined() -> None:
    """A read reply has the request's CAN id: the next read of that motor waits for it."""
    outstanding: dict[int, int] = {}
    worst = 0
    lock = threading.Lock()
    motors = FakeMotors([1, 2])

    def respond(f: Frame) -> list[Frame]:
        nonlocal worst
        node = f.arbitration_id >> 5
        with lock:
            outstanding[node] = outstanding.get(node, 0) + 1
            worst = max(worst, outstanding[node])
        out = motors(f)
        with lock:
            outstanding[node] -= 1
        return out

    t = ScriptedTransport(respond)
    with Bus(t, timeout=0.25, stop_on_close=False) as bus:
        report = bus.motor(1).dump_error()
        assert not report and len(report.words) == 7
        reads = [ReadParam(n, 1, DataType.F32) for n in (1, 2, 1, 2)] + [FastRead(1)]
        assert [type(r).__name__ for r in bus.request(reads)] == ["ParamValue"] * 4 + ["MotorState"]
    assert worst == 1


def test_close_wakes_a_waiting_request() -> None:
    t = ScriptedTransport()  # never answers
    bus = Bus(t, timeout=30, stop_on_close=False)
    errors: list[BaseException] = []

    def ask() -> None:
        try:
            bus.motor(1).get_state()
        except BaseException as exc:
            errors.append(exc)

    th = threading.Thread(target=ask)
    th.start()
    time.sleep(0.05)
    bus.close()
    th.join(2)
    assert not th.is_alive()
    assert isinstance(errors[0], BusClosedError)
    with pytest.raises(BusClosedError):
        bus.motor(1).set_angle(0, 0, 10)
    bus.close()  # idempotent


class BrokenTransport(ScriptedTransport):
    def recv(self, timeout: float | None = None) -> Frame | None:
        time.sleep(0.01)
        raise OSError("device unplugged")


def test_receive_failure_fails_requests_fast() -> None:
    with Bus(BrokenTransport(), timeout=60, stop_on_close=False) as bus:
        time.sleep(0.05)
        t0 = time.monotonic()
        with pytest.raises(BusClosedError, match="unplugged"):
            bus.motor(1).get_state()
        assert time.monotonic() - t0 < 30  # failed at once instead of waiting 60 s


def test_threads_share_one_bus(bus: Bus, motors: FakeMotors) -> None:
    for i in (1, 2, 3):
        motors.positions[i] = float(i)
    errors: list[BaseException] = []

    def worker(node: int) -> None:
        try:
            for _ in range(50):
                assert bus.motor(node).get_state().angle == float(node)
                assert bus.motor(node).get_id() == node
        except BaseException as exc:
            errors.append(exc)

    threads = [threading.Thread(target=worker, args=(n,)) for n in (1, 2, 3) * 2]
    for th in threads:
        th.start()
    for th in threads:
        th.join(10)
    assert not errors


def test_invalid_options() -> None:
    with pytest.raises(drempower.ValidationError):
        Bus(ScriptedTransport(), start="sometimes")  # type: ignore[arg-type]
    with pytest.raises(drempower.ValidationError):
        Bus(ScriptedTransport(), timeout=0)


def test_reply_of_another_data_type_is_an_anomaly_not_an_answer() -> None:
    """vbus_voltage is f32: an s16 reply for it answers nothing and is counted (more cases on scripted time)."""

    def wrong_type(f: Frame) -> list[Frame]:
        return [ParamValue(f.arbitration_id >> 5, 1, DataType.S16, 0).encode()]

    t = ScriptedTransport(wrong_type)
    with Bus(t, timeout=0.05, stop_on_close=False) as bus:
        with pytest.raises(drempower.TimeoutError):
            bus.motor(1).read_property("vbus_voltage")
        assert bus.stats["anomalies"] == 1 and bus.stats["unmatched"] == 1


def test_wrong_type_reply_leaves_the_request_waiting_for_the_right_one() -> None:
    def both(f: Frame) -> list[Frame]:
        node = f.arbitration_id >> 5
        return [ParamValue(node, 1, DataType.S16, 0).encode(), ParamValue(node, 1, DataType.F32, 24.5).encode()]

    with Bus(ScriptedTransport(both), timeout=0.5, stop_on_close=False) as bus:
        assert bus.motor(1).read_property("vbus_voltage") == 24.5
        assert bus.stats["anomalies"] == 1
