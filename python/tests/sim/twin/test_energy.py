"""The 6-joint arm with idle motors and an ideal model conserves its energy."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from pathlib import Path

import drempower
from drempower.client.engine.effects import sleep

from .conftest import model_copy, robot_file

_JOINTS = ("base_yaw", "shoulder", "elbow", "wrist_roll", "wrist_pitch", "flange_roll")


def _ideal(root: ET.Element) -> None:
    """No damping, friction loss, joint limits or contacts: nothing that takes energy out; and the
    RK4 integrator (the semi-implicit Euler of implicitfast itself drifts on this chaotic, undamped arm)."""
    for joint in root.iter("joint"):
        joint.set("damping", "0")
        joint.set("frictionloss", "0")
        joint.attrib.pop("range", None)
    option = root.find("option")
    assert option is not None
    option.set("integrator", "RK4")
    ET.SubElement(option, "flag", contact="disable")


def test_energy_is_conserved_over_10_s(tmp_path: Path) -> None:
    model = model_copy(tmp_path, "arm6.xml", _ideal)
    joints = {name: {"id": i + 1, "friction": "model"} for i, name in enumerate(_JOINTS)}
    path = robot_file(tmp_path, model, joints, bus="arm")
    with drempower.open_robot(path, sim={"clock": "virtual"}) as robot:
        twin = robot.twin
        assert twin is not None
        bus = robot.bus("arm")
        for joint in robot.joints.values():
            joint.set_mode(1)  # idle: no motor torque
        for name, angle in (("shoulder", 0.6), ("elbow", -0.9), ("wrist_pitch", 0.8)):
            twin.set_joint(name, angle)
        twin.set_joint("base_yaw", 0.0, velocity=1.5)
        potential, kinetic = twin.energy()
        start = potential + kinetic
        drift = 0.0
        peak_kinetic = kinetic
        for _ in range(1000):  # 10 s
            bus.run(sleep(0.01))
            potential, kinetic = twin.energy()
            drift = max(drift, abs(potential + kinetic - start))
            peak_kinetic = max(peak_kinetic, kinetic)
        moved = abs(twin.joint_position("shoulder") - 0.6) + abs(twin.joint_position("elbow") + 0.9)
    print(
        f"arm energy over 10 s: drift {drift:.5f} J, peak kinetic energy {peak_kinetic:.3f} J, "
        f"{drift / peak_kinetic:.3%} of it; start {start:.3f} J"
    )
    assert moved > math.radians(20)  # it swung: energy went back and forth between its forms
    assert peak_kinetic > 1.0
    assert drift <= 0.005 * peak_kinetic
