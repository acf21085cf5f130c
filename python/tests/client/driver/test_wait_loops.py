"""Each flavour of the driver's wait on its own: threaded (a caller reading the descriptor, or woken by
the receive thread), asyncio (the loop holding the reader role, or woken from another thread) and the
virtual clock. Each ends at its reply, times out at its deadline when no reply comes, and the asyncio
one never blocks its event loop."""

from __future__ import annotations

import asyncio
import itertools
import os
import select
import signal
import threading
import time
import tty
from collections.abc import Iterator
from contextlib import contextmanager

import pytest

import drempower
from drempower.client.driver import bus_driver as driver
from drempower.client.driver.wait_asyncio import AsyncWaits
from drempower.client.driver.wait_threaded import ThreadWaits, Wake
from drempower.client.driver.wait_virtual import VirtualWaits
from drempower.protocol import FastRead, State, encode_aa
from drempower.sim import SimBus, attach_adapter_pty
from drempower.transports.serial_adapter import AdapterTransport

WALL = ("receive-thread", "caller-reads", "adapter-receive-thread")
"""Buses on a wall clock: the in-process simulator at 1 Mbit/s in real time with every read left to the
receive thread, the adapter pty read by its callers, and the adapter pty read by the receive thread."""


@contextmanager
def wall_bus(
    kind: str, monkeypatch: pytest.MonkeyPatch, timeout: float = 1.0
) -> Iterator[tuple[drempower.Bus, SimBus]]:
    """A threaded bus of ``kind`` (see :data:`WALL`) on simulated motors 1 and 2, motor 2 silent."""
    monkeypatch.setattr(driver.BusDriver, "caller_reads", kind == "caller-reads")
    if kind == "receive-thread":
        sim = SimBus(ids=[1, 2], bitrate=1_000_000)
        sim.faults.silent.add(2)
        with drempower.open_bus("sim", bus=sim, time_scale=1.0, timeout=timeout, stop_on_close=False) as bus:
            yield bus, sim
        return
    sim = SimBus(ids=[1, 2])
    sim.faults.silent.add(2)
    pty = attach_adapter_pty(sim)
    try:
        with drempower.open_bus("adapter", pty.path, timeout=timeout, stop_on_close=False) as bus:
            yield bus, sim
    finally:
        pty.close()


def _pty_adapter() -> tuple[AdapterTransport, int]:
    master, slave = os.openpty()
    tty.setraw(master)
    t = AdapterTransport(os.ttyname(slave), exclusive=False)
    os.close(slave)
    return t, master


# ---------------------------------------------------------------------- threaded


def test_a_wake_is_one_shot_idempotent_and_bounded() -> None:
    w = Wake()
    t0 = time.monotonic()
    w.wait(0.05)  # not set: the whole timeout
    assert time.monotonic() - t0 >= 0.04
    w.set()
    w.set()  # a second wake-up before the wait is the same one
    t0 = time.monotonic()
    w.wait(5.0)
    assert time.monotonic() - t0 < 0.5  # set: at once
    t0 = time.monotonic()
    w.wait(0.05)  # the wait cleared it
    assert time.monotonic() - t0 >= 0.04
    threading.Timer(0.05, w.set).start()  # from another thread
    t0 = time.monotonic()
    w.wait(5.0)
    assert time.monotonic() - t0 < 2.0


@pytest.mark.parametrize("kind", WALL)
def test_threaded_wait_ends_at_the_reply_and_times_out_at_the_deadline(
    kind: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    with wall_bus(kind, monkeypatch, timeout=5.0) as (bus, _):
        assert isinstance(bus._core._waits, ThreadWaits)
        assert (bus._core._fd is not None) == (kind == "caller-reads")
        for _ in range(3):
            t0 = time.monotonic()
            assert bus.motor(1).get_state().node == 1
            assert time.monotonic() - t0 < 0.5  # woken by its reply, not by a slice of its 5 s timeout
        t0 = time.monotonic()
        with pytest.raises(drempower.TimeoutError, match="motor 2"):
            bus.motor(2).get_state(timeout=0.3)
        took = time.monotonic() - t0
        assert 0.3 <= took < 0.8
        assert bus.motor(1).get_state().node == 1  # the bus still works


@pytest.mark.parametrize("kind", WALL)
def test_threaded_waits_of_several_threads_each_end_at_their_own_deadline(
    kind: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    with wall_bus(kind, monkeypatch) as (bus, _):
        ended: dict[float, float] = {}
        t0 = time.monotonic()

        def silent(timeout: float) -> None:
            with pytest.raises(drempower.TimeoutError):
                bus.motor(2).get_state(timeout=timeout)
            ended[timeout] = time.monotonic() - t0

        threads = [threading.Thread(target=silent, args=(t,)) for t in (0.4, 0.15)]
        for th in threads:
            th.start()
        got = [bus.motor(1).get_state().node for _ in range(5)]  # meanwhile this thread is answered
        for th in threads:
            th.join(5)
        assert got == [1] * 5
        assert 0.15 <= ended[0.15] < 0.38  # not held back by the later deadline
        assert 0.4 <= ended[0.4] < 0.8


@pytest.mark.parametrize("kind", WALL)
def test_ctrl_c_in_a_threaded_wait_leaves_nothing_waiting(kind: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """A real SIGINT interrupts the wait at once (in ``select`` or asleep), and the interrupted request
    is cancelled: the next request to that motor does not queue behind it for its 5 s."""

    def ctrl_c() -> None:
        signal.pthread_kill(threading.main_thread().ident or 0, signal.SIGINT)

    with wall_bus(kind, monkeypatch, timeout=5.0) as (bus, sim):
        timer = threading.Timer(0.1, ctrl_c)
        t0 = time.monotonic()
        timer.start()
        with pytest.raises(KeyboardInterrupt):
            bus.motor(2).get_state()  # silent: would wait 5 s
        assert time.monotonic() - t0 < 2.0
        timer.join()
        sim.faults.silent.discard(2)
        t0 = time.monotonic()
        assert bus.motor(2).get_state().node == 2
        assert time.monotonic() - t0 < 1.0
        t0 = time.monotonic()
        assert bus.motor(1).get_state().node == 1
        assert time.monotonic() - t0 < 1.0


def test_threaded_pass_time_sleeps_its_time_unless_its_condition_or_a_close_ends_it(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    with wall_bus("receive-thread", monkeypatch) as (bus, _):
        core = bus._core
        t0 = time.monotonic()
        core.pass_time(0.2)
        assert 0.2 <= time.monotonic() - t0 < 0.6
        seen: list[int] = []
        bus.subscribe(lambda st: seen.append(st.node), 1)
        threading.Timer(0.05, lambda: bus.motor(1).get_state()).start()
        t0 = time.monotonic()
        core.pass_time(5.0, until=lambda: bool(seen))  # the state taken by the receive thread ends it
        assert seen == [1] and time.monotonic() - t0 < 2.0
        threading.Timer(0.05, core.close).start()
        t0 = time.monotonic()
        core.pass_time(5.0)
        assert core.closed and time.monotonic() - t0 < 2.0


# ---------------------------------------------------------------------- asyncio


@pytest.mark.parametrize("kind", WALL)
def test_asyncio_wait_leaves_the_event_loop_free_and_times_out_at_the_deadline(
    kind: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(driver.BusDriver, "caller_reads", kind == "caller-reads")
    sim = SimBus(ids=[1, 2], bitrate=1_000_000 if kind == "receive-thread" else None)
    sim.faults.silent.add(2)
    pty = attach_adapter_pty(sim) if kind != "receive-thread" else None

    async def main() -> tuple[float, float]:
        if pty is None:
            abus = drempower.open_bus_async("sim", bus=sim, time_scale=1.0, timeout=1.0, stop_on_close=False)
        else:
            abus = drempower.open_bus_async("adapter", pty.path, timeout=1.0, stop_on_close=False)
        async with abus:
            assert (await abus.motor(1).get_state()).node == 1
            assert isinstance(abus._core._run_async.__self__, AsyncWaits)  # type: ignore[union-attr]
            threads = threading.active_count()
            ticks: list[float] = []
            stop = asyncio.Event()

            async def ticker() -> None:
                while not stop.is_set():
                    await asyncio.sleep(0.01)
                    ticks.append(time.monotonic())

            t0 = time.monotonic()
            tick = asyncio.create_task(ticker())
            with pytest.raises(drempower.TimeoutError, match="motor 2"):
                await abus.motor(2).get_state(timeout=0.5)
            t1 = time.monotonic()
            stop.set()
            await tick
            nodes = [(await abus.motor(1).get_state()).node for _ in range(20)]
            assert nodes == [1] * 20
            assert threading.active_count() == threads  # no thread per call
            times = [t0, *(t for t in ticks if t < t1), t1]
            return t1 - t0, max(b - a for a, b in itertools.pairwise(times))

    try:
        took, gap = asyncio.run(main())
    finally:
        if pty is not None:
            pty.close()
    assert 0.5 <= took < 0.9
    assert gap < 0.25  # the loop ran other tasks all along (blocked while waiting, it would skip 0.5 s)


def test_a_coroutine_takes_the_reader_role_for_its_loop_once_the_receive_thread_is_done() -> None:
    """The receive thread is busy in a state callback when the call starts: the coroutine is woken when
    the role is free, registers its loop as the reader, and its reply answers the call (no timeout)."""
    t, master = _pty_adapter()
    abus = drempower.AsyncBus(t, timeout=1.0, stop_on_close=False)
    busy, release = threading.Event(), threading.Event()

    def slow(st: object) -> None:
        busy.set()
        release.wait(5.0)

    def motor() -> None:
        request, seen = encode_aa(FastRead(1).encode()), b""
        while request not in seen:  # the call's fast read reached the wire
            if not select.select([master], [], [], 2.0)[0]:
                return
            seen += os.read(master, 64)
        os.write(master, encode_aa(State(1, 7.0, 0.0, 0.0, True, False).encode()))
        release.set()

    async def main() -> tuple[bool, float, float, bool]:
        abus.subscribe(slow, 4)
        os.write(master, encode_aa(State(4, 1.0, 0.0, 0.0, False, False).encode()))
        assert await asyncio.to_thread(busy.wait, 2.0)  # the receive thread holds the role, in the callback
        free = abus._core._loop_reader is None  # not yet taken by the loop
        answer = threading.Thread(target=motor)
        answer.start()
        t0 = time.monotonic()
        st = await abus.motor(1).get_state()
        took = time.monotonic() - t0
        answer.join(5)
        rd = abus._core._loop_reader
        return free, st.angle, took, rd is not None and rd.loop is asyncio.get_running_loop()

    try:
        free, angle, took, held = asyncio.run(main())
    finally:
        release.set()
        abus._core.close()
        os.close(master)
    assert free and angle == 7.0
    assert took < 0.9  # answered, not woken by its 1 s deadline
    assert held  # the loop took the role for the calls that follow


# ---------------------------------------------------------------------- virtual clock


def test_virtual_wait_lets_time_pass_exactly_to_the_replys_arrival() -> None:
    sim = SimBus(ids=[1], bitrate=1_000_000)
    with drempower.open_bus("sim", bus=sim, clock="virtual", timeout=0.2, stop_on_close=False) as bus:
        core = bus._core
        assert isinstance(core._waits, VirtualWaits)
        for _ in range(3):
            t0 = core.now()
            st = bus.motor(1).get_state()
            assert st.timestamp == core.now()  # the wait stopped as the reply arrived, not a slice later
            assert 100e-6 < st.timestamp - t0 < 1e-3  # a request and its reply: two frames at 1 Mbit/s


@pytest.mark.parametrize("timeout", [0.013, 0.37])
def test_virtual_wait_for_a_missing_reply_ends_exactly_at_its_deadline(timeout: float) -> None:
    with drempower.open_bus("sim", motors=[1, 2], clock="virtual", stop_on_close=False) as bus:
        bus.transport.bus.faults.silent.add(2)  # type: ignore[attr-defined]
        core = bus._core
        wall, t0 = time.monotonic(), core.now()
        with pytest.raises(drempower.TimeoutError, match="motor 2"):
            bus.motor(2).get_state(timeout=timeout)
        assert core.now() - t0 == pytest.approx(timeout, abs=1e-6)  # not rounded up to a step of 50 ms
        assert time.monotonic() - wall < 0.5


def test_virtual_wait_from_a_coroutine_runs_inside_the_call() -> None:
    async def main() -> tuple[float, float]:
        async with drempower.open_bus_async("sim", motors=[1, 2], clock="virtual", stop_on_close=False) as abus:
            abus.transport.bus.faults.silent.add(2)  # type: ignore[attr-defined]
            core = abus._core
            t0, wall = core.now(), time.monotonic()
            with pytest.raises(drempower.TimeoutError, match="motor 2"):
                await abus.motor(2).get_state(timeout=0.5)
            return core.now() - t0, time.monotonic() - wall

    simulated, wall = asyncio.run(main())
    assert simulated == pytest.approx(0.5, abs=1e-6)
    assert wall < 0.4
