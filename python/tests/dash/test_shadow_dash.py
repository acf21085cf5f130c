"""The dashboard with the shadow twin (``drempower dash --robot FILE --shadow``): the 3D view draws the twin as a
second, translucent arm beside the robot, the plots each motor's twin angle beside its own, and a divergence (a
contact the model lacks) is shown on the page, written to the log, and acts as the robot file says (here: the
shoulder holds)."""

from __future__ import annotations

import logging
import math
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import pytest

pytest.importorskip("aiohttp")
pytest.importorskip("mujoco")

from drempower import open_robot

from ..conftest import REPO_ROOT
from .conftest import serve_in_thread
from .test_browser import eventually

ROBOTS = REPO_ROOT / "examples" / "robots"


def _real_arm(tmp: Path) -> Path:
    """arm6 with a rigid ball the twin's model lacks (the upper arm meets it near 0.57 rad); the shoulder's
    on_divergence is "hold", the others' the default ("warn")."""
    root = ET.parse(ROBOTS / "arm6.xml").getroot()
    world = root.find("worldbody")
    assert world is not None
    ET.SubElement(
        world, "geom", name="obstacle", type="sphere", size="0.05", pos="0.25 0 0.45", contype="0", conaffinity="1"
    )
    model = tmp / "real.xml"
    ET.ElementTree(root).write(model)
    text = (ROBOTS / "arm6.toml").read_text().replace('file = "arm6.xml"', f'file = "{model}"')
    robot = tmp / "real.toml"
    robot.write_text(text.replace("[joints.shoulder]\n", '[joints.shoulder]\non_divergence = "hold"\n'))
    return robot


def test_the_shadow_is_drawn_and_a_divergence_is_shown_logged_and_held(
    browser: Any, tmp_path: Path, shots: Path, caplog: pytest.LogCaptureFixture
) -> None:
    caplog.set_level(logging.INFO, logger="drempower.dash")
    robot = open_robot(_real_arm(tmp_path), stop_on_close=False)
    shadow = robot.shadow(model=str(ROBOTS / "arm6.xml"))
    url, hub, dash, loop, thread = serve_in_thread(robot, shadow=shadow)
    ctx = browser.new_context(viewport={"width": 800, "height": 500})
    try:
        p = ctx.new_page()
        p.set_default_timeout(15_000)
        p.goto(url)
        p.get_by_role("button", name="Scan ids 1-63").click()
        p.wait_for_function("document.querySelector('#scan-text').textContent.startsWith('done')")
        p.get_by_role("tab", name="3D").click()
        p.wait_for_function("window.drempowerView && window.drempowerView.ready && window.drempowerView.shadow")
        assert p.locator("#shadow-note").is_hidden()
        # the twin's arm follows the robot's where the model is right: the elbow moves, both arms show it
        robot.joint("elbow").set_position(-0.5)

        def elbows() -> tuple[float, float, float]:
            drawn, ghost = p.evaluate("[window.drempowerView.jointAngles(), window.drempowerView.shadowAngles()]")
            return drawn["elbow"], ghost["elbow"], math.degrees(shadow.twin_positions()["elbow"])

        assert eventually(lambda: abs(elbows()[1] + 28.6) < 2.0, 10), elbows()
        drawn, ghost, twin = elbows()
        assert abs(ghost - twin) < 2.0 and abs(drawn - ghost) < 2.0
        assert shadow.events == []
        # the plots: each motor's twin angle as a series beside its own
        p.get_by_role("tab", name="Plots").click()
        p.wait_for_function("window.dashPlot && window.dashPlot.series.some(s => s.label.endsWith('angle twin'))")
        drawn_twin = (
            "(() => { const k = window.dashPlot.series.findIndex(s => s.label.endsWith('angle twin'));"
            " return window.dashPlot.data[k].filter(v => v !== null).length; })()"
        )
        assert eventually(lambda: p.evaluate(drawn_twin) > 0, 5)
        labels = p.evaluate("window.dashPlot.series.map(s => s.label)")
        assert sum(label.endswith("angle twin") for label in labels) == 6, labels
        p.get_by_role("tab", name="3D").click()
        # into the ball the twin lacks: flagged, on the page and in the log, and the shoulder holds
        robot.joint("shoulder").set_position(0.8, bandwidth=5.0)
        p.wait_for_function("!document.querySelector('#shadow-note').hidden")
        note = p.locator("#shadow-note").inner_text()
        assert "joint 'shoulder' diverges from its twin: position residual" in note and note.endswith("; hold"), note
        assert "shoulder" in p.locator("#v3d-shadow").inner_text()
        assert any("shadow: joint 'shoulder' diverges" in r.getMessage() for r in caplog.records)
        assert eventually(shadow.acted.is_set, 5)
        shoulder = robot.joint_states()["shoulder"].position
        assert shoulder < 0.62  # stopped at the ball, short of the program's 0.8 rad
        assert abs(shadow.events[0].residual) > math.radians(3.0)  # the twin, without the ball, went on

        def shoulders() -> tuple[float, float]:
            ghost = p.evaluate("window.drempowerView.shadowAngles()")["shoulder"]
            return ghost, math.degrees(shadow.twin_positions()["shoulder"])

        assert eventually(lambda: abs(shoulders()[0] - shoulders()[1]) < 2.0, 5), shoulders()  # drawn where it is
        p.screenshot(path=str(shots / "shadow-3d.png"))
    finally:
        ctx.close()
        loop.call_soon_threadsafe(dash.stopping.set)
        thread.join(10)
        hub.close()
        shadow.close()
        robot.close()


def test_shadow_without_a_model_is_refused_as_a_usage_error(tmp_path: Path) -> None:
    robot = tmp_path / "plain.toml"
    robot.write_text("[buses.arm]\ninterface = 'sim'\n[joints.j]\nbus = 'arm'\nid = 1\n")
    for args in (["--shadow"], ["--robot", str(robot), "--shadow"]):
        out = subprocess.run(
            [sys.executable, "-m", "drempower", "dash", "--port", "0", *args],
            capture_output=True,
            text=True,
            timeout=60,
            check=False,
        )
        assert out.returncode == 2, out.stderr
        line = out.stderr.strip().splitlines()[-1]  # after the usage, as for every usage error
        assert "--shadow needs" in line and "Traceback" not in out.stderr, out.stderr
    assert "plain.toml: a [model]" in line
