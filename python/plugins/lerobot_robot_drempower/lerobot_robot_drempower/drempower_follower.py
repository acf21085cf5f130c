"""The ``drempower`` follower robot: a DrEmpower arm from its robot file, driven by joint positions.

Observation: ``<joint>.pos`` (deg at the joint), optionally ``<joint>.vel`` (deg/s),
``<joint>.torque`` (Nm) and ``<joint>.temp`` (the winding, degC), plus the cameras. A joint whose
motor reports an error (the E bit of its state) ends the observation or the action with
:class:`~drempower.MotorFaultError` naming the joint, the error and its fix, instead of stale values.
Action: ``<joint>.pos`` (deg). Each action is one control
cycle (``robot.cycle``) of T-mode (filtered position) commands, through the safety gate: the robot
file's limits and ``max_step`` refuse it (nothing is sent, the gate's ``SoftLimitError`` is raised);
a target beyond the model's range of a joint without limits in the file is refused the same way.
``max_relative_target`` bounds the step toward the target instead, as LeRobot's arms do.
"""

from __future__ import annotations

import logging
import math
from functools import cached_property
from typing import Any

from lerobot.cameras.utils import make_cameras_from_configs
from lerobot.robots import Robot
from lerobot.utils.errors import DeviceAlreadyConnectedError, DeviceNotConnectedError

from drempower import MotorFaultError, PositionMode, SoftLimitError, ValidationError
from drempower.robot import Robot as DrRobot

from .arm import POS, TEMP, TORQUE, VEL, choose_joints, degrees, open_arm, position_keys, release
from .config_drempower_follower import DrEmpowerFollowerConfig
from .ranges import joint_ranges

__all__ = ["DrEmpowerFollower"]

log = logging.getLogger(__name__)


class DrEmpowerFollower(Robot):  # type: ignore[misc]  # LeRobot has no type information
    """A follower arm of DrEmpower joints (see the module's description)."""

    config_class = DrEmpowerFollowerConfig
    name = "drempower"

    def __init__(self, config: DrEmpowerFollowerConfig) -> None:
        super().__init__(config)
        self.config = config
        self.choice = choose_joints(config.robot_file, config.joints)
        self.cameras: dict[str, Any] = make_cameras_from_configs(config.cameras)
        self.robot: DrRobot | None = None
        self.ranges: dict[str, tuple[float, float, str]] = {}
        """Joint -> (low, high, where from), deg, of the joints whose range the plugin checks (the model's)."""
        self._last: dict[str, float] = {}
        """The last target (deg) sent to each joint, else its position when connected."""

    # ------------------------------------------------------------------ features

    @cached_property
    def observation_features(self) -> dict[str, Any]:
        out: dict[str, Any] = {}
        for n in self.choice.names:
            out[f"{n}{POS}"] = float
            if self.config.observe_speeds:
                out[f"{n}{VEL}"] = float
            if self.config.observe_torques:
                out[f"{n}{TORQUE}"] = float
            if self.config.observe_temperatures:
                out[f"{n}{TEMP}"] = float
        for key, cam in self.config.cameras.items():
            out[key] = (cam.height, cam.width, 3)
        return out

    @cached_property
    def action_features(self) -> dict[str, type]:
        return position_keys(self.choice.names)

    # ------------------------------------------------------------------ lifetime

    @property
    def is_connected(self) -> bool:
        return self.robot is not None and all(c.is_connected for c in self.cameras.values())

    def connect(self, calibrate: bool = True) -> None:
        """Open the buses, enable the joints (closed loop) and connect the cameras."""
        if self.robot is not None:
            raise DeviceAlreadyConnectedError(f"{self} is already connected")
        robot = open_arm(self.choice, self.config.sim, self.config.timeout)
        try:
            states = robot.joint_states(self.choice.names)
            self._last = {n: degrees(states[n].position) for n in self.choice.names}
            self.ranges = joint_ranges(robot, self.choice.names)
            for cam in self.cameras.values():
                cam.connect()
        except BaseException:
            release(robot, self.choice.names)
            raise
        self.robot = robot
        log.info("%s connected: %s, joints %s", self, self.choice.spec.source, ", ".join(self.choice.names))

    @property
    def is_calibrated(self) -> bool:
        return True

    def calibrate(self) -> None:
        """Nothing to ask: each joint's zero is its motor's (kept in the motor) through the robot file's
        ``gear`` and ``offset``, its range the file's ``limits`` (else the model's joint range)."""
        for n in self.choice.names:
            js = self.choice.spec.joints[n]
            own = js.limits.get("position")
            if own is not None:
                rng = f"{degrees(own[0]):.1f}..{degrees(own[1]):.1f} deg (the robot file's limits)"
            elif n in self.ranges:
                low, high, where = self.ranges[n]
                rng = f"{low:.1f}..{high:.1f} deg ({where})"
            else:
                rng = "none known (connect to read the model's)"
            log.info(
                "%s: motor %d on bus %s; zero: the motor's, gear %g, offset %g rad; range %s",
                *(n, js.id, js.bus, js.gear, js.offset, rng),
            )

    def configure(self) -> None:
        """Nothing to write: the motors keep their configuration (gains, limits) in flash."""

    def disconnect(self) -> None:
        """Leave every joint as its ``on_timeout`` says (hold or idle), close the buses and the cameras."""
        robot, self.robot = self.robot, None
        if robot is None:
            raise DeviceNotConnectedError(f"{self} is not connected")
        try:
            release(robot, self.choice.names)
        finally:
            for cam in self.cameras.values():
                if cam.is_connected:
                    cam.disconnect()
        log.info("%s disconnected", self)

    # ------------------------------------------------------------------ data

    def _robot(self) -> DrRobot:
        if self.robot is None:
            raise DeviceNotConnectedError(f"{self} is not connected: run connect() first")
        return self.robot

    def get_observation(self) -> dict[str, Any]:
        """Fresh joint states (one read per joint; a missing reply is ``drempower.TimeoutError``)."""
        robot = self._robot()
        states = robot.joint_states(self.choice.names)
        self._check_faults({n: st.error for n, st in states.items()})
        temps = robot.health(self.choice.names) if self.config.observe_temperatures else {}
        out: dict[str, Any] = {}
        for n in self.choice.names:
            st = states[n]
            out[f"{n}{POS}"] = degrees(st.position)
            if self.config.observe_speeds:
                out[f"{n}{VEL}"] = degrees(st.velocity)
            if self.config.observe_torques:
                out[f"{n}{TORQUE}"] = st.torque
            if self.config.observe_temperatures:
                out[f"{n}{TEMP}"] = temps[n].motor_temp_c
        for key, cam in self.cameras.items():
            out[key] = cam.async_read()
        return out

    def send_action(self, action: dict[str, Any]) -> dict[str, Any]:
        """Move every joint toward its ``<joint>.pos`` (deg) at once; returns the targets sent."""
        robot = self._robot()
        goal = self._goal(action)
        goal = self._bounded(goal)
        for n, deg in goal.items():
            rng = self.ranges.get(n)
            if rng is not None and not rng[0] <= deg <= rng[1]:
                js = self.choice.spec.joints[n]
                raise SoftLimitError(js.id, f"{n}{POS}", deg, rng[0], rng[1], "deg", rng[2])
        commands = {}
        for n, deg in goal.items():
            joint = robot.joint(n)
            angle = joint.gearing.motor_angle(math.radians(deg))
            commands[n] = joint.make_angle(angle, 0.0, self.config.bandwidth, PositionMode.T)
        states = robot.cycle(commands)  # through the safety gate before anything is sent; the states come back
        self._check_faults({n: st.error for n, st in states.items()})
        self._last.update(goal)
        return {f"{n}{POS}": deg for n, deg in goal.items()}

    def _check_faults(self, errors: dict[str, bool]) -> None:
        """Raise :class:`MotorFaultError` for the first joint whose motor reports an error: the joint, its
        error words and every flag's fix (read now), so a step never goes on with a faulted motor."""
        faulted = [n for n, e in errors.items() if e]
        if not faulted:
            return
        health = self._robot().health(faulted)
        n = faulted[0]
        h = health[n]
        exc = MotorFaultError(h.id, f"(joint {n})", h.errors)
        fixes = "; ".join(str(f) for f in h.faults)
        exc.args = (f"{exc}. {fixes}" if fixes else str(exc),)
        raise exc

    def _goal(self, action: dict[str, Any]) -> dict[str, float]:
        """The targets (deg) of ``action``: one finite ``<joint>.pos`` for every joint driven."""
        goal: dict[str, float] = {}
        for n in self.choice.names:
            key = f"{n}{POS}"
            if key not in action:
                raise ValidationError(f"action: no {key!r} (expected {', '.join(self.action_features)})")
            value = float(action[key])
            if not math.isfinite(value):
                raise ValidationError(f"action {key}={value}: expected a finite angle in deg")
            goal[n] = value
        extra = sorted(k for k in action if k.endswith(POS) and k[: -len(POS)] not in self.choice.names)
        if extra:
            raise ValidationError(f"action {extra[0]!r}: not a joint driven (joints: {', '.join(self.choice.names)})")
        return goal

    def _bounded(self, goal: dict[str, float]) -> dict[str, float]:
        """``goal`` with each step from the last target bounded by ``max_relative_target`` (a warning says so)."""
        caps = self.config.max_relative_target
        if caps is None:
            return goal
        out: dict[str, float] = {}
        cut: list[str] = []
        for n, deg in goal.items():
            cap = caps.get(n) if isinstance(caps, dict) else caps
            last = self._last[n]
            out[n] = deg if cap is None else min(max(deg, last - cap), last + cap)
            if out[n] != deg:
                cut.append(f"{n} {deg:.2f} -> {out[n]:.2f} deg")
        if cut:
            log.warning("max_relative_target: steps bounded: %s", ", ".join(cut))
        return out
