#!/usr/bin/env python3
"""Start skew of synchronised moves across buses, and the robot's cost beside one bus.

Run: ``python3 bench/bench_robot.py [--moves N]``. Prints figures; asserts nothing.

1. Skew between the buses' start frames of ``robot.set_angles`` (T mode, so no
   reads before the move) over 2 and 4 buses, simulated in process and python-can
   ``virtual`` channels with a simulator attached: median, 95th percentile and
   maximum. The floor beside it: the spread of the same start frames sent one
   after the other from one thread (what one sending thread could do at best).
2. ``robot.get_states()`` of one motor per bus beside ``bus.motor(1).get_state()``
   on one bus: the cost of running each bus's part on its own thread.
"""

from __future__ import annotations

import argparse
import itertools
import statistics
import sys
import tempfile
import time
from contextlib import ExitStack
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "python" / "src"))

import drempower
from drempower.client.engine.commands import make_angles
from drempower.sim import SimBus, SimRunner, attach_python_can

_channels = itertools.count()


def _file(kind: str, buses: int, folder: Path, stack: ExitStack) -> Path:
    lines = []
    for b in range(buses):
        if kind == "sim":
            lines += [f"[buses.b{b}]", 'interface = "sim"']
        else:
            channel = f"drempower-bench-robot-{b}-{next(_channels)}"
            sim = SimBus(ids=[1])
            stack.callback(SimRunner(sim, 1.0).start().stop)
            stack.callback(attach_python_can(sim, channel=channel).close)
            lines += [f"[buses.b{b}]", 'interface = "virtual"', f'channel = "{channel}"', "timeout = 0.5"]
        lines += [f"[joints.j{b}]", f'bus = "b{b}"', "id = 1"]
    path = folder / f"{kind}-{buses}.toml"
    path.write_text("\n".join(lines) + "\n")
    return path


def _us(values: list[float]) -> str:
    v = sorted(values)
    p95 = v[min(len(v) - 1, int(0.95 * len(v)))]
    return f"median {statistics.median(v) * 1e6:7.1f} us  p95 {p95 * 1e6:7.1f} us  max {v[-1] * 1e6:7.1f} us"


def skew(kind: str, buses: int, moves: int, folder: Path) -> None:
    with ExitStack() as stack:
        robot = stack.enter_context(drempower.open_robot(_file(kind, buses, folder, stack), stop_on_close=False))
        names = list(robot.joints)
        spreads, floors = [], []
        for k in range(moves):
            target = {n: float(k % 20) for n in names}
            spreads.append(robot.set_angles(target, 0.0, 50.0, 0).skew)
            # the floor: the same presets and starts, one bus after the other from this thread
            sent = []
            for n in names:
                presets, start = make_angles([1], [float(k % 20)], 0.0, 50.0, 0)
                robot.joint(n).bus.send_batch(presets, start)
                sent.append(time.monotonic())
            floors.append(sent[-1] - sent[0])
        print(f"  {kind:7s} {buses} buses  skew   {_us(spreads)}")
        print(f"  {'':7s} {'':7s}  floor  {_us(floors)}  (one thread, bus after bus)")


def states(moves: int, folder: Path) -> None:
    with ExitStack() as stack:
        robot = stack.enter_context(drempower.open_robot(_file("sim", 2, folder, stack), stop_on_close=False))
        one = robot.joint("j0")
        for label, call in (
            ("one bus, motor.get_state()", one.get_state),
            ("2 buses, robot.get_states()", robot.get_states),
        ):
            call()
            ts = []
            for _ in range(moves):
                t = time.perf_counter()
                call()
                ts.append(time.perf_counter() - t)
            print(f"  {label:30s} {_us(ts)}")


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__)
    p.add_argument("--moves", type=int, default=200, help="moves (and reads) per figure (default 200)")
    args = p.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        print("start skew of a synchronised move (T mode):")
        for kind in ("sim", "virtual"):
            for buses in (2, 4):
                skew(kind, buses, args.moves, folder)
        print("reading every bus at once:")
        states(args.moves, folder)


if __name__ == "__main__":
    main()
