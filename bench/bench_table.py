#!/usr/bin/env python3
"""The speed table in one run: every figure beside its floor, measured on this machine now.

Run: ``python3 bench/bench_table.py [--requests N] [--seconds S] [--rows GROUP,...]``. Prints figures;
asserts nothing. ``--rows`` picks groups of rows (adapter, python-can, inprocess, codec, cycle, idle,
import; all by default).

Rows (the floor of each in brackets):

1. ``get_state`` median over the simulator's USB-CAN adapter pty (0xAA), threaded
   client [a minimal client doing ``os.write`` / ``select`` / ``os.read`` on the same pty];
2. the same through the asyncio client [the same raw floor]; rows 1 and 2 are also measured with
   the simulators (the client's and the floor's) each in a process of its own, as an adapter is its
   own device: then they do not share the client's interpreter lock;
3. ``get_state`` over python-can's ``virtual`` bus and over ``socketcand`` on 127.0.0.1,
   drempower's client and python-can's (``python-can:socketcand``) [bare python-can doing the same
   exchange, send the fast read and receive the reply, on the same interface with the same kind of
   simulator peer], and over slcan on the simulated adapter's pty,
   drempower's reader and python-can's (``python-can:slcan``) [the raw pty client writing the slcan
   line and reading the answer and reply lines]: wall time and CPU time per call (the process's,
   every thread: the peers' too), and drempower's transport alone doing the exchange (send,
   ``select``, ``read_nowait``; no client) beside the same floor, so that what the client adds shows;
   slcan and socketcand are also measured with the simulators (the client's and the floor's) each in a
   process of its own, as an slcan adapter or a socketcand server is (wall time: the process's CPU would
   no longer count the peers');
4. ``get_state`` through the in-process simulator with instant delivery [the
   simulated bus answering the fast read by itself: ``SimBus.send``], in alternating blocks; and how
   often Python's cycle collector ran during 10 000 requests [as many ``SimBus.send``];
5. codec: encode + decode of one frame, a mix of commands and replies [the same
   ``struct`` pack/unpack on plain tuples, without validation];
6. the 0xAA stream decoder, per frame [cutting the frames out of the stream with no checks];
7. ``bus.cycle`` of one motor with reply-state on, on the simulator's 1 Mbit/s
   timing model run in 20 us steps [the bus limit: 1 Mbit/s over the bits one cycle puts on the wire;
   and a minimal client on the same clock, which hands the encoded command to the simulator's
   transport and waits in ``select`` for the state: no client library];
8. wake-ups per second of the receive thread of an idle open bus, adapter and UART
   ptys [a thread blocked in ``select`` with no timeout];
9. CPU time of ``import drempower`` in a fresh interpreter [``python -c pass``].

Row 7's clock is a thread that advances the simulated bus to the wall time every 20 us (less often
where a short ``sleep`` wakes late); the motors answer at once. A frame the client sends starts at
the simulated time of the clock's last step, and a reply reaches the client at the first step after
its last bit. So the figure counts the steps a cycle spans: the client's own time between a reply
and its next command counts only when the clock steps meanwhile (it runs while the client waits or
releases the interpreter lock). The minimal client shows what this model leaves of the bus limit for
any client, and ``bus.cycle`` is also printed against it (blocks alternate as in rows 1 and 2).

Rows 1-4 alternate blocks of the client with blocks of the floor; their ratio is the median
of the blocks' ratios (a shared machine's load changes within a run). Rows 1, 2 and 7 are also
measured with callers leaving every read to the receive thread (``BusDriver.caller_reads =
False``), the way replies reached callers before.
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import gc
import json
import os
import platform
import select
import statistics
import struct
import subprocess
import sys
import threading
import time
import timeit
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent
# the drempower source tree measured: this checkout's, or another's in DREMPOWER_SRC (bench_against.py)
SRC = Path(os.environ.get("DREMPOWER_SRC") or HERE.parent / "python" / "src")
sys.path.insert(0, str(SRC))
sys.path.insert(0, str(HERE))

import bench_client  # noqa: E402  (the client links, the raw pty floor, the fine simulated clock, the cycle's bits)
import bench_idle  # noqa: E402  (import CPU time, wake-up counting)
import can  # noqa: E402
from bench_client import RawFloor  # noqa: E402

import drempower  # noqa: E402

try:  # the client in its rooms; a tree before them (bench_against.py) has the driver as one module
    from drempower.client.driver.bus_driver import BusDriver
except ImportError:
    from drempower.client.driver import BusDriver  # type: ignore[attr-defined,no-redef]
from drempower.protocol import (  # noqa: E402
    AADecoder,
    DataType,
    FastRead,
    Frame,
    ParamValue,
    PositionQ,
    PositionT,
    ReadParam,
    State,
    Velocity,
    VelocityMode,
    WriteParam,
    decode_command,
    decode_reply,
    encode_aa,
)
from drempower.sim import (  # noqa: E402
    SimBus,
    attach_adapter_pty,
    attach_python_can,
    attach_socketcand,
    attach_uart_pty,
)
from drempower.transports import Transport, open_transport  # noqa: E402
from drempower.transports.sim import SimTransport  # noqa: E402

ROWS: list[tuple[str, str, str, str]] = []


def row(measure: str, figure: str, floor: str, ratio: str) -> None:
    ROWS.append((measure, figure, floor, ratio))
    print(f"  {measure:<52} {figure:>14}   floor {floor:>12}   {ratio}", flush=True)


def best(fn: Callable[[], object], items: int, seconds: float, repeat: int = 5) -> float:
    """Best of ``repeat`` timed runs, in seconds per item."""
    timer = timeit.Timer(fn)
    loops, _ = timer.autorange()
    loops = max(1, int(loops * seconds / repeat / 0.2))
    return min(timer.repeat(repeat=repeat, number=loops)) / loops / items


@contextlib.contextmanager
def sim_process() -> Iterator[str]:
    """A simulator of motor 1 in its own process (``drempower sim --adapter-pty``), as an adapter is its
    own device; yields the adapter pty's path."""
    with sim_attachment("--adapter-pty") as info:
        yield str(info["path"])


@contextlib.contextmanager
def sim_attachment(*options: str) -> Iterator[dict[str, Any]]:
    """A simulator of motor 1 in its own process (``drempower sim OPTIONS``); yields what it printed of
    its attachment (``path``, or ``host`` and ``port``)."""
    cmd = [sys.executable, "-m", "drempower", "sim", *options, "--json"]
    env = {**os.environ, "PYTHONPATH": str(SRC)}
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, text=True, env=env)
    try:
        attachment: dict[str, Any] | None = None
        assert proc.stdout is not None
        for line in proc.stdout:
            info = json.loads(line)
            if "attachment" in info:
                attachment = info
            if info.get("running"):
                break
        if attachment is None:
            raise RuntimeError(f"the simulator process gave no attachment ({' '.join(options)})")
        yield attachment
    finally:
        proc.terminate()
        proc.wait(5)


ROUNDS = 20
"""The floor and the client are measured in alternating blocks, so that a change of the machine's
load during the run moves both; the ratio printed is the median of the blocks' ratios."""


def _timed(fn: Callable[[], object], n: int, out: list[float]) -> None:
    for _ in range(n):
        t0 = time.perf_counter()
        fn()
        out.append(time.perf_counter() - t0)


async def _timed_async(fn: Callable[[], Any], n: int, out: list[float]) -> None:
    for _ in range(n):
        t0 = time.perf_counter()
        await fn()
        out.append(time.perf_counter() - t0)


def _ratio(client: list[list[float]], floor: list[list[float]]) -> tuple[float, float, float]:
    """Overall medians (us) of the floor and the client, and the median over the blocks of the
    client's median over the floor's median in the block beside it (steady under a changing load)."""
    per_block = [statistics.median(c) / statistics.median(f) for c, f in zip(client, floor, strict=True)]
    flat_f = [x for b in floor for x in b]
    flat_c = [x for b in client for x in b]
    return statistics.median(flat_f) * 1e6, statistics.median(flat_c) * 1e6, statistics.median(per_block)


def adapter_latency(n: int, own_process: bool = False) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
    """(floor us, get_state us, ratio) over the adapter pty, threaded and asyncio (see :func:`_ratio`);
    with ``own_process`` the client's and the floor's simulators each run in a process of their own."""
    with contextlib.ExitStack() as stack:
        if own_process:
            path, floor = stack.enter_context(sim_process()), RawFloor("adapter", stack.enter_context(sim_process()))
        else:
            pty = attach_adapter_pty(SimBus(ids=[1]))
            stack.callback(pty.close)
            path, floor = pty.path, RawFloor("adapter")
        stack.callback(floor.close)
        return _adapter_latency(n, path, floor)


def _adapter_latency(
    n: int, path: str, floor: RawFloor
) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
    block = max(1, n // ROUNDS)
    f_sync: list[list[float]] = []
    sync: list[list[float]] = []
    f_async: list[list[float]] = []
    asy: list[list[float]] = []
    with drempower.open_bus("adapter", path, timeout=1.0, stop_on_close=False) as bus:
        get = bus.motor(1).get_state
        _timed(get, 50, [])
        _timed(floor, 50, [])
        for _ in range(ROUNDS):
            f_sync.append([])
            sync.append([])
            _timed(floor, block, f_sync[-1])
            _timed(get, block, sync[-1])

    async def run_async() -> None:
        async with drempower.open_bus_async("adapter", path, timeout=1.0, stop_on_close=False) as abus:
            aget = abus.motor(1).get_state
            await _timed_async(aget, 50, [])
            for _ in range(ROUNDS):
                f_async.append([])
                asy.append([])
                _timed(floor, block, f_async[-1])
                await _timed_async(aget, block, asy[-1])

    asyncio.run(run_async())
    return _ratio(sync, f_sync), _ratio(asy, f_async)


def adapter_rows(n: int) -> None:
    sync, asy = adapter_latency(n)
    own_sync, own_asy = adapter_latency(n, own_process=True)
    BusDriver.caller_reads = False
    try:
        sync_rx, asy_rx = adapter_latency(n)
    finally:
        BusDriver.caller_reads = True
    for label, (fl, got, ratio) in (
        ("get_state, adapter pty (0xAA), threaded", sync),
        ("get_state, adapter pty (0xAA), asyncio", asy),
        ("  threaded, simulator in its own process", own_sync),
        ("  asyncio, simulator in its own process", own_asy),
        ("  threaded, receive thread + event handoff", sync_rx),
        ("  asyncio, receive thread + call_soon_threadsafe", asy_rx),
    ):
        row(label, f"{got:.0f} us", f"{fl:.0f} us", f"{ratio:.2f}x floor")


def inprocess(n: int) -> None:
    sim = SimBus(ids=[1])
    bare = SimBus(ids=[1])
    bare.add_listener(lambda f: None)
    request = FastRead(1).encode()
    with drempower.open_bus("sim", bus=sim, time_scale=0, timeout=1.0, stop_on_close=False) as bus:
        wall, _ = alternate(lambda: bare.send(request), bus.motor(1).get_state, n=max(n, 20 * ROUNDS))[0]
    floor, inproc, ratio = wall
    row("get_state, in-process simulator", f"{inproc:.1f} us", f"{floor:.1f} us", f"{ratio:.1f}x")
    with drempower.open_bus("sim", bus=SimBus(ids=[1]), time_scale=0, timeout=1.0, stop_on_close=False) as bus:
        m = bus.motor(1)
        ours = collections_during(lambda: (m.get_state(), m.get_volcur()), COLLECTED_REQUESTS // 2)
    sends = collections_during(lambda: bare.send(request), COLLECTED_REQUESTS)
    row(
        f"  cycle collector runs in {COLLECTED_REQUESTS} requests (get_state, get_volcur)",
        f"{ours} runs",
        f"{sends} runs",
        "(each run pauses the caller; floor: as many SimBus.send)",
    )


COLLECTED_REQUESTS = 10_000
"""Requests over which the cycle collector's runs are counted (after a warm-up)."""


def collections_during(fn: Callable[[], object], n: int) -> int:
    """How often Python's cycle collector ran (any generation) during ``n`` calls of ``fn``."""
    for _ in range(50):
        fn()
    gc.collect()
    runs = [0]

    def count(phase: str, info: dict[str, int]) -> None:
        if phase == "start":
            runs[0] += 1

    gc.callbacks.append(count)
    try:
        for _ in range(n):
            fn()
    finally:
        gc.callbacks.remove(count)
    return runs[0]


class BareCan:
    """Bare python-can doing the client's exchange: send the fast read, receive the reply."""

    def __init__(self, **config: Any) -> None:
        self.bus = can.Bus(**config)
        frame = FastRead(1).encode()
        self.msg = can.Message(arbitration_id=frame.arbitration_id, data=frame.data, is_extended_id=False)

    def __call__(self) -> None:
        self.bus.send(self.msg)
        if self.bus.recv(1.0) is None:
            raise TimeoutError("no reply through python-can")

    def close(self) -> None:
        self.bus.shutdown()


@contextlib.contextmanager
def python_can_floor(kind: str) -> Iterator[Callable[[], None]]:
    """The floor of link ``kind``, on a simulator of its own: bare python-can on the same interface with
    the same kind of peer (``virtual``, ``socketcand``), or the raw pty client (``slcan``)."""
    sim = SimBus(ids=[1])
    with contextlib.ExitStack() as stack:
        floor: BareCan | RawFloor
        if kind == "virtual":
            channel = f"drempower-bench-floor-{os.getpid()}"
            stack.callback(attach_python_can(sim, channel=channel).close)
            floor = BareCan(interface="virtual", channel=channel)
        elif kind in ("socketcand", "python-can:socketcand"):
            server = attach_socketcand(sim)
            stack.callback(server.close)
            floor = BareCan(interface="socketcand", channel="can0", host=server.host, port=server.port)
        else:
            floor = RawFloor("slcan")
        stack.callback(floor.close)
        yield floor


def alternate(
    floor: Callable[[], object], *others: Callable[[], object], n: int
) -> list[tuple[tuple[float, float, float], tuple[float, float, float]]]:
    """Blocks of ``floor`` and each of ``others`` in turn: for each of ``others``, (floor us, its us, ratio)
    of the wall time per call (see :func:`_ratio`) and of the process's CPU time per call (every thread:
    the peers' too)."""
    block = max(1, n // ROUNDS)
    fns = (floor, *others)
    for fn in fns:
        _timed(fn, 50, [])
    walls: list[list[list[float]]] = [[] for _ in fns]
    cpus: list[list[float]] = [[] for _ in fns]
    for _ in range(ROUNDS):
        for fn, wall, cpu in zip(fns, walls, cpus, strict=True):
            wall.append([])
            t0 = time.process_time()
            _timed(fn, block, wall[-1])
            cpu.append((time.process_time() - t0) / block)
    out = []
    for wall, cpu in zip(walls[1:], cpus[1:], strict=True):
        per_block = statistics.median(c / f for c, f in zip(cpu, cpus[0], strict=True))
        out.append(
            (_ratio(wall, walls[0]), (statistics.median(cpus[0]) * 1e6, statistics.median(cpu) * 1e6, per_block))
        )
    return out


def transport_alone(t: Transport) -> Callable[[], None]:
    """drempower's transport alone doing the exchange, no client: send the fast read, wait in ``select`` on
    its descriptor and ``read_nowait`` until a frame is there (``recv`` on a transport without one)."""
    request = FastRead(1).encode()
    fd = t.fileno()

    def exchange() -> None:
        t.send(request)
        if fd is None:
            if t.recv(1.0) is None:
                raise TimeoutError("no reply through the transport")
            return
        while True:
            if not select.select([fd], [], [], 1.0)[0]:
                raise TimeoutError("no reply through the transport")
            if t.read_nowait():
                return

    return exchange


PYTHON_CAN = (
    ("virtual", "python-can virtual", "bare python-can"),
    ("socketcand", "socketcand, 127.0.0.1 (drempower's client)", "bare python-can"),
    ("python-can:socketcand", "socketcand, 127.0.0.1 (python-can's)", "bare python-can"),
    ("slcan", "slcan pty (drempower's reader)", "raw pty"),
    ("python-can:slcan", "slcan pty (python-can:slcan)", "raw pty"),
)
"""The links of the python-can rows: (link of ``bench_client.link``, label, what the floor is)."""


def python_can(n: int) -> None:
    for kind, label, what in PYTHON_CAN:
        with (
            bench_client.link(kind, SimBus(ids=[1])) as bus,
            bench_client.endpoint(kind, SimBus(ids=[1])) as t,
            python_can_floor(kind) as floor,
        ):
            client, alone = alternate(floor, bus.motor(1).get_state, transport_alone(t), n=n)
        (fw, cw, rw), (fc, cc, rc) = client
        row(f"get_state, {label}", f"{cw:.0f} us", f"{fw:.0f} us", f"{rw:.2f}x {what}")
        row("  CPU per call (every thread)", f"{cc:.0f} us", f"{fc:.0f} us", f"{rc:.2f}x {what}")
        (fw, cw, rw), (fc, cc, rc) = alone
        row("  the transport alone, no client: wall", f"{cw:.0f} us", f"{fw:.0f} us", f"{rw:.2f}x {what}")
        row("  the transport alone: CPU per call", f"{cc:.0f} us", f"{fc:.0f} us", f"{rc:.2f}x {what}")
        if kind in ("slcan", "socketcand"):
            fw, cw, rw = own_process(kind, n)
            row("  wall, simulators in processes of their own", f"{cw:.0f} us", f"{fw:.0f} us", f"{rw:.2f}x {what}")


def own_process(kind: str, n: int) -> tuple[float, float, float]:
    """(floor us, get_state us, ratio) of the wall time over ``kind`` (``slcan`` or ``socketcand``) with
    the client's and the floor's simulators each in a process of its own, as an slcan adapter or a
    socketcand server is (see :func:`_ratio`)."""
    with contextlib.ExitStack() as stack:
        floor: BareCan | RawFloor
        if kind == "slcan":
            floor = RawFloor("slcan", stack.enter_context(sim_process()))
            stack.callback(floor.close)
            t = open_transport("slcan", stack.enter_context(sim_process()), bench_client.BITRATE, sleep_after_open=0)
        else:
            server = stack.enter_context(sim_attachment("--socketcand-port", "0"))
            floor = BareCan(interface="socketcand", channel="can0", host=server["host"], port=server["port"])
            stack.callback(floor.close)
            ours = stack.enter_context(sim_attachment("--socketcand-port", "0"))
            t = open_transport("socketcand", "can0", host=ours["host"], port=ours["port"])
        stack.callback(t.close)
        bus = stack.enter_context(drempower.open_bus(transport=t, timeout=1.0, stop_on_close=False))
        return alternate(floor, bus.motor(1).get_state, n=n)[0][0]


def codec(seconds: float) -> None:
    msgs = [
        PositionT(1, 90.0, 10.0),
        PositionQ(2, -150.0, 10.0, 5.0),
        Velocity(4, 20.0, 1.5, VelocityMode.PASSTHROUGH),
        ReadParam(7, 38007, DataType.F32),
        WriteParam(8, 31214, DataType.U32, 1),
        FastRead(9),
    ]
    replies = [State(1, 90.0, 1.5, -0.25, True, False), ParamValue(7, 38007, DataType.F32, -92.5)]
    n = len(msgs) + len(replies)

    def pair() -> None:
        for m in msgs:
            f = m.encode()
            decode_command(f.arbitration_id, f.data)
        for r in replies:
            f = r.encode()
            decode_reply(f.arbitration_id, f.data)

    fss = struct.Struct("<fhh")
    pack, unpack = fss.pack, fss.unpack
    values = [(m.node, 0x1A, -150.0, 10.0, 5.0) for m in msgs + replies]  # type: ignore[operator]

    def floor_pair() -> None:
        for node, cmd, a, b, c in values:
            f = ((node << 5) | cmd, pack(a, round(b * 100), round(c * 100)))
            p, v, t = unpack(f[1])
            (f[0] >> 5, p, v / 100, t / 100)

    cost, fl = best(pair, n, seconds), best(floor_pair, n, seconds)
    row("codec: encode + decode, one frame (mix)", f"{cost * 1e6:.2f} us", f"{fl * 1e6:.2f} us", f"{cost / fl:.1f}x")

    frames = [r.encode() for r in replies] + [m.encode() for m in msgs]
    stream = b"".join(encode_aa(f) for f in frames) * 16
    count = 16 * len(frames)
    frame_new = tuple.__new__

    def floor_aa() -> None:
        for i in range(0, len(stream), 16):
            frame_new(Frame, ((stream[i + 6] << 8) | stream[i + 7], stream[i + 8 : i + 16], False, False))

    one = [encode_aa(f) for f in frames]
    dec = AADecoder()

    def each() -> None:
        for chunk in one:
            dec.feed(chunk)

    def floor_each() -> None:
        for chunk in one:
            for i in range(0, len(chunk), 16):
                frame_new(Frame, ((chunk[i + 6] << 8) | chunk[i + 7], chunk[i + 8 : i + 16], False, False))

    s, fs = best(lambda: AADecoder().feed(stream), count, seconds), best(floor_aa, count, seconds)
    row("0xAA stream decoder, 128 frames a feed", f"{s * 1e6:.2f} us/frame", f"{fs * 1e6:.2f} us", f"{s / fs:.1f}x")
    e, fe = best(each, len(one), seconds), best(floor_each, len(one), seconds)
    row("0xAA stream decoder, one frame a feed", f"{e * 1e6:.2f} us/frame", f"{fe * 1e6:.2f} us", f"{e / fe:.1f}x")


class FineClock(bench_client.FineClock):
    """Runs the simulated bus in real time in steps of 20 us, with the thread's timer slack at 1 ns
    (Linux), so that the clock's steps stay well below a frame's 111-125 us at 1 Mbit/s."""

    def _run(self) -> None:
        try:
            import ctypes

            ctypes.CDLL(None).prctl(29, 1, 0, 0, 0)  # PR_SET_TIMERSLACK
        except (OSError, AttributeError):
            pass
        super()._run()


def cycle_rate(seconds: float) -> float:
    """Control cycles per second of ``bus.cycle`` (one T-mode command, reply-state on) on the fine clock."""
    sim = SimBus(ids=[1], bitrate=1_000_000)
    with (
        FineClock(sim, 20e-6),
        drempower.open_bus("sim", bus=sim, time_scale=0, stop_on_close=False) as bus,
    ):
        m = bus.motor(1)
        m.enable_reply_state(True)
        cmd = [m.make_angle(12.34, 0, 100)]
        for _ in range(50):
            bus.cycle(cmd, reply_state=True)
        done, t0 = 0, time.perf_counter()
        while time.perf_counter() - t0 < seconds:
            bus.cycle(cmd, reply_state=True)
            done += 1
        return done / (time.perf_counter() - t0)


def raw_cycle_rate(seconds: float) -> float:
    """The same cycle by a minimal client on the same clock: the encoded command handed to the simulator's
    transport, ``select`` on its descriptor and ``read_nowait`` until the motor's frame is there (no
    client library: no matching, decoding, bookkeeping or timers)."""
    sim = SimBus(ids=[1], bitrate=1_000_000)
    t = SimTransport(bus=sim, time_scale=0)
    try:
        with FineClock(sim, 20e-6):
            fd = t.fileno()
            assert fd is not None
            frame = PositionT(1, 12.34, 100.0).encode()

            def one() -> None:
                t.send(frame)
                while not t.read_nowait():
                    if not select.select([fd], [], [], 1.0)[0]:
                        raise TimeoutError("no state frame from the simulated motor")

            t.send(WriteParam(1, 31214, DataType.U32, 1).encode())  # enable_reply_state (no answer)
            time.sleep(0.01)
            for _ in range(50):
                one()
            done, t0 = 0, time.perf_counter()
            while time.perf_counter() - t0 < seconds:
                one()
                done += 1
            return done / (time.perf_counter() - t0)
    finally:
        t.close()


CYCLE_ROUNDS = 4
"""Blocks of the client and of the minimal client, alternating (see :data:`ROUNDS`)."""


def cycle(seconds: float) -> None:
    limit = 1_000_000 / bench_client.cycle_bits(1, True)
    block = seconds / CYCLE_ROUNDS
    got: list[float] = []
    raw: list[float] = []
    for _ in range(CYCLE_ROUNDS):
        got.append(cycle_rate(block))
        raw.append(raw_cycle_rate(block))
    BusDriver.caller_reads = False
    try:
        got_rx = cycle_rate(seconds)
    finally:
        BusDriver.caller_reads = True
    rate, floor = statistics.median(got), statistics.median(raw)
    of_raw = statistics.median(g / r for g, r in zip(got, raw, strict=True))
    lim = f"{limit:.0f} /s"
    row("bus.cycle, 1 motor, reply-state on, 1 Mbit/s", f"{rate:.0f} /s", lim, f"{rate / limit:.1%} of limit")
    row("  a minimal client on the same clock", f"{floor:.0f} /s", lim, f"{floor / limit:.1%} of limit")
    row("  bus.cycle against that minimal client", f"{of_raw:.1%}", "100%", "")
    row("  the same, receive thread + event handoff", f"{got_rx:.0f} /s", lim, f"{got_rx / limit:.1%} of limit")


def idle(seconds: float) -> None:
    rd, wr = os.pipe()
    t = threading.Thread(target=select.select, args=([rd], [], []), daemon=True)
    t.start()
    time.sleep(0.1)
    floor = bench_idle.wakeups(t.native_id, seconds)
    os.write(wr, b"x")
    t.join()
    os.close(rd)
    os.close(wr)
    for kind in ("adapter", "uart"):
        sim = SimBus(ids=[1])
        pty = attach_adapter_pty(sim) if kind == "adapter" else attach_uart_pty(sim, 1)
        try:
            with drempower.open_bus(kind, pty.path, timeout=1.0, stop_on_close=False) as bus:
                bus.motor(1).get_state()
                time.sleep(0.3)
                rx = [t for t in threading.enumerate() if t.name.startswith("drempower rx")]
                rate = bench_idle.wakeups(rx[0].native_id if rx else None, seconds)
        finally:
            pty.close()
        shown = "n/a" if rate is None else f"{rate:.1f} /s"
        row(f"wake-ups of an idle open bus, {kind} pty", shown, "n/a" if floor is None else f"{floor:.1f} /s", "")


def import_cpu(runs: int) -> None:
    import tempfile

    with tempfile.TemporaryDirectory() as cache:
        env = dict(os.environ)
        env.pop("PYTHONDONTWRITEBYTECODE", None)
        env["PYTHONPYCACHEPREFIX"] = cache
        env["PYTHONPATH"] = os.pathsep.join(filter(None, (str(bench_idle.SRC), env.get("PYTHONPATH"))))
        for code in ("pass", "import drempower"):
            bench_idle.cpu_ms(code, env)
        bare = statistics.median(bench_idle.cpu_ms("pass", env) for _ in range(runs))
        full = statistics.median(bench_idle.cpu_ms("import drempower", env) for _ in range(runs))
    row("import drempower, CPU time", f"{full:.0f} ms", f"{bare:.0f} ms", f"+{full - bare:.0f} ms")


ROW_GROUPS = ("adapter", "python-can", "inprocess", "codec", "cycle", "idle", "import")
"""The groups of rows ``--rows`` picks from, in the order they run."""


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--requests", type=int, default=2000, help="calls per latency figure (default 2000)")
    ap.add_argument("--seconds", type=float, default=1.0, help="time per throughput figure (default 1)")
    ap.add_argument("--idle-seconds", type=float, default=3.0, help="time per wake-up figure (default 3)")
    ap.add_argument("--runs", type=int, default=5, help="fresh interpreters for the import figure (default 5)")
    ap.add_argument(
        "--rows",
        default=",".join(ROW_GROUPS),
        help=f"comma-separated groups of rows to run (default all: {','.join(ROW_GROUPS)})",
    )
    args = ap.parse_args()
    picked = [g.strip() for g in args.rows.split(",") if g.strip()]
    unknown = [g for g in picked if g not in ROW_GROUPS]
    if unknown:
        ap.error(f"--rows: unknown {', '.join(unknown)}; choose from {', '.join(ROW_GROUPS)}")
    runs: dict[str, Callable[[], None]] = {
        "adapter": lambda: adapter_rows(args.requests),
        "python-can": lambda: python_can(args.requests),
        "inprocess": lambda: inprocess(args.requests),
        "codec": lambda: codec(args.seconds),
        "cycle": lambda: cycle(args.seconds),
        "idle": lambda: idle(args.idle_seconds),
        "import": lambda: import_cpu(args.runs),
    }
    print(f"drempower speed table: Python {platform.python_version()} ({platform.python_implementation()})")
    for group in ROW_GROUPS:
        if group in picked:
            runs[group]()


if __name__ == "__main__":
    main()
