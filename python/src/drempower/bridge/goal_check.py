"""A ``FollowJointTrajectory`` goal checked before anything moves: its joints, its points, its tolerances.

:class:`GoalCheck` turns a goal into a :class:`CheckedGoal` (the trajectory in rad
at the joints, each joint's path and goal tolerances with the server's defaults
filled in) or refuses it with :class:`_GoalError`, whose ``code`` is the name of
the action result's error code (``INVALID_JOINTS``, ``INVALID_GOAL``, ...).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from ..errors import DrEmpowerError, ValidationError
from ..motion.trajectory import Trajectory

__all__ = ["CheckedGoal", "GoalCheck", "Tolerances"]


class _Canceled(Exception):  # a signal between the action's parts, never raised to a caller
    """A cancel request (or a newer goal) stopped the goal."""


class _GoalError(DrEmpowerError):
    """A goal refused or ended with an error code of the action's result (``code``: its name)."""

    def __init__(self, code: str, text: str) -> None:
        super().__init__(text)
        self.code, self.text = code, text


@dataclass(frozen=True)
class Tolerances:
    """Each joint's tolerances of a goal: path (rad, rad/s) and goal (rad, rad/s, s after the end)."""

    path: dict[str, float]
    """Largest tracking error (rad; ``inf``: not checked)."""
    path_speed: dict[str, float]
    """Largest speed (rad/s) of the joints that have one."""
    goal: dict[str, float]
    """Largest distance (rad) from the last point at the end."""
    goal_speed: dict[str, float]
    """Largest speed (rad/s) at the end, for the joints that have one."""
    goal_time: float
    """s after the trajectory's end the joints have to get within ``goal``."""

    def check_path_speed(self, name: str, speed: float) -> None:
        """Raise ``PATH_TOLERANCE_VIOLATED`` when joint ``name``'s ``speed`` (rad/s) is above its path's."""
        if name in self.path_speed and speed > self.path_speed[name]:
            raise _GoalError(
                "PATH_TOLERANCE_VIOLATED",
                f"joint {name!r}: speed {speed:.4g} rad/s above the path tolerance's "
                f"velocity {self.path_speed[name]:g} rad/s",
            )

    def off_goal(
        self, names: Sequence[str], end: Sequence[float], actual: Mapping[str, float], speed: Mapping[str, float]
    ) -> list[tuple[str, float]]:
        """The joints (with their distance, rad) not yet within the goal tolerance of ``end``."""
        return [
            (n, abs(actual[n] - end[k]))
            for k, n in enumerate(names)
            if abs(actual[n] - end[k]) > self.goal[n] or (n in self.goal_speed and speed[n] > self.goal_speed[n])
        ]

    def late(self, name: str, err: float) -> _GoalError:
        """``GOAL_TOLERANCE_VIOLATED`` for joint ``name``, ``err`` rad from the goal once the time is up."""
        return _GoalError(
            "GOAL_TOLERANCE_VIOLATED",
            f"joint {name!r}: {err:.4g} rad from the goal {self.goal_time:g} s after the trajectory's end "
            f"(goal tolerance {self.goal[name]:g} rad)",
        )


@dataclass(frozen=True)
class CheckedGoal:
    """A goal that passed :class:`GoalCheck`."""

    trajectory: Trajectory
    names: list[str]
    tolerances: Tolerances


class GoalCheck:
    """Checks goals against the served ``joints`` (names) with the server's defaults.

    ``where(names)``: where those joints are now (rad), for a first point after
    0 s; ``path_tolerance`` (rad, ``inf``: not checked), ``goal_tolerance`` (rad)
    and ``goal_time`` (s): what a goal's 0 means.
    """

    def __init__(
        self,
        joints: Sequence[str],
        where: Callable[[Sequence[str]], dict[str, float]],
        *,
        path_tolerance: float,
        goal_tolerance: float,
        goal_time: float,
    ) -> None:
        self.joints = list(joints)
        self._where = where
        self.path_tolerance, self.goal_tolerance, self.goal_time = path_tolerance, goal_tolerance, goal_time

    @staticmethod
    def check_components(goal: Any) -> None:
        """Refuse a goal with component tolerances (multi-DOF joints), before it waits for its start."""
        if len(goal.component_path_tolerance) or len(goal.component_goal_tolerance):
            raise _GoalError("INVALID_JOINTS", "component tolerances are for multi-DOF joints, which are not served")

    def check(self, goal: Any) -> CheckedGoal:
        """``goal`` (a ``FollowJointTrajectory_Goal``) checked, where the joints are read now when its first
        point is after 0 s; :class:`_GoalError` when it is refused."""
        tr = self.trajectory(goal)
        names = list(tr.joints)
        path, path_speed = self._tolerances(goal, names, "path")
        pos, speed = self._tolerances(goal, names, "goal")
        gt = goal.goal_time_tolerance
        goal_time = gt.sec + gt.nanosec * 1e-9 or self.goal_time
        return CheckedGoal(tr, names, Tolerances(path, path_speed, pos, speed, goal_time))

    def trajectory(self, goal: Any) -> Trajectory:
        """The goal's trajectory (from where the joints are when its first point is after 0 s)."""
        tr = goal.trajectory
        names = [str(n) for n in tr.joint_names]
        unknown = [n for n in names if n not in self.joints]
        if unknown or not names:
            raise _GoalError(
                "INVALID_JOINTS",
                f"joint {unknown[0]!r} is not served (joints: {', '.join(self.joints)})"
                if unknown
                else "the trajectory names no joint",
            )
        if len(set(names)) != len(names):
            raise _GoalError("INVALID_JOINTS", "a joint is named twice")
        if len(goal.multi_dof_trajectory.joint_names):
            raise _GoalError("INVALID_JOINTS", "multi-DOF joints are not served")
        if not len(tr.points):
            raise _GoalError("INVALID_GOAL", "the trajectory has no point")
        times, rows, vels = [], [], []
        for k, p in enumerate(tr.points):
            if len(p.positions) != len(names):
                raise _GoalError("INVALID_GOAL", f"point {k}: {len(p.positions)} positions for {len(names)} joints")
            times.append(p.time_from_start.sec + p.time_from_start.nanosec * 1e-9)
            rows.append([float(x) for x in p.positions])
            vels.append([float(x) for x in p.velocities] if len(p.velocities) == len(names) else None)
        if times[0] > 0:
            at = self._where(names)
            times.insert(0, 0.0)
            rows.insert(0, [at[n] for n in names])
            vels.insert(0, [0.0] * len(names))
        velocities = vels if all(v is not None for v in vels) else None
        try:
            return Trajectory(times, rows, velocities, joints=names)  # type: ignore[arg-type]
        except ValidationError as exc:
            raise _GoalError("INVALID_GOAL", str(exc)) from exc

    def _tolerances(self, goal: Any, names: Sequence[str], which: str) -> tuple[dict[str, float], dict[str, float]]:
        """Position and velocity tolerances per joint (``path`` or ``goal``), defaults filled in."""
        default = self.path_tolerance if which == "path" else self.goal_tolerance
        pos = {n: default for n in names}
        vel: dict[str, float] = {}
        for tol in getattr(goal, f"{which}_tolerance"):
            if tol.name not in pos:
                raise _GoalError("INVALID_JOINTS", f"{which}_tolerance names joint {tol.name!r}, not in the trajectory")
            if tol.position < 0:
                pos[tol.name] = math.inf
            elif tol.position > 0:
                pos[tol.name] = float(tol.position)
            if tol.velocity > 0:
                vel[tol.name] = float(tol.velocity)
        return pos, vel
