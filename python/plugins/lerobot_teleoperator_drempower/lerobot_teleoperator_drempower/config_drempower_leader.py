"""The configuration of the ``drempower_leader`` teleoperator (``--teleop.type=drempower_leader``)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from lerobot.teleoperators import TeleoperatorConfig
from lerobot_robot_drempower.arm import check_sim, choose_joints

from drempower import ConfigError
from drempower.protocol import StartImpedance

__all__ = ["DrEmpowerLeaderConfig"]


@TeleoperatorConfig.register_subclass("drempower_leader")
@dataclass
class DrEmpowerLeaderConfig(TeleoperatorConfig):  # type: ignore[misc]  # LeRobot has no type information
    """A DrEmpower arm in teach mode whose joint positions (deg) are the actions.

    ``robot_file``, ``joints`` and ``sim`` as the ``drempower`` follower's (use the same joint names and
    order on both). ``rate``: teach cycles per s. ``kd``: the joints' damping (Nm s/rad at the motor).
    ``compensate``: gravity compensation from the robot file's model (None: when the file names one;
    the ``physics`` extra). ``timeout``: s per request (None: the buses' own).
    """

    robot_file: str = ""
    joints: list[str] = field(default_factory=list)
    sim: dict[str, Any] = field(default_factory=dict)
    rate: float = 100.0
    kd: float = 0.05
    compensate: bool | None = None
    timeout: float | None = None

    def __post_init__(self) -> None:
        choice = choose_joints(self.robot_file, self.joints)
        check_sim(self.sim)
        if not (math.isfinite(self.rate) and 0 < self.rate <= 1000):
            raise ConfigError(f"rate={self.rate}: teach cycles per s are 0..1000")
        if not (math.isfinite(self.kd) and self.kd >= 0):
            raise ConfigError(f"kd={self.kd}: the damping is a value of 0 Nm s/rad or more")
        StartImpedance(0, 0.0, self.kd).encode()  # within what the frame carries (FieldRangeError names kd)
        if self.compensate and choice.spec.model is None:
            raise ConfigError(f"compensate=True: {choice.spec.source} names no [model] to compute gravity from")
        if self.timeout is not None and not (math.isfinite(self.timeout) and self.timeout > 0):
            raise ConfigError(f"timeout={self.timeout}: expected a time above 0 s")
