"""A checked ``FollowJointTrajectory`` goal followed through the control cycle, to the goal tolerance.

:class:`GoalRunner` plans the trajectory on the buses' lanes
(:func:`drempower.motion.plan.make_plan`), passes each bus's safety gate before
anything is sent, streams it (:func:`drempower.motion.follow_sync.stream`)
checking the path tolerances at each cycle, then waits for the joints to settle
within the goal tolerance. A cancel holds every joint where it is.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable, Mapping, Sequence
from typing import Any

from ..client.api.bus_sync import Bus
from ..client.engine.state import MotorState
from ..errors import ValidationError
from ..motion.follow_sync import stream
from ..motion.plan import make_plan, robot_lanes, robot_limits
from ..robot.config import RobotSpec
from ..robot.joint import Gearing
from .goal_check import CheckedGoal, _Canceled, _GoalError

__all__ = ["Feedback", "GoalRunner"]

_States = dict[int, MotorState]
Feedback = Callable[[Sequence[str], Sequence[float], Sequence[float]], None]
"""Called with the goal's joints, where they should be and where they are (rad)."""


class GoalRunner:
    """Follows goals on the joints of ``spec`` (each of ``joints``: motor id, gearing, bus name) over ``buses``.

    ``rate``: the cycle rate (Hz); ``feedback_rate`` (Hz); ``start_tolerance``
    (rad): how far from the first point the joints may be.
    """

    def __init__(
        self,
        spec: RobotSpec,
        joints: Mapping[str, tuple[int, Gearing, str]],
        buses: Mapping[str, Bus],
        *,
        rate: float,
        feedback_rate: float,
        start_tolerance: float,
    ) -> None:
        self.spec = spec
        self._joints = dict(joints)
        self._buses = dict(buses)
        self.rate, self.feedback_rate, self.start_tolerance = rate, feedback_rate, start_tolerance

    def positions(self, names: Sequence[str]) -> dict[str, float]:
        """Where the joints ``names`` are (rad), read now."""
        out: dict[str, float] = {}
        for name in names:
            node, g, bus = self._joints[name]
            st = self._buses[bus].request([_fast_read(node)])[0]
            out[name] = g.joint_state(st).position
        return out

    def run(self, goal: CheckedGoal, cancel: threading.Event, feedback: Feedback) -> None:
        """Follow ``goal`` until its joints are within its goal tolerance; :class:`_Canceled` once ``cancel``
        is set (the joints hold), :class:`_GoalError` for a tolerance violated or a start too far."""
        tr, names, tol = goal.trajectory, goal.names, goal.tolerances
        all_buses = self._buses
        lanes = robot_lanes(
            self.spec, names, lambda b: all_buses[b].transport.wire_bitrate, lambda b: all_buses[b].reply_state
        )
        try:
            plan = make_plan(
                tr,
                lanes,
                rate=self.rate,
                mode="position",
                max_error=tol.path,
                limits=robot_limits(self.spec, names, None),
                kp=20.0,
                kd=1.0,
                bandwidth=None,
                torques=None,
                timeout=None,
            )
        except ValidationError as exc:
            raise _GoalError("INVALID_GOAL", str(exc)) from exc
        for lane in lanes:  # a cancel or a path error holds every joint where it is, as the controller does
            lane.on_timeout = ["hold"] * len(lane.ids)
        buses = {lane.bus: all_buses[lane.bus] for lane in lanes}
        joint_of = {
            (lane.bus, i): (n, u) for lane in lanes for i, n, u in zip(lane.ids, lane.names, lane.units, strict=True)
        }
        period = 1.0 / self.feedback_rate

        def at(states: Mapping[str, _States]) -> dict[str, float]:
            """Each joint's position (rad) in ``states``."""
            return {
                joint_of[(b, i)][0]: joint_of[(b, i)][1].position(st)
                for b, sts in states.items()
                for i, st in sts.items()
            }

        def speeds(states: Mapping[str, _States], of: Mapping[str, float]) -> dict[str, float]:
            """The speed (rad/s) in ``states`` of each joint in ``of``."""
            out = {}
            for b, sts in states.items():
                for i, st in sts.items():
                    n, u = joint_of[(b, i)]
                    if n in of:
                        out[n] = abs(u.position(_moved(st)) - u.position(st))
            return out

        clock: dict[str, float] = {"calls": 0, "t0": 0.0, "next": 0.0}

        def each(work: Mapping[str, Callable[[], _States]]) -> dict[str, _States]:
            if cancel.is_set():
                raise _Canceled
            got = {bus: fn() for bus, fn in work.items()}
            if tol.path_speed:  # only what a tolerance asks for: this runs at every cycle
                for n, v in speeds(got, tol.path_speed).items():
                    tol.check_path_speed(n, v)
            now = time.monotonic()
            clock["calls"] += 1
            if clock["calls"] == 2:
                clock["t0"] = now
            if clock["calls"] >= 2 and now >= clock["next"]:
                late = now - clock["next"] >= period  # the first one, or a stall: start again from now
                clock["next"] = now + period if late else clock["next"] + period
                actual = at(got)
                sample = tr.sample(min(now - clock["t0"], tr.duration)).positions
                feedback(names, sample, [actual.get(n, math.nan) for n in names])
            return got

        for lane in lanes:  # the safety gate before anything is sent (the follower's way out would send holds)
            buses[lane.bus].pass_gate(plan.commands[0][lane.bus], False)
        try:
            stream(plan, buses, each, self.start_tolerance, False)
        except ValidationError as exc:  # where the joints are is too far from the start
            raise _GoalError("INVALID_GOAL", str(exc)) from exc
        # the last command stands (the last point): wait for the joints to settle within the goal tolerance
        end = tr.sample(tr.duration).positions
        deadline = time.monotonic() + tol.goal_time
        while True:
            if cancel.is_set():
                _hold(lanes, buses, plan)
                raise _Canceled
            states = {
                lane.bus: dict(zip(lane.ids, buses[lane.bus].request([_fast_read(i) for i in lane.ids]), strict=True))
                for lane in lanes
            }
            actual = at(states)
            feedback(names, end, [actual[n] for n in names])
            off = tol.off_goal(names, end, actual, speeds(states, actual))
            if not off:
                return
            if time.monotonic() > deadline:
                raise tol.late(*off[0])
            time.sleep(period)


def _hold(lanes: Sequence[Any], buses: Mapping[str, Bus], plan: Any) -> None:
    for lane in lanes:
        bus = buses[lane.bus]
        states = dict(zip(lane.ids, bus.request([_fast_read(i) for i in lane.ids], missing_ok=True), strict=True))
        bus.send_many(plan.hold_messages(lane, {i: s for i, s in states.items() if s is not None}))


def _fast_read(node: int) -> Any:
    from ..protocol.messages import FastRead

    return FastRead(node)


def _moved(st: MotorState) -> MotorState:
    """``st`` a second later at its speed (for a velocity tolerance in the joint's units per s)."""
    return st._replace(angle=st.angle + st.speed * 6.0)
