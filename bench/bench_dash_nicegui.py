#!/usr/bin/env python3
"""The alternative the dashboard was measured against: NiceGUI's ECharts fed the same samples.

Run: ``python3 bench/bench_dash_nicegui.py [--motors 6] [--seconds S]`` in an
environment with ``nicegui`` and ``playwright`` installed (neither is a
dependency of drempower). Prints figures; asserts nothing.

A NiceGUI page shows one ``ui.echart`` with angle, speed and torque of every
simulated motor (heartbeats at 500 samples/s each) over a 10 s window; every
40 ms the server min/max-decimates each series to 600 points and pushes the
chart's new options (NiceGUI's way of updating a chart). The same measurement
as ``bench_dash.py``: display frames per second in the page and the CPU of the
server (with its simulator) and of the browser.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "python" / "src"))
sys.path.insert(0, str(Path(__file__).resolve().parent))

SERVER = r"""
import collections, sys, time
from nicegui import ui
import drempower

n, port = int(sys.argv[1]), int(sys.argv[2])
ids = list(range(1, n + 1))
bus = drempower.open_bus("sim", motors=ids, stop_on_close=False)
for i in ids:
    bus.motor(i).write_property("can.config.heartbeat_ms", 2)
    bus.motor(i).set_speed(10 + i)
pending = collections.deque()
bus.subscribe(pending.append)
data = {i: collections.deque() for i in ids}
t0 = time.monotonic()
chart = None

def decimate(rows, k, x0, x1, buckets=300):
    out, dt, j = [], (x1 - x0) / buckets, 0
    rows = list(rows)
    for b in range(buckets):
        lim, lo, hi = x0 + (b + 1) * dt, None, None
        while j < len(rows) and rows[j][0] < lim:
            v = rows[j][k]; lo = v if lo is None or v < lo else lo; hi = v if hi is None or v > hi else hi; j += 1
        if lo is not None:
            out += [[x0 + b * dt, lo], [x0 + (b + 0.5) * dt, hi]]
    return out

def update():
    while pending:
        st = pending.popleft()
        data[st.node].append((st.timestamp - t0, st.angle, st.speed, st.torque))
    now = time.monotonic() - t0
    series = []
    for i in ids:
        d = data[i]
        while d and d[0][0] < now - 10:
            d.popleft()
        for k in (1, 2, 3):
            series.append({"type": "line", "showSymbol": False, "data": decimate(d, k, now - 10, now)})
    chart.options["series"] = series
    chart.options["xAxis"] = {"type": "value", "min": now - 10, "max": now}
    chart.update()

@ui.page("/")
def page():
    global chart
    chart = ui.echart({"animation": False, "xAxis": {"type": "value"}, "yAxis": {"type": "value"}, "series": []})
    chart.classes("w-full h-96")
    ui.timer(0.04, update)

ui.run(host="127.0.0.1", port=port, show=False, reload=False, title="nicegui bench")
"""


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--motors", type=int, default=6)
    ap.add_argument("--seconds", type=float, default=5.0)
    a = ap.parse_args()
    try:
        import nicegui
        from playwright.sync_api import sync_playwright
    except ImportError:
        print("bench_dash_nicegui: needs nicegui and playwright (not dependencies of drempower)")
        return
    import socket

    from bench_dash import ARGS, CHROMIUM, _cpu_seconds, descendants_cpu

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    srv = subprocess.Popen([sys.executable, "-c", SERVER, str(a.motors), str(port)], stderr=subprocess.DEVNULL)
    try:
        with sync_playwright() as pw:
            browser = pw.chromium.launch(executable_path=CHROMIUM, headless=True, args=ARGS)
            page = browser.new_page(viewport={"width": 1200, "height": 700})
            page.add_init_script("window.__f=0;(function f(){window.__f++;requestAnimationFrame(f)})()")
            deadline = time.monotonic() + 30
            while True:
                try:
                    page.goto(f"http://127.0.0.1:{port}/")
                    break
                except Exception:
                    if time.monotonic() > deadline:
                        raise
                    time.sleep(0.5)
            page.wait_for_selector("canvas")
            time.sleep(2)
            f0, s0, b0, w0 = (
                page.evaluate("window.__f"),
                _cpu_seconds(srv.pid),
                descendants_cpu(os.getpid()),
                time.monotonic(),
            )
            time.sleep(a.seconds)
            f1, s1, b1, w1 = (
                page.evaluate("window.__f"),
                _cpu_seconds(srv.pid),
                descendants_cpu(os.getpid()),
                time.monotonic(),
            )
            b1 -= s1  # the server is a child of this process too
            b0 -= s0
            wall = w1 - w0
            print(f"NiceGUI {nicegui.__version__} ECharts, {a.motors} motors x 3 channels at 500 samples/s:")
            print(
                f"  page frames/s {(f1 - f0) / wall:.1f}, server CPU {100 * (s1 - s0) / wall:.0f} %, "
                f"browser CPU {100 * (b1 - b0) / wall:.0f} % (of one core)"
            )
            browser.close()
    finally:
        srv.terminate()
        srv.wait(10)


if __name__ == "__main__":
    main()
