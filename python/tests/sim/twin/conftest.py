"""Helpers of the twin's tests: robot files and test copies of the example models.

Every test here needs MuJoCo (the ``physics`` extra, installed by ``make test``).
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from collections.abc import Callable
from pathlib import Path

import pytest

from ...conftest import REPO_ROOT

pytest.importorskip("mujoco", reason="the robot twin needs MuJoCo: pip install 'drempower[physics]'")

ROBOTS = REPO_ROOT / "examples" / "robots"
"""The example robots (models and robot files)."""
G = 9.81
"""Standard gravity as MuJoCo's default (m/s^2)."""


def model_copy(tmp: Path, name: str, edit: Callable[[ET.Element], None]) -> Path:
    """A copy of example model ``name`` in ``tmp``, changed by ``edit(root)`` (includes resolved by path)."""
    root = ET.parse(ROBOTS / name).getroot()
    edit(root)
    for inc in root.iter("include"):
        inc.set("file", str(ROBOTS / inc.get("file", "")))
    out = tmp / f"test-{name}"
    ET.ElementTree(root).write(out)
    return out


def robot_file(
    tmp: Path, model: Path, joints: dict[str, dict[str, object]], *, bus: str = "can0", **bus_opts: object
) -> Path:
    """A robot file in ``tmp``: ``model`` and one sim bus ``bus`` carrying ``joints`` (name -> keys)."""
    lines = ["[model]", f'file = "{model}"', "", f"[buses.{bus}]", 'interface = "sim"']
    lines += [f"{k} = {_toml(v)}" for k, v in bus_opts.items()]
    for name, keys in joints.items():
        lines += ["", f"[joints.{name}]", f'bus = "{keys.get("bus", bus)}"']
        lines += [f"{k} = {_toml(v)}" for k, v in keys.items() if k != "bus"]
    out = tmp / "robot.toml"
    out.write_text("\n".join(lines) + "\n")
    return out


def _toml(value: object) -> str:
    if isinstance(value, dict):
        return "{" + ", ".join(f'"{k}" = {_toml(v)}' for k, v in value.items()) + "}"
    return f'"{value}"' if isinstance(value, str) else repr(value)


PENDULUM_GAINS = {
    "axis0.controller.config.pos_gain": 10.0,
    "axis0.controller.config.vel_gain": 0.5,
    "axis0.controller.config.vel_integrator_gain": 5.0,
}
"""The pendulum example's motor gains (its robot file's sim_params)."""


def pendulum_arm() -> tuple[float, float]:
    """Mass (kg) and distance from the axis to the centre of mass (m) of the pendulum's arm, from its model."""
    root = ET.parse(ROBOTS / "pendulum.xml").getroot()
    body = next(b for b in root.iter("body") if b.get("name") == "arm")
    inertial = body.find("inertial")
    assert inertial is not None
    pos = [float(x) for x in inertial.get("pos", "0 0 0").split()]
    return float(inertial.get("mass", "0")), math.hypot(*pos)


def pendulum_inertia() -> float:
    """The pendulum arm's moment of inertia about its axis (kg m^2): centre term plus m d^2."""
    root = ET.parse(ROBOTS / "pendulum.xml").getroot()
    body = next(b for b in root.iter("body") if b.get("name") == "arm")
    inertial = body.find("inertial")
    assert inertial is not None
    m, d = pendulum_arm()
    iyy = float(inertial.get("diaginertia", "0 0 0").split()[1])
    return iyy + m * d * d
