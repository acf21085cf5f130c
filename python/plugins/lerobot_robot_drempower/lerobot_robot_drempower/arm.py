"""A DrEmpower robot file seen as a LeRobot arm: the joints it drives, their feature keys and units.

LeRobot's arms name each value ``<joint>.pos`` (and ``.vel``, ``.torque``); these are in degrees at
the joint (through the robot file's ``gear`` and ``offset``, as LeRobot's ``use_degrees`` arms),
degrees per second, and Nm at the joint. Shared by the follower robot and the leader teleoperator.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping, Sequence
from typing import Any

from drempower import ConfigError, open_robot
from drempower.client.driver.signals import install_stop_handlers
from drempower.robot import Robot, RobotSpec, load_robot

__all__ = [
    "ArmChoice",
    "check_sim",
    "choose_joints",
    "degrees",
    "open_arm",
    "position_keys",
    "release",
]

POS, VEL, TORQUE, TEMP = ".pos", ".vel", ".torque", ".temp"
"""The key suffixes of LeRobot's arms: position (deg), speed (deg/s), torque (Nm)."""

_SIM_OPTIONS = frozenset(("clock", "time_scale", "bitrate", "host_queue", "seed", "config_dir"))
"""The ``sim`` options a plugin passes on to ``open_robot`` (the simulated buses' own)."""


class ArmChoice:
    """The robot file ``spec`` and the joints a device drives (``names``, in file order unless given)."""

    __slots__ = ("names", "spec")

    def __init__(self, spec: RobotSpec, names: list[str]) -> None:
        self.spec = spec
        self.names = names


def choose_joints(robot_file: str | os.PathLike[str], joints: Sequence[str], field: str = "joints") -> ArmChoice:
    """Load ``robot_file`` and check ``joints`` (empty: every joint of the file); raises
    :class:`drempower.ConfigError` naming the field, the joint and the file's joints."""
    if not str(robot_file):
        raise ConfigError("robot_file: missing: the robot file (TOML) of the arm, e.g. --robot.robot_file=arm6.toml")
    spec = load_robot(robot_file)
    if not joints:
        return ArmChoice(spec, list(spec.joints))
    names: list[str] = []
    for name in joints:
        if name not in spec.joints:
            known = ", ".join(spec.joints)
            raise ConfigError(f"{field}: {name!r} is not a joint of {spec.source} (its joints: {known})")
        if name in names:
            raise ConfigError(f"{field}: {name!r} is given twice")
        names.append(name)
    return ArmChoice(spec, names)


def check_sim(sim: Mapping[str, Any]) -> dict[str, Any]:
    """The ``sim`` options (for the file's simulated buses) as ``open_robot`` takes them."""
    unknown = sorted(set(sim) - _SIM_OPTIONS)
    if unknown:
        raise ConfigError(f"sim: unknown option {unknown[0]!r} (options: {', '.join(sorted(_SIM_OPTIONS))})")
    return dict(sim)


def position_keys(names: Sequence[str]) -> dict[str, type]:
    """The position features of ``names``: ``{"<joint>.pos": float}``."""
    return {f"{n}{POS}": float for n in names}


def open_arm(choice: ArmChoice, sim: Mapping[str, Any], timeout: float | None) -> Robot:
    """Open the robot file's buses (the file's ``sim`` buses with ``sim`` options) and enable the chosen
    joints (closed loop). Closing the buses sends nothing: :func:`release` leaves the joints as their
    ``on_timeout`` says. SIGTERM and SIGHUP then end the process as ``SystemExit`` (128 + the signal) in
    its main thread, so that LeRobot's ``finally`` disconnects (and so releases) its devices, as on Ctrl-C."""
    install_stop_handlers()
    robot = open_robot(choice.spec, timeout=timeout, stop_on_close=False, sim=dict(sim) or None)
    try:
        for name in choice.names:
            robot.joint(name).enable()
    except BaseException:
        robot.close()
        raise
    return robot


def release(robot: Robot, names: Sequence[str]) -> None:
    """Leave each joint in its safe state, the robot file's ``on_timeout``: ``"hold"`` (speed 0 in closed
    loop: it holds where it is) or ``"idle"`` (released), then close the buses. Every joint is tried; the
    first failure is raised after the rest."""
    first: BaseException | None = None
    for name in names:
        joint = robot.joint(name)
        try:
            if robot.spec.joints[name].on_timeout == "idle":
                joint.idle()
            else:
                joint.stop()
        except Exception as exc:  # release the others anyway
            first = first or exc
    try:
        robot.close()
    except Exception as exc:
        first = first or exc
    if first is not None:
        raise first


def degrees(rad: float) -> float:
    """``rad`` in degrees (the unit of the ``.pos`` and ``.vel`` features)."""
    return math.degrees(rad)
