"""The configuration of the ``drempower`` follower robot (``--robot.type=drempower``)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from lerobot.cameras import CameraConfig
from lerobot.robots import RobotConfig

from drempower import ConfigError

from .arm import check_sim, choose_joints

__all__ = ["DrEmpowerFollowerConfig"]


@RobotConfig.register_subclass("drempower")
@dataclass
class DrEmpowerFollowerConfig(RobotConfig):  # type: ignore[misc]  # LeRobot has no type information
    """A DrEmpower arm described by a robot file, following position actions (deg at the joints).

    ``robot_file``: the robot file (TOML; its ``sim`` buses run the simulator, the twin when it names a
    model). ``joints``: the joints driven, in this order (empty: all, in file order). ``sim``: options
    for the file's simulated buses, as ``open_robot`` takes them (``clock``, ``time_scale``...).
    ``observe_speeds`` / ``observe_torques`` / ``observe_temperatures``: add ``<joint>.vel`` (deg/s) /
    ``<joint>.torque`` (Nm) / ``<joint>.temp`` (winding, degC; five more reads per joint) to the observation.
    ``bandwidth``: the T-mode position filter (1/s, 0..300). ``max_relative_target``:
    deg, one for all joints or by joint: a target further than this from the last one sent is moved
    that far toward it (LeRobot's meaning); the robot file's ``max_step`` is the gate's and refuses.
    ``timeout``: s per request (None: the buses' own).
    """

    robot_file: str = ""
    joints: list[str] = field(default_factory=list)
    sim: dict[str, Any] = field(default_factory=dict)
    observe_speeds: bool = False
    observe_torques: bool = False
    observe_temperatures: bool = False
    bandwidth: float = 20.0
    max_relative_target: float | dict[str, float] | None = None
    timeout: float | None = None
    cameras: dict[str, CameraConfig] = field(default_factory=dict)

    def __post_init__(self) -> None:
        super().__post_init__()
        choice = choose_joints(self.robot_file, self.joints)
        check_sim(self.sim)
        if not (math.isfinite(self.bandwidth) and 0 < self.bandwidth <= 300):
            raise ConfigError(f"bandwidth={self.bandwidth}: the position filter's bandwidth is 0..300 1/s")
        if self.timeout is not None and not (math.isfinite(self.timeout) and self.timeout > 0):
            raise ConfigError(f"timeout={self.timeout}: expected a time above 0 s")
        caps = self.max_relative_target
        if isinstance(caps, dict):
            for name, cap in caps.items():
                if name not in choice.names:
                    raise ConfigError(
                        f"max_relative_target: {name!r} is not a joint driven (joints: {', '.join(choice.names)})"
                    )
                _check_cap(f"max_relative_target[{name}]", cap)
        elif caps is not None:
            _check_cap("max_relative_target", caps)


def _check_cap(field: str, value: float) -> None:
    if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
        raise ConfigError(f"{field}={value}: expected a step above 0 deg")
