"""``drempower bridge --robot FILE`` with ``[health]``: the bridge runs the file's supervisor, acts per joint (two
buses, both with a motor 1, each joint its own action) and says so on ``/diagnostics`` at once."""

from __future__ import annotations

import logging
import threading
import time
from pathlib import Path
from typing import Any

import pytest

from drempower.bridge import rosmsg
from drempower.bridge.diagnostics import DIAGNOSTIC_ARRAY, OK, WARN
from drempower.bridge.server import Bridge, BridgeOptions
from drempower.protocol.enums import AxisState
from drempower.robot.config import load_robot
from drempower.transports.sim import SimTransport

from ..robots import GEARED_ROBOT
from .conftest import free_port, session, wait_for

pytestmark = pytest.mark.timeout(60)

ROBOT = (
    GEARED_ROBOT.replace('bus = "left"\nid = 1\n', 'bus = "left"\nid = 1\non_overheat = "idle"\n', 1)
    + '[health]\nperiod = 0.1\non_overheat = "hold"\n'
)


def test_the_files_supervisor_acts_per_joint_and_diagnostics_reports_it_at_once(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    caplog.set_level(logging.INFO, "drempower.health")
    path = tmp_path / "robot.toml"
    path.write_text(ROBOT)
    spec = load_robot(path)
    sims = {"left": SimTransport([1, 2]), "right": SimTransport([1])}
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    got: list[tuple[float, Any]] = []
    lock = threading.Lock()

    def heard(sample: Any) -> None:
        with lock:
            got.append((time.monotonic(), rosmsg.decode(sample.payload.to_bytes(), DIAGNOSTIC_ARRAY)))

    def status(name: str) -> Any:
        with lock:
            return {s.name: s for s in got[-1][1].status}[name] if got else None

    with session(listen=[endpoint]) as sess:
        bridge = Bridge(sims, sess, BridgeOptions(dict(spec.joints), prefix=f"h{free_port()}", robot=spec))
        try:
            assert bridge.diagnostics.period == 0.1
            with session(connect=[endpoint]) as ros:
                sub = ros.declare_subscriber(bridge.diagnostics_key, heard)
                wait_for(lambda: status("drempower/elbow") is not None and status("drempower/elbow").level == OK, 10)
                shoulder, elbow = sims["left"].bus.motors[1], sims["right"].bus.motors[1]
                for sim, m in ((sims["left"], shoulder), (sims["right"], elbow)):
                    with sim.bus.lock:
                        m.thermal.winding = 91.0  # 4 K below the firmware's derating
                heated = time.monotonic()
                wait_for(lambda: all(status(f"drempower/{j}").level == WARN for j in ("shoulder", "elbow")), limit=10)
                first_warn = next(t for t, msg in got if any(s.level == WARN for s in msg.status))
                sub.undeclare()
            kinds = {(e.joint, e.kind, e.action) for e in bridge.diagnostics.events}
            assert kinds == {("shoulder", "overheat", "idle"), ("elbow", "overheat", "hold")}
            assert shoulder.state == AxisState.IDLE  # its own on_overheat
            assert elbow.state == AxisState.CLOSED_LOOP_CONTROL  # [health]'s: hold
            assert status("drempower/wrist").level == OK
            assert "Released it (idle)" in status("drempower/shoulder").message
            assert "Holding it (speed 0)" in status("drempower/elbow").message
            assert first_warn - heated < 0.9  # with the event, not at the next 1 s array
        finally:
            bridge.close()
            for s in sims.values():
                s.close()
    lines = [r.getMessage() for r in caplog.records if r.name == "drempower.health"]
    assert any("joint shoulder (motor 1)" in x for x in lines) and any("joint elbow (motor 1)" in x for x in lines)
