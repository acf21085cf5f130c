"""On the twin the current that heats a motor is the one its load draws: the pendulum held level warms by the
documented model, the pendulum hanging down does not."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

import drempower
from drempower.client.engine.effects import sleep
from drempower.sim.thermal import ThermalModel

from .conftest import PENDULUM_GAINS, ROBOTS, G, pendulum_arm, robot_file

TM = ThermalModel()


@pytest.mark.parametrize("angle_deg", [90.0, 0.0])
def test_the_held_load_heats_the_winding_as_the_model_says(tmp_path: Path, angle_deg: float) -> None:
    m, d = pendulum_arm()
    path = robot_file(
        tmp_path, ROBOTS / "pendulum.xml", {"swing": {"id": 1, "friction": "model", "sim_params": PENDULUM_GAINS}}
    )
    with drempower.open_robot(path, sim={"clock": "virtual"}) as robot:
        joint = robot.joint("swing")
        joint.set_position(math.radians(angle_deg))
        robot.bus("can0").run(sleep(2.0))
        amps = abs(float(joint.read_property("axis0.motor.current_control.Iq_measured")))
        before = joint.health()
        robot.bus("can0").run(sleep(60.0))
        after = joint.health()
    assert amps == pytest.approx(m * G * d * math.sin(math.radians(angle_deg)), abs=0.05)  # 1 A per Nm
    assert after.name == "swing" and after.errors == {}
    rise = 1.5 * amps**2 * 0.2 * TM.winding_r_th
    expected = TM.ambient_c + rise + (before.motor_temp_c - TM.ambient_c - rise) * math.exp(-60.0 / TM.winding_tau)
    print(f"{angle_deg:g} deg: {amps:.3f} A, winding {after.motor_temp_c:.2f} degC, model {expected:.2f} degC")
    assert after.motor_temp_c == pytest.approx(expected, abs=0.05 + 0.01 * rise)
    if angle_deg == 0.0:
        assert after.motor_temp_c < TM.ambient_c + 0.1
    else:
        assert after.motor_temp_c > TM.ambient_c + 14.0


def test_the_joints_thermal_constants_from_the_robot_file_drive_the_twins_heat(tmp_path: Path) -> None:
    """``[joints.swing.thermal]``: the held pendulum warms by the file's time constant and resistance, not the
    estimates'."""
    own = {"winding_tau": 120.0, "winding_r_th": 6.0, "ambient_c": 30.0}
    path = robot_file(
        tmp_path,
        ROBOTS / "pendulum.xml",
        {"swing": {"id": 1, "friction": "model", "sim_params": PENDULUM_GAINS, "thermal": own}},
    )
    with drempower.open_robot(path, sim={"clock": "virtual"}) as robot:
        joint = robot.joint("swing")
        assert joint.health().motor_temp_c == pytest.approx(30.0)  # the file's room
        joint.set_position(math.radians(90.0))
        robot.bus("can0").run(sleep(2.0))
        amps = abs(float(joint.read_property("axis0.motor.current_control.Iq_measured")))
        before = joint.health()
        robot.bus("can0").run(sleep(120.0))
        after = joint.health()
    rise = 1.5 * amps**2 * 0.2 * own["winding_r_th"]
    expected = 30.0 + rise + (before.motor_temp_c - 30.0 - rise) * math.exp(-1.0)  # one of its time constants
    assert after.motor_temp_c == pytest.approx(expected, abs=0.05 + 0.01 * rise)
    estimate = TM.ambient_c + 1.5 * amps**2 * 0.2 * TM.winding_r_th * (1 - math.exp(-122.0 / TM.winding_tau))
    assert abs(after.motor_temp_c - estimate) > 3.0  # the estimates would have said otherwise
