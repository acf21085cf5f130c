"""The LeRobot plugins open their arm through ``open_arm`` (``open_robot``): a robot file with ``[health]`` has its
supervisor running for the device's whole connection, acting per joint, and stopped when the device releases the
arm. This part needs no LeRobot: the plugin's arm module is loaded from its file, so the main run checks it too."""

from __future__ import annotations

import importlib.util
from pathlib import Path
from types import ModuleType

from drempower.protocol.enums import AxisState

ARM_MODULE = Path(__file__).resolve().parents[2] / "plugins/lerobot_robot_drempower/lerobot_robot_drempower/arm.py"


def _arm() -> ModuleType:
    spec = importlib.util.spec_from_file_location("drempower_lerobot_arm", ARM_MODULE)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_plugins_arm_runs_the_files_supervisor_until_released(tmp_path: Path) -> None:
    arm = _arm()
    path = tmp_path / "arm.toml"
    path.write_text(
        '[buses.can0]\ninterface = "sim"\n'
        '[joints.shoulder]\nbus = "can0"\nid = 1\non_overheat = "idle"\n'
        '[joints.elbow]\nbus = "can0"\nid = 2\n'
        '[health]\nperiod = 0.5\non_overheat = "hold"\n'
    )
    robot = arm.open_arm(arm.choose_joints(path, []), {"clock": "virtual"}, 1.0)
    run = robot.health_run
    try:
        assert run is not None and run.running
        sim = robot.bus("can0").transport.bus
        sim.motors[1].thermal.winding = 91.0
        robot.bus("can0").pass_time(0.6)
        assert [(e.joint, e.kind, e.action) for e in run.events] == [("shoulder", "overheat", "idle")]
        assert sim.motors[1].state == AxisState.IDLE
        assert sim.motors[2].state == AxisState.CLOSED_LOOP_CONTROL
    finally:
        arm.release(robot, ["shoulder", "elbow"])
    assert not run.running and robot.closed
