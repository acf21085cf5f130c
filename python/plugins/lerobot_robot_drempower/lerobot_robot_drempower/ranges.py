"""The joints' ranges the follower checks itself: the model's joint ranges, for joints the robot file
gives no ``limits`` (those the safety gate checks)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

from drempower.motion.plan import model_ranges, robot_limits
from drempower.robot import Robot

__all__ = ["joint_ranges"]


def joint_ranges(robot: Robot, names: Sequence[str]) -> dict[str, tuple[float, float, str]]:
    """Joint -> (low, high, where from) in deg, for the joints of ``names`` whose range comes from the
    robot's model (the twin's, else the model file's when MuJoCo is installed)."""
    model = _model(robot)
    if model is None:
        return {}
    out: dict[str, tuple[float, float, str]] = {}
    for name, known in robot_limits(robot.spec, names, model_ranges(model)).items():
        rng = known.get("position")
        if rng is None or robot.spec.joints[name].limits:
            continue  # the robot file's limits: the gate's
        out[name] = (math.degrees(rng[0]), math.degrees(rng[1]), str(known["source"]))
    return out


def _model(robot: Robot) -> Any:
    twin = robot.twin
    if twin is not None:
        return twin.model
    if robot.spec.model is None:
        return None
    try:
        import mujoco
    except ImportError:
        return None
    return mujoco.MjModel.from_xml_path(robot.spec.model.file)
