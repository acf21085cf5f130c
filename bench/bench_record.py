#!/usr/bin/env python3
"""MCAP recording rate against the simulator's 1 Mbit/s timing model.

Run: ``python3 bench/bench_record.py [--seconds S] [--heartbeat-ms MS]``. Prints figures; asserts nothing.

6 simulated motors send heartbeats every MS ms (1 ms by default: 1000 state
frames per motor and second, about 75 % of a 1 Mbit/s bus); a
:class:`drempower.records.Recorder` attached to the bus writes every frame and
every joint state to an MCAP file. The frames on the simulated wire are counted
by a listener of the simulated bus, independently of the recorder, and compared
with the frames in the file (read back with mcap's reader). Floor: 500 samples/s
per motor, 0 frames lost.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "python" / "src"))

from mcap.reader import make_reader

from drempower import open_bus
from drempower.protocol.ids import Frame
from drempower.records.recorder import Recorder

MOTORS = [1, 2, 3, 4, 5, 6]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=5.0)
    ap.add_argument("--heartbeat-ms", type=int, default=1)
    args = ap.parse_args()
    seen: list[Frame] = []
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "bench.mcap"
        with open_bus("sim", motors=MOTORS, bitrate=1_000_000) as bus:
            sim = bus.transport.bus  # type: ignore[attr-defined]
            rec = Recorder(path).attach(bus)
            sim.add_listener(seen.append, host_frames=True)
            for i in MOTORS:
                bus.motor(i).write_property("can.config.heartbeat_ms", args.heartbeat_ms)
            t0, s0 = time.monotonic(), sim.now
            time.sleep(args.seconds)
            for i in MOTORS:
                bus.motor(i).write_property("can.config.heartbeat_ms", 0)
            wall, simulated = time.monotonic() - t0, sim.now - s0
            time.sleep(0.2)
            sim.remove_listener(seen.append)
            rec.close()
            load = sim.stats
        with open(path, "rb") as fh:
            summary = make_reader(fh).get_summary()
        counts = {c.topic: summary.statistics.channel_message_counts[i] for i, c in summary.channels.items()}
        size = path.stat().st_size
    in_file = counts.get("/can/tx", 0) + counts.get("/can/rx", 0)
    states = counts.get("/joint_states", 0)
    print(
        f"6 motors, heartbeat {args.heartbeat_ms} ms, 1 Mbit/s timing model, "
        f"{wall:.1f} s wall ({simulated:.1f} s simulated)"
    )
    print(f"  frames on the wire      {len(seen):8d}")
    print(f"  frames in the file      {in_file:8d}   lost {len(seen) - in_file}   (floor: 0 lost)")
    print(f"  samples/s per motor     {states / wall / len(MOTORS):8.0f}   (floor: 500)")
    print(f"  bus utilisation         {load.utilisation * 100:7.1f} %")
    print(f"  file size               {size / 1e6:8.2f} MB ({size / max(in_file + states, 1):.1f} bytes per message)")


if __name__ == "__main__":
    main()
