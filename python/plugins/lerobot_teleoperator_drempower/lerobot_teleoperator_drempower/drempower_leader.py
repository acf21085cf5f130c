"""The ``drempower_leader`` teleoperator: a DrEmpower arm in teach mode; its joint positions are the actions.

``connect`` enables the joints and runs ``robot.teach`` on a thread: each joint under impedance
control with no stiffness, a little damping and, when the robot file names a model, its gravity
torque, so that a person moves the arm by hand and it stays where it is left. ``get_action`` gives
the latest positions as ``<joint>.pos`` (deg at the joint), the keys of the ``drempower`` follower's
actions. ``disconnect`` ends teach mode (the joints hold), then leaves each joint as the robot file's
``on_timeout`` says.
"""

from __future__ import annotations

import logging
import math
import threading
import time
from collections.abc import Mapping
from functools import cached_property
from typing import Any

from lerobot.teleoperators import Teleoperator
from lerobot.utils.errors import DeviceAlreadyConnectedError, DeviceNotConnectedError
from lerobot_robot_drempower.arm import POS, choose_joints, open_arm, position_keys, release

from drempower import DrEmpowerError, TimeoutError, ValidationError
from drempower.robot import Robot as DrRobot

from .config_drempower_leader import DrEmpowerLeaderConfig

__all__ = ["DrEmpowerLeader"]

log = logging.getLogger(__name__)

FIRST_STATE_WAIT = 10.0
"""s to wait for teach mode's first cycle when connecting."""


class DrEmpowerLeader(Teleoperator):  # type: ignore[misc]  # LeRobot has no type information
    """A leader arm of DrEmpower joints in teach mode (see the module's description)."""

    config_class = DrEmpowerLeaderConfig
    name = "drempower_leader"

    def __init__(self, config: DrEmpowerLeaderConfig) -> None:
        super().__init__(config)
        self.config = config
        self.choice = choose_joints(config.robot_file, config.joints)
        self.compensate = self.choice.spec.model is not None if config.compensate is None else config.compensate
        self.robot: DrRobot | None = None
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()
        self._lock = threading.Lock()
        self._latest: dict[str, float] = {}
        self._cycles = 0
        self._error: BaseException | None = None

    @cached_property
    def action_features(self) -> dict[str, type]:
        return position_keys(self.choice.names)

    @cached_property
    def feedback_features(self) -> dict[str, type]:
        return {}

    @property
    def is_connected(self) -> bool:
        return self.robot is not None

    def connect(self, calibrate: bool = True) -> None:
        """Open the buses, enable the joints and start teach mode; returns after its first cycle."""
        if self.robot is not None:
            raise DeviceAlreadyConnectedError(f"{self} is already connected")
        robot = open_arm(self.choice, self.config.sim, self.config.timeout)
        self._stop.clear()
        self._error = None
        self._cycles = 0
        self._thread = threading.Thread(target=self._teach, args=(robot,), name="drempower-leader", daemon=True)
        self._thread.start()
        deadline = time.monotonic() + FIRST_STATE_WAIT
        while self._cycles == 0 and self._thread.is_alive() and time.monotonic() < deadline:
            time.sleep(0.005)
        if self._cycles == 0:
            self._stop.set()
            self._thread.join(FIRST_STATE_WAIT)
            release(robot, self.choice.names)
            if self._error is not None:
                raise self._error
            ids = [self.choice.spec.joints[n].id for n in self.choice.names]
            where = f"leader {self.choice.spec.source}: teach mode ran no cycle within {FIRST_STATE_WAIT:g} s"
            raise TimeoutError(ids, "teach mode's first cycle", FIRST_STATE_WAIT, where)
        self.robot = robot
        log.info(
            "%s connected: %s in teach mode (gravity compensation %s)",
            self,
            self.choice.spec.source,
            "on" if self.compensate else "off",
        )

    def _teach(self, robot: DrRobot) -> None:
        try:
            robot.teach(
                None,
                joints=self.choice.names,
                rate=self.config.rate,
                kd=self.config.kd,
                compensate=self.compensate,
                on_state=self._seen,
                stop=self._stop.is_set,
            )
        except BaseException as exc:  # handed to get_action
            if not (self._stop.is_set() and isinstance(exc, DrEmpowerError) and self._cycles < 2):
                self._error = exc

    def _seen(self, t: float, positions: Mapping[str, float]) -> None:
        with self._lock:
            self._latest = {n: math.degrees(p) for n, p in positions.items()}
            self._cycles += 1

    @property
    def is_calibrated(self) -> bool:
        return True

    def calibrate(self) -> None:
        """Nothing to ask: the zero and ranges come from the motors and the robot file (as the follower's)."""

    def configure(self) -> None:
        """Nothing to write: teach mode sets the joints' control each cycle."""

    def get_action(self) -> dict[str, float]:
        """The joints' latest positions (deg), ``{"<joint>.pos": deg}``; raises what stopped teach mode."""
        if self.robot is None:
            raise DeviceNotConnectedError(f"{self} is not connected: run connect() first")
        if self._error is not None:
            where = self.choice.spec.source
            raise DrEmpowerError(f"leader {where}: teach mode stopped: {self._error}") from self._error
        if self._thread is None or not self._thread.is_alive():
            raise DrEmpowerError(f"leader {self.choice.spec.source}: teach mode stopped")
        with self._lock:
            latest = dict(self._latest)
        return {f"{n}{POS}": latest[n] for n in self.choice.names}

    def send_feedback(self, feedback: dict[str, Any]) -> None:
        """The leader takes no feedback (``feedback_features`` is empty): an empty one is accepted, any other
        refused naming its keys (nothing is sent)."""
        if feedback:
            raise ValidationError(f"feedback={sorted(feedback)}: {self.name} takes no feedback (its features: none)")

    def disconnect(self) -> None:
        """End teach mode (the joints hold where they are), then leave them as ``on_timeout`` says."""
        robot, self.robot = self.robot, None
        if robot is None:
            raise DeviceNotConnectedError(f"{self} is not connected")
        self._stop.set()
        if self._thread is not None:
            self._thread.join(FIRST_STATE_WAIT)
        release(robot, self.choice.names)
        log.info("%s disconnected", self)
