"""A joint in impedance mode, pushed by a known torque from outside: its stiffness is the motor's kp."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

import drempower
from drempower.client.engine.effects import sleep

from .conftest import model_copy, robot_file


def _no_gravity(root: ET.Element) -> None:
    option = root.find("option")
    assert option is not None
    option.set("gravity", "0 0 0")


@pytest.mark.parametrize("gear", [1.0, -2.0])
def test_measured_stiffness_is_kp(tmp_path: Path, gear: float) -> None:
    """kp Nm/rad at the motor is kp gear^2 at the joint: torque pushes of +2 and -1 Nm at the joint
    move it by (2 - -1) / (kp gear^2) rad."""
    kp, kd = 20.0, 2.0
    model = model_copy(tmp_path, "pendulum.xml", _no_gravity)
    path = robot_file(tmp_path, model, {"swing": {"id": 1, "gear": gear, "friction": "model"}})
    with drempower.open_robot(path, sim={"clock": "virtual"}) as robot:
        twin = robot.twin
        assert twin is not None
        joint = robot.joint("swing")
        bus = robot.bus("can0")
        joint.impedance_control(0.0, 0.0, 0.0, kp, kd)
        settled: dict[float, float] = {}
        for torque in (2.0, -1.0):
            twin.push_joint("swing", torque=torque, duration=3.0)
            bus.run(sleep(2.5))
            settled[torque] = joint.get_joint_state().position
            bus.run(sleep(0.6))
            assert twin.pushes == []
    measured = (2.0 - -1.0) / (settled[2.0] - settled[-1.0])
    expected = kp * gear * gear
    print(f"gear {gear:+g}: stiffness {measured:.3f} Nm/rad at the joint, kp gear^2 = {expected:.3f}")
    assert measured == pytest.approx(expected, rel=0.03)
    assert math.copysign(1.0, settled[2.0]) == 1.0  # a positive push turns the joint the positive way
