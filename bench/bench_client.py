#!/usr/bin/env python3
"""Client latency and control-cycle rate against the simulator.

Run: ``python3 bench/bench_client.py [--requests N] [--seconds S]``. Prints figures; asserts nothing.

1. Round-trip latency of ``get_state`` (fast read) and ``read_property`` through
   every transport (in-process, python-can virtual, slcan (drempower's and
   python-can's) and 0xAA over the adapter pty, the motor UART pty, socketcand
   over TCP on 127.0.0.1 (drempower's client and python-can's)), with the
   simulator answering at once: the cost of the client, the transport and the
   attachment, median and 99th percentile.
2. ``bus.cycle`` rate for 1, 6 and 12 motors on the simulator's 1 Mbit/s timing
   model (frames take their real length on the wire, one at a time), with
   enable_reply_state on (one frame each way per motor) and off (command + fast
   read + reply), beside the bus's theoretical limit: 1 Mbit/s divided by the
   bits one cycle puts on the wire (exact frame lengths, stuff bits included).
"""

from __future__ import annotations

import argparse
import itertools
import os
import platform
import select
import statistics
import sys
import threading
import time
import tty
from collections.abc import Callable, Iterator
from contextlib import ExitStack, contextmanager
from pathlib import Path
from typing import Any

# the drempower source tree measured: this checkout's, or another's in DREMPOWER_SRC (bench_against.py)
sys.path.insert(0, os.environ.get("DREMPOWER_SRC") or str(Path(__file__).resolve().parent.parent / "python" / "src"))

import drempower
from drempower.client import Bus
from drempower.protocol import FastRead, PositionT, State, encode_aa, encode_uart11
from drempower.sim import (
    SimBus,
    attach_adapter_pty,
    attach_python_can,
    attach_socketcand,
    attach_uart_pty,
    frame_bits,
)
from drempower.transports import Transport, open_transport

TRANSPORTS = (
    "inprocess",
    "virtual",
    "slcan",
    "python-can:slcan",
    "adapter",
    "uart",
    "socketcand",
    "python-can:socketcand",
)
BITRATE = 1_000_000
_channels = itertools.count()


@contextmanager
def endpoint(kind: str, sim: SimBus) -> Iterator[Transport]:
    """An open transport of ``kind`` (any but ``inprocess``) to ``sim`` through its attachment (the simulated
    clock is not run: replies are instant); both are closed after."""
    with ExitStack() as stack:
        if kind == "virtual":
            channel = f"drempower-bench-{next(_channels)}"
            stack.callback(attach_python_can(sim, channel=channel).close)
            t = open_transport("virtual", channel)
        elif kind in ("slcan", "python-can:slcan", "adapter"):
            pty = attach_adapter_pty(sim)
            stack.callback(pty.close)
            if kind == "adapter":
                t = open_transport("adapter", pty.path)
            else:
                t = open_transport(kind, pty.path, BITRATE, sleep_after_open=0)
        elif kind == "uart":
            pty = attach_uart_pty(sim, 1)
            stack.callback(pty.close)
            t = open_transport("uart", pty.path)
        elif kind in ("socketcand", "python-can:socketcand"):
            server = attach_socketcand(sim)
            stack.callback(server.close)
            t = open_transport(kind, "can0", host=server.host, port=server.port)
        else:
            raise ValueError(f"unknown link {kind!r}")
        stack.callback(t.close)
        yield t


@contextmanager
def link(kind: str, sim: SimBus) -> Iterator[Bus]:
    """A client bus on ``sim`` through transport ``kind`` (the simulated clock is not run: replies are instant)."""
    opts: dict[str, Any] = {"timeout": 1.0, "stop_on_close": False}
    if kind == "inprocess":
        with drempower.open_bus("sim", bus=sim, time_scale=0, **opts) as bus:
            yield bus
        return
    with endpoint(kind, sim) as t, drempower.open_bus(transport=t, **opts) as bus:
        yield bus


def timings(fn: Callable[[], object], n: int) -> tuple[float, float]:
    """Median and 99th percentile of ``n`` calls, in microseconds (after a short warm-up)."""
    for _ in range(min(50, n)):
        fn()
    out = []
    for _ in range(n):
        t0 = time.perf_counter()
        fn()
        out.append(time.perf_counter() - t0)
    out.sort()
    return statistics.median(out) * 1e6, out[min(len(out) - 1, int(len(out) * 0.99))] * 1e6


class RawFloor:
    """The floor of a round trip on a simulator's pty: a minimal client that writes the fast-read frame
    with ``os.write`` and takes the whole reply with ``select`` + ``os.read`` (no decoding).

    ``kind`` is the pty's framing: ``adapter`` (0xAA), ``slcan`` (text lines: the channel is opened
    first; the reply is the adapter's ``z`` answer and the state frame's line) or ``uart`` (11 bytes).
    The pty is its own simulator's, in this process, unless ``path`` is given.
    """

    def __init__(self, kind: str = "adapter", path: str | None = None) -> None:
        self.pty = None
        if path is None:
            sim = SimBus(ids=[1])
            self.pty = attach_uart_pty(sim, 1) if kind == "uart" else attach_adapter_pty(sim)
            path = self.pty.path
        self.fd = os.open(path, os.O_RDWR | os.O_NOCTTY)
        tty.setraw(self.fd)
        frame = FastRead(1).encode()
        reply = State(1, 0.0, 0.0, 0.0, True, False).encode()
        if kind == "uart":
            self.request, self.size = encode_uart11(frame.arbitration_id, frame.data), 11
        elif kind == "slcan":
            from drempower.protocol.slcan import encode_slcan  # (a revision compared may have none)

            self.request, self.size = encode_slcan(frame), len(b"z\r" + encode_slcan(reply))
            os.write(self.fd, b"C\rS8\rO\r")
            self._take(3)  # the three answers
        else:
            self.request, self.size = encode_aa(frame), len(encode_aa(reply))

    def _take(self, size: int) -> None:
        fd, got = self.fd, 0
        while got < size:
            if not select.select([fd], [], [], 1.0)[0]:
                raise TimeoutError("no reply on the pty")
            got += len(os.read(fd, size - got))

    def __call__(self) -> None:
        os.write(self.fd, self.request)
        self._take(self.size)

    def close(self) -> None:
        os.close(self.fd)
        if self.pty is not None:
            self.pty.close()


def raw_floor(kind: str, n: int) -> tuple[float, float]:
    """Median and 99th percentile (us) of :class:`RawFloor` on a pty of ``kind``."""
    floor = RawFloor(kind)
    try:
        return timings(floor, n)
    finally:
        floor.close()


def latency(n: int) -> None:
    print(f"round trip through each transport ({n} calls each; simulator answers at once)")
    print(f"  {'transport':<16} {'get_state median':>17} {'p99':>9} {'read_property median':>21} {'p99':>9}")
    for kind in TRANSPORTS:
        sim = SimBus(ids=[1])
        with link(kind, sim) as bus:
            m = bus.motor(1)
            gs = timings(m.get_state, n)
            rp = timings(lambda m=m: m.read_property(38012), n)  # type: ignore[misc]
        print(f"  {kind:<16} {gs[0]:14.0f} us {gs[1]:6.0f} us {rp[0]:18.0f} us {rp[1]:6.0f} us")
        if kind in ("adapter", "uart", "slcan"):
            floor = raw_floor(kind, n)
            print(
                f"  {'  raw floor':<16} {floor[0]:14.0f} us {floor[1]:6.0f} us"
                f"   (os.write + select + os.read on the same pty; get_state = {gs[0] / floor[0]:.1f}x floor)"
            )


class FineClock:
    """Runs a SimBus in real time with a fine step, so that the 1 Mbit/s timing model shows through."""

    def __init__(self, sim: SimBus, period: float = 50e-6) -> None:
        self.sim = sim
        self.period = period
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)

    def _run(self) -> None:
        last = time.perf_counter()
        while not self._stop.is_set():
            time.sleep(self.period)
            now = time.perf_counter()
            self.sim.advance(min(now - last, 0.01))
            last = now

    def __enter__(self) -> FineClock:
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._stop.set()
        self._thread.join()


def cycle_bits(n: int, reply_state: bool) -> int:
    """Bits on the wire for one cycle of ``n`` motors (typical frames: T command, state reply, fast read)."""
    bits = 0
    for node in range(1, n + 1):
        cmd = PositionT(node, 12.34, 100.0).encode()
        rep = State(node, 12.3, 1.5, 0.2, False, False).encode()
        bits += frame_bits(cmd.arbitration_id, cmd.data) + frame_bits(rep.arbitration_id, rep.data)
        if not reply_state:
            fr = FastRead(node).encode()
            bits += frame_bits(fr.arbitration_id, fr.data)
    return bits


def cycles(seconds: float) -> None:
    print(f"bus.cycle on the simulator's {BITRATE // 1000} kbit/s timing model ({seconds:g} s per figure)")
    print(
        f"  {'motors':>6} {'reply_state':>11} {'frames/cycle':>12} {'measured':>14} {'bus limit':>14} {'of limit':>9}"
    )
    for n in (1, 6, 12):
        for reply_state in (True, False):
            ids = list(range(1, n + 1))
            sim = SimBus(ids=ids, bitrate=BITRATE)
            with FineClock(sim), drempower.open_bus("sim", bus=sim, time_scale=0, stop_on_close=False) as bus:
                motors = [bus.motor(i) for i in ids]
                for m in motors:
                    m.enable_reply_state(reply_state)
                frames0 = sim.stats.frames
                done = 0
                t0 = time.perf_counter()
                while time.perf_counter() - t0 < seconds:
                    bus.cycle([m.make_angle(12.34, 0, 100) for m in motors], reply_state=reply_state)
                    done += 1
                elapsed = time.perf_counter() - t0
                per_cycle = (sim.stats.frames - frames0) / max(done, 1)
            rate = done / elapsed
            limit = BITRATE / cycle_bits(n, reply_state)
            on = "on" if reply_state else "off"
            print(f"  {n:>6} {on:>11} {per_cycle:12.1f} {rate:10.0f} /s {limit:10.0f} /s {rate / limit:8.0%}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--requests", type=int, default=1000, help="calls per latency figure (default 1000)")
    ap.add_argument("--seconds", type=float, default=1.0, help="time per control-cycle figure (default 1)")
    args = ap.parse_args()
    print(f"drempower client benchmark: Python {platform.python_version()} ({platform.python_implementation()})")
    latency(args.requests)
    cycles(args.seconds)


if __name__ == "__main__":
    main()
