#!/usr/bin/env python3
"""The Zenoh bridge on 127.0.0.1: state stream rate, command-to-frame latency, remote against local get_state.

Run: ``python3 bench/bench_bridge.py [--seconds S] [--requests N]`` (needs the ``bridge``
extra). Prints figures beside their floor; asserts nothing.

1. ``joint_states`` messages per second a plain Zenoh subscriber receives, at the
   default 100 Hz and asked for 1000 Hz (2 motors; each message costs one fast
   read per motor on the bus), beside the rate asked for.
2. Command-to-frame latency: from a plain Zenoh ``put`` of ``position_commands``
   (CDR) to the command frame on the simulated bus; and from a remote drempower
   client's ``set_speed`` to its frame on the bus.
3. ``get_state`` round trip of a client on an in-process simulator, and of a
   remote client of ``drempower bridge --sim`` running as its own process
   (frames tunnelled, its 100 Hz state stream on), median and 99th percentile.
   The simulators answer at once (no wire time), so the difference is what
   Zenoh and the bridge add.
4. Memory of a bridge serving a 100 Hz ``joint_states`` subscriber for
   ``--memory-seconds``: growth of Python's heap (tracemalloc) and of the
   process's resident set, per minute, beside the floor (none).
"""

from __future__ import annotations

import argparse
import gc
import os
import platform
import signal
import socket
import statistics
import subprocess
import sys
import threading
import time
import tracemalloc
from collections.abc import Callable
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "python" / "src"))

import numpy as np

import drempower
from drempower.bridge import rmw, rosmsg
from drempower.bridge.server import Bridge, BridgeOptions
from drempower.protocol.ids import Cmd, Frame, SysCmd
from drempower.sim import SimBus
from drempower.transports.sim import SimTransport
from drempower.transports.zenoh_config import open_session


def free_endpoint() -> str:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return f"tcp/127.0.0.1:{s.getsockname()[1]}"


def stats(samples: list[float]) -> str:
    s = sorted(samples)
    p99 = s[min(len(s) - 1, int(len(s) * 0.99))]
    return f"median {statistics.median(s) * 1e6:7.0f} us   p99 {p99 * 1e6:7.0f} us   (n={len(s)})"


class Served:
    def __init__(self, rate: float = 100.0) -> None:
        self.sim = SimTransport([1, 2])
        self.endpoint = free_endpoint()
        self.session = open_session([], [self.endpoint], gossip=False)
        self.bridge = Bridge(
            self.sim, self.session, BridgeOptions({"motor_1": 1, "motor_2": 2}, prefix="bench", rate=rate)
        )

    def close(self) -> None:
        self.bridge.close()
        self.session.close()
        self.sim.close()


def state_rate(seconds: float) -> None:
    print("1. joint_states messages/s received by a plain Zenoh subscriber (2 motors)")
    for rate in (100.0, 1000.0):
        served = Served(rate)
        count = 0

        def on(_: object) -> None:
            nonlocal count
            count += 1

        peer = open_session([served.endpoint], [], gossip=False)
        sub = peer.declare_subscriber(served.bridge.joint_states_key, on)
        time.sleep(0.5)
        count = 0
        time.sleep(seconds)
        got = count / seconds
        sub.undeclare()
        peer.close()
        served.close()
        print(f"   asked {rate:6.0f}/s   received {got:7.1f}/s   floor (asked) {rate:6.0f}/s")


def command_latency(n: int) -> None:
    print("2. command-to-frame latency (until the frame is on the simulated bus)")
    served = Served()
    bus_sim: SimBus = served.sim.bus
    seen = threading.Event()
    wanted: list[Callable[[Frame], bool]] = []

    def tap(frame: Frame) -> None:
        if wanted and wanted[0](frame):
            seen.set()

    bus_sim.add_listener(tap, host_frames=True)
    peer = open_session([served.endpoint], [], gossip=False)
    pub = peer.declare_publisher(served.bridge.command_keys["position_commands"])
    t = rosmsg.typestore().types
    layout = t["std_msgs/msg/MultiArrayLayout"](dim=[], data_offset=0)
    time.sleep(0.3)
    # several motors: T-mode presets, then the start that moves them together
    wanted.append(lambda f: f.arbitration_id & 0x1F == Cmd.SYSTEM and f.data[:1] == bytes([SysCmd.START_T]))
    ros: list[float] = []
    for i in range(n):
        msg = t[rosmsg.FLOAT64_MULTI_ARRAY](layout=layout, data=np.array([0.001 * i, 0.0]))
        payload = rosmsg.encode(msg, rosmsg.FLOAT64_MULTI_ARRAY)
        seen.clear()
        t0 = time.perf_counter()
        pub.put(payload, attachment=rmw.Attachment(i, time.time_ns(), bytes(16)).encode())
        if seen.wait(1.0):
            ros.append(time.perf_counter() - t0)
        time.sleep(0.002)
    print(f"   ROS 2 position_commands -> T-mode start frame: {stats(ros)}")
    pub.undeclare()
    peer.close()
    wanted[0] = lambda f: f.arbitration_id & 0x1F == Cmd.VELOCITY
    remote: list[float] = []
    with drempower.open_bus("zenoh", "bench", connect=served.endpoint, gossip=False) as bus:
        m = bus.motor(1)
        for i in range(n):
            seen.clear()
            t0 = time.perf_counter()
            m.set_speed(1.0 + (i % 5))
            if seen.wait(1.0):
                remote.append(time.perf_counter() - t0)
            time.sleep(0.002)
    print(f"   remote drempower set_speed -> its frame:       {stats(remote)}")
    bus_sim.remove_listener(tap)
    served.close()


def get_state_latency(n: int) -> None:
    print("3. get_state round trip: local in-process simulator, and remote through a bridge process")
    with drempower.open_bus("sim", motors=[1, 2], stop_on_close=False) as local:
        samples = []
        for _ in range(n):
            t0 = time.perf_counter()
            local.motor(1).get_state()
            samples.append(time.perf_counter() - t0)
        print(f"   local : {stats(samples)}")
    endpoint = free_endpoint()
    argv = [sys.executable, "-m", "drempower", "bridge", "--sim", "1,2", "--listen", endpoint]
    argv += ["--connect", free_endpoint(), "--prefix", "bench3", "--json"]
    bridge = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    try:
        assert bridge.stdout is not None
        bridge.stdout.readline()  # serving
        with drempower.open_bus("zenoh", "bench3", connect=endpoint, gossip=False, stop_on_close=False) as bus:
            samples = []
            for _ in range(n):
                t0 = time.perf_counter()
                bus.motor(1).get_state()
                samples.append(time.perf_counter() - t0)
            print(f"   remote: {stats(samples)}   floor: local + one Zenoh round trip on loopback")
    finally:
        bridge.send_signal(signal.SIGTERM)
        bridge.wait(20)


def _rss() -> int:
    """Resident set size of this process (bytes; Linux)."""
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")


def memory_growth(seconds: float) -> None:
    print(f"4. memory of a bridge serving a 100 Hz joint_states subscriber, over {seconds:g} s")
    served = Served(100.0)
    peer = open_session([served.endpoint], [], gossip=False)
    got = [0]
    sub = peer.declare_subscriber(served.bridge.joint_states_key, lambda _s: got.__setitem__(0, got[0] + 1))
    try:
        time.sleep(3.0)  # the sessions, the stream and the allocator settle first
        tracemalloc.start()
        gc.collect()
        own0 = tracemalloc.get_tracemalloc_memory()  # tracemalloc's own traces are no growth of the bridge
        heap0, rss0, n0, t0 = tracemalloc.get_traced_memory()[0], _rss() - own0, got[0], time.monotonic()
        time.sleep(seconds)
        gc.collect()
        own = tracemalloc.get_tracemalloc_memory()
        heap, rss, minutes = tracemalloc.get_traced_memory()[0], _rss() - own, (time.monotonic() - t0) / 60
        tracemalloc.stop()
        print(f"   messages received {got[0] - n0} ({(got[0] - n0) / (minutes * 60):.1f}/s)")
        print(f"   Python heap  {(heap - heap0) / minutes / 1e6:+7.3f} MB/min   floor 0")
        print(f"   resident set {(rss - rss0) / minutes / 1e6:+7.3f} MB/min   floor 0")
    finally:
        sub.undeclare()
        peer.close()
        served.close()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=3.0, help="seconds per state-rate measurement")
    ap.add_argument("--requests", type=int, default=500, help="samples per latency figure")
    ap.add_argument("--memory-seconds", type=float, default=60.0, help="seconds of the memory measurement")
    args = ap.parse_args()
    print(f"Python {platform.python_version()} on {platform.machine()}, Zenoh over TCP on 127.0.0.1")
    state_rate(args.seconds)
    command_latency(args.requests)
    get_state_latency(args.requests)
    memory_growth(args.memory_seconds)


if __name__ == "__main__":
    main()
