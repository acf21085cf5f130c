"""The joints' ranges the follower checks itself: the model's joint ranges, for joints the robot file
gives no ``position`` limit (those the safety gate checks)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

from drempower.motion.plan import model_ranges
from drempower.robot import Robot

__all__ = ["joint_ranges"]


def joint_ranges(robot: Robot, names: Sequence[str]) -> dict[str, tuple[float, float, str]]:
    """Joint -> (low, high, where from) in deg, for the joints of ``names`` without a ``position`` limit
    in the robot file whose model joint has a range (the twin's model, else the model file's when MuJoCo
    is installed)."""
    model = _model(robot)
    if model is None:
        return {}
    model_range = model_ranges(model)
    out: dict[str, tuple[float, float, str]] = {}
    for name in names:
        js = robot.spec.joints[name]
        if "position" in js.limits:
            continue  # the robot file's: the gate's
        mj_name = js.model_joint or name
        rng = model_range(mj_name)
        if rng is not None:
            out[name] = (math.degrees(rng[0]), math.degrees(rng[1]), f"the range of model joint {mj_name!r}")
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
