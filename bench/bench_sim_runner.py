#!/usr/bin/env python3
"""The simulator's timing runner: control-cycle rate through an external simulator, idle CPU.

Run: ``python3 bench/bench_sim_runner.py [--seconds S]``. Prints figures; asserts nothing.

1. ``bus.cycle`` rate for one motor (a T-mode hold answered by a fast read) on
   the 1 Mbit/s timing model: in-process (``open_bus("sim", bitrate=1_000_000)``)
   and through an external ``drempower sim --bitrate 1M`` over the adapter pty,
   beside the bus's floor (1 Mbit/s over the bits one cycle puts on the wire).
2. CPU used by an external ``drempower sim --ids 1,2,3`` with idle motors,
   from ``/proc/PID/stat`` over the measuring time (Linux only).
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "python" / "src"))

import drempower
from drempower.protocol import FastRead, PositionT
from drempower.sim.timing import frame_bits


def _cycle_rate(bus: drempower.Bus, seconds: float) -> float:
    cmd = [PositionT(1, 0.0, 20.0)]
    bus.cycle(cmd, reply_state=False)
    n, end = 0, time.monotonic() + seconds
    start = time.monotonic()
    while time.monotonic() < end:
        bus.cycle(cmd, reply_state=False, timeout=0.5)
        n += 1
    return n / (time.monotonic() - start)


def _start_sim(*argv: str) -> tuple[subprocess.Popen[str], str]:
    proc = subprocess.Popen(
        [sys.executable, "-m", "drempower", "sim", *argv], stdout=subprocess.PIPE, text=True, bufsize=1
    )
    assert proc.stdout is not None
    text = ""
    while "Ctrl-C stops" not in text:
        line = proc.stdout.readline()
        if not line:
            raise SystemExit(f"the simulator did not start: {text}")
        text += line
    return proc, text


def _cpu_seconds(pid: int) -> float:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--seconds", type=float, default=3.0, help="measuring time of each cycle figure")
    ap.add_argument("--idle-seconds", type=float, default=10.0, help="measuring time of the idle CPU")
    args = ap.parse_args()
    cyc = [PositionT(1, 0.0, 20.0).encode(), FastRead(1).encode()]
    bits = sum(frame_bits(f.arbitration_id, f.data) for f in cyc) + 111
    print(f"floor: 1 Mbit/s / {bits} bits per cycle = {1e6 / bits:.0f} cycles/s")
    with drempower.open_bus("sim", motors=[1], bitrate=1_000_000) as bus:
        print(f"in-process sim, 1 Mbit/s:          {_cycle_rate(bus, args.seconds):7.0f} cycles/s")
    proc, text = _start_sim("--ids", "1", "--bitrate", "1M", "--adapter-pty")
    try:
        m = re.search(r"adapter \(0xAA frames and slcan\): (\S+)", text)
        assert m, text
        with drempower.open_bus("adapter", m.group(1), stop_on_close=False) as bus:
            print(f"external sim --bitrate 1M, adapter: {_cycle_rate(bus, args.seconds):7.0f} cycles/s")
    finally:
        proc.terminate()
        proc.wait(10)
    proc, _ = _start_sim("--ids", "1,2,3", "--adapter-pty")
    try:
        time.sleep(1.0)
        c0, t0 = _cpu_seconds(proc.pid), time.monotonic()
        time.sleep(args.idle_seconds)
        c1, t1 = _cpu_seconds(proc.pid), time.monotonic()
        print(f"idle external sim (3 motors):      {100 * (c1 - c0) / (t1 - t0):7.1f} % of one CPU")
    finally:
        proc.terminate()
        proc.wait(10)


if __name__ == "__main__":
    main()
