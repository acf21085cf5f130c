"""The driver's ways of taking replies: callers reading the descriptor, the receive thread, the
instant simulator's replies taken in the send; several callers at once on one bus."""

from __future__ import annotations

import asyncio
import os
import select
import threading
import time
import tty
from collections.abc import Iterator

import pytest

import drempower
from drempower.client.driver import bus_driver as driver
from drempower.protocol import FastRead, State, encode_aa
from drempower.protocol.ids import Frame
from drempower.sim import SimBus, attach_adapter_pty
from drempower.transports.serial_adapter import AdapterTransport
from drempower.transports.sim import SimTransport

from ..links import link

IDS = [1, 2, 3, 4]
ROUNDS = 40


@pytest.fixture(params=[True, False], ids=["caller-reads", "receive-thread"])
def caller_reads(request: pytest.FixtureRequest, monkeypatch: pytest.MonkeyPatch) -> Iterator[bool]:
    monkeypatch.setattr(driver.BusDriver, "caller_reads", request.param)
    yield request.param


@pytest.mark.parametrize("kind", ["adapter", "uart", "inprocess", "inprocess-1M", "vclock-1M"])
def test_four_threads_get_their_own_motors_answers(kind: str, caller_reads: bool) -> None:
    ids = [1] if kind == "uart" else IDS  # a UART reaches one motor
    timed = kind.endswith("-1M")  # frames take their time on a 1 Mbit/s bus, delivered by the runner
    virtual = kind.startswith("vclock")  # ...or as the callers let the simulator's virtual time pass
    sim = SimBus(ids=ids, bitrate=1_000_000 if timed else None)
    scale = 1.0 if timed else 0 if kind == "inprocess" else 20.0
    where = "inprocess" if virtual else kind.split("-")[0]
    with link(where, sim, time_scale=scale, clock="virtual" if virtual else "wall", timeout=1.0) as bus:
        assert bus.virtual == virtual
        assert (bus._core._fd is not None) == (caller_reads and not virtual)
        errors: list[BaseException] = []
        seen: dict[int, list[int]] = {i: [] for i in range(4)}
        start = threading.Barrier(4)

        def worker(t: int) -> None:
            node = ids[t % len(ids)]
            m = bus.motor(node)
            try:
                start.wait(5)
                for _ in range(ROUNDS):
                    st = m.get_state()
                    seen[t].append(st.node)
                    seen[t].append(int(m.read_property("axis0.config.can_node_id")))
            except BaseException as exc:  # reported below
                errors.append(exc)

        threads = [threading.Thread(target=worker, args=(t,)) for t in range(4)]
        for th in threads:
            th.start()
        for th in threads:
            th.join(60)
        assert not any(th.is_alive() for th in threads)
        assert errors == []
        for t in range(4):
            assert seen[t] == [ids[t % len(ids)]] * (2 * ROUNDS)
        assert bus.stats["anomalies"] == 0


def test_four_coroutines_share_one_adapter_bus(caller_reads: bool) -> None:
    sim = SimBus(ids=IDS)
    pty = attach_adapter_pty(sim)
    try:

        async def main() -> list[list[int]]:
            async with drempower.open_bus_async("adapter", pty.path, timeout=1.0, stop_on_close=False) as abus:

                async def one(node: int) -> list[int]:
                    got = []
                    for _ in range(ROUNDS):
                        got.append((await abus.motor(node).get_state()).node)
                        got.append(int(await abus.motor(node).read_property("axis0.config.can_node_id")))
                    return got

                return list(await asyncio.gather(*(one(n) for n in IDS)))

        results = asyncio.run(main())
    finally:
        pty.close()
    assert results == [[n] * (2 * ROUNDS) for n in IDS]


def test_instant_simulator_answers_in_the_calling_thread() -> None:
    sim = SimBus(ids=[1])
    with link("inprocess", sim, time_scale=0, timeout=1.0) as bus:
        callers: list[int] = []
        bus.subscribe(lambda st: callers.append(threading.get_ident()), 1)
        st = bus.motor(1).get_state()
        assert st.node == 1
        # the reply was taken in the send: the state reached the subscriber in this thread, not the receive thread
        assert callers == [threading.get_ident()]


def _stray(transport: object) -> Frame:
    """Queue a state frame nobody asked for on the simulator ``transport``; returns it."""
    assert isinstance(transport, SimTransport)
    stray = State(1, 1.0, 0.0, 0.0, False, False).encode()._replace(arbitration_id=(1 << 5) | 0x1E)
    transport._deliver(stray)
    return stray


def test_late_frames_queued_before_a_send_are_taken_first() -> None:
    sim = SimBus(ids=[1])
    # on the virtual clock no receive thread runs: the frame waits in the queue until the send
    with link("inprocess", sim, clock="virtual", timeout=1.0) as bus:
        order: list[str] = []
        bus.on_unsolicited = lambda f: order.append("stray")
        bus.subscribe(lambda st: order.append("reply"), 1)
        _stray(bus.transport)
        assert bus.motor(1).get_state().node == 1
        assert order == ["stray", "reply"]  # taken before the reply to the request sent after it
        assert bus.stats["frames_received"] == 2


def test_a_late_frame_is_taken_once_whoever_takes_it() -> None:
    # on a wall clock the receive thread may take the frame before the send does: it reaches the hook once
    sim = SimBus(ids=[1])
    with link("inprocess", sim, time_scale=0, timeout=1.0) as bus:
        seen: list[Frame] = []
        got = threading.Event()
        bus.on_unsolicited = lambda f: (seen.append(f), got.set())
        stray = _stray(bus.transport)
        assert bus.motor(1).get_state().node == 1
        assert got.wait(2.0)
        assert seen == [stray]
        assert bus.stats["frames_received"] == 2


def _pty_adapter() -> tuple[AdapterTransport, int]:
    master, slave = os.openpty()
    tty.setraw(master)
    path = os.ttyname(slave)
    t = AdapterTransport(path, exclusive=False)
    os.close(slave)
    return t, master


def test_adapter_read_nowait_takes_what_is_there_and_keeps_a_partial_frame() -> None:
    t, master = _pty_adapter()
    try:
        fd = t.fileno()
        assert isinstance(fd, int)
        assert t.read_nowait() == []  # nothing there: no wait
        frame = State(3, 12.5, 1.0, -0.5, True, False).encode()
        raw = encode_aa(frame)
        os.write(master, raw + raw[:5])
        assert select.select([fd], [], [], 2.0)[0] == [fd]
        assert t.read_nowait() == [frame]
        os.write(master, raw[5:])
        assert select.select([fd], [], [], 2.0)[0] == [fd]
        assert t.read_nowait() == [frame]
    finally:
        t.close()
        os.close(master)


def test_a_caller_reading_the_descriptor_times_out_and_the_bus_still_works() -> None:
    t, master = _pty_adapter()
    bus = drempower.Bus(t, timeout=0.05, stop_on_close=False)
    try:
        with pytest.raises(drempower.TimeoutError):
            bus.motor(2).get_state()
        request = encode_aa(FastRead(2).encode())
        assert os.read(master, 64) == request  # the request went out once, and nothing else
        reply = encode_aa(State(2, 5.0, 0.0, 0.0, True, False).encode())

        def answer() -> None:
            if select.select([master], [], [], 2.0)[0]:
                os.read(master, 64)
                os.write(master, reply)

        th = threading.Thread(target=answer)
        th.start()
        assert bus.motor(2).get_state(timeout=2.0).angle == pytest.approx(5.0)
        th.join(5)
    finally:
        bus.close()
        os.close(master)


def test_frames_nobody_asked_for_reach_subscribers_through_the_receive_thread() -> None:
    t, master = _pty_adapter()
    bus = drempower.Bus(t, timeout=0.05, stop_on_close=False)
    try:
        got = threading.Event()
        states: list[tuple[int, int]] = []

        def seen(st: object) -> None:
            states.append((getattr(st, "node", 0), threading.get_ident()))
            got.set()

        bus.subscribe(seen, 4)
        with pytest.raises(drempower.TimeoutError):  # a caller read the descriptor just now
            bus.motor(4).get_state()
        os.write(master, encode_aa(State(4, 1.0, 0.0, 0.0, False, False).encode()))
        assert got.wait(2.0)
        assert states[0][0] == 4
        assert states[0][1] != threading.get_ident()  # the receive thread took it, no caller was waiting
    finally:
        bus.close()
        os.close(master)


def test_closing_the_bus_ends_a_caller_waiting_in_select() -> None:
    t, master = _pty_adapter()
    bus = drempower.Bus(t, timeout=30.0, stop_on_close=False)
    try:
        errors: list[BaseException] = []

        def wait() -> None:
            try:
                bus.motor(1).get_state()
            except BaseException as exc:  # reported below
                errors.append(exc)

        th = threading.Thread(target=wait)
        th.start()
        assert select.select([master], [], [], 2.0)[0]  # the request is out: the caller waits for its reply
        bus.close()
        th.join(2.0)
        assert not th.is_alive()
        assert len(errors) == 1 and isinstance(errors[0], drempower.BusClosedError)
    finally:
        bus.close()
        os.close(master)


def test_a_caller_that_found_the_receive_thread_reading_takes_over_when_it_is_done() -> None:
    """The receive thread is busy in a state callback when a call starts: once it is done it hands the
    reading over, so the reply that came meanwhile answers the call (no timeout)."""
    t, master = _pty_adapter()
    bus = drempower.Bus(t, timeout=1.0, stop_on_close=False)
    busy, release = threading.Event(), threading.Event()

    def slow(st: object) -> None:
        busy.set()
        release.wait(5.0)

    try:
        bus.subscribe(slow, 4)
        os.write(master, encode_aa(State(4, 1.0, 0.0, 0.0, False, False).encode()))
        assert busy.wait(2.0)  # the receive thread holds the reader role, inside the callback
        result: list[object] = []
        caller = threading.Thread(target=lambda: result.append(bus.motor(1).get_state()))
        started = time.monotonic()
        caller.start()
        request = encode_aa(FastRead(1).encode())
        seen = b""
        while request not in seen:  # the call's fast read reached the wire
            assert select.select([master], [], [], 2.0)[0]
            seen += os.read(master, 64)
        os.write(master, encode_aa(State(1, 7.0, 0.0, 0.0, True, False).encode()))
        release.set()
        caller.join(3.0)
        assert result and getattr(result[0], "angle", None) == 7.0
        assert time.monotonic() - started < 0.9  # answered, not woken by its 1 s deadline
    finally:
        release.set()
        bus.close()
        os.close(master)


def test_the_event_loop_keeps_the_reader_role_while_in_use_and_lets_it_go_when_idle() -> None:
    sim = SimBus(ids=[1])
    pty = attach_adapter_pty(sim)
    try:

        async def main() -> None:
            async with drempower.open_bus_async("adapter", pty.path, timeout=1.0, stop_on_close=False) as abus:
                core = abus._core
                for _ in range(5):
                    assert (await abus.motor(1).get_state()).node == 1
                    held = core._loop_reader
                    assert held is not None and held.loop is asyncio.get_running_loop()  # one registration, kept
                assert core._reader.locked()
                await asyncio.sleep(10 * driver._LINGER)
                assert core._loop_reader is None  # idle: the role is free again
                assert not core._reader.locked()
                # the receive thread reads again: a frame nobody asked for reaches the hook
                seen: list[Frame] = []
                got = threading.Event()
                abus.on_unsolicited = lambda f: (seen.append(f), got.set())
                stray = State(1, 1.0, 0.0, 0.0, False, False).encode()._replace(arbitration_id=(1 << 5) | 0x1E)
                sim.send(stray)
                assert await asyncio.to_thread(got.wait, 2.0)
                assert seen == [stray]

        asyncio.run(main())
    finally:
        pty.close()


def test_a_loop_closed_while_holding_the_reader_role_leaves_the_bus_usable() -> None:
    from drempower.client.engine.ops import fast_read

    sim = SimBus(ids=[1])
    pty = attach_adapter_pty(sim)
    try:
        holder: list[drempower.AsyncBus] = []

        async def first() -> None:
            abus = drempower.open_bus_async("adapter", pty.path, timeout=1.0, stop_on_close=False)
            holder.append(abus)
            assert (await abus.motor(1).get_state()).node == 1
            assert abus._core._loop_reader is not None  # still held when asyncio.run closes the loop

        asyncio.run(first())
        core = holder[0]._core
        try:
            t0 = time.monotonic()
            st = core.run(fast_read(1))  # a threaded caller: the receive thread reclaims the role
            assert st.node == 1
            assert time.monotonic() - t0 < 0.5
            assert core._loop_reader is None

            async def second() -> int:
                return (await holder[0].motor(1).get_state()).node  # another loop takes the role

            assert asyncio.run(second()) == 1
        finally:
            core.close()
    finally:
        pty.close()


def test_closing_from_a_worker_thread_unregisters_the_descriptor_in_the_loop_first() -> None:
    sims = [SimBus(ids=[1]), SimBus(ids=[2])]
    ptys = [attach_adapter_pty(s) for s in sims]
    try:

        async def main() -> list[int]:
            nodes = []
            for k, pty in enumerate(ptys):
                for _ in range(2):  # the second bus may get the first one's descriptor number
                    abus = drempower.open_bus_async("adapter", pty.path, timeout=1.0, stop_on_close=False)
                    nodes.append((await abus.motor(k + 1).get_state()).node)
                    await abus.close()  # in a worker thread, while this loop holds the role
                    assert abus._core._loop_reader is None
            return nodes

        assert asyncio.run(main()) == [1, 1, 2, 2]
    finally:
        for pty in ptys:
            pty.close()


@pytest.mark.parametrize("order", ["short-first", "long-first"])
def test_coroutines_of_one_loop_time_out_each_at_its_own_deadline(order: str) -> None:
    sim = SimBus(ids=[1])
    pty = attach_adapter_pty(sim)
    try:

        async def main() -> dict[float, float]:
            async with drempower.open_bus_async("adapter", pty.path, timeout=1.0, stop_on_close=False) as abus:
                assert (await abus.motor(1).get_state()).node == 1  # the loop takes the reader role
                t0 = time.monotonic()
                ended: dict[float, float] = {}

                async def silent(timeout: float) -> None:
                    with pytest.raises(drempower.TimeoutError):
                        await abus.motor(9).get_state(timeout=timeout)  # nobody answers at id 9
                    ended[timeout] = time.monotonic() - t0

                first, second = (0.1, 0.3) if order == "short-first" else (0.3, 0.1)
                await asyncio.gather(silent(first), silent(second))
                return ended

        ended = asyncio.run(main())
    finally:
        pty.close()
    assert 0.1 <= ended[0.1] < 0.29  # not held back by the other coroutine's later deadline
    assert 0.3 <= ended[0.3] < 0.45  # nor dropped when the earlier one's timer fired


def test_a_stopped_or_busy_loop_gives_the_reader_role_to_threads_that_need_it() -> None:
    from drempower.client.engine.ops import fast_read

    sim = SimBus(ids=[1])
    pty = attach_adapter_pty(sim)
    loop = asyncio.new_event_loop()
    try:
        abus = drempower.open_bus_async("adapter", pty.path, timeout=0.3, stop_on_close=False)
        core = abus._core
        assert loop.run_until_complete(abus.motor(1).get_state()).node == 1
        assert core._loop_reader is not None  # the loop stopped with the role

        def timed() -> float:
            t0 = time.monotonic()
            assert core.run(fast_read(1)).node == 1
            return time.monotonic() - t0

        assert timed() < 0.2  # this thread, the loop's own: takes the role back at once
        assert loop.run_until_complete(abus.motor(1).get_state()).node == 1
        took: list[float] = []
        worker = threading.Thread(target=lambda: took.append(timed()))
        worker.start()
        worker.join(5)
        assert took and took[0] < 0.2  # another thread, while the loop is stopped

        async def blocking_inside() -> float:
            await abus.motor(1).get_state()
            return timed()  # a blocking call from a coroutine: the loop cannot read meanwhile

        assert loop.run_until_complete(blocking_inside()) < 0.2
        assert loop.run_until_complete(abus.motor(1).get_state()).node == 1  # the loop takes it again
        core.close()
    finally:
        loop.close()
        pty.close()


def test_a_close_never_waits_for_a_busy_loop_and_its_descriptor_is_not_left_registered() -> None:
    sims = [SimBus(ids=[1]), SimBus(ids=[2])]
    ptys = [attach_adapter_pty(s) for s in sims]
    try:

        async def main() -> tuple[float, int]:
            loop = asyncio.get_running_loop()
            first = drempower.open_bus_async("adapter", ptys[0].path, timeout=1.0, stop_on_close=False)
            assert (await first.motor(1).get_state()).node == 1
            rd = first._core._loop_reader
            assert rd is not None
            registered = rd.fd
            took: list[float] = []

            def close_elsewhere() -> None:
                t0 = time.monotonic()
                first._core.close()
                took.append(time.monotonic() - t0)

            worker = threading.Thread(target=close_elsewhere)
            worker.start()
            time.sleep(0.3)  # the loop is blocked while the other thread closes the bus
            worker.join(5)
            second = drempower.open_bus_async("adapter", ptys[1].path, timeout=1.0, stop_on_close=False)
            node = (await second.motor(2).get_state()).node  # whatever descriptor number it got
            await asyncio.sleep(0)
            assert rd.fd == -1 and not loop.remove_reader(registered)  # unregistered in the loop, closed
            await second.close()
            return took[0], node

        took, node = asyncio.run(main())
        assert took < 0.2
        assert node == 2
    finally:
        for pty in ptys:
            pty.close()
