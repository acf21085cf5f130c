"""The dashboard over a robot of two simulated buses (``drempower dash --robot FILE``)."""

from __future__ import annotations

import asyncio
import contextlib
import json
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

aiohttp = pytest.importorskip("aiohttp")

from drempower import open_robot  # noqa: E402
from drempower.protocol.enums import AxisState  # noqa: E402

from .conftest import serve_in_thread  # noqa: E402
from .test_browser import eventually  # noqa: E402

ROBOT = """
[buses.left]
interface = "sim"
[buses.right]
interface = "sim"
[joints.shoulder]
bus = "left"
id = 1
[joints.elbow]
bus = "right"
id = 1
[joints.wrist]
bus = "right"
id = 2
"""
SHOULDER, ELBOW, WRIST = 1, 65, 66
"""Their keys on the page: bus index * 64 + motor id (the left and right buses both have a motor 1)."""


@pytest.fixture
def robot_file(tmp_path: Path) -> Path:
    path = tmp_path / "robot.toml"
    path.write_text(ROBOT)
    return path


@pytest.fixture
def served_robot(robot_file: Path) -> Iterator[tuple[str, Any, Any, dict[int, Any]]]:
    robot = open_robot(robot_file, stop_on_close=False)
    url, hub, dash, loop, thread = serve_in_thread(robot)
    sims = {
        SHOULDER: robot.buses["left"].transport.bus.motors[1],
        ELBOW: robot.buses["right"].transport.bus.motors[1],
        WRIST: robot.buses["right"].transport.bus.motors[2],
    }
    try:
        yield url, hub, robot, sims
    finally:
        loop.call_soon_threadsafe(dash.stopping.set)
        thread.join(10)
        hub.close()
        robot.close()


async def test_a_robot_dashboard_keys_motors_by_bus_controls_by_joint_and_stops_every_bus(
    served_robot: tuple[str, Any, Any, dict[int, Any]],
) -> None:
    url, hub, _, sims = served_robot
    async with aiohttp.ClientSession() as s, s.ws_connect(url.replace("http:", "ws:") + "ws") as ws:
        hello = await ws.receive_json(timeout=5)
        at_joint = {"units": "joint", "gear": 1.0, "offset_deg": 0.0}  # the page's units: at each joint
        assert hello["names"] == {
            "1": {"name": "shoulder", "joint": "shoulder", "bus": "left", "id": 1, **at_joint},
            "65": {"name": "elbow", "joint": "elbow", "bus": "right", "id": 1, **at_joint},
            "66": {"name": "wrist", "joint": "wrist", "bus": "right", "id": 2, **at_joint},
        }
        assert hello["bus"].startswith("robot ") and "left: " in hello["bus"] and "right: " in hello["bus"]
        seen: set[int] = set()

        async def ask(req: int, **msg: object) -> dict[str, Any]:
            await ws.send_json({"req": req, **msg})
            while True:
                await ws.send_json({"op": "hb"})
                m: dict[str, Any] = await ws.receive_json(timeout=10)
                if m["t"] == "samples":
                    seen.update(row[0] for row in m["s"])
                if m["t"] == "reply" and m["req"] == req:
                    return m

        async def tick() -> None:
            """The page's heartbeat, and what arrives meanwhile (for up to 0.1 s)."""
            await ws.send_json({"op": "hb"})
            with contextlib.suppress(asyncio.TimeoutError):
                m = await ws.receive_json(timeout=0.1)
                if m["t"] == "samples":
                    seen.update(row[0] for row in m["s"])

        r = await ask(1, op="scan")
        assert [(f["id"], f["bus"], f["motor"], f["joint"]) for f in r["result"]] == [
            (SHOULDER, "left", 1, "shoulder"),
            (ELBOW, "right", 1, "elbow"),
            (WRIST, "right", 2, "wrist"),
        ]
        # control by key: the elbow (motor 1 of the right bus) runs, the shoulder (motor 1 of the left) does not
        assert (await ask(2, op="control", action="V", id=ELBOW, speed=20))["ok"]
        deadline = time.monotonic() + 5
        while abs(sims[ELBOW].speed - 20) > 1 and time.monotonic() < deadline:
            await tick()
        assert abs(sims[ELBOW].speed - 20) <= 1 and abs(sims[SHOULDER].speed) < 0.01
        assert hub.commanded == {ELBOW}
        # a synchronised move across the two buses, by joint
        r = await ask(4, op="control", action="sync_move", ids=[SHOULDER, WRIST], angles=[10, 20], speed=60, accel=100)
        assert r["ok"], r
        deadline = time.monotonic() + 8
        while time.monotonic() < deadline and not (
            abs(sims[SHOULDER].position - 10) < 0.1 and abs(sims[WRIST].position - 20) < 0.1
        ):
            await tick()
        assert abs(sims[SHOULDER].position - 10) < 0.1 and abs(sims[WRIST].position - 20) < 0.1
        assert {SHOULDER, ELBOW, WRIST} <= seen  # samples of every motor of both buses, by key
        # a key of no bus, refused
        r = await ask(6, op="control", action="V", id=129, speed=5)
        assert not r["ok"] and "id=129" in r["error"]
        # ESTOP: every motor of both buses
        assert (await ask(7, op="estop"))["ok"]
        stopped = lambda: all(m.state != AxisState.CLOSED_LOOP_CONTROL and abs(m.speed) < 1 for m in sims.values())  # noqa: E731
        assert eventually(stopped, 2), [(m.state, m.speed) for m in sims.values()]


def test_dash_takes_a_robot_file(robot_file: Path) -> None:
    p = subprocess.Popen(
        [sys.executable, "-m", "drempower", "dash", "--port", "0", "--json", "--robot", str(robot_file)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        assert p.stdout is not None
        url = json.loads(p.stdout.readline())["url"]

        async def hello() -> dict[str, Any]:
            async with aiohttp.ClientSession() as s, s.ws_connect(url.replace("http:", "ws:") + "ws") as ws:
                return dict(await ws.receive_json(timeout=5))

        h = asyncio.run(hello())
        assert sorted(n["joint"] for n in h["names"].values()) == ["elbow", "shoulder", "wrist"]
        p.send_signal(signal.SIGTERM)
        assert p.wait(10) == 128 + signal.SIGTERM
    finally:
        if p.poll() is None:
            p.kill()
        p.communicate(timeout=10)


def test_robot_conflicts_with_another_connection(robot_file: Path) -> None:
    r = subprocess.run(
        [sys.executable, "-m", "drempower", "dash", "--port", "0", "--robot", str(robot_file), "--sim", "1"],
        capture_output=True,
        text=True,
        timeout=30,
    )
    assert r.returncode == 2 and "--robot and --sim conflict" in r.stderr and "Traceback" not in r.stderr


def test_the_robot_page_names_joints_and_its_estop_stops_both_buses(
    browser: Any, served_robot: tuple[str, Any, Any, dict[int, Any]], shots: Path
) -> None:
    url, _, robot, sims = served_robot
    ctx = browser.new_context(viewport={"width": 1100, "height": 640})
    try:
        p = ctx.new_page()
        p.set_default_timeout(10_000)
        p.goto(url)
        p.wait_for_function("window.dashStats && window.dashStats.connected")
        p.get_by_role("button", name="Rescan ids 1-63").click()
        p.wait_for_function("document.querySelector('#scan-text').textContent.startsWith('done')")
        assert p.locator("#scan-text").inner_text() == "done: 3 motor(s): shoulder, elbow, wrist"
        p.wait_for_function("document.querySelectorAll('.card').length === 3")
        assert p.locator(".card h3").all_inner_texts() == [
            "shoulder bus left, id 1",
            "elbow bus right, id 1",
            "wrist bus right, id 2",
        ]
        p.screenshot(path=str(shots / "dash-robot.png"))
        p.get_by_role("tab", name="Control").click()
        options = p.locator("#ctl-motor option")
        assert options.all_inner_texts() == ["shoulder", "elbow", "wrist"]
        p.locator("#ctl-motor").select_option(label="elbow")
        p.locator("#vel-speed").fill("30")
        p.get_by_role("button", name="Run").click()
        assert eventually(lambda: abs(sims[ELBOW].speed - 30) < 1, 5), sims[ELBOW].speed
        assert abs(sims[SHOULDER].speed) < 0.01
        robot.joint("shoulder").set_speed(-20)  # a motor of the other bus, moving too
        assert eventually(lambda: abs(sims[SHOULDER].speed + 20) < 1, 5)
        p.get_by_role("button", name="ESTOP").click()
        stopped = lambda: all(m.state != AxisState.CLOSED_LOOP_CONTROL and abs(m.speed) < 1 for m in sims.values())  # noqa: E731
        assert eventually(stopped, 2), [(m.state, m.speed) for m in sims.values()]
    finally:
        ctx.close()


def test_the_dashboards_end_holds_a_joint_that_holds_and_idles_one_that_says_idle(tmp_path: Path) -> None:
    """Its way out (SIGTERM, the last page gone): a robot file's joints do their on_timeout; an arm is not dropped."""
    from drempower.dash.hub import Hub

    path = tmp_path / "robot.toml"
    path.write_text(
        ROBOT.replace(
            '[joints.wrist]\nbus = "right"\nid = 2\n', '[joints.wrist]\nbus = "right"\nid = 2\non_timeout = "idle"\n'
        )
    )
    with open_robot(path, stop_on_close=False) as robot:
        hub = Hub(robot)
        try:
            robot.joint("shoulder").set_speed(20, enable=True)
            robot.joint("wrist").set_speed(20, enable=True)
            hub.commanded.update({SHOULDER, WRIST})
            assert sorted(hub.idle_commanded("SIGTERM")) == [SHOULDER, WRIST]
            shoulder = robot.buses["left"].transport.bus.motors[1]
            wrist = robot.buses["right"].transport.bus.motors[2]
            deadline = time.monotonic() + 5
            while time.monotonic() < deadline and not (abs(shoulder.speed) < 0.5 and wrist.state == AxisState.IDLE):
                time.sleep(0.02)
            assert shoulder.state == AxisState.CLOSED_LOOP_CONTROL and abs(shoulder.speed) < 0.5  # held
            assert wrist.state == AxisState.IDLE
        finally:
            hub.close()


@pytest.fixture
def limited_robot(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Iterator[tuple[str, Any, Path]]:
    """The robot with limits on its elbow, served (opened outside the test's event loop), by a relative path."""
    monkeypatch.chdir(tmp_path)
    path = Path("robot.toml")
    path.write_text(
        ROBOT.replace(
            '[joints.elbow]\nbus = "right"\nid = 1\n',
            '[joints.elbow]\nbus = "right"\nid = 1\nlimits = { position = [-1.0, 1.0], speed = 2.0 }\n',
        )
    )
    robot = open_robot(path, stop_on_close=False)
    url, hub, dash, loop, thread = serve_in_thread(robot)
    try:
        yield url, hub, path
    finally:
        loop.call_soon_threadsafe(dash.stopping.set)
        thread.join(10)
        hub.close()
        robot.close()


def test_a_robot_dashboard_takes_the_files_limits_and_names_the_joint_in_its_messages(
    limited_robot: tuple[str, Any, Path],
) -> None:
    """The Control view's limits are the robot file's (speed 2 rad/s at the elbow: 19.1 r/min, not the
    motor's 300); a refusal names the joint; the idle hint is a command that works (--robot). (Its own
    event loop in a thread of its own: a browser test before it keeps the main thread's.)"""
    errors: list[BaseException] = []

    def run() -> None:
        try:
            asyncio.run(_limits_and_words(*limited_robot))
        except BaseException as exc:
            errors.append(exc)

    th = threading.Thread(target=run)
    th.start()
    th.join(60)
    if errors:
        raise errors[0]


async def _limits_and_words(url: str, hub: Any, path: Path) -> None:
    async with aiohttp.ClientSession() as s, s.ws_connect(url.replace("http:", "ws:") + "ws") as ws:
        await ws.receive_json(timeout=5)

        async def ask(req: int, **msg: object) -> dict[str, Any]:
            await ws.send_json({"req": req, **msg})
            while True:
                await ws.send_json({"op": "hb"})
                m: dict[str, Any] = await ws.receive_json(timeout=10)
                if m["t"] == "reply" and m["req"] == req:
                    return m

        assert (await ask(1, op="scan"))["ok"]
        limits = hub.limits[ELBOW]
        assert limits["speed"] == pytest.approx(2.0 * 60 / (2 * 3.141592653589793), rel=1e-6)
        assert limits["position"] == pytest.approx([-57.29578, 57.29578], rel=1e-5)
        assert "[joints.elbow] limits" in limits["set_by"]["speed"]
        r = await ask(2, op="control", action="V", id=ELBOW, speed=25)
        assert not r["ok"] and "elbow (bus right, motor 1)" in r["error"] and "[joints.elbow] limits" in r["error"]
        assert (await ask(3, op="control", action="idle", id=WRIST))["ok"]
        r = await ask(4, op="control", action="V", id=WRIST, speed=5)
        assert not r["ok"] and f"drempower enable wrist --robot {path}" in r["error"], r["error"]


def test_the_control_view_on_a_robot_shows_the_files_limits_and_its_default_move_passes(
    browser: Any, limited_robot: tuple[str, Any, Path], shots: Path
) -> None:
    """In Chromium: the limits line of the elbow is the robot file's, the default Move is within them and
    accepted, and a message is cleared when the view changes."""
    url, hub, path = limited_robot
    ctx = browser.new_context(viewport={"width": 1100, "height": 700})
    try:
        p = ctx.new_page()
        p.set_default_timeout(10_000)
        p.goto(url)
        p.wait_for_function("window.dashStats && window.dashStats.connected")
        p.get_by_role("button", name="Rescan ids 1-63").click()
        p.wait_for_function("document.querySelector('#scan-text').textContent.startsWith('done')")
        p.get_by_role("tab", name="Control").click()
        p.locator("#ctl-motor").select_option(label="elbow")
        p.wait_for_function("document.querySelector('#ctl-limits').textContent.includes('position')")
        limits = p.locator("#ctl-limits").inner_text()
        assert "position -57.2958..57.2958 deg, speed ±19.0986 r/min" in limits, limits
        assert f"set by {path}: [joints.elbow] limits" in limits, limits
        assert float(p.locator("#pos-speed").input_value()) <= 19.0986  # the default 20 brought within
        assert float(p.locator("#pos-angle").input_value()) <= 57.2958  # the default 90 brought within
        p.get_by_role("button", name="Enable").first.click()
        p.get_by_role("button", name="Move", exact=True).click()
        assert eventually(lambda: ELBOW in hub.commanded, 5), p.locator("#msg").inner_text()
        p.screenshot(path=str(shots / "dash-robot-limits.png"))
        p.locator("#pos-speed").fill("200")  # refused in the page, beyond the file's limit
        p.get_by_role("button", name="Move", exact=True).click()
        p.wait_for_function("document.querySelector('#msg').textContent !== ''")
        p.get_by_role("tab", name="Plots").click()
        assert p.locator("#msg").inner_text() == ""  # the message belonged to the Control view
    finally:
        ctx.close()
