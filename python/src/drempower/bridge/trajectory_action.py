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
* the status topic is transient local as in ROS 2: its last message is kept
  for subscribers that join later (a Zenoh advanced publisher with a cache of
  one, as rmw_zenoh declares one for that durability).
"""

from __future__ import annotations

import logging
import math
import threading
import time
import uuid as uuidlib
from collections import OrderedDict
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from ..client.engine.state import MotorState
from ..errors import DrEmpowerError, MotorIdleError, ValidationError
from ..motion.follow_sync import stream
from ..motion.plan import FollowError, make_plan, robot_lanes, robot_limits
from ..motion.trajectory import Trajectory
from ..robot.config import BusSpec, RobotSpec
from . import rmw, rosaction, rosmsg
from .bus_face import in_ros_terms

if TYPE_CHECKING:
    from .server import Bridge

__all__ = ["DEFAULT_ACTION", "TrajectoryAction", "GoalOutcome"]

_log = logging.getLogger("drempower.bridge")

DEFAULT_ACTION = "follow_joint_trajectory"
"""The action's name (relative: in the bridge's namespace), as ``joint_trajectory_controller``'s."""
_STATUS_QOS = ":1:,1:,:,:,,"
"""rmw_zenoh's compact QoS of the status topic: transient local, keep last 1."""
_KEEP = 16
"""Finished goals kept for get_result and the status array."""
_States = dict[int, MotorState]


class _Canceled(Exception):
    """A cancel request stopped the goal."""


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
        import zenoh

        if not 10 <= feedback_rate <= rate:
            raise ValueError(f"feedback_rate={feedback_rate!r}: 10 Hz .. the cycle rate ({rate:g} Hz)")
        for key, v in (
            ("path_tolerance", path_tolerance),
            ("goal_tolerance", goal_tolerance),
            ("goal_time", goal_time),
        ):
            if not v > 0:
                raise ValueError(f"{key}={v!r}: expected > 0")
        self.bridge = bridge
        bridge.busy = self.running  # the command topics wait while a goal runs
        self.rate, self.feedback_rate = float(rate), float(feedback_rate)
        self.path_tolerance, self.goal_tolerance, self.goal_time = path_tolerance, goal_tolerance, goal_time
        self.start_tolerance = start_tolerance
        self._zenoh = zenoh
        self._store = rosaction.typestore()
        self._types = self._store.types
        o, s = bridge.options, bridge.session
        ns, zid = bridge.namespace, str(s.zid())
        self.name = rmw.qualify(ns, name)
        self.keys: dict[str, str] = {}
        self._decls: list[Any] = []
        self._lock = threading.Lock()
        self._goals: OrderedDict[bytes, _Goal] = OrderedDict()
        self._running: _Goal | None = None
        self._closed = threading.Event()
        self._thread: threading.Thread | None = None
        self._seq = {"feedback": 0, "status": 0}
        self._put_lock = threading.Lock()
        self._gids: dict[str, bytes] = {}
        spec_joints = {j.name: j for j, _, _ in bridge._joints}
        self._spec = RobotSpec({b: BusSpec(b, "bridge") for b in bridge.faces}, spec_joints, "the bridge's joints")
        handlers = {"send_goal": self._send_goal, "cancel_goal": self._cancel_goal, "get_result": self._get_result}
        try:
            for entity, role in enumerate(rosaction.ROLES, start=2000):
                typename = rosaction.role_type(rosaction.FOLLOW_JOINT_TRAJECTORY, role)
                dds, h = rosmsg.dds_type_name(typename), rosmsg.ros_type_hash(typename)
                fq = f"{self.name}/_action/{role}"
                kind: rmw.EntityKind = "SS" if role in handlers else "MP"
                qos = _STATUS_QOS if role == "status" else rmw.DEFAULT_QOS
                token = rmw.entity_token(o.domain_id, zid, 0, entity, kind, ns, o.node_name, fq, dds, h, qos)
                self._decls.append(s.liveliness().declare_token(token))
                key = self.keys[role] = rmw.topic_key(o.domain_id, fq, dds, h)
                self._gids[role] = rmw.make_gid(token)
                if role in handlers:
                    h_ = handlers[role]
                    self._decls.append(s.declare_queryable(key, lambda q, h_=h_: self._serve(q, h_), complete=True))
                elif role == "status":  # transient local: late subscribers get the last status
                    from zenoh import ext

                    pub = ext.declare_advanced_publisher(
                        s,
                        key,
                        cache=ext.CacheConfig(1),
                        sample_miss_detection=ext.MissDetectionConfig(heartbeat=None, sporadic_heartbeat=None),
                        publisher_detection=True,
                    )
                    self._decls.append(pub)
                    setattr(self, f"_{role}_pub", pub)
                else:
                    pub = s.declare_publisher(key)
                    self._decls.append(pub)
                    setattr(self, f"_{role}_pub", pub)
        except BaseException:
            self.close()
            raise

    # ------------------------------------------------------------------ services

    def _serve(self, query: Any, handler: Callable[[Any, rmw.Attachment], bytes | None]) -> None:
        att = query.attachment.to_bytes() if query.attachment is not None else b""
        try:
            req = rmw.Attachment.decode(att)
        except ValueError:
            req = rmw.Attachment(0, 0, bytes(rmw.GID_SIZE))
        try:
            payload = handler(query, req)
        except Exception as exc:  # a malformed request: logged, no reply (the caller times out)
            _log.warning("%s: request refused: %s", self.name, exc)
            return
        if payload is not None:
            self._reply(query, req, payload)

    def _reply(self, query: Any, req: rmw.Attachment, payload: bytes) -> None:
        back = rmw.Attachment(req.sequence_number, time.time_ns(), req.gid).encode()
        query.reply(query.key_expr, payload, attachment=back)

    def _decode(self, query: Any, typename: str) -> Any:
        if query.payload is None:
            raise ValueError(f"no {typename} in the request")
        return rosmsg.decode(query.payload.to_bytes(), typename)

    def _stamp(self, ns: int) -> Any:
        return self._types["builtin_interfaces/msg/Time"](sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)

    def _send_goal(self, query: Any, _: rmw.Attachment) -> bytes:
        t = rosaction.FOLLOW_JOINT_TRAJECTORY
        req = self._decode(query, t + "_SendGoal_Request")
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
        resp = self._types[t + "_SendGoal_Response"](accepted=accepted, stamp=self._stamp(now))
        return rosmsg.encode(resp, t + "_SendGoal_Response")

    def _cancel_goal(self, query: Any, _: rmw.Attachment) -> bytes:
        req = self._decode(query, rosaction.CANCEL_GOAL + "_Request")
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
        T = self._types
        resp = T[rosaction.CANCEL_GOAL + "_Response"](
            return_code=code, goals_canceling=[self._goal_info(g) for g in canceling]
        )
        return rosmsg.encode(resp, rosaction.CANCEL_GOAL + "_Response")

    def _get_result(self, query: Any, att: rmw.Attachment) -> bytes | None:
        t = rosaction.FOLLOW_JOINT_TRAJECTORY
        req = self._decode(query, t + "_GetResult_Request")
        gid = bytes(bytearray(req.goal_id.uuid))
        with self._lock:
            g = self._goals.get(gid)
            if g is not None and g.outcome is None:
                g.waiting.append((query, att))  # answered when the goal ends
                return None
        return self._result(g)

    def _result(self, g: _Goal | None) -> bytes:
        t = rosaction.FOLLOW_JOINT_TRAJECTORY
        out = g.outcome if g is not None else None
        result = self._types[t + "_Result"](
            error_code=out.error_code if out else 0, error_string=out.error_string if out else "unknown goal"
        )
        status = out.status if out else rosaction.STATUS["UNKNOWN"]
        return rosmsg.encode(
            self._types[t + "_GetResult_Response"](status=status, result=result), t + "_GetResult_Response"
        )

    # ------------------------------------------------------------------ topics

    def _goal_info(self, g: _Goal) -> Any:
        T = self._types
        return T["action_msgs/msg/GoalInfo"](
            goal_id=T["unique_identifier_msgs/msg/UUID"](uuid=_uuid_array(g.id)), stamp=self._stamp(g.accepted_at)
        )

    def _put(self, role: str, payload: bytes) -> None:
        with self._put_lock:  # the executor's thread and Zenoh's callbacks both publish status
            self._seq[role] += 1
            att = rmw.Attachment(self._seq[role], time.time_ns(), self._gids[role]).encode()
            getattr(self, f"_{role}_pub").put(payload, attachment=att)

    def running(self) -> str | None:
        """Why other commands to the joints are refused now: a goal executing (else None)."""
        with self._lock:
            g = self._running
        return None if g is None else f"goal {uuidlib.UUID(bytes=g.id)} of {self.name} is executing"

    def _publish_status(self) -> None:
        T = self._types
        with self._lock:
            goals = [
                T["action_msgs/msg/GoalStatus"](goal_info=self._goal_info(g), status=g.status)
                for g in self._goals.values()
            ]
        self._put(
            "status", rosmsg.encode(T[rosaction.GOAL_STATUS_ARRAY](status_list=goals), rosaction.GOAL_STATUS_ARRAY)
        )

    def _feedback(self, g: _Goal, names: Sequence[str], desired: Sequence[float], actual: Sequence[float]) -> None:
        import numpy as np

        T = self._types
        t = rosaction.FOLLOW_JOINT_TRAJECTORY
        now = time.time_ns()
        zero = T["builtin_interfaces/msg/Duration"](sec=0, nanosec=0)

        def point(values: Sequence[float]) -> Any:
            empty = np.array([], dtype=np.float64)
            return T["trajectory_msgs/msg/JointTrajectoryPoint"](
                positions=np.array(values, dtype=np.float64),
                velocities=empty,
                accelerations=empty,
                effort=empty,
                time_from_start=zero,
            )

        def multi() -> Any:
            return T["trajectory_msgs/msg/MultiDOFJointTrajectoryPoint"](
                transforms=[], velocities=[], accelerations=[], time_from_start=zero
            )

        fb = T[t + "_Feedback"](
            header=T["std_msgs/msg/Header"](stamp=self._stamp(now), frame_id=""),
            joint_names=list(names),
            desired=point(desired),
            actual=point(actual),
            error=point([d - a for d, a in zip(desired, actual, strict=True)]),
            multi_dof_joint_names=[],
            multi_dof_desired=multi(),
            multi_dof_actual=multi(),
            multi_dof_error=multi(),
        )
        msg = T[t + "_FeedbackMessage"](
            goal_id=T["unique_identifier_msgs/msg/UUID"](uuid=_uuid_array(g.id)), feedback=fb
        )
        self._put("feedback", rosmsg.encode(msg, t + "_FeedbackMessage"))

    # ------------------------------------------------------------------ execution

    def _positions(self, names: Sequence[str]) -> dict[str, float]:
        """Where the joints ``names`` are (rad), read now."""
        out: dict[str, float] = {}
        for name in names:
            j, g, face = next(x for x in self.bridge._joints if x[0].name == name)
            st = face.bus.request([_fast_read(j.id)])[0]
            out[name] = g.joint_state(st).position
        return out

    def _trajectory(self, goal: Any) -> Trajectory:
        """The goal's trajectory (from where the joints are when its first point is after 0 s)."""
        tr = goal.trajectory
        names = [str(n) for n in tr.joint_names]
        unknown = [n for n in names if n not in self._spec.joints]
        if unknown or not names:
            raise _Invalid(
                "INVALID_JOINTS",
                f"joint {unknown[0]!r} is not served (joints: {', '.join(self._spec.joints)})"
                if unknown
                else "the trajectory names no joint",
            )
        if len(set(names)) != len(names):
            raise _Invalid("INVALID_JOINTS", "a joint is named twice")
        if len(goal.multi_dof_trajectory.joint_names):
            raise _Invalid("INVALID_JOINTS", "multi-DOF joints are not served")
        if not len(tr.points):
            raise _Invalid("INVALID_GOAL", "the trajectory has no point")
        times, rows, vels = [], [], []
        for k, p in enumerate(tr.points):
            if len(p.positions) != len(names):
                raise _Invalid("INVALID_GOAL", f"point {k}: {len(p.positions)} positions for {len(names)} joints")
            times.append(p.time_from_start.sec + p.time_from_start.nanosec * 1e-9)
            rows.append([float(x) for x in p.positions])
            vels.append([float(x) for x in p.velocities] if len(p.velocities) == len(names) else None)
        if times[0] > 0:
            at = self._positions(names)
            times.insert(0, 0.0)
            rows.insert(0, [at[n] for n in names])
            vels.insert(0, [0.0] * len(names))
        velocities = vels if all(v is not None for v in vels) else None
        try:
            return Trajectory(times, rows, velocities, joints=names)  # type: ignore[arg-type]
        except ValidationError as exc:
            raise _Invalid("INVALID_GOAL", str(exc)) from exc

    def _tolerances(self, goal: Any, names: Sequence[str], which: str) -> tuple[dict[str, float], dict[str, float]]:
        """Position and velocity tolerances per joint (``path`` or ``goal``), defaults filled in."""
        default = self.path_tolerance if which == "path" else self.goal_tolerance
        pos = {n: default for n in names}
        vel: dict[str, float] = {}
        for tol in getattr(goal, f"{which}_tolerance"):
            if tol.name not in pos:
                raise _Invalid("INVALID_JOINTS", f"{which}_tolerance names joint {tol.name!r}, not in the trajectory")
            if tol.position < 0:
                pos[tol.name] = math.inf
            elif tol.position > 0:
                pos[tol.name] = float(tol.position)
            if tol.velocity > 0:
                vel[tol.name] = float(tol.velocity)
        return pos, vel

    def _execute(self, g: _Goal, before: threading.Thread | None = None) -> None:
        if before is not None:  # the goal this one preempted: it holds its joints and ends first
            before.join()
        try:
            outcome = self._run(g)
        except _Invalid as exc:
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
                self._reply(query, att, payload)
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
        if len(g.goal.component_path_tolerance) or len(g.goal.component_goal_tolerance):
            raise _Invalid("INVALID_JOINTS", "component tolerances are for multi-DOF joints, which are not served")
        self._wait_start(g)
        tr = self._trajectory(g.goal)
        names = list(tr.joints)
        path, path_vel = self._tolerances(g.goal, names, "path")
        goal_pos, goal_vel = self._tolerances(g.goal, names, "goal")
        gt = g.goal.goal_time_tolerance
        goal_time = gt.sec + gt.nanosec * 1e-9 or self.goal_time
        faces = self.bridge.faces
        lanes = robot_lanes(
            self._spec,
            names,
            lambda b: faces[b].bus.transport.wire_bitrate,
            lambda b: faces[b].bus.reply_state,
        )
        try:
            plan = make_plan(
                tr,
                lanes,
                rate=self.rate,
                mode="position",
                max_error=path,
                limits=robot_limits(self._spec, names, None),
                kp=20.0,
                kd=1.0,
                bandwidth=None,
                torques=None,
                timeout=None,
            )
        except ValidationError as exc:
            raise _Invalid("INVALID_GOAL", str(exc)) from exc
        for lane in lanes:  # a cancel or a path error holds every joint where it is, as the controller does
            lane.on_timeout = ["hold"] * len(lane.ids)
        buses = {lane.bus: faces[lane.bus].bus for lane in lanes}
        joint_of = {
            (lane.bus, i): (n, u) for lane in lanes for i, n, u in zip(lane.ids, lane.names, lane.units, strict=True)
        }
        period = 1.0 / self.feedback_rate
        clock: dict[str, float] = {"calls": 0, "t0": 0.0, "next": 0.0}

        def each(work: Mapping[str, Callable[[], _States]]) -> dict[str, _States]:
            if g.cancel.is_set():
                raise _Canceled
            got = {bus: fn() for bus, fn in work.items()}
            for b, sts in got.items():
                for i, st in sts.items():
                    n, u = joint_of[(b, i)]
                    if n in path_vel:
                        speed = abs(u.position(_moved(st)) - u.position(st))
                        if speed > path_vel[n]:
                            raise _Invalid(
                                "PATH_TOLERANCE_VIOLATED",
                                f"joint {n!r}: speed {speed:.4g} rad/s above the path tolerance's "
                                f"velocity {path_vel[n]:g} rad/s",
                            )
            now = time.monotonic()
            clock["calls"] += 1
            if clock["calls"] == 2:
                clock["t0"] = now
            if clock["calls"] >= 2 and now >= clock["next"]:
                late = now - clock["next"] >= period  # the first one, or a stall: start again from now
                clock["next"] = now + period if late else clock["next"] + period
                actual = {
                    joint_of[(b, i)][0]: joint_of[(b, i)][1].position(st)
                    for b, sts in got.items()
                    for i, st in sts.items()
                }
                sample = tr.sample(min(now - clock["t0"], tr.duration)).positions
                self._feedback(g, names, sample, [actual.get(n, math.nan) for n in names])
            return got

        for lane in lanes:  # the safety gate before anything is sent (the follower's way out would send holds)
            buses[lane.bus].pass_gate(plan.commands[0][lane.bus], False)
        try:
            stream(plan, buses, each, self.start_tolerance, False)
        except ValidationError as exc:  # where the joints are is too far from the start
            raise _Invalid("INVALID_GOAL", str(exc)) from exc
        # the last command stands (the last point): wait for the joints to settle within the goal tolerance
        end = tr.sample(tr.duration).positions
        deadline = time.monotonic() + goal_time
        while True:
            if g.cancel.is_set():
                self._hold(lanes, buses, plan)
                raise _Canceled
            states = {
                lane.bus: dict(zip(lane.ids, buses[lane.bus].request([_fast_read(i) for i in lane.ids]), strict=True))
                for lane in lanes
            }
            actual = {
                joint_of[(b, i)][0]: joint_of[(b, i)][1].position(st)
                for b, sts in states.items()
                for i, st in sts.items()
            }
            speed = {
                joint_of[(b, i)][0]: abs(joint_of[(b, i)][1].position(_moved(st)) - joint_of[(b, i)][1].position(st))
                for b, sts in states.items()
                for i, st in sts.items()
            }
            self._feedback(g, names, end, [actual[n] for n in names])
            off = [
                (n, abs(actual[n] - end[k]))
                for k, n in enumerate(names)
                if abs(actual[n] - end[k]) > goal_pos[n] or (n in goal_vel and speed[n] > goal_vel[n])
            ]
            if not off:
                return GoalOutcome(rosaction.STATUS["SUCCEEDED"], 0, "")
            if time.monotonic() > deadline:
                n, err = off[0]
                raise _Invalid(
                    "GOAL_TOLERANCE_VIOLATED",
                    f"joint {n!r}: {err:.4g} rad from the goal {goal_time:g} s after the trajectory's end "
                    f"(goal tolerance {goal_pos[n]:g} rad)",
                )
            time.sleep(period)

    def _hold(self, lanes: Sequence[Any], buses: Mapping[str, Any], plan: Any) -> None:
        for lane in lanes:
            bus = buses[lane.bus]
            states = dict(zip(lane.ids, bus.request([_fast_read(i) for i in lane.ids], missing_ok=True), strict=True))
            bus.send_many(plan.hold_messages(lane, {i: s for i, s in states.items() if s is not None}))

    def close(self) -> None:
        """Cancel a running goal (the joints hold) and stop serving. Idempotent."""
        self._closed.set()
        with self._lock:
            running = self._running
        if running is not None:
            running.cancel.set()
        if self._thread is not None:
            self._thread.join(5.0)
        for d in reversed(self._decls):
            try:
                d.undeclare()
            except Exception as exc:
                _log.debug("undeclare: %s", exc)


class _Invalid(DrEmpowerError):
    """A goal refused or ended with an error code of the action's result."""

    def __init__(self, code: str, text: str) -> None:
        super().__init__(text)
        self.code, self.text = code, text


def _uuid_array(gid: bytes) -> Any:
    import numpy as np

    return np.frombuffer(gid, dtype=np.uint8).copy()


def _fast_read(node: int) -> Any:
    from ..protocol.messages import FastRead

    return FastRead(node)


def _moved(st: MotorState) -> MotorState:
    """``st`` a second later at its speed (for a velocity tolerance in the joint's units per s)."""
    return st._replace(angle=st.angle + st.speed * 6.0)
