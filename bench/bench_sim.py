#!/usr/bin/env python3
"""Simulator speed: simulated motor-seconds per wall-clock second.

Run: ``python3 bench/bench_sim.py [--seconds S]``. Prints figures; asserts nothing.
Every motor runs back-and-forth Q moves. "instant" delivers frames at once with
no host traffic; "1 Mbit/s" adds the bus timing model and a host polling every
motor with a fast read every 10 ms (the replies too go through arbitration).
Real time for N motors needs N motor-seconds per second.
"""

from __future__ import annotations

import argparse
import platform
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "python" / "src"))

from drempower.protocol import FastRead, PositionQ
from drempower.sim import SimBus

POLL = 0.01
"""Host polling period of the timed runs (s)."""
MOVE = 2.0
"""Time between successive Q moves (s); a 360 deg move at 200 r/min and 300 (r/min)/s takes 0.97 s."""


def run(n: int, seconds: float, bitrate: int | None) -> tuple[float, float]:
    """Motor-seconds per wall second, and the bus utilisation, for ``n`` motors."""
    bus = SimBus(range(1, n + 1), bitrate=bitrate)
    ids = list(bus.motors)
    reads = [FastRead(i).encode() for i in ids]
    per_move = round(MOVE / POLL)
    start = time.perf_counter()
    for k in range(round(seconds / POLL)):
        if k % per_move == 0:
            target = 360.0 if (k // per_move) % 2 == 0 else 0.0
            for i in ids:
                bus.send(PositionQ(i, target, 200.0, 300.0).encode())
        if bitrate is not None:
            for f in reads:
                bus.send(f)
        bus.advance(POLL)
    wall = time.perf_counter() - start
    return n * seconds / wall, bus.stats.utilisation


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=4.0, help="simulated seconds per run (default 4)")
    args = parser.parse_args()
    print(f"Python {platform.python_version()} on {platform.machine()}; {args.seconds:g} s simulated per run")
    print(f"{'motors':>6}  {'bus':<10} {'motor-s/s':>10}  {'x real time':>11}  {'bus load':>8}")
    for bitrate in (None, 1_000_000):
        for n in (1, 8, 32):
            rate, load = run(n, args.seconds, bitrate)
            kind = "instant" if bitrate is None else "1 Mbit/s"
            print(f"{n:>6}  {kind:<10} {rate:>10.0f}  {rate / n:>11.1f}  {load:>8.0%}")


if __name__ == "__main__":
    main()
