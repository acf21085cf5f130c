"""The in-process simulator on its virtual clock: the client waits by letting simulated time pass.

Every wait (a move, a timeout, a sleep, a retry) takes its full length in simulated time and almost
none in wall time; stopping (close, estop, signals) behaves as on real time.
"""

from __future__ import annotations

import asyncio
import itertools
import os
import signal
import threading
import time
from types import FrameType

import pytest

import drempower
from drempower.client import BusClosedError, PositionMode, open_bus_async
from drempower.client.engine.effects import sleep
from drempower.client.engine.session import idle_frames
from drempower.protocol.ids import Frame
from drempower.sim import Faults, SimBus, SimRunner
from drempower.transports import TransportError
from drempower.transports.sim import SimTransport

from ..links import Recorder


def _rx_threads() -> list[str]:
    return [t.name for t in threading.enumerate() if t.name.startswith(("drempower rx", "drempower-sim"))]


def test_a_three_second_move_ends_in_milliseconds_with_the_motor_at_its_target() -> None:
    before = _rx_threads()
    with drempower.open_bus("sim", motors=[1], clock="virtual", stop_on_close=False) as bus:
        assert bus.virtual and "virtual clock" in bus.transport.description
        assert _rx_threads() == before  # no receive thread, no runner
        sim = bus.transport.bus  # type: ignore[attr-defined]
        m = bus.motor(1)
        wall, t0 = time.perf_counter(), bus.now()
        t = bus.set_angles([1], [180], 10, 100, PositionMode.Q)  # 180 deg at 10 r/min: 3.1 s
        assert t == pytest.approx(3.1)
        state = m.wait_position_done(10)
        elapsed = bus.now() - t0
        assert time.perf_counter() - wall < 0.3
        assert t <= elapsed < t + 0.1  # the move's own length of simulated time
        assert state.angle == pytest.approx(180, abs=0.05) and state.trajectory_done
        assert sim.motors[1].position == pytest.approx(180, abs=0.05)
        assert state.timestamp == pytest.approx(bus.now())  # states are stamped on the simulated clock


def test_a_silent_motor_times_out_after_its_timeout_of_simulated_time() -> None:
    with drempower.open_bus("sim", motors=[1, 2], clock="virtual", timeout=1.0, stop_on_close=False) as bus:
        bus.transport.bus.faults.silent.add(2)  # type: ignore[attr-defined]
        wall, t0 = time.perf_counter(), bus.now()
        with pytest.raises(drempower.TimeoutError, match="motor 2: no answer to a fast read") as info:
            bus.motor(2).get_state()
        assert time.perf_counter() - wall < 0.5  # of a 1 s wait
        assert bus.now() - t0 == pytest.approx(1.0)
        assert info.value.nodes == (2,)
        assert bus.motor(1).get_state().node == 1  # the other motor answers at once, no time passing
        assert bus.now() - t0 == pytest.approx(1.0)


def test_retries_take_their_timeouts_in_simulated_time() -> None:
    sim = SimBus(ids=[1])
    with drempower.open_bus("sim", bus=sim, clock="virtual", timeout=0.2, retries=2, stop_on_close=False) as bus:
        sim.faults.silent.add(1)
        t0 = bus.now()
        with pytest.raises(drempower.TimeoutError):
            bus.motor(1).read_property("axis0.error")
        assert bus.now() - t0 == pytest.approx(3 * 0.2)  # the request and its two retries


def test_a_sleep_lets_exactly_its_time_pass_and_the_motors_move_meanwhile() -> None:
    with drempower.open_bus("sim", motors=[1], clock="virtual", stop_on_close=False) as bus:
        sim = bus.transport.bus  # type: ignore[attr-defined]
        m = bus.motor(1)
        m.set_speed(60, 0, 1)  # 60 r/min: 360 deg/s
        t0, wall = bus.now(), time.perf_counter()
        bus.run(sleep(2.0))
        assert bus.now() - t0 == pytest.approx(2.0)
        assert time.perf_counter() - wall < 0.3
        assert sim.motors[1].position == pytest.approx(720, abs=20)
        assert m.get_state().angle == pytest.approx(sim.motors[1].position, abs=0.01)
        m.set_speed(0)


def test_the_asyncio_bus_runs_on_the_virtual_clock() -> None:
    async def main() -> tuple[float, float, float]:
        async with open_bus_async("sim", motors=[1, 2], clock="virtual", timeout=0.5, stop_on_close=False) as bus:
            t0 = bus.now()
            await bus.set_angles([1, 2], [90, -90], 20, 100, PositionMode.Q)
            done = await bus.positions_done([1, 2], timeout=10)
            assert [done[i].angle for i in (1, 2)] == pytest.approx([90, -90], abs=0.05)
            moved = bus.now() - t0
            bus.transport.bus.faults.silent.add(2)  # type: ignore[attr-defined]
            t1 = bus.now()
            with pytest.raises(drempower.TimeoutError, match="motor 2"):
                await bus.motor(2).get_state()
            with pytest.raises(drempower.TimeoutError):
                await bus.motor(1).wait_state(timeout=0.25)  # no heartbeats: nothing comes
            waited = bus.now() - t1
            t2 = bus.now()
            await bus._core.run_async(sleep(2.0))  # the driver's own entry point, not only the front end's
            assert bus.now() - t2 == pytest.approx(2.0)
            return moved, waited, t0

    wall = time.perf_counter()
    moved, waited, _ = asyncio.run(main())
    assert time.perf_counter() - wall < 0.5
    assert moved > 0.75  # 90 deg at 20 r/min takes 0.85 s of simulated time
    assert waited == pytest.approx(0.5 + 0.25)


def test_stop_on_close_and_estop_stop_the_motors() -> None:
    sim = SimBus(ids=[1, 2])
    rec = Recorder(sim)
    bus = drempower.open_bus("sim", bus=sim, clock="virtual")  # stop_on_close=True
    bus.motor(1).set_speed(30, 0, 1)
    bus.motor(2).set_angle(3000, 10, 100, PositionMode.Q)
    bus.run(sleep(0.5))
    assert sim.motors[1].speed == pytest.approx(30, abs=1) and sim.motors[2].speed > 5  # r/min: both move
    bus.motor(2).estop()
    with pytest.raises(drempower.MotorFaultError, match="ESTOP_REQUESTED"):
        bus.motor(2).wait_position_done(5)
    bus.close()
    assert bus.closed
    assert rec.frames[-2:] == idle_frames([1, 2])  # the stop frames went out on close
    sim.advance(1.0)
    held = sim.motors[1].position
    sim.advance(1.0)
    assert sim.motors[1].position == pytest.approx(held, abs=0.01)  # idle: it no longer turns


@pytest.mark.skipif(not hasattr(signal, "SIGHUP"), reason="POSIX signals")
@pytest.mark.usefixtures("_restore_handlers")
def test_sigterm_mid_move_stops_the_motor_and_ends_the_wait() -> None:
    """The signal arrives at a moment of simulated time, while the caller waits for the move."""
    calls: list[int] = []

    def own(signum: int, frame: FrameType | None) -> None:
        calls.append(signum)

    signal.signal(signal.SIGTERM, own)
    sim = SimBus(ids=[1])
    bus = drempower.open_bus("sim", bus=sim, clock="virtual")
    try:
        bus.motor(1).set_angle(720, 10, 100, PositionMode.Q)
        sim.schedule(sim.now + 1.0, lambda: os.kill(os.getpid(), signal.SIGTERM))
        with pytest.raises(BusClosedError):
            bus.motor(1).wait_position_done(20)
        assert calls == [signal.SIGTERM] and bus.closed
        stopped_at = sim.motors[1].position
        assert 30 < stopped_at < 90  # about 1 s into the move
        sim.advance(2.0)
        assert sim.motors[1].position == pytest.approx(stopped_at, abs=5.0)  # idle: it coasts, 120 deg short
    finally:
        bus.close()


def test_threads_share_one_virtual_clock_without_overshooting_each_others_deadlines() -> None:
    sim = SimBus(ids=[1, 2])
    with drempower.open_bus("sim", bus=sim, clock="virtual", stop_on_close=False) as bus:
        sim.faults.silent.add(2)
        results: dict[str, float] = {}
        errors: list[BaseException] = []
        go = threading.Barrier(2)

        def sleeper() -> None:
            go.wait(5)
            t0 = bus.now()
            bus.run(sleep(2.0))
            results["sleep"] = bus.now() - t0

        def asker() -> None:
            go.wait(5)
            t0 = bus.now()
            try:
                bus.motor(2).get_state(timeout=0.3)
            except drempower.TimeoutError:
                results["timeout"] = bus.now() - t0
            except BaseException as exc:
                errors.append(exc)

        threads = [threading.Thread(target=f) for f in (sleeper, asker)]
        for th in threads:
            th.start()
        for th in threads:
            th.join(10)
        assert errors == [] and not any(th.is_alive() for th in threads)
        assert results["sleep"] == pytest.approx(2.0, abs=0.06)
        assert results["timeout"] == pytest.approx(0.3, abs=0.06)  # not carried along to the sleeper's 2 s


def test_a_timed_bus_delivers_frames_at_their_simulated_times() -> None:
    """With a bit rate, frames take their time on the wire; replies arrive when their frames end."""
    sim = SimBus(ids=[1, 2, 3], bitrate=1_000_000)
    with drempower.open_bus("sim", bus=sim, clock="virtual", timeout=0.2, stop_on_close=False) as bus:
        t0 = bus.now()
        st = bus.motor(1).get_state()
        assert 100e-6 < st.timestamp - t0 < 1e-3  # a request and its reply: two frames at 1 Mbit/s
        bus.set_angles([1, 2, 3], [10, 20, 30], 30, 100, PositionMode.Q)
        done = bus.positions_done([1, 2, 3], timeout=5)
        assert [done[i].angle for i in (1, 2, 3)] == pytest.approx([10, 20, 30], abs=0.05)


def test_the_transport_receives_on_simulated_time() -> None:
    t = SimTransport([1], clock="virtual")
    try:
        wall = time.perf_counter()
        assert t.recv(0.5) is None
        assert t.now() == pytest.approx(0.5)
        assert time.perf_counter() - wall < 0.25  # of a 0.5 s wait
        assert t.wait_sent(0.1) is True  # instant delivery: nothing waits on the wire
    finally:
        t.close()


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"clock": "fast"}, r"clock='fast': must be one of 'wall', 'virtual'"),
        ({"clock": "virtual", "time_scale": 5}, r"time_scale=5: takes no value with clock='virtual'"),
        ({"ids": [1, 2]}, r"ids=\[1, 2\]: the simulated motors are given as motors= \(e.g. motors=\[1, 2\]\)"),
    ],
)
def test_bad_clock_options_are_refused(options: dict[str, object], message: str) -> None:
    with pytest.raises(drempower.ValidationError, match=message):
        SimTransport([1], **options)  # type: ignore[arg-type]
    with pytest.raises(TransportError, match=message):
        drempower.open_bus("sim", motors=[1], **options)


def test_a_bus_run_by_a_runner_cannot_also_run_on_the_virtual_clock() -> None:
    sim = SimBus(ids=[1])
    with SimRunner(sim, 1.0), pytest.raises(drempower.ValidationError, match="already run by a SimRunner"):
        SimTransport(bus=sim, clock="virtual")


def test_faults_act_on_simulated_time() -> None:
    """A reply late by 0.3 s answers a request with a timeout of 0.5 s, after exactly that delay."""
    sim = SimBus(ids=[1], faults=Faults(reply_delay=0.3))
    with drempower.open_bus("sim", bus=sim, clock="virtual", timeout=0.5, stop_on_close=False) as bus:
        t0 = bus.now()
        st = bus.motor(1).get_state()
        assert st.timestamp - t0 == pytest.approx(0.3)
        with pytest.raises(drempower.TimeoutError):
            bus.motor(1).read_property("axis0.error", timeout=0.2)
        assert bus.stats["unmatched"] == 0
        bus.run(sleep(0.2))  # the late reply arrives now, 0.6 s after t0: it answers nothing
        assert bus.stats["unmatched"] == 1
        assert bus.now() - t0 == pytest.approx(0.7)


def test_pass_time_takes_frames_until_its_condition() -> None:
    sim = SimBus(ids=[1], faults=Faults(reply_delay=0.3))
    with drempower.open_bus("sim", bus=sim, clock="virtual", timeout=0.1, stop_on_close=False) as bus:
        got: list[Frame] = []
        bus.on_unsolicited = got.append
        with pytest.raises(drempower.TimeoutError):
            bus.motor(1).read_property("axis0.error")
        t0 = bus.now()
        bus.pass_time(1.0, until=lambda: bool(got))
        assert len(got) == 1 and bus.now() - t0 == pytest.approx(0.2)  # the reply came 0.3 s after the read
        bus.pass_time(0.5)
        assert bus.now() - t0 == pytest.approx(0.7)


def test_compat_receive_data_waits_on_simulated_time() -> None:
    from drempower import compat

    bus = compat.open("sim", motors=[1], clock="virtual", timeout=1.0, faults=Faults(reply_delay=0.3))
    try:
        t0 = bus.now()
        compat.send_command(1, 0x1E, [0] * 8)  # a fast read by hand: its reply is 0.3 s late
        data = compat.receive_data()
        assert data is not None and compat.READ_FLAG == 1
        assert bus.now() - t0 == pytest.approx(0.3)
        assert compat.receive_data(timeout=0.25) is None and compat.READ_FLAG == -1
        assert bus.now() - t0 == pytest.approx(0.55)
    finally:
        compat.close()


def test_heartbeats_arrive_at_their_period_of_simulated_time() -> None:
    with drempower.open_bus("sim", motors=[1], clock="virtual", stop_on_close=False) as bus:
        m = bus.motor(1)
        m.write_property("can.config.heartbeat_ms", 100)
        seen: list[float] = []
        with m.subscribe(lambda st: seen.append(st.timestamp)):
            wall = time.perf_counter()
            first = m.wait_state(timeout=1.0)
            bus.run(sleep(1.0))
        assert time.perf_counter() - wall < 0.2
        assert seen[0] == first.timestamp
        gaps = [b - a for a, b in itertools.pairwise(seen)]
        assert len(gaps) >= 9 and gaps == pytest.approx([0.1] * len(gaps), abs=1e-3)
