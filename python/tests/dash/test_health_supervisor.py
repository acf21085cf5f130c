"""The dashboard over a robot file with ``[health]`` (``drempower dash --robot FILE``): the supervisor runs on its
own, the cards and the Health view carry its level per joint and its events with what it did, the log names them."""

from __future__ import annotations

import logging
import time
from pathlib import Path
from typing import Any

import pytest

from drempower import open_robot
from drempower.dash.hub import Hub
from drempower.protocol.enums import AxisState

ROBOT = """
[buses.can0]
interface = "sim"
[joints.shoulder]
bus = "can0"
id = 1
on_overheat = "idle"
[joints.elbow]
bus = "can0"
id = 2
[health]
period = 0.05
"""


def test_the_robot_dashboard_shows_the_supervisors_level_and_events(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    caplog.set_level(logging.INFO, "drempower.dash")
    path = tmp_path / "robot.toml"
    path.write_text(ROBOT)
    robot = open_robot(path, stop_on_close=False)
    hub = Hub(robot)
    try:
        hub.do_scan(lambda *_: None)
        sim = robot.bus("can0").transport.bus  # type: ignore[attr-defined]
        with sim.lock:
            sim.motors[1].thermal.winding = 91.0  # 4 K below the firmware's derating
        end = time.monotonic() + 20.0
        while time.monotonic() < end and not hub.health_events:
            time.sleep(0.02)
        cards = hub.do_cards()
        assert cards[1]["level"] == "warn" and cards[2]["level"] == "ok"
        (event,) = cards[1]["events"]
        assert (event["kind"], event["action"]) == ("overheat", "idle")
        assert (
            event["text"].startswith("joint shoulder (motor 1): the winding at 9")
            and "Released it (idle)" in event["text"]
        )
        assert cards[2]["events"] == []
        assert sim.motors[1].state == AxisState.IDLE  # the file's action for this joint, with no page open
        assert any("health: joint shoulder (motor 1)" in r.getMessage() for r in caplog.records)
    finally:
        hub.close()
        robot.close()
    assert robot.health_run is not None and not robot.health_run.running


def test_the_health_view_in_chromium_shows_what_the_supervisor_did(tmp_path: Path, browser: Any) -> None:
    from .conftest import serve_in_thread

    path = tmp_path / "robot.toml"
    path.write_text(ROBOT.replace("period = 0.05", "period = 0.2"))
    robot = open_robot(path, stop_on_close=False)
    url, hub, dash, loop, thread = serve_in_thread(robot)
    ctx = browser.new_context(viewport={"width": 1100, "height": 640})
    try:
        page = ctx.new_page()
        page.set_default_timeout(20_000)
        page.goto(url)
        page.wait_for_function("window.dashStats && window.dashStats.connected")
        page.get_by_role("tab", name="Health").click()
        page.wait_for_function("document.querySelectorAll('#health-table tbody tr').length === 2")
        sim = robot.bus("can0").transport.bus  # type: ignore[attr-defined]
        with sim.lock:
            sim.motors[1].thermal.winding = 91.0
        page.wait_for_function(
            'document.querySelector(\'#health-table tr[data-id="1"] .event[data-action="idle"]\') !== null'
        )
        row1 = page.locator('#health-table tr[data-id="1"]')
        assert row1.get_attribute("class") == "health-warn"
        assert "joint shoulder (motor 1)" in row1.inner_text() and "Released it (idle)" in row1.inner_text()
        row2 = page.locator('#health-table tr[data-id="2"]')
        assert row2.get_attribute("class") == "health-ok" and row2.locator(".event").count() == 0
    finally:
        ctx.close()
        loop.call_soon_threadsafe(dash.stopping.set)
        thread.join(10)
        hub.close()
        robot.close()


def test_events_from_before_the_dashboard_listened_are_shown_once(tmp_path: Path) -> None:
    path = tmp_path / "robot.toml"
    path.write_text(ROBOT.replace("period = 0.05", "period = 0.05\nwarn_c = 20.0"))  # the room is "hot"
    robot = open_robot(path, stop_on_close=False)
    try:
        run = robot.health_run
        assert run is not None
        end = time.monotonic() + 20.0
        while time.monotonic() < end and len(run.events) < 2:
            time.sleep(0.02)
        early = list(run.events)
        assert {e.joint for e in early} == {"shoulder", "elbow"} and all(e.kind == "hot" for e in early)
        hub = Hub(robot)
        try:
            time.sleep(0.3)  # more steps: nothing new begins
            assert [e for _, _, e in hub.health_events] == early
        finally:
            hub.close()
    finally:
        robot.close()
