"""A robot file's thermal constants per joint (``[joints.NAME.thermal]``) and per sim bus (``thermal = {...}``)
reach the simulated motors, checked with errors that name the file, the key and the range."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

import drempower
from drempower.errors import ConfigError, ValidationError
from drempower.protocol import Torque
from drempower.robotfile import THERMAL_KEYS, load_robot
from drempower.sim import SimBus
from drempower.sim.thermal import ThermalModel

ROBOT = """
[buses.can0]
interface = "sim"
{bus}
[joints.a]
bus = "can0"
id = 1
{joint}
[joints.b]
bus = "can0"
id = 2
"""


def _file(tmp_path: Path, bus: str = "", joint: str = "") -> Path:
    p = tmp_path / "robot.toml"
    p.write_text(ROBOT.format(bus=bus, joint=joint))
    return p


def test_the_keys_are_the_models_constants() -> None:
    assert set(THERMAL_KEYS) == set(ThermalModel.__dataclass_fields__)
    for key, (lo, hi, _) in THERMAL_KEYS.items():
        assert lo <= getattr(ThermalModel(), key) <= hi  # the estimates are within the ranges allowed


def test_a_joints_constants_over_its_buses_over_the_estimates_heat_as_documented(tmp_path: Path) -> None:
    path = _file(
        tmp_path,
        bus="thermal = { winding_r_th = 6.0 }",
        joint="[joints.a.thermal]\nwinding_tau = 100.0\nambient_c = 30.0",
    )
    with drempower.open_robot(path, sim={"clock": "virtual"}, supervise=False) as robot:
        sim = robot.bus("can0").transport.bus  # type: ignore[attr-defined]
        a, b = sim.motors[1].model.thermal, sim.motors[2].model.thermal
        assert (a.winding_tau, a.winding_r_th, a.ambient_c) == (100.0, 6.0, 30.0)
        assert (b.winding_tau, b.winding_r_th, b.ambient_c) == (ThermalModel().winding_tau, 6.0, 25.0)
        for m in sim.motors.values():
            m.locked = True
        robot.bus("can0").send_many([Torque(1, 3.0), Torque(2, 3.0)])
        robot.bus("can0").pass_time(100.0)
        ha, hb = robot.joint("a").health(), robot.joint("b").health()
    rise = 1.5 * 3.0**2 * 0.2 * 6.0  # 3 A in 0.2 ohm, 6 K/W
    assert ha.motor_temp_c - 30.0 == pytest.approx(rise * (1 - math.exp(-1.0)), rel=5e-3)  # one time constant
    assert hb.motor_temp_c - 25.0 == pytest.approx(rise * (1 - math.exp(-100.0 / 300.0)), rel=5e-3)


@pytest.mark.parametrize(
    ("bus", "joint", "message"),
    [
        (
            "",
            "[joints.a.thermal]\nwinding_tau = 0.0",
            r"robot.toml: \[joints.a\]: thermal: winding_tau=0.0: expected 1..36000 s",
        ),
        ("", "[joints.a.thermal]\nambient_c = 120", r"\[joints.a\]: thermal: ambient_c=120: expected -40..80 degC"),
        (
            "",
            '[joints.a.thermal]\nwinding_r_th = "hot"',
            r"\[joints.a\]: thermal: winding_r_th='hot': expected a finite number",
        ),
        ("", "[joints.a.thermal]\ntau = 3.0", r"\[joints.a\]: thermal: unknown key 'tau': the keys are ambient_c, "),
        ("", "thermal = 3.0", r"\[joints.a\]: thermal: expected a table"),
        ("thermal = { board_tau = 1e6 }", "", r"\[buses.can0\]: thermal: board_tau=1000000.0: expected 1..36000 s"),
    ],
)
def test_a_bad_thermal_table_names_the_file_the_key_and_the_range(
    tmp_path: Path, bus: str, joint: str, message: str
) -> None:
    with pytest.raises(ConfigError, match=message):
        load_robot(_file(tmp_path, bus, joint))


def test_only_a_sim_bus_takes_thermal_constants(tmp_path: Path) -> None:
    path = tmp_path / "robot.toml"
    path.write_text(
        '[buses.can0]\ninterface = "socketcan"\nchannel = "vcan9"\nthermal = { winding_tau = 10.0 }\n'
        '[joints.a]\nbus = "can0"\nid = 1\n'
    )
    with pytest.raises(ConfigError, match=r"\[buses.can0\]: thermal: only a sim bus simulates heat"):
        load_robot(path)


def test_the_simulator_checks_them_too() -> None:
    with pytest.raises(ValidationError, match=r"motor_thermal: motor 1: winding_tau=0.5: expected 1..36000 s"):
        SimBus([1], motor_thermal={1: {"winding_tau": 0.5}})
    with pytest.raises(ValidationError, match=r"motor_thermal: motor 3 is not simulated"):
        SimBus([1], motor_thermal={3: {"winding_tau": 50.0}})
