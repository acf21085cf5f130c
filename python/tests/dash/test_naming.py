"""The dashboard names motors by the one naming rule and its CSV has the columns of monitor and state --json."""

from __future__ import annotations

import csv
import io
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from drempower import open_robot
from drempower.naming import COLUMNS, TIME_COLUMN

from .conftest import Served, serve_in_thread

HEADER = [
    TIME_COLUMN[0],
    *(COLUMNS[c][0] for c in ("id",)),
    "name",
    *(COLUMNS[c][0] for c in ("position", "speed", "torque", "done", "error")),
    *("target_" + COLUMNS[c][0] for c in ("position", "speed", "torque")),
    "units",
]
"""The CSV's header: the keys (with units) of ``monitor --csv`` and ``state --json``, the motor's name, and
``units`` as ``state --json --robot`` says it (``joint``: at the joint, ``motor``: the motor's)."""


def test_the_header_is_that_of_monitor_and_state() -> None:
    assert HEADER == [
        "time_s",
        "id",
        "name",
        "position_deg",
        "speed_rpm",
        "torque_nm",
        "done",
        "error",
        "target_position_deg",
        "target_speed_rpm",
        "target_torque_nm",
        "units",
    ]


def _labels_and_csv(p: Any, names: list[str]) -> tuple[dict[str, list[str]], list[str], list[dict[str, str]]]:
    """Scan, then what the page labels its motors ``names`` with (cards, selects, legend) and its CSV export."""
    cards = len(names)
    p.get_by_role("tab", name="Bus").click()
    p.get_by_role("button", name="Rescan ids 1-63").click()
    p.wait_for_function("document.querySelector('#scan-text').textContent.startsWith('done')")
    p.wait_for_function(f"document.querySelectorAll('.card').length === {cards}")
    labels = {
        "cards": p.locator(".card h3").all_inner_texts(),
        "scan": [p.locator("#scan-text").inner_text()],
    }
    p.get_by_role("tab", name="Control").click()
    labels["control"] = p.locator("#ctl-motor option").all_inner_texts()
    p.get_by_role("tab", name="Plots").click()
    p.wait_for_function("window.dashStats.received > 50")
    shown = " && ".join(f"t.includes('{n}:')" for n in names)  # the rates of every motor, once samples came
    p.wait_for_function(f"(t => {shown})(document.querySelector('#plot-per-motor').textContent)")
    labels["legend"] = p.locator(".u-legend .u-series .u-label").all_inner_texts()
    labels["per_motor"] = [p.locator("#plot-per-motor").inner_text()]
    with p.expect_download() as dl:
        p.get_by_role("button", name="Export CSV").click()
    text = Path(dl.value.path()).read_text()
    header = text.splitlines()[0].split(",")
    return labels, header, list(csv.DictReader(io.StringIO(text)))


def test_a_plain_bus_names_its_motors_motor_id(page: Any, served: Served) -> None:
    names = ["motor_1", "motor_2", "motor_3"]
    labels, header, rows = _labels_and_csv(page, names)
    assert labels["cards"] == names
    assert labels["scan"] == ["done: 3 motor(s): motor_1, motor_2, motor_3"]
    assert labels["control"] == names
    assert {"motor_1 angle", "motor_2 angle", "motor_3 angle"} <= set(labels["legend"])
    assert all(f"{n}:" in labels["per_motor"][0] for n in names)
    assert not any(label.startswith(("Motor ", "m1 ", "m2 ")) for got in labels.values() for label in got)
    assert header == HEADER
    assert {r["name"] for r in rows} == set(names)
    assert all(r["name"] == f"motor_{r['id']}" for r in rows)
    assert {r["units"] for r in rows} == {"motor"}  # bare motors: the motor's units
    assert all(float(r["time_s"]) >= 0 and r["position_deg"] != "" for r in rows)


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
"""


@pytest.fixture
def robot_url(tmp_path: Path) -> Iterator[str]:
    path = tmp_path / "robot.toml"
    path.write_text(ROBOT)
    robot = open_robot(path, stop_on_close=False)
    url, hub, dash, loop, thread = serve_in_thread(robot)
    try:
        yield url
    finally:
        loop.call_soon_threadsafe(dash.stopping.set)
        thread.join(10)
        hub.close()
        robot.close()


def test_a_robot_files_joint_names_label_its_motors(browser: Any, robot_url: str) -> None:
    ctx = browser.new_context(viewport={"width": 1100, "height": 640}, accept_downloads=True)
    try:
        p = ctx.new_page()
        p.set_default_timeout(10_000)
        p.goto(robot_url)
        p.wait_for_function("window.dashStats && window.dashStats.connected")
        labels, header, rows = _labels_and_csv(p, ["shoulder", "elbow"])
    finally:
        ctx.close()
    assert labels["cards"] == ["shoulder bus left, id 1", "elbow bus right, id 1"]
    assert labels["scan"] == ["done: 2 motor(s): shoulder, elbow"]
    assert labels["control"] == ["shoulder", "elbow"]
    assert {"shoulder angle", "elbow angle"} <= set(labels["legend"])
    assert "shoulder:" in labels["per_motor"][0] and "elbow:" in labels["per_motor"][0]
    assert header == HEADER
    assert {(r["name"], r["id"]) for r in rows} == {("shoulder", "1"), ("elbow", "1")}
    assert {r["units"] for r in rows} == {"joint"}  # a robot file's joints: at the joint
