#!/usr/bin/env python3
"""What drempower costs while it does nothing: ``import drempower`` and an idle open bus.

Run: ``python3 bench/bench_idle.py [--seconds S]``. Prints figures beside their floor; asserts nothing.

1. CPU time (user + system) of a fresh interpreter running ``import drempower``,
   with bytecode already compiled (as after installing a wheel), beside the bare
   interpreter (``python -c pass``) and the two core dependencies
   (``import can, serial``, which drempower itself imports only when a bus opens);
   and the command line's start: ``drempower --version`` and ``drempower state 1 --sim 1``
   beside ``import can, serial``.
2. Wake-ups per second of the receive thread of an open, idle bus on the
   simulator's USB-CAN adapter pty (0xAA) and on a motor's UART pty: how often
   the kernel scheduled that thread (``/proc/<pid>/task/<tid>/schedstat``, Linux
   only) while no frame arrived, beside a thread blocked in ``select`` on the same
   kind of descriptor with no timeout (the floor: no wake-ups).
3. How long ``close`` of that idle bus takes (its receive thread must notice).
"""

from __future__ import annotations

import argparse
import os
import platform
import resource
import select
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

SRC = Path(os.environ.get("DREMPOWER_SRC") or Path(__file__).resolve().parent.parent / "python" / "src")
sys.path.insert(0, str(SRC))


def cpu_ms(code: str, env: dict[str, str]) -> float:
    """CPU time (ms) of a fresh interpreter running ``code``."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run([sys.executable, "-c", code], check=True, env=env, stdout=subprocess.DEVNULL)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime) * 1e3


def import_time(runs: int) -> None:
    print(f"import: CPU time of a fresh interpreter, median of {runs} runs (bytecode compiled beforehand)")
    with tempfile.TemporaryDirectory() as cache:
        env = dict(os.environ)
        env.pop("PYTHONDONTWRITEBYTECODE", None)
        env["PYTHONPYCACHEPREFIX"] = cache  # compiled once here, reused by every measured run
        env["PYTHONPATH"] = os.pathsep.join(filter(None, (str(SRC), env.get("PYTHONPATH"))))
        cases = [
            ("floor: python -c pass", "pass"),
            ("import can, serial (core dependencies)", "import can, serial"),
            ("import drempower.protocol", "import drempower.protocol"),
            ("import drempower", "import drempower"),
            ("import drempower; drempower.AsyncBus", "import drempower; drempower.AsyncBus"),
            ("drempower --version", _cli("--version")),
            ("drempower state 1 --sim 1", _cli("state", "1", "--sim", "1")),
        ]
        for _, code in cases:
            cpu_ms(code, env)  # warm-up: fills the bytecode cache
        medians: dict[str, float] = {}
        for label, code in cases:
            figures = [cpu_ms(code, env) for _ in range(runs)]
            medians[label] = statistics.median(figures)
            over = ""
            if label.startswith("drempower "):
                over = f"  {medians[label] - medians[cases[1][0]]:+.0f} ms over import can, serial"
            print(f"  {label:<40} {medians[label]:6.0f} ms  (min {min(figures):.0f}){over}")


def _cli(*argv: str) -> str:
    """Python code that runs ``drempower ARGV`` as the console script does."""
    run = "runpy.run_module('drempower', run_name='__main__')"
    return f"import runpy, sys; sys.argv = ['drempower', *{list(argv)!r}]; {run}"


def _runs(tid: int) -> int | None:
    """How many times the kernel has scheduled thread ``tid`` (None off Linux)."""
    try:
        with open(f"/proc/{os.getpid()}/task/{tid}/schedstat") as f:
            return int(f.read().split()[2])
    except (OSError, IndexError, ValueError):
        return None


def wakeups(tid: int | None, seconds: float) -> float | None:
    if tid is None:
        return None
    r0, t0 = _runs(tid), time.monotonic()
    time.sleep(seconds)
    r1, t1 = _runs(tid), time.monotonic()
    if r0 is None or r1 is None:
        return None
    return (r1 - r0) / (t1 - t0)


def idle(seconds: float) -> None:
    import drempower
    from drempower.sim import SimBus, attach_adapter_pty, attach_uart_pty

    print(f"idle bus: wake-ups per second of the receive thread over {seconds:g} s with no traffic")
    rd, wr = os.pipe()
    floor_thread = threading.Thread(target=select.select, args=([rd], [], []), daemon=True)
    floor_thread.start()
    time.sleep(0.1)
    floor = wakeups(floor_thread.native_id, seconds)
    os.write(wr, b"x")
    floor_thread.join()
    os.close(rd)
    os.close(wr)
    if floor is None:
        print("  (needs /proc/<pid>/task/<tid>/schedstat: Linux only)")
        return
    closes: dict[str, float] = {}
    for kind in ("adapter", "uart"):
        sim = SimBus(ids=[1])
        pty = attach_adapter_pty(sim) if kind == "adapter" else attach_uart_pty(sim, 1)
        try:
            bus = drempower.open_bus(kind, pty.path, timeout=1.0, stop_on_close=False)
            try:
                bus.motor(1).get_state()
                time.sleep(0.3)
                rx = [t for t in threading.enumerate() if t.name.startswith("drempower rx")]
                rate = wakeups(rx[0].native_id if rx else None, seconds)
            finally:
                t0 = time.perf_counter()
                bus.close()
                closes[kind] = time.perf_counter() - t0
        finally:
            pty.close()
        shown = "n/a" if rate is None else f"{rate:5.1f}"
        print(f"  {kind + ' pty, open_bus idle':<40} {shown} /s   floor (select, no timeout) {floor:4.1f} /s")
    print("close of that idle bus (stop_on_close=False: nothing to send):")
    for kind, took in closes.items():
        print(f"  {kind + ' pty':<40} {took * 1e3:6.1f} ms")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--runs", type=int, default=7, help="fresh interpreters per import figure (default 7)")
    ap.add_argument("--seconds", type=float, default=5.0, help="idle time per wake-up figure (default 5)")
    args = ap.parse_args()
    print(f"drempower idle benchmark: Python {platform.python_version()} ({platform.python_implementation()})")
    import_time(args.runs)
    idle(args.seconds)


if __name__ == "__main__":
    main()
