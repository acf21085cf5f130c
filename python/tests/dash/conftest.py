"""Fixtures of the dashboard tests: a dashboard on simulated motors (in a thread) and a headless Chromium.

Debian's ``chromium`` (``/usr/bin/chromium``) is driven by Playwright; set
``DREMPOWER_SCREENSHOTS=1`` to write the screenshots into ``docs/img``
(otherwise they go to a temporary folder).
"""

from __future__ import annotations

import asyncio
import os
import shutil
import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest

from drempower import open_bus
from drempower.client import Bus
from drempower.robot import Robot
from drempower.sim import SimBus

from ..conftest import REPO_ROOT

pytest.importorskip("aiohttp")
from drempower.dash import Dashboard, Hub
from drempower.logline import STDERR

CHROMIUM = os.environ.get("DREMPOWER_CHROMIUM", "/usr/bin/chromium")
CHROMIUM_ARGS = [
    "--no-sandbox",
    "--disable-gpu",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--no-first-run",
]


@dataclass
class Served:
    url: str
    bus: Bus
    sim: SimBus
    hub: Hub
    dash: Dashboard
    loop: asyncio.AbstractEventLoop


@pytest.fixture(autouse=True)
def _log_lines_stay_in_their_test() -> Iterator[None]:
    """The dashboard's log lines are written to stderr by a thread of their own: let them out before the
    test ends, so pytest captures them with the test instead of printing them between tests."""
    yield
    STDERR.flush_for(2.0)


def serve_in_thread(
    bus: Bus | Robot, *, read_only: bool = False, **kwargs: Any
) -> tuple[str, Hub, Dashboard, asyncio.AbstractEventLoop, threading.Thread]:
    """Run a dashboard on ``bus`` (or a robot's buses) in its own thread; returns its URL once it listens."""
    hub = Hub(bus, poll_hz=50, read_only=read_only)
    loop = asyncio.new_event_loop()
    ready = threading.Event()
    box: dict[str, Any] = {}

    def on_ready(url: str) -> None:
        box["url"] = url
        ready.set()

    def main() -> None:
        asyncio.set_event_loop(loop)
        dash = Dashboard(hub, **kwargs)
        box["dash"] = dash
        try:
            loop.run_until_complete(dash.serve("127.0.0.1", 0, on_ready))
        finally:
            loop.close()

    t = threading.Thread(target=main, name="dashboard", daemon=True)
    t.start()
    assert ready.wait(10), "the dashboard did not start"
    return box["url"], hub, box["dash"], loop, t


@pytest.fixture(scope="module")
def served() -> Iterator[Served]:
    bus = open_bus("sim", motors=[1, 2, 3], stop_on_close=False)
    url, hub, dash, loop, thread = serve_in_thread(bus)
    try:
        yield Served(url, bus, bus.transport.bus, hub, dash, loop)  # type: ignore[attr-defined]
    finally:
        loop.call_soon_threadsafe(dash.stopping.set)
        thread.join(10)
        hub.close()
        bus.close()


@pytest.fixture(scope="module")
def browser() -> Iterator[Any]:
    sync_api = pytest.importorskip("playwright.sync_api")
    if not (os.path.exists(CHROMIUM) or shutil.which(CHROMIUM)):
        if os.environ.get("CI"):
            pytest.fail(f"{CHROMIUM} is missing (make test installs Debian's chromium)")
        pytest.skip(f"{CHROMIUM} is missing: apt-get install chromium")
    with sync_api.sync_playwright() as pw:
        b = pw.chromium.launch(executable_path=CHROMIUM, headless=True, args=CHROMIUM_ARGS)
        try:
            yield b
        finally:
            b.close()


@pytest.fixture
def page(browser: Any, served: Served) -> Iterator[Any]:
    ctx = browser.new_context(viewport={"width": 1100, "height": 640}, accept_downloads=True)
    p = ctx.new_page()
    p.set_default_timeout(10_000)
    errors: list[str] = []
    p.on("pageerror", lambda e: errors.append(str(e)))
    p.goto(served.url)
    p.wait_for_function("window.dashStats && window.dashStats.connected")
    try:
        yield p
    finally:
        ctx.close()
        deadline = time.monotonic() + 5  # the server's "disconnected" line belongs to this test
        while served.dash.clients and time.monotonic() < deadline:
            time.sleep(0.01)
        STDERR.flush_for(2.0)
    assert not errors, f"errors in the page: {errors}"


@pytest.fixture(scope="module")
def shots(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Where screenshots go: docs/img with DREMPOWER_SCREENSHOTS=1, else a temporary folder."""
    if os.environ.get("DREMPOWER_SCREENSHOTS"):
        out = REPO_ROOT / "docs" / "img"
        out.mkdir(parents=True, exist_ok=True)
        return out
    return tmp_path_factory.mktemp("shots")
