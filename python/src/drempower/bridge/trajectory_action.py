"""``control_msgs/action/FollowJointTrajectory`` on the bridge, executed by ``follow``.

The action server MoveIt's ``moveit_simple_controller_manager`` (and
``ros2 action send_goal``) talks to, over rmw_zenoh's mapping of actions
(:mod:`drempower.bridge.rosaction`): goals under ``<name>/_action/send_goal``,
cancels, results, feedback and status.

A goal runs one at a time: a new goal preempts the one executing, as
``joint_trajectory_controller`` does (the old one ends ``CANCELED`` once its
joints hold where they are, then the new one starts from there). Accepted, it
is checked and followed through the control cycle
(:func:`drempower.motion.follow_sync.stream`, rad at the joints):

* its joints must be the bridge's (``INVALID_JOINTS``); its points need one
  position per joint and increasing ``time_from_start``; a first point after
  0 s starts from where the joints are; the robot file's limits and the bus's
  capacity are checked before anything moves (``INVALID_GOAL``);
* ``trajectory.header.stamp`` is when it starts: zero or a time already past
  starts it now; a time ahead waits for it (a cancel or a newer goal ends the
  wait);
* ``path_tolerance`` (position, rad; 0 takes the server's default, -1 none) is
  each joint's largest tracking error, and its ``velocity`` (rad/s, > 0) the
  largest speed: beyond either the joints hold where they are
  (``PATH_TOLERANCE_VIOLATED``); ``component_path_tolerance`` and
  ``component_goal_tolerance`` (multi-DOF joints) do not apply: such goals are
  refused;
* at the end, every joint must be within ``goal_tolerance`` (position, and
  velocity when given) of the last point within ``goal_time_tolerance`` s
  (``GOAL_TOLERANCE_VIOLATED``);
* feedback (desired, actual, error) at ``feedback_rate`` Hz; a cancel holds the
  joints where they are (speed 0 in closed loop via T mode at the measured angle);
* the status topic is transient local as in ROS 2 (:mod:`.action_wire`).

Its parts: :mod:`.action_wire` (the action's entities on Zenoh), :mod:`.goal_check`
(a goal's joints, points and tolerances) and :mod:`.goal_run` (following it);
this module keeps the goals: accepted, preempted, canceled, their results.
"""

from __future__ import annotations

import logging
import math
import threading
import time
import uuid as uuidlib
from collections import OrderedDict
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from ..errors import MotorIdleError
from ..motion.plan import FollowError
from ..robot.config import BusSpec, RobotSpec
from . import rmw, rosaction
from .action_wire import ActionWire
from .bus_face import in_ros_terms
from .goal_check import GoalCheck, _Canceled, _GoalError
from .goal_run import GoalRunner

if TYPE_CHECKING:
    from .server import Bridge

__all__ = ["DEFAULT_ACTION", "TrajectoryAction", "GoalOutcome"]

_log = logging.getLogger("drempower.bridge")

DEFAULT_ACTION = "follow_joint_trajectory"
"""The action's name (relative: in the bridge's namespace), as ``joint_trajectory_controller``'s."""
_KEEP = 16
"""Finished goals kept for get_result and the status array."""


@dataclass
class GoalOutcome:
    """How a goal ended: its status (``SUCCEEDED``, ``CANCELED``, ``ABORTED``), error code and text."""

    status: int
    error_code: int = 0
    error_string: str = ""


@dataclass
class _Goal:
    id: bytes
    accepted_at: int
    """ns since the epoch."""
    goal: Any
    status: int = rosaction.STATUS["ACCEPTED"]
    outcome: GoalOutcome | None = None
    cancel: threading.Event = field(default_factory=threading.Event)
    preempted_by: bytes | None = None
    """The newer goal that ended this one."""
    waiting: list[tuple[Any, rmw.Attachment]] = field(default_factory=list)
    """get_result queries answered when the goal ends."""


class TrajectoryAction:
    """Serve ``FollowJointTrajectory`` as action ``name`` on ``bridge`` until :meth:`close`.

    ``rate``: follow's cycle rate (Hz); ``feedback_rate`` (Hz, >= 10); defaults for
    goals that leave them 0: ``path_tolerance`` (rad, ``inf``: not checked),
    ``goal_tolerance`` (rad) and ``goal_time`` (s after the last point).
    """

    def __init__(
        self,
        bridge: Bridge,
        name: str = DEFAULT_ACTION,
        *,
        rate: float = 100.0,
        feedback_rate: float = 20.0,
        path_tolerance: float = math.inf,
        goal_tolerance: float = 0.02,
        goal_time: float = 1.0,
        start_tolerance: float = 0.1,
    ) -> None:
        if not 10 <= feedback_rate <= rate:
            raise ValueError(f"feedback_rate={feedback_rate!r}: 10 Hz .. the cycle rate ({rate:g} Hz)")
        for key, v in (
            ("path_tolerance", path_tolerance),
            ("goal_tolerance", goal_tolerance),
            ("goal_time", goal_time),
        ):
            if not v > 0:
                raise ValueError(f"{key}={v!r}: expected > 0")
        self.rate, self.feedback_rate = float(rate), float(feedback_rate)
        o = bridge.options
        self.name = rmw.qualify(bridge.namespace, name)
        self._lock = threading.Lock()
        self._goals: OrderedDict[bytes, _Goal] = OrderedDict()
        self._running: _Goal | None = None
        self._closed = threading.Event()
        self._thread: threading.Thread | None = None
        spec = RobotSpec(
            {b: BusSpec(b, "bridge") for b in bridge.faces},
            {j.name: j for j, _, _ in bridge.joints},
            "the bridge's joints",
        )
        self.runner = GoalRunner(
            spec,
            {j.name: (j.id, g, j.bus) for j, g, _ in bridge.joints},
            {b: face.bus for b, face in bridge.faces.items()},
            rate=self.rate,
            feedback_rate=self.feedback_rate,
            start_tolerance=start_tolerance,
        )
        """Follows a checked goal on the buses (:mod:`.goal_run`)."""
        self.check = GoalCheck(
            list(spec.joints),
            self.runner.positions,
            path_tolerance=path_tolerance,
            goal_tolerance=goal_tolerance,
            goal_time=goal_time,
        )
        """Checks a goal before anything moves (:mod:`.goal_check`)."""
        self.wire = ActionWire(bridge.session, o.domain_id, bridge.namespace, o.node_name, self.name)
        """The action's entities on Zenoh (:mod:`.action_wire`)."""
        self.keys = self.wire.keys
        bridge.busy = self.running  # the command topics wait while a goal runs
        try:
            self.wire.serve(
                {"send_goal": self._send_goal, "cancel_goal": self._cancel_goal, "get_result": self._get_result}
            )
        except BaseException:
            self.close()
            raise

    # ------------------------------------------------------------------ services

    def _send_goal(self, query: Any, _: rmw.Attachment) -> bytes:
        req = self.wire.decode(query, rosaction.FOLLOW_JOINT_TRAJECTORY + "_SendGoal_Request")
        gid = bytes(bytearray(req.goal_id.uuid))
        now = time.time_ns()
        with self._lock:
            accepted = gid not in self._goals and not self._closed.is_set()
            previous = self._running
            if accepted:
                if previous is not None:  # preempted: it holds and ends, then this one starts
                    previous.preempted_by = gid
                    previous.status = rosaction.STATUS["CANCELING"]
                    previous.cancel.set()
                goal = _Goal(gid, now, req.goal)
                self._goals[gid] = goal
                while len(self._goals) > _KEEP:
                    self._goals.popitem(last=False)
                self._running = goal
                thread = threading.Thread(target=self._execute, args=(goal, self._thread), name="drempower bridge goal")
                self._thread = thread
        if accepted:
            self._publish_status()
            thread.start()
        else:
            why = "the server is closing" if self._closed.is_set() else "its id is taken"
            _log.warning("%s: goal %s rejected: %s", self.name, uuidlib.UUID(bytes=gid), why)
        return self.wire.send_goal_response(accepted, now)

    def _cancel_goal(self, query: Any, _: rmw.Attachment) -> bytes:
        req = self.wire.decode(query, rosaction.CANCEL_GOAL + "_Request")
        gid = bytes(bytearray(req.goal_info.goal_id.uuid))
        canceling, code = [], 0
        with self._lock:
            if not any(gid):  # zero id: every goal
                targets = [g for g in self._goals.values() if g.outcome is None]
            else:
                g = self._goals.get(gid)
                targets = [] if g is None or g.outcome is not None else [g]
                if g is None:
                    code = 2  # ERROR_UNKNOWN_GOAL_ID
                elif g.outcome is not None:
                    code = 3  # ERROR_GOAL_TERMINATED
            for g in targets:
                g.status = rosaction.STATUS["CANCELING"]
                g.cancel.set()
                canceling.append(g)
        if canceling:
            self._publish_status()
        return self.wire.cancel_response(code, [(g.id, g.accepted_at) for g in canceling])

    def _get_result(self, query: Any, att: rmw.Attachment) -> bytes | None:
        req = self.wire.decode(query, rosaction.FOLLOW_JOINT_TRAJECTORY + "_GetResult_Request")
        gid = bytes(bytearray(req.goal_id.uuid))
        with self._lock:
            g = self._goals.get(gid)
            if g is not None and g.outcome is None:
                g.waiting.append((query, att))  # answered when the goal ends
                return None
        return self._result(g)

    def _result(self, g: _Goal | None) -> bytes:
        out = g.outcome if g is not None else None
        if out is None:
            return self.wire.result(rosaction.STATUS["UNKNOWN"], 0, "unknown goal")
        return self.wire.result(out.status, out.error_code, out.error_string)

    def running(self) -> str | None:
        """Why other commands to the joints are refused now: a goal executing (else None)."""
        with self._lock:
            g = self._running
        return None if g is None else f"goal {uuidlib.UUID(bytes=g.id)} of {self.name} is executing"

    def _publish_status(self) -> None:
        with self._lock:
            goals = [(g.id, g.accepted_at, g.status) for g in self._goals.values()]
        self.wire.status(goals)

    # ------------------------------------------------------------------ execution

    def _execute(self, g: _Goal, before: threading.Thread | None = None) -> None:
        if before is not None:  # the goal this one preempted: it holds its joints and ends first
            before.join()
        try:
            outcome = self._run(g)
        except _GoalError as exc:
            outcome = GoalOutcome(rosaction.STATUS["ABORTED"], rosaction.ERROR[exc.code], exc.text)
        except _Canceled:
            text = "canceled: the joints hold where they are"
            if g.preempted_by is not None:
                text = f"preempted by goal {uuidlib.UUID(bytes=g.preempted_by)}: the joints hold where they are"
            outcome = GoalOutcome(rosaction.STATUS["CANCELED"], 0, text)
        except FollowError as exc:
            outcome = GoalOutcome(rosaction.STATUS["ABORTED"], rosaction.ERROR["PATH_TOLERANCE_VIOLATED"], str(exc))
        except MotorIdleError as exc:  # nothing was sent
            text = str(in_ros_terms(exc))  # the words of the bridge's topics
            outcome = GoalOutcome(rosaction.STATUS["ABORTED"], rosaction.ERROR["INVALID_GOAL"], text)
        except Exception as exc:  # a bus failure: the follower held what it could
            outcome = GoalOutcome(rosaction.STATUS["ABORTED"], rosaction.ERROR["PATH_TOLERANCE_VIOLATED"], str(exc))
        level = logging.INFO if outcome.status == rosaction.STATUS["SUCCEEDED"] else logging.WARNING
        _log.log(level, "%s: goal %s: %s", self.name, uuidlib.UUID(bytes=g.id), outcome.error_string or "succeeded")
        with self._lock:
            g.outcome, g.status = outcome, outcome.status
            waiting, g.waiting = g.waiting, []
            if self._running is g:
                self._running = None
        self._publish_status()
        payload = self._result(g)
        for query, att in waiting:
            try:
                self.wire.reply(query, att, payload)
            except Exception as exc:
                _log.warning("%s: a result could not be sent: %s", self.name, exc)
            del query

    def _wait_start(self, g: _Goal) -> None:
        """Wait for the trajectory's ``header.stamp`` when it is ahead (zero or past: start now)."""
        st = g.goal.trajectory.header.stamp
        start = st.sec * 1_000_000_000 + st.nanosec
        while start and time.time_ns() < start:
            if g.cancel.wait(min(0.05, (start - time.time_ns()) / 1e9)):
                raise _Canceled

    def _run(self, g: _Goal) -> GoalOutcome:
        if g.cancel.is_set():  # canceled or preempted before it began: nothing was sent
            raise _Canceled
        g.status = rosaction.STATUS["EXECUTING"]
        self._publish_status()
        self.check.check_components(g.goal)
        self._wait_start(g)
        checked = self.check.check(g.goal)
        self.runner.run(checked, g.cancel, lambda n, d, a: self.wire.feedback(g.id, n, d, a))
        return GoalOutcome(rosaction.STATUS["SUCCEEDED"], 0, "")

    def close(self) -> None:
        """Cancel a running goal (the joints hold) and stop serving. Idempotent."""
        self._closed.set()
        with self._lock:
            running = self._running
        if running is not None:
            running.cancel.set()
        if self._thread is not None:
            self._thread.join(5.0)
        self.wire.close()
