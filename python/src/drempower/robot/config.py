"""The robot file (buses and joints, TOML) under the robot layer's import path: its model lives in
:mod:`drempower.robotfile`, below the simulator and the transports, which read robot files too."""

from __future__ import annotations

from ..robotfile import (
    FRICTIONS,
    IDENTIFIED_KEYS,
    JOINT_LIMITS,
    JOINT_NAME,
    ON_TIMEOUT,
    BusSpec,
    JointSpec,
    ModelSpec,
    RobotSpec,
    bus_options,
    load_robot,
    parse_robot,
)

__all__ = [
    "bus_options",
    "BusSpec",
    "JointSpec",
    "ModelSpec",
    "RobotSpec",
    "load_robot",
    "parse_robot",
    "JOINT_NAME",
    "JOINT_LIMITS",
    "FRICTIONS",
    "IDENTIFIED_KEYS",
    "ON_TIMEOUT",
]
