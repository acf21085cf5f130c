#!/usr/bin/env python3
"""Dashboard throughput: samples per second delivered to a browser, display frames per second, server CPU.

Run: ``python3 bench/bench_dash.py [--seconds S] [--motors 1,6,12]``. Prints figures; asserts nothing.

For 1, 6 and 12 simulated motors sending heartbeats at 500 samples/s each, a
dashboard runs in this process and a headless Chromium (Debian's
``/usr/bin/chromium``, driven by Playwright) shows the Plots view with angle,
speed and torque of every motor and their targets. Over ``--seconds`` it
measures the samples the page received (and how many the server sent that the
page did not get: lost), the frames the page drew, and the CPU time of this
process (dashboard server, client and the simulator together) and of the
browser's processes per wall second.
"""

from __future__ import annotations

import argparse
import asyncio
import os
import platform
import sys
import threading
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "python" / "src"))

from drempower import open_bus
from drempower.dash import Dashboard, Hub

RATE = 500
CHROMIUM = os.environ.get("DREMPOWER_CHROMIUM", "/usr/bin/chromium")
ARGS = [
    "--no-sandbox",
    "--disable-gpu",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--no-first-run",
]


def _cpu_seconds(pid: int) -> float:
    """utime + stime of one process (s), 0 if it is gone."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except OSError:
        return 0.0
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def descendants_cpu(root: int) -> float:
    """CPU seconds of every process below ``root`` (the browser and its Playwright driver)."""
    parent: dict[int, int] = {}
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            try:
                parent[int(d.name)] = int((d / "stat").read_text().rsplit(")", 1)[1].split()[1])
            except (OSError, ValueError, IndexError):
                continue
    below, changed = {root}, True
    while changed:
        changed = False
        for pid, pp in parent.items():
            if pp in below and pid not in below:
                below.add(pid)
                changed = True
    return sum(_cpu_seconds(p) for p in below if p != root)


def serve(hub: Hub) -> tuple[str, Dashboard, asyncio.AbstractEventLoop, threading.Thread]:
    loop = asyncio.new_event_loop()
    ready = threading.Event()
    box: dict[str, Any] = {}

    def main() -> None:
        asyncio.set_event_loop(loop)
        box["dash"] = Dashboard(hub)
        loop.run_until_complete(box["dash"].serve("127.0.0.1", 0, lambda url: (box.update(url=url), ready.set())))
        loop.close()

    t = threading.Thread(target=main, daemon=True)
    t.start()
    if not ready.wait(10):
        raise SystemExit("the dashboard did not start")
    return box["url"], box["dash"], loop, t


def run(browser: Any, n: int, seconds: float) -> dict[str, float]:
    ids = list(range(1, n + 1))
    bus = open_bus("sim", motors=ids, stop_on_close=False)
    hub = Hub(bus)
    url, dash, loop, thread = serve(hub)
    try:
        hub.motors = {i: {"id": i} for i in ids}
        hub.do_rate("bench", RATE)
        page = browser.new_page(viewport={"width": 1200, "height": 700})
        page.add_init_script("window.__f=0;(function f(){window.__f++;requestAnimationFrame(f)})()")
        page.goto(url)
        page.get_by_role("tab", name="Plots").click()
        page.wait_for_function(f"document.querySelectorAll('#plot-motors input').length === {n}")
        for ch in ("speed", "torque"):
            page.locator(f"#plot-channels input[value={ch}]").check()
        for i in ids:  # something moving on every motor
            bus.motor(i).set_speed(10 + i)
        time.sleep(2.0)
        s0 = page.evaluate("[window.dashStats.received, window.dashStats.frames, window.__f]")
        c0, b0, w0 = time.process_time(), descendants_cpu(os.getpid()), time.monotonic()
        time.sleep(seconds)
        s1 = page.evaluate("[window.dashStats.received, window.dashStats.frames, window.__f]")
        c1, b1, w1 = time.process_time(), descendants_cpu(os.getpid()), time.monotonic()
        time.sleep(0.3)
        st = page.evaluate("window.dashStats")
        lost = st["serverTotal"] - st["firstTotal"] - st["received"]
        page.close()
        for i in ids:
            bus.motor(i).set_mode(1)
        wall = w1 - w0
        return {
            "samples": (s1[0] - s0[0]) / wall,
            "fps": (s1[1] - s0[1]) / wall,
            "raf": (s1[2] - s0[2]) / wall,
            "cpu": 100 * (c1 - c0) / wall,
            "browser": 100 * (b1 - b0) / wall,
            "lost": lost,
        }
    finally:
        loop.call_soon_threadsafe(dash.stopping.set)
        thread.join(10)
        hub.close()
        bus.close()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=5.0)
    ap.add_argument("--motors", default="1,6,12")
    a = ap.parse_args()
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        print("bench_dash: needs playwright (pip install -e 'python[dev]')")
        return
    if not os.path.exists(CHROMIUM):
        print(f"bench_dash: needs {CHROMIUM} (apt-get install chromium)")
        return
    print(
        f"dashboard throughput ({platform.python_implementation()} {platform.python_version()}, {os.cpu_count()} cores)"
    )
    heads = ("motors", "samples/s", "floor", "lost", "fps", "page fps", "server CPU %", "browser CPU %")
    print(" ".join(f"{h:>{w}}" for h, w in zip(heads, (6, 10, 8, 5, 5, 8, 13, 14), strict=True)))
    with sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=CHROMIUM, headless=True, args=ARGS)
        try:
            for n in (int(x) for x in a.motors.split(",")):
                r = run(browser, n, a.seconds)
                print(
                    f"{n:>6} {r['samples']:>10.0f} {n * RATE:>8} {r['lost']:>5.0f} {r['fps']:>5.1f} {r['raf']:>8.1f}"
                    f" {r['cpu']:>13.0f} {r['browser']:>14.0f}"
                )
        finally:
            browser.close()
    print(
        "floor: every motor's 500 samples/s delivered, 0 lost, the chart redrawn at the 25 batches/s the server sends"
    )
    print("fps: chart redraws per second; page fps: the browser's animation frames (60 when nothing blocks it)")
    print("CPU: % of one core; server = this process (server + client + simulator), browser = Chromium + driver")


if __name__ == "__main__":
    main()
