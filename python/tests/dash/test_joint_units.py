"""The dashboard on a robot file takes and shows a joint in the joint's units (deg, r/min and Nm at the
joint: its gear and offset applied), a bare motor in the motor's: the controls, the samples and their
targets, the limits, the refusals and the Tuning step; the page says which (``drempower dash --robot``)."""

from __future__ import annotations

import math
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

pytest.importorskip("aiohttp")

from drempower import open_robot
from drempower.dash.hub import Hub

from .conftest import serve_in_thread
from .test_browser import eventually

ROBOT = """
[buses.left]
interface = "sim"
[buses.right]
interface = "sim"
[joints.shoulder]
bus = "left"
id = 1
gear = 2.0
offset = 0.1
[joints.elbow]
bus = "right"
id = 1
"""
SHOULDER, ELBOW = 1, 65
OFFSET_DEG = math.degrees(0.1)


def motor_deg(joint_deg: float) -> float:
    """Where the shoulder's motor is when the joint is at ``joint_deg``."""
    return (joint_deg - OFFSET_DEG) * 2.0


@pytest.fixture
def geared(tmp_path: Path) -> Iterator[tuple[Any, Hub]]:
    path = tmp_path / "robot.toml"
    path.write_text(ROBOT)
    robot = open_robot(path, stop_on_close=False)
    hub = Hub(robot, poll_hz=50)
    try:
        hub.do_scan(lambda *a: None)
        yield robot, hub
    finally:
        hub.close()
        robot.close()


def _sim(robot: Any, bus: str) -> Any:
    return robot.buses[bus].transport.bus.motors[1]


def test_the_controls_take_degrees_at_the_joint_and_the_samples_show_them(geared: tuple[Any, Hub]) -> None:
    robot, hub = geared
    names = hub.names()
    assert names[SHOULDER]["units"] == "joint" and names[SHOULDER]["gear"] == 2.0
    assert names[SHOULDER]["offset_deg"] == pytest.approx(OFFSET_DEG)
    hub.do_control("t", {"action": "enable", "id": SHOULDER})
    hub.do_control("t", {"action": "Q", "id": SHOULDER, "angle": 30, "speed": 30, "param": 100})
    sim = _sim(robot, "left")
    assert eventually(lambda: abs(sim.position - motor_deg(30)) < 0.2, 15), sim.position  # 48.5 deg at the motor
    time.sleep(0.2)
    rows = [r for r in hub.take_samples() if r[0] == SHOULDER]
    assert rows and rows[-1][2] == pytest.approx(30, abs=0.2)  # the sample at the joint
    assert rows[-1][6] == pytest.approx(30)  # and its target
    # a jog at the joint: 5 deg there is 10 at the motor
    hub.do_control("t", {"action": "jog", "id": SHOULDER, "delta": 5, "speed": 30, "param": 100})
    assert eventually(lambda: abs(sim.position - motor_deg(35)) < 0.2, 15), sim.position
    # the limits the page shows are at the joint: half the motor's speed and twice its torque
    shown, motor = hub.shown_limits(SHOULDER), hub.limits[SHOULDER]
    assert shown is not None and shown["units"] == "joint"
    assert shown["speed"] == pytest.approx(motor["speed"] / 2) and shown["torque"] == pytest.approx(motor["torque"] * 2)
    # refusals in the units typed: beyond the motor's speed limit, and beyond what the wire holds
    half = motor["speed"] / 2
    with pytest.raises(Exception) as err:
        hub.do_control("t", {"action": "V", "id": SHOULDER, "speed": half + 10})  # 20 r/min too fast at the motor
    text = str(err.value)
    assert f"speed={half + 10:g}: outside -{half:g}..{half:g} r/min at the joint" in text and "shoulder" in text, text
    with pytest.raises(Exception) as err:
        hub.do_control("t", {"action": "V", "id": SHOULDER, "speed": 200})  # 400 at the motor: no such value
    text = str(err.value)
    assert "speed=200 at the joint" in text and "-163.84..163.835 at the joint" in text, text
    assert hub.targets[SHOULDER][1] is None  # nothing sent: the jog's target stands, no speed target


def test_the_tuning_step_of_a_joint_is_at_the_joint(geared: tuple[Any, Hub]) -> None:
    robot, hub = geared
    hub.do_control("t", {"action": "enable", "id": SHOULDER})
    hub.do_control("t", {"action": "Q", "id": SHOULDER, "angle": 20, "speed": 30, "param": 100})
    sim = _sim(robot, "left")
    assert eventually(lambda: abs(sim.position - motor_deg(20)) < 0.2, 15), sim.position
    r = hub.do_step("t", {"id": SHOULDER, "mode": "position", "amplitude": 10, "duration": 1.5, "bandwidth": 20})
    assert r["units"] == "joint"
    assert r["base"] == pytest.approx(20, abs=0.3) and r["target"] == pytest.approx(r["base"] + 10)
    assert r["y"][-1] == pytest.approx(r["target"], abs=0.5)  # the trace at the joint
    assert sim.position == pytest.approx(motor_deg(r["target"]), abs=1.0)  # 20 deg more at the motor


def test_the_page_takes_and_shows_the_shoulder_at_the_joint(browser: Any, tmp_path: Path, shots: Path) -> None:
    """In Chromium: the Control view says its units are the joint's, its limits are at the joint, a Move
    to 30 deg puts the 2:1 shoulder (offset 0.1 rad) there, the plotted state and the CSV are at the
    joint and say so; the Tuning view's amplitude is at the joint."""
    path = tmp_path / "robot.toml"
    path.write_text(ROBOT)
    robot = open_robot(path, stop_on_close=False)
    url, hub, dash, loop, thread = serve_in_thread(robot)
    ctx = browser.new_context(viewport={"width": 1100, "height": 700}, accept_downloads=True)
    try:
        p = ctx.new_page()
        p.set_default_timeout(10_000)
        p.goto(url)
        p.wait_for_function("window.dashStats && window.dashStats.connected")
        p.get_by_role("button", name="Rescan ids 1-63").click()
        p.wait_for_function("document.querySelector('#scan-text').textContent.startsWith('done')")
        p.get_by_role("tab", name="Control").click()
        p.locator("#ctl-motor").select_option(label="shoulder")
        p.wait_for_function("document.querySelector('#ctl-limits').textContent.includes('limits of')")
        units = p.locator("#ctl-units").inner_text()
        assert "at the joint (gear 2, offset 5.72958 deg: motor angle = (joint angle - offset) x gear)" in units, units
        limits = p.locator("#ctl-limits").inner_text()
        speed = hub.limits[SHOULDER]["speed"] / 2
        assert "limits of shoulder at the joint:" in limits and f"speed ±{speed:.6g} r/min" in limits, limits
        p.get_by_role("button", name="Enable").first.click()
        p.locator("#pos-angle").fill("30")
        p.locator("#pos-speed").fill("30")
        p.get_by_role("button", name="Move", exact=True).click()
        sim = _sim(robot, "left")
        assert eventually(lambda: abs(sim.position - motor_deg(30)) < 0.3, 15), (
            sim.position,
            p.locator("#msg").inner_text(),
        )
        p.wait_for_function("document.querySelector('#ctl-state').textContent.includes('angle 30.0')")
        assert p.locator("#ctl-state").inner_text().startswith("at the joint: angle 30.0")
        p.screenshot(path=str(shots / "dash-robot-joint-units.png"))
        p.get_by_role("tab", name="Plots").click()
        with p.expect_download() as got:
            p.locator("#plot-csv").click()
        lines = Path(got.value.path()).read_text().splitlines()
        assert lines[0].endswith(",units"), lines[0]
        last = [x for x in lines[1:] if x.split(",")[2] == "shoulder"][-1].split(",")
        assert float(last[3]) == pytest.approx(30, abs=0.3) and last[-1] == "joint", last
        p.get_by_role("tab", name="Tuning").click()
        p.locator("#tun-motor").select_option(label="shoulder")
        p.wait_for_function("document.querySelector('#tun-amp-label').textContent.includes('at the joint')")
    finally:
        ctx.close()
        loop.call_soon_threadsafe(dash.stopping.set)
        thread.join(10)
        hub.close()
        robot.close()
